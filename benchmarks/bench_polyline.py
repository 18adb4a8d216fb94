"""Point-sequence curvature (fuzzyfeed.geometry.polyline) against the paper's three-point estimate
(seed 002 eq. 4–9, a few vectorised numpy lines: the anchor), on the infinity shape sampled
uniformly in arc length, rounded to 3 decimals (what a CAM post writes) and at full precision.

    python benchmarks/bench_polyline.py [--points 20000] [--repeat 3]

Prints points/s of both and their ratio, plus the error of both against the NURBS curvature
(max and 95th percentile, relative to the largest κ). The first call is timed on its own line
(``first call``: from :data:`fuzzyfeed.geometry.polyline_runs.COMPILED_MIN_VERTICES` vertices on it includes
importing numba and loading, or once after an install compiling, the run search), the figures
after it are the best of --repeat later calls. The last line is slowdown_vs_three_point=X
(rounded points).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from fuzzyfeed.io.shapes import load_shape
from fuzzyfeed.geometry.polyline import polyline_curvature
from fuzzyfeed.geometry.sampling import sample_by_arc_length, three_point_curvature


def best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=20000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    curve = load_shape("infinity").curve
    samples = sample_by_arc_length(curve, n=args.points)
    ratio = None
    for label, pts in (("3 decimals", np.round(samples.xyz[:, :2], 3)),
                       ("full precision", samples.xyz[:, :2].copy())):
        t_first = best(lambda: polyline_curvature(pts), 1)
        print(f"{label}: first call {t_first:.3f} s")
        t_ours = best(lambda: polyline_curvature(pts), args.repeat)
        t_three = best(lambda: three_point_curvature(pts), args.repeat)
        scale = samples.curvature.max()
        e_ours = np.abs(polyline_curvature(pts).curvature - samples.curvature)[3:-3] / scale
        e_three = np.abs(three_point_curvature(pts) - samples.curvature)[3:-3] / scale
        print(f"{label}: {args.points} points  polyline_curvature {args.points / t_ours:,.0f} points/s"
              f"  three-point {args.points / t_three:,.0f} points/s  ratio {t_ours / t_three:.0f}x")
        print(f"  error vs NURBS κ (of max κ): polyline max {e_ours.max():.4f} p95 "
              f"{np.percentile(e_ours, 95):.4f}; three-point max {e_three.max():.4f} p95 "
              f"{np.percentile(e_three, 95):.4f}")
        if ratio is None:
            ratio = t_ours / t_three
    print(f"slowdown_vs_three_point={ratio:.1f}")


if __name__ == "__main__":
    main()
