"""What a junction state (v, a ≠ 0) at a valley bottom could buy, measured locally (issue 38).

The window passes every junction at zero acceleration; at the valley bottoms it adds (a fall into
the junction, a rise out of it: benchmarks/slw_junction_kinds.py's ``valley``) the feed sits at
~0.97 of the zero-acceleration limit and ~8 % under what a state with a ≠ 0 allows there. This
measures what replacing that bottom by a state (v', a') would gain, before the window is changed:

per valley junction J of a seven-phase schedule (blocks L and R either side, as released), the
stretch from the start of L's last fall (or of the cruise at that fall's top feed just before it)
to the end of R's first rise (or of the cruise at its top feed just after it) is scheduled again
as: cruise at v_L, fall (v_L, 0) → (v', a') ending at J (slw/acc_profile.py, under L's fall
acceleration), rise (v', a') → (v_R, 0) (under R's rise acceleration), cruise at v_R, within the
same stretch (the neighbours' top feeds and everything outside the stretch unchanged). The
candidates: v' on a grid from the schedule's v_J up to ``v_any`` (slw_junction_kinds: the highest
feed the axis region |a·T_j + v²·κN_j| ≤ A_j allows at J with |a| ≤ the tangential acceleration),
a' on a grid of that region's interval at v' (_kernels.acc_range), the seven-phase transitions
only. A candidate is kept when both transitions fit their budgets (the fall within L's stretch,
the rise within R's; a rise from (v', a' < 0) that would pass below zero feed is refused) and the
ticks of the stretch (times k·Ts from its start, positions on the curve) pass
fuzzyfeed.slw.check.tick_ratios' every limit (feed, axis velocities and accelerations, jerk,
path jerk; the first and last 3 ticks, which tick_ratios brings to rest, left out). The fastest
kept candidate is the valley's gain; the zero-acceleration candidate at the schedule's own feeds
is the stretch's baseline (its time and its tick check, printed as ``base ok``).

Why a candidate faster than the baseline was refused is counted per valley (the reason of the
fastest refused one): ``fit`` (a transition longer than its budget: the jerk and acceleration
limits within the neighbours' stretch), ``dip`` (the rise from a' < 0 passes zero feed), or the
tick check's worst limit (``acceleration y`` …: the stretch's profile over a limit somewhere, e.g.
the feed's true minimum — where a = 0 — moved off J to a point whose zero-acceleration limit is
lower).

Valleys whose baseline fails the local tick check (the stretch re-planned at the schedule's own
feeds is not what the schedule did there) are counted but not moved.

The gain is a local bound in one sense and short of it in another: the neighbours' top feeds are
kept (a higher valley could let a short neighbour's peak rise too: not counted), and only valleys
of the released schedule are moved (the junctions a changed plan would add or drop are not).

Run: PYTHONPATH=<tree> python benchmarks/slw_valley_gain.py [--stride K] [--levels N]
"""

from __future__ import annotations

import argparse
import math
import sys
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_slw import cases  # noqa: E402
from slw_junction_kinds import axis_region_top, junction_kinds  # noqa: E402
from slw_time_split import split  # noqa: E402

from fuzzyfeed.slw.acc_profile import acc_transition, speed_range  # noqa: E402
from fuzzyfeed.geometry.interpolate import interpolate_u  # noqa: E402
from fuzzyfeed.slw.check import corner_ticks, tick_ratios  # noqa: E402
from fuzzyfeed.slw.lookahead import KINK_MIN  # noqa: E402
from fuzzyfeed.slw.preprocess import joins  # noqa: E402
from fuzzyfeed.slw.preprocess import evaluate_reference  # noqa: E402

#: Ticks at each end of a stretch left out of its check (tick_ratios brings the motion to rest
#: before the first and after the last tick).
EDGE_TICKS = 3
#: A tick may pass a limit by this fraction (fuzzyfeed.slw.check.TICK_RTOL).
TICK_RTOL = 5e-5


_KINKS: dict = {}


