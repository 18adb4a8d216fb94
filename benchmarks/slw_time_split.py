"""Where a schedule's time over the jerk-limited floor goes (issue 38), per built-in case of bench_slw.

The floor's corner chain cuts the path at its chain points (true corners and local minima of the
pointwise limit: fuzzyfeed.slw.floor.chain_points) and bounds each gap between two of them alone
(max of its free jerk-limited time and the acceleration-limited bound's time over it). Per gap, the
schedule's own time over it minus that gap bound is the gap's excess; the gaps are grouped:

- ``start`` / ``end``: the path's first and last gap (the rise from rest, the final stop);
- ``corner``: a gap with a true corner at either end (a corner's stop-and-go);
- ``run``: another gap where the schedule reaches ≥ 97 % of the command feed (a straight run or a
  bend passed near F);
- ``bend``: another gap (between two minima of the limit, below the feed all along: the window's
  junctions at curvature minima);

``junc`` is the part of the excess in gaps holding one or more of the window's junctions that are
not chain points (repair junctions or block cuts: where the window ends a block at zero
acceleration), counted apart from the groups above; ``couple`` is floor − Σ gap bounds (the held
chain's coupling or the legs/bound taking over: time the floor has that no gap shows). Every share
is a fraction of the floor, so the groups add up to the ratio − 1.

Run: PYTHONPATH=<tree> python benchmarks/slw_time_split.py [--random N] [--stride K]
[--transition both|cosine|seven-phase] [--only NAME ...]
Prints one line per case and, per transition, the median and the mean share of each group over
all cases and over the cases within ±0.03 of the median ratio (the median cases).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_slw import cases  # noqa: E402

from fuzzyfeed.slw import path_bound, schedule  # noqa: E402
from fuzzyfeed.slw.floor import (CHAIN_BATCH, bound_gap_times, chain_points, gap_accelerations,  # noqa: E402
                                 gap_times, jerk_floor, point_acceleration)
from fuzzyfeed.slw.preprocess import corners  # noqa: E402

GROUPS = ("start", "end", "corner", "run", "bend", "junc", "couple")


def gap_bounds(curve, limits, bound):
    """Chain points s (with 0 and the end), their feeds, and each gap's bound (as corner_chain_s's
    free chain: max of the free jerk-limited time and the bound's time over it)."""
    s_p, v_p = chain_points(curve, limits)
    jerk, feed = limits.jerk_mm_s3, limits.feed_mm_s
    s, inverse = np.unique(np.concatenate([[0.0], s_p, [curve.length]]), return_inverse=True)
    v = np.full(s.size, np.inf)
    np.minimum.at(v, inverse, np.concatenate([[0.0], v_p, [0.0]]))
    acc = gap_accelerations(curve, limits, s)
    g, v1, v2 = np.diff(s), v[:-1], v[1:]
    least = bound_gap_times(bound, s)
    free = np.empty(g.size)
    a1, a2 = np.minimum(acc, point_acceleration(v1, jerk)), np.minimum(acc, point_acceleration(v2, jerk))
    for k in range(0, g.size, CHAIN_BATCH):
        part = slice(k, k + CHAIN_BATCH)
        free[part] = gap_times(g[part], v1[part], v2[part], feed, acc[part], jerk, a1[part], -a2[part])
    return s, v, np.maximum(free, least)


