"""How near the jerk-limited floor is the whole-path LP (fuzzyfeed.slw.optimal), beside the window?

On bench_slw's built-in cases (shapes, polylines blended as ``schedule`` blends them, cam10000,
cusp-cubic, ``--random`` random NURBS; both machines): the LP's time T = Σ 2h/(√x_k + √x_{k+1})
on its grid (3h/√x next to a rest: the constant-jerk start), before any servo ticks, over the
floor (fuzzyfeed.slw.floor.jerk_floor), beside the window's seven-phase cycle time over the same
floor, in the same run; the LP's compute (CPU s) and iterations. ``--stride K`` keeps every K-th case.

Run: python benchmarks/slw_optimal_gain.py [--random N] [--stride K]
Last line: lp_median=… lp_worst=… window_median=… window_worst=… lp_worst_cpu_s=… (over the cases run).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_slw import cases  # noqa: E402

from fuzzyfeed.geometry.polyline_fit import fit_polyline  # noqa: E402
from fuzzyfeed.slw import path_bound, schedule  # noqa: E402
from fuzzyfeed.slw.floor import jerk_floor  # noqa: E402
from fuzzyfeed.slw.optimal import optimal_profile, profile_time  # noqa: E402
from fuzzyfeed.slw.warm import warm_kernels  # noqa: E402


def run(name: str, curve, limits) -> dict:
    followed = fit_polyline(curve).curve if curve.degree == 1 else curve
    bound = path_bound(followed, limits, halve=False)
    floor = jerk_floor(followed, limits, bound)
    t0 = time.process_time()
    log: list[float] = []
    s, x, _ = optimal_profile(followed, limits, log=log)
    cpu = time.process_time() - t0
    lp = profile_time(s, x, limits.jerk_mm_s3)
    t0 = time.process_time()
    window = schedule(curve, limits, transition="seven-phase", planner="window").cycle_time_s
    wcpu = time.process_time() - t0
    return {"name": name, "n": s.size, "lp": lp / floor, "window": window / floor, "bound": lp / bound.time_s,
            "cpu": cpu, "wcpu": wcpu, "its": len(log)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--random", type=int, default=110)
    ap.add_argument("--stride", type=int, default=1)
    args = ap.parse_args()
    warm_kernels()
    print(f"{'case':<34} {'nodes':>7} {'LP/floor':>9} {'win/floor':>9} {'LP/bound':>9} {'LP cpu':>7} {'its':>4} {'win cpu':>7}")
    rows = []
    for i, (name, curve, limits, _) in enumerate(cases(args.random, 0, builtin_only=True)):
        if i % args.stride:
            continue
        r = run(name, curve, limits)
        rows.append(r)
        print(f"{name:<34} {r['n']:7d} {r['lp']:9.4f} {r['window']:9.4f} {r['bound']:9.4f} {r['cpu']:7.2f} "
              f"{r['its']:4d} {r['wcpu']:7.2f}", flush=True)
    lp = np.array([r["lp"] for r in rows])
    win = np.array([r["window"] for r in rows])
    below = int((lp >= 1.0 - 1e-9).sum())
    print(f"{len(rows)} cases; LP over the floor: median {np.median(lp):.4f}, worst {lp.max():.4f}; window (seven-phase) "
          f"median {np.median(win):.4f}, worst {win.max():.4f}; LP faster than the window on {(lp < win).sum()}; "
          f"LP at or above the floor on {below}; LP/bound min {min(r['bound'] for r in rows):.4f}")
    print(f"lp_median={np.median(lp):.4f} lp_worst={lp.max():.4f} window_median={np.median(win):.4f} "
          f"window_worst={win.max():.4f} lp_worst_cpu_s={max(r['cpu'] for r in rows):.2f}")


if __name__ == "__main__":
    main()