def kinks_u(curve) -> np.ndarray:
    """Parameters of the path's kinks (as fuzzyfeed.slw.trajectory.schedule passes to its check)."""
    if id(curve) not in _KINKS:
        s_j, _, _, jump = joins(curve)
        kinks = s_j[jump.max(axis=1, initial=0.0) > KINK_MIN] if s_j.size else s_j
        _KINKS[id(curve)] = (curve, np.atleast_1d(curve.param_at_length(kinks)) if kinks.size else kinks)
    return _KINKS[id(curve)][1]


def _cruise(v: float, length: float):
    return ("cruise", length / v if v > 0.0 else 0.0, v)


def stretch_state(pieces, t):
    """s, v, a, j at times ``t`` (array) of a stretch of pieces: ("cruise", T, v) or ("acc", T,
    AccSegment), from s = 0."""
    s, v, a, j = (np.zeros_like(t) for _ in range(4))
    t0, s0 = 0.0, 0.0
    for n, (kind, dur, x) in enumerate(pieces):
        last = n == len(pieces) - 1
        sel = (t >= t0) & ((t <= t0 + dur) if last else (t < t0 + dur))
        tau = t[sel] - t0
        if kind == "cruise":
            s[sel], v[sel] = s0 + x * tau, x
            s0 += x * dur
        else:
            ss, vv, aa, jj = x.state(tau)
            s[sel], v[sel], a[sel], j[sel] = s0 + ss, vv, aa, jj
            s0 += x.length_mm
        t0 += dur
    return s, v, a, j


def tick_check(curve, limits, s_start: float, pieces, t_start: float = 0.0, s_before=None, s_after=None):
    """(worst limit name, its ratio) over the stretch's interior ticks (module docstring). The
    stretch starts at ``t_start`` on the schedule's clock: its ticks are the schedule's, k·Ts.
    ``s_before``, ``s_after``: the schedule's tick arc lengths before and after the stretch. The
    chord-exact interpolator (fuzzyfeed.geometry.interpolate) scales every chord by one factor
    over the whole path, so the stretch's ticks are interpolated with the rest of the path's
    (targets jumping from 0 to the stretch and from it to the end put them 1.1 mm off on
    butterfly, and an axis 6 x over its acceleration where the schedule's own ticks pass)."""
    total = sum(p[1] for p in pieces)
    ts = limits.ts_s
    k0 = math.ceil(t_start / ts - 1e-9)
    t = np.arange(k0, math.floor((t_start + total) / ts + 1e-9) + 1) * ts - t_start
    t = t[(t >= 0.0) & (t <= total)]
    s, _, _, j = stretch_state(pieces, t)
    s = np.clip(s_start + s, 0.0, curve.length)
    head = np.zeros(0) if s_before is None else np.asarray(s_before, dtype=float)
    head = head[head < s[0]]
    if not head.size or head[0] != 0.0:
        head = np.concatenate([[0.0], head])
    tail = np.zeros(0) if s_after is None else np.asarray(s_after, dtype=float)
    tail = tail[tail > s[-1]]
    if not tail.size or tail[-1] != curve.length:
        tail = np.concatenate([tail, [curve.length]])
    u = interpolate_u(curve, np.concatenate([head, s, tail]), "best")
    xyz = curve.evaluate(u, order=0)[0]
    if xyz.shape[1] < 3:
        xyz = np.hstack([xyz, np.zeros((xyz.shape[0], 3 - xyz.shape[1]))])
    jerk = np.concatenate([np.zeros(head.size), j, np.zeros(tail.size)])
    ratios = tick_ratios(xyz, jerk, limits, corner_ticks(u, kinks_u(curve)))
    lo, hi = head.size + EDGE_TICKS, head.size + s.size - EDGE_TICKS
    worst, name = -np.inf, ""
    for key, r in ratios.items():
        inner = r[lo:hi]
        if inner.size and np.nanmax(inner) > worst:
            worst, name = float(np.nanmax(inner)), key
    return name, worst


