"""The window's own schedules through fuzzyfeed.slw.phase_ticks: time and tick ratios come back?

Per case (the shipped shapes and a few random NURBS of tests/slw_cases.py, both machines of
bench_slw): ``schedule(curve, limits, transition="seven-phase")``; its profile (the released blocks'
segments, evaluated exactly) sampled as x = v² and a on an arc-length grid of ≤ ``--step`` mm plus
every block junction (``--no-junctions``: only the full stops; x = 0 there); ``ticks_from_phase``
on it: with the sampled a (a_grid) and the jerk limit, with a only, with J only;
then the same interpolation (interpolate_u "best") and the tick check's ratios (check.tick_ratios,
true corners left out of the path jerk as ``schedule`` does; and whether check.breach, the
schedule's own last check, refuses the ticks). Printed per case: the window's time,
the ticks' time over it and the worst ratio to each limit per variant, and the window's own.

Run: python benchmarks/phase_ticks_roundtrip.py [--random N] [--step 0.25]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import slw_cases  # noqa: E402

from fuzzyfeed.geometry.interpolate import interpolate_u  # noqa: E402
from fuzzyfeed.io.shapes import load_shape, shape_names  # noqa: E402
from fuzzyfeed.machine.limits import MachineLimits  # noqa: E402
from fuzzyfeed.slw import schedule  # noqa: E402
from fuzzyfeed.slw.check import breach, corner_ticks, tick_ratios  # noqa: E402
from fuzzyfeed.slw.lookahead import KINK_MIN  # noqa: E402
from fuzzyfeed.slw.phase_ticks import ticks_from_phase  # noqa: E402
from fuzzyfeed.slw.preprocess import joins  # noqa: E402

MACHINES = slw_cases.RECORDED_MACHINES
KEYS = ("feed", "acc", "jerk")
#: (label, pass the sampled a, pass the jerk limit)
VARIANTS = (("a+J", True, True), ("a", True, False), ("J", False, True))


def sampled_profile(traj, step: float, junctions_on: bool = True):
    """(s, x, a) of the window's profile on a grid of ≤ step mm with every full stop (and with
    ``junctions_on`` every block junction) on it."""
    segs = [seg for b in traj.blocks for seg in b.segments if seg.duration_s > 0.0]
    total = traj.curve.length
    scale = total / sum(seg.length_mm for seg in segs)     # as trajectory._sample_profile
    stops = np.array([b.s1 for b in traj.blocks[:-1] if b.v_end == 0.0]) * scale
    # every block junction on the grid too (the window's critical points: its valleys), as a
    # planner's grid has its corners and knots
    junctions = np.array([b.s1 for b in traj.blocks[:-1]]) * scale if junctions_on else stops
    grid = np.unique(np.concatenate([np.linspace(0.0, total, int(np.ceil(total / step)) + 1), junctions, stops]))
    grid = grid[np.concatenate([[True], np.diff(grid) > 1e-9 * total])]
    v, a, _ = slw_cases.profile_at(segs, grid, scale)
    at_stop = np.isin(grid, stops) | (grid == 0.0) | (grid == total)
    v[at_stop], a[at_stop] = 0.0, 0.0
    return grid, v * v, a


def ratios(curve, limits, s, jerk, kinks_u) -> dict[str, float]:
    u = interpolate_u(curve, s, "best")
    xyz = curve.evaluate(u, order=0)[0]
    if xyz.shape[1] == 2:
        xyz = np.hstack([xyz, np.zeros((xyz.shape[0], 1))])
    r = tick_ratios(xyz, jerk, limits, corner_ticks(u, kinks_u))
    return {"feed": max(r["feed"].max(), *(r[f"velocity {ax}"].max() for ax in "xyz")),
            "acc": max(r[f"acceleration {ax}"].max() for ax in "xyz"),
            "jerk": max(float(np.nanmax(r["path jerk"], initial=0.0)), float(r["jerk"].max())),
            "breach": breach(xyz, u, np.asarray(jerk), limits, kinks_u) is not None}


def run(name: str, curve, limits: MachineLimits, step: float, junctions_on: bool = True) -> dict:
    traj = schedule(curve, limits, transition="seven-phase", planner="window")
    s_j, _, _, jump = joins(traj.curve)
    kinks = s_j[jump.max(axis=1, initial=0.0) > KINK_MIN] if s_j.size else s_j
    kinks_u = np.atleast_1d(traj.curve.param_at_length(kinks)) if kinks.size else kinks
    grid, x, a = sampled_profile(traj, step, junctions_on)
    out = {"name": name, "time": traj.cycle_time_s,
           "window": ratios(traj.curve, limits, traj.s_mm, traj.jerk_mm_s3, kinks_u)}
    for label, a_grid, jerk in VARIANTS:
        t, s, v, acc, j = ticks_from_phase(grid, x, limits.ts_s, a_grid=a if a_grid else None,
                                           jerk_mm_s3=limits.jerk_mm_s3 if jerk else None)
        out[label] = ratios(traj.curve, limits, s, j, kinks_u)
        out[label]["time"] = float(t[-1]) / traj.cycle_time_s
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--random", type=int, default=6, help="random NURBS cases (seeds 0..N-1)")
    parser.add_argument("--step", type=float, default=0.25, help="grid spacing, mm")
    parser.add_argument("--no-junctions", action="store_true", help="the window's block junctions not on the grid")
    args = parser.parse_args()
    cases = [(n, load_shape(n).curve) for n in shape_names()]
    cases += [(f"nurbs{seed}", slw_cases.random_nurbs(seed)[0]) for seed in range(args.random)]
    print(f"{'case':<26} {'window s':>9} | " + " | ".join(
        f"{'T/Tw ' + v[0]:>9} {'feed':>7} {'acc':>7} {'jerk':>7}" for v in VARIANTS)
        + f" | window {'feed':>7} {'acc':>7} {'jerk':>7}")
    rows = []
    for name, curve in cases:
        for mname, lim in MACHINES.items():
            r = run(f"{name}/{mname}", curve, lim, args.step, not args.no_junctions)
            rows.append(r)
            print(f"{r['name']:<26} {r['time']:9.4f} | " + " | ".join(
                f"{r[v[0]]['time']:9.5f} " + " ".join(f"{r[v[0]][k]:7.4f}" for k in KEYS) for v in VARIANTS)
                + " |        " + " ".join(f"{r['window'][k]:7.4f}" for k in KEYS), flush=True)
    for label, _, _ in VARIANTS:
        time = np.array([r[label]["time"] for r in rows])
        excess = {k: max(r[label][k] / max(r["window"][k], 1e-300) for r in rows) for k in KEYS}
        over = {k: max(r[label][k] for r in rows) for k in KEYS}
        breaches = sum(r[label]["breach"] for r in rows)
        print(f"# {label}: time/window median {np.median(time):.5f} range [{time.min():.5f}, {time.max():.5f}]; "
              "worst ratio " + ", ".join(f"{k} {over[k]:.4f}" for k in KEYS)
              + "; worst over the window's own " + ", ".join(f"{k} {excess[k]:.4f}" for k in KEYS)
              + f"; check.breach: {breaches} of {len(rows)}")


if __name__ == "__main__":
    main()
