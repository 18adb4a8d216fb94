"""Which of the window's added junctions a nonzero junction acceleration could help (issue 38).

Every junction the look-ahead window adds (a repair's or a block cut's, not a chain point of the
floor: as benchmarks/slw_time_split.py's ``junc``) is a zero acceleration. Per junction, the
transitions either side of it (the last segment of the block before, the first of the block
after) give its kind:

- ``through``: a rise into it and a rise out of it, or a fall and a fall: the feed passes it
  monotonically, and only here can a junction state (v, a ≠ 0) (slw/acc_profile.py) keep the
  acceleration instead of ramping it to zero and back;
- ``valley`` (a fall then a rise) / ``peak`` (a rise then a fall): an extremum of the feed,
  where a = 0 is what any smooth profile has;
- ``flat``: a cruise on either side (a = 0 there anyway, in the schedule as it is; a stair: a
  transition into the junction's feed, then a cruise at it, where a plan choosing junction states
  could follow the limit in one transition instead).

The flats are also counted by their two sides (``fall>cruise``: a fall into the junction, a cruise
out of it; …).

At the valley bottoms (``valley`` and ``flat``), the junction's feed against two limits at its
point: ``vlim``, the pointwise limit with zero tangential acceleration (the centripetal part alone
on each axis, the command feed, axis velocities, chord, cap), and ``v_any``, the same with the
axis accelerations' maximum-velocity curve instead of the centripetal part alone (any tangential
acceleration |a| ≤ the machine's tangential acceleration, by bisection on _kernels.acc_range under
_kernels.mvc: an upper bound for a junction state (v, a ≠ 0), which jerk limits further).

Per transition it prints the count of each kind and the share of slw_time_split's ``junc`` excess
(% of the floor) in gaps whose added junctions are all ``through`` (``through``), none (``other``),
or both (``mixed``).

Run: PYTHONPATH=<tree> python benchmarks/slw_junction_kinds.py [--stride K] [--transition ...]
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_slw import cases  # noqa: E402
from slw_time_split import split  # noqa: E402

KINDS = ("through", "valley", "peak", "flat")


_NAMES = {-1: "fall", 0: "cruise", 1: "rise"}


def _direction(seg) -> int:
    return (seg.v1 > seg.v0) - (seg.v1 < seg.v0)


def junction_kinds(traj, s_points, tol):
    """(s, kind, sides) of every block boundary that is no chain point in ``s_points``."""
    out = []
    for left, right in zip(traj.blocks[:-1], traj.blocks[1:]):
        if not left.segments or not right.segments:
            continue
        s = left.s1
        if s_points.size and np.abs(s_points - s).min() <= tol:
            continue
        d0, d1 = _direction(left.segments[-1]), _direction(right.segments[0])
        kind = "flat" if d0 == 0 or d1 == 0 else "through" if d0 == d1 else "valley" if d0 < d1 else "peak"
        out.append((s, kind, f"{_NAMES[d0]}>{_NAMES[d1]}"))
    return out


def axis_region_top(tangent, kn, acc, a_t: float, good: float, bad: float) -> float:
    """The largest x = v² in [good, bad] whose axis-region interval of a (``_kernels.acc_range``)
    meets [−a_t, a_t]: ``bad`` if it does, else bisected (60 steps; an infinite ``bad`` doubles)."""
    import fuzzyfeed.slw._kernels as kernels

    t_i, k_i = np.ascontiguousarray(tangent), np.ascontiguousarray(kn)
    lo, hi = kernels.acc_range(bad, t_i, k_i, acc) if np.isfinite(bad) else (np.inf, -np.inf)
    if lo <= hi and lo <= a_t and hi >= -a_t:
        return bad
    for _ in range(60):
        mid = 0.5 * (good + bad) if np.isfinite(bad) else 2.0 * good + 1.0
        lo, hi = kernels.acc_range(mid, t_i, k_i, acc)
        good, bad = (mid, bad) if (lo <= hi and lo <= a_t and hi >= -a_t) else (good, mid)
    return good


def bottom_ratios(traj, limits, cap, bottoms):
    """v_J / vlim and v_J / v_any at the junctions ``bottoms`` ((s, v_J) pairs; module docstring)."""
    import fuzzyfeed.slw._kernels as kernels
    from fuzzyfeed.slw.lookahead import SlidingWindow
    from fuzzyfeed.slw.preprocess import evaluate_reference

    if not bottoms:
        return np.empty(0), np.empty(0)
    s = np.array([b[0] for b in bottoms])
    v = np.array([b[1] for b in bottoms])
    order = np.argsort(s)
    s, v = s[order], v[order]
    ref = evaluate_reference(traj.curve, limits, s, cap=cap)
    d = ref.tangent.shape[1]
    acc = np.asarray(limits.axis_acc_mm_s2, dtype=float)[:d]
    x = np.empty(s.size)
    kernels.mvc(np.ascontiguousarray(ref.tangent), np.ascontiguousarray(ref.kn), acc, x)
    # the other limits (command, axis velocities, chord, cap): the window's lifted limit, which is
    # them wherever the centripetal part binds (window_check.BlockCheck._feed_limit_numpy)
    other = SlidingWindow(limits, traj.curve, cap=cap)._feed_limit_numpy(ref.s, ref.vlim, ref.tangent, ref.kn)
    a_t = limits.tangential_acc_mm_s2
    for i in range(s.size):  # the largest x whose range of a meets [−a_t, a_t]
        x[i] = axis_region_top(ref.tangent[i], ref.kn[i], acc, a_t, min(ref.vlim[i] ** 2, x[i]), x[i])
    v_any = np.minimum(np.sqrt(x), other)
    return v / ref.vlim, v / v_any


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--random", type=int, default=110)
    ap.add_argument("--stride", type=int, default=1, help="every K-th case only")
    ap.add_argument("--transition", choices=("both", "seven-phase", "cosine"), default="both")
    args = ap.parse_args()
    transitions = ("cosine", "seven-phase") if args.transition == "both" else (args.transition,)
    counts = {t: Counter() for t in transitions}
    shares = {t: [] for t in transitions}
    sides = {t: Counter() for t in transitions}
    bottoms = {t: ([], []) for t in transitions}
    for i, (name, curve, lim, cap) in enumerate(cases(args.random, 1, builtin_only=True)):
        if i % args.stride:
            continue
        for t in transitions:
            r = split(f"{name}/{t}", curve, lim, t, cap)
            traj, s, excess = r["detail"]
            tol = max(1e-3, 1e-6 * traj.curve.length)
            kinds = junction_kinds(traj, s, tol)
            by_s = {round(b.s1, 9): b.v_end for b in traj.blocks}
            r0, r1 = bottom_ratios(traj, lim, cap, [(x, by_s[round(x, 9)]) for x, k, _ in kinds
                                                     if k in ("valley", "flat")])
            bottoms[t][0].extend(r0.tolist())
            bottoms[t][1].extend(r1.tolist())
            c = Counter(k for _, k, _ in kinds)
            counts[t].update(c)
            sides[t].update(x for _, k, x in kinds if k == "flat")
            part = {"through": 0.0, "other": 0.0, "mixed": 0.0}
            gap = np.clip(np.searchsorted(s, [x for x, _, _ in kinds]) - 1, 0, max(excess.size - 1, 0))
            inner = (gap > 0) & (gap < excess.size - 1)   # slw_time_split counts start/end apart
            for g in np.unique(gap[inner]):
                ks = {k for (_, k, _), gg, ok in zip(kinds, gap, inner) if ok and gg == g}
                part["through" if ks == {"through"} else "other" if "through" not in ks else "mixed"] += \
                    float(excess[g]) / r["floor"]
            shares[t].append(part)
            print(f"{name}/{t:<12} ratio {r['ratio']:.4f} junc {100 * r['shares']['junc']:5.2f} % | "
                  + " ".join(f"{k} {c.get(k, 0):3d}" for k in KINDS) + " | junc excess % of floor: "
                  + " ".join(f"{k} {100 * v:5.2f}" for k, v in part.items()), flush=True)
    for t in transitions:
        tab = {k: np.array([p[k] for p in shares[t]]) for k in ("through", "other", "mixed")}
        total = sum(counts[t].values())
        print(f"{t}: {len(shares[t])} cases, {total} added junctions: "
              + ", ".join(f"{k} {counts[t].get(k, 0)} ({100 * counts[t].get(k, 0) / max(total, 1):.0f} %)"
                          for k in KINDS)
              + (f"; at the bottoms v_J/vlim median {np.median(bottoms[t][0]):.4f}, v_J/v_any median "
                 f"{np.median(bottoms[t][1]):.4f} (mean {np.mean(bottoms[t][1]):.4f})" if bottoms[t][0] else "")
              + " (flats: " + ", ".join(f"{x} {n}" for x, n in sides[t].most_common()) + ")"
              + "; junc excess, mean % of the floor: "
              + ", ".join(f"{k} {100 * v.mean():.2f}" for k, v in tab.items()))


if __name__ == "__main__":
    main()