def v_any_at(ref, i, limits, x_mvc, v_other):
    """The highest feed with a nonempty axis-region interval meeting |a| ≤ the tangential
    acceleration at reference point i (slw_junction_kinds.bottom_ratios, one point)."""
    d = ref.tangent.shape[1]
    acc = np.asarray(limits.axis_acc_mm_s2, dtype=float)[:d]
    good = axis_region_top(ref.tangent[i], ref.kn[i], acc, limits.tangential_acc_mm_s2,
                           min(ref.vlim[i] ** 2, x_mvc), x_mvc)
    return min(float(np.sqrt(good)), v_other)


def valley_gain(traj, limits, cap, left, right, levels: int, max_checks: int, accs: int = 9):
    """The baseline and best times of one valley between released blocks ``left`` and ``right``,
    whether the baseline passes the tick check, the reason (``gain`` or why not), v_J, the best
    (v', a'), v_any and the room the neighbours leave, min(v_L, v_R)/v_J (a dict)."""
    import fuzzyfeed.slw._kernels as kernels
    from fuzzyfeed.slw.lookahead import SlidingWindow

    jerk = limits.jerk_mm_s3
    fall, rise = left.segments[-1], right.segments[0]
    v_j = fall.v1
    top_l = max(max(x.v0, x.v1) for x in left.segments)
    top_r = max(max(x.v0, x.v1) for x in right.segments)
    up_l, down_l = left.acc_mm_s2, left.acc_down_mm_s2 if left.acc_down_mm_s2 is not None else left.acc_mm_s2
    up_r, down_r = right.acc_mm_s2, right.acc_down_mm_s2 if right.acc_down_mm_s2 is not None else right.acc_mm_s2
    v_l, v_r = left.v_start, right.v_end
    s_j = left.s1
    s_start = left.s0
    # the stretch on the schedule's clock, and the schedule's ticks before it (tick_check)
    at = next(i for i, b in enumerate(traj.blocks) if b is left)
    t_start = float(sum(b.duration_s for b in traj.blocks[:at]))
    s_before = traj.s_mm[:int(np.searchsorted(traj.t_s, t_start - 1e-12))]
    s_after = traj.s_mm[int(np.searchsorted(traj.t_s, t_start + left.duration_s + right.duration_s + 1e-12)):]

    def side(v1, a1, outer, top, length, acc_outer, acc_inner, into):
        """A block between its outer junction (``outer``, a = 0) and J (v1, a1): outer → peak p (≤
        ``top``) → J, the highest p that fits ``length`` (bisection), the rest a cruise at p."""
        def parts(p):
            a = acc_transition(outer, 0.0, p, 0.0, acc_outer, jerk)
            b = acc_transition(p, 0.0, v1, a1, acc_inner, jerk) if into else acc_transition(v1, a1, p, 0.0,
                                                                                           acc_inner, jerk)
            return a, b, a.length_mm + b.length_mm
        lo = max(outer, v1)
        if lo > top * (1 + 1e-12):
            return None
        a, b, d = parts(top)
        p = top
        if d > length * (1 + 1e-12):
            a, b, d = parts(lo)
            if d > length * (1 + 1e-12):
                return None
            good, bad = lo, top
            for _ in range(50):
                mid = 0.5 * (good + bad)
                good, bad = (mid, bad) if parts(mid)[2] <= length else (good, mid)
            p = good
            a, b, d = parts(p)
        outer_part, inner = ("acc", a.duration_s, a), ("acc", b.duration_s, b)
        cruise = _cruise(p, max(length - d, 0.0))
        if speed_range(b)[0] <= 0.0:
            return "dip"
        return [outer_part, cruise, inner] if into else [inner, cruise, ("acc", a.duration_s, a)]

    def pieces(v1, a1):
        # the right block's outer transition is a fall q → v_R: acc_transition(v_R, 0, q, 0) has
        # the same duration and length (a seven-phase ramp with zero-acceleration ends is
        # symmetric in time), its state is sampled from the fall below
        lp = side(v1, a1, v_l, top_l, left.s1 - left.s0, up_l, down_l, True)
        rp = side(v1, a1, v_r, top_r, right.s1 - right.s0, down_r, up_r, False)
        if lp is None or rp is None:
            return None, "fit"
        if isinstance(lp, str) or isinstance(rp, str):
            return None, "dip"
        last = rp[-1][2]
        rp[-1] = ("acc", last.duration_s, acc_transition(last.v1, 0.0, last.v0, 0.0, down_r, jerk))
        return lp + rp, ""

    def time_of(p):
        return sum(x[1] for x in p)

    base, why = pieces(v_j, 0.0)
    if base is None:
        return None
    t_base = time_of(base)
    name, worst = tick_check(traj.curve, limits, s_start, base, t_start, s_before, s_after)
    base_ok = worst <= 1.0 + TICK_RTOL
    # the axis region at J
    ref = evaluate_reference(traj.curve, limits, np.array([s_j]), cap=cap)
    d = ref.tangent.shape[1]
    axis_acc = np.asarray(limits.axis_acc_mm_s2, dtype=float)[:d]
    x = np.empty(1)
    kernels.mvc(np.ascontiguousarray(ref.tangent), np.ascontiguousarray(ref.kn), axis_acc, x)
    other = SlidingWindow(limits, traj.curve, cap=cap)._feed_limit_numpy(ref.s, ref.vlim, ref.tangent, ref.kn)
    v_any = v_any_at(ref, 0, limits, float(x[0]), float(other[0]))
    a_lim = min(down_l, up_r)
    cands = []
    # feeds up to v_any, and as many up to the lower neighbour's top (below it the valley stays one)
    top = min(top_l, top_r, max(v_any, v_j))
    grid = np.unique(np.concatenate([np.linspace(v_j, max(v_any, v_j), levels + 1)[1:],
                                     np.linspace(v_j, top, levels + 1)[1:]]))
    for v1 in grid[grid > v_j]:
        lo, hi = kernels.acc_range(v1 * v1, np.ascontiguousarray(ref.tangent[0]),
                                   np.ascontiguousarray(ref.kn[0]), axis_acc)
        lo, hi = max(lo, -a_lim), min(hi, a_lim)
        if lo > hi:
            continue
        for a1 in np.unique(np.concatenate([np.linspace(lo, hi, accs), [min(max(0.0, lo), hi)]])):
            p, why = pieces(float(v1), float(a1))
            cands.append((time_of(p) if p is not None else np.inf, float(v1), float(a1), p, why))
    cands.sort(key=lambda c: c[0])
    # the fastest candidate that passes, and the fastest with a' = 0 (a junction at zero
    # acceleration, only higher: what the plan alone could give, without a junction state)
    reason, checks, best, best_zero = "none faster", 0, None, None
    for t_c, v1, a1, p, why in cands:
        if p is None:
            if reason == "none faster":
                reason = why
            continue
        if t_c >= t_base or (best is not None and best_zero is not None):
            break
        if best is not None and a1 != 0.0:
            continue
        if checks >= max_checks:
            reason = reason if reason != "none faster" else "checks"
            break
        checks += 1
        name, worst = tick_check(traj.curve, limits, s_start, p, t_start, s_before, s_after)
        if worst <= 1.0 + TICK_RTOL:
            if best is None:
                best = (t_c, v1, a1)
            if a1 == 0.0:
                best_zero = (t_c, v1, a1)
        elif reason in ("none faster", "fit", "dip"):
            reason = name
    out = dict(base=t_base, base_ok=base_ok, v_j=v_j, v_any=v_any, room=min(top_l, top_r) / v_j,
               vlim=float(ref.vlim[0]))
    if best is None:
        return dict(out, best=t_base, zero=t_base, reason=reason, v=v_j, a=0.0)
    return dict(out, best=best[0], zero=best_zero[0] if best_zero else t_base, reason="gain", v=best[1], a=best[2])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--random", type=int, default=110)
    ap.add_argument("--stride", type=int, default=7, help="every K-th case only")
    ap.add_argument("--levels", type=int, default=16, help="feed levels from v_J to v_any")
    ap.add_argument("--checks", type=int, default=40, help="tick checks per valley at most")
    ap.add_argument("--accs", type=int, default=9, help="accelerations per feed level")
    args = ap.parse_args()
    reasons = Counter()
    ratios_old, ratios_new, gains, gains_zero, moved = [], [], [], [], []
    n_valleys = n_base_bad = 0
    rooms = []
    for i, (name, curve, lim, cap) in enumerate(cases(args.random, 1, builtin_only=True)):
        if i % args.stride:
            continue
        r = split(f"{name}/seven-phase", curve, lim, "seven-phase", cap)
        traj, s, _ = r["detail"]
        tol = max(1e-3, 1e-6 * traj.curve.length)
        valleys = {round(x, 9) for x, k, _ in junction_kinds(traj, s, tol) if k == "valley"}
        saved, saved_zero, case_reasons = 0.0, 0.0, Counter()
        for left, right in zip(traj.blocks[:-1], traj.blocks[1:]):
            if round(left.s1, 9) not in valleys:
                continue
            out = valley_gain(traj, lim, cap, left, right, args.levels, args.checks, args.accs)
            if out is None:
                case_reasons["base unfit"] += 1
                continue
            n_valleys += 1
            n_base_bad += not out["base_ok"]
            case_reasons[out["reason"]] += 1
            rooms.append((out["reason"], out["room"], out["v_any"] / out["v_j"], out["vlim"] / out["v_j"]))
            if out["reason"] == "gain" and out["base_ok"]:
                saved += out["base"] - out["best"]
                saved_zero += out["base"] - out["zero"]
                moved.append((out["v"] / out["v_j"], out["a"], out["v_any"] / out["v_j"], out["room"]))
        reasons.update(case_reasons)
        old = r["ratio"]
        new = (traj.cycle_time_s - saved) / r["floor"]
        ratios_old.append(old)
        ratios_new.append(new)
        gains.append(100.0 * saved / r["floor"])
        gains_zero.append(100.0 * saved_zero / r["floor"])
        print(f"{name:<32} ratio {old:.4f} -> {new:.4f} (valleys: "
              + ", ".join(f"{k} {n}" for k, n in case_reasons.most_common()) + ")", flush=True)
    print(f"seven-phase: {len(ratios_old)} cases, {n_valleys} valleys ({n_base_bad} whose zero-acceleration "
          f"baseline fails the local tick check); per valley: "
          + ", ".join(f"{k} {n}" for k, n in reasons.most_common()))
    if ratios_old:
        print(f"median ratio {np.median(ratios_old):.4f} -> {np.median(ratios_new):.4f}; mean gain "
              f"{np.mean(gains):.3f} % of the floor (max {np.max(gains):.3f} %), of which with a' = 0 at the "
              f"junction (a higher junction feed alone) {np.mean(gains_zero):.3f} % (max {np.max(gains_zero):.3f} %)")
    if rooms:
        for label, sel in (("gain", lambda k: k == "gain"), ("no gain", lambda k: k != "gain")):
            x = np.array([(r, a, z) for k, r, a, z in rooms if sel(k)])
            if x.size:
                print(f"{label}: {x.shape[0]} valleys, room min(v_L, v_R)/v_J median {np.median(x[:, 0]):.4f} "
                      f"(< 1.01: {int((x[:, 0] < 1.01).sum())}), v_any/v_J median {np.median(x[:, 1]):.4f}, "
                      f"vlim/v_J median {np.median(x[:, 2]):.4f} (vlim: the zero-acceleration limit at J)")
    if moved:
        m = np.array(moved)
        print(f"moved valleys: v'/v_J median {np.median(m[:, 0]):.4f} (max {m[:, 0].max():.4f}), v_any/v_J median "
              f"{np.median(m[:, 2]):.4f}, a' < 0 {int((m[:, 1] < 0).sum())}, a' > 0 {int((m[:, 1] > 0).sum())}, "
              f"a' = 0 {int((m[:, 1] == 0).sum())}; v' within 0.1 % of the lower neighbour top (the valley gone) "
              f"{int((m[:, 0] >= m[:, 3] * (1 - 1e-3)).sum())}, within 0.1 % of v_any "
              f"{int((m[:, 0] >= m[:, 2] * (1 - 1e-3)).sum())}")


if __name__ == "__main__":
    main()