def split(name: str, curve, limits, transition: str, cap=None) -> dict:
    traj = schedule(curve, limits, transition=transition, feed_cap=cap, planner="window")
    c = traj.curve
    bound = path_bound(c, limits, feed_cap=cap, halve=False)
    floor = jerk_floor(c, limits, bound)
    s, v, gb = gap_bounds(c, limits, bound)
    t_at = np.interp(s, traj.s_mm, traj.t_s)
    t_at[-1] = traj.cycle_time_s
    excess = np.diff(t_at) - gb
    s_c, _ = corners(c, limits)
    is_corner = np.isin(s, s_c)
    m = excess.size
    group = np.full(m, "bend", dtype=object)
    # the top feed the schedule reaches in each gap
    k = np.searchsorted(traj.s_mm, s)
    top = np.array([traj.feed_mm_s[a:b + 1].max() if b > a else 0.0 for a, b in zip(k[:-1], k[1:])])
    group[top >= 0.97 * limits.feed_mm_s] = "run"
    group[is_corner[:-1] | is_corner[1:]] = "corner"
    group[0], group[-1] = "start", "end"
    # the window's junctions that are no chain point (tolerance: a micron or 1e-6 of the length)
    crit = np.asarray(traj.critical_s_mm, dtype=float)
    tol = max(1e-3, 1e-6 * c.length)
    if crit.size:
        near = np.abs(crit[:, None] - s[None, :]).min(axis=1) <= tol if s.size else np.zeros(crit.size, bool)
        extra = crit[~near]
        holds = np.zeros(m, dtype=bool)
        holds[np.clip(np.searchsorted(s, extra) - 1, 0, m - 1)] = True
        group[holds & (group != "start") & (group != "end")] = "junc"
    shares = {g: float(excess[group == g].sum()) / floor for g in GROUPS[:-1]}
    shares["couple"] = (floor - gb.sum()) / floor
    # junction feed at the chain points against the chain's feed (interior points, finite feeds)
    v_at = np.interp(s, traj.s_mm, traj.feed_mm_s)
    inner = np.isfinite(v[1:-1]) & (v[1:-1] > 0)
    deficit = float(np.median(v_at[1:-1][inner] / v[1:-1][inner])) if inner.any() else float("nan")
    return {"name": name, "ratio": traj.cycle_time_s / floor, "floor": floor, "shares": shares,
            "gaps": m, "extra": int(crit.size - (crit.size and near.sum())), "feed_at_points": deficit,
            # for slw_junction_kinds.py: the schedule, the gaps' ends and their excess (s)
            "detail": (traj, s, excess)}


def line(r: dict) -> str:
    sh = " ".join(f"{g} {100 * r['shares'][g]:6.2f}" for g in GROUPS)
    return (f"{r['name']:<36} {r['ratio']:7.4f}  {sh}  gaps {r['gaps']:5d} extra {r['extra']:4d} "
            f"v/v_chain {r['feed_at_points']:.3f}")


def report(rows: list[dict], label: str) -> None:
    ratios = np.array([r["ratio"] for r in rows])
    med = float(np.median(ratios))
    near = [r for r in rows if abs(r["ratio"] - med) <= 0.03]
    for sel, what in ((rows, "all"), (near, f"median cases (|ratio - {med:.4f}| <= 0.03)")):
        if not sel:
            continue
        tab = {g: np.array([r["shares"][g] for r in sel]) for g in GROUPS}
        print(f"{label}, {what}, {len(sel)} cases: % of the floor, mean (median) — "
              + ", ".join(f"{g} {100 * tab[g].mean():.2f} ({100 * np.median(tab[g]):.2f})" for g in GROUPS))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--random", type=int, default=110)
    ap.add_argument("--stride", type=int, default=1, help="every K-th case only")
    ap.add_argument("--transition", choices=("both", "seven-phase", "cosine"), default="both")
    ap.add_argument("--only", nargs="+", help="only these cases (path/machine as bench_slw prints them)")
    args = ap.parse_args()
    transitions = ("cosine", "seven-phase") if args.transition == "both" else (args.transition,)
    print("% of the floor per group; ratio - 1 = their sum")
    rows: dict[str, list[dict]] = {t: [] for t in transitions}
    for i, (name, curve, lim, cap) in enumerate(cases(args.random, 1, builtin_only=True)):
        if (args.only and name not in args.only) or (not args.only and i % args.stride):
            continue
        for t in transitions:
            try:
                r = split(f"{name}/{t}", curve, lim, t, cap)
            except Exception as exc:  # noqa: BLE001 - a benchmark reports every failure
                print(f"{name}/{t} FAILED {type(exc).__name__}: {exc}"[:200], flush=True)
                continue
            rows[t].append(r)
            print(line(r), flush=True)
    for t, rs in rows.items():
        if rs:
            report(rs, t)


if __name__ == "__main__":
    main()
