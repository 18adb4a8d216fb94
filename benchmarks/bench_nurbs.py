"""Throughput of C, C', C'' evaluation: fuzzyfeed vs scipy BSpline (homogeneous + quotient rule)
vs geomdl, measured in the same run on every shipped shape.

    python benchmarks/bench_nurbs.py [--points 1000000] [--geomdl-points 2000] [--repeat 5]

Each figure is the best of --repeat runs (the machine is shared; the minimum is the least noisy
estimate). The last line gives the worst ratio over the shapes:
ratio_vs_scipy=X ratio_vs_geomdl=Y (throughput of fuzzyfeed divided by the anchor's).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.interpolate import BSpline

from fuzzyfeed.io.shapes import load_shape, shape_names


def best_time(fn, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def scipy_evaluator(curve):
    """C, C', C'' from scipy BSpline on homogeneous coordinates and the quotient rule."""
    homogeneous = np.hstack([curve.control_points * curve.weights[:, None], curve.weights[:, None]])
    spline = BSpline(curve.knots, homogeneous, curve.degree)
    d1, d2 = spline.derivative(1), spline.derivative(2)
    dim = curve.dim

    def evaluate(u):
        a0, a1, a2 = spline(u), d1(u), d2(u)
        w0, w1, w2 = a0[:, dim:], a1[:, dim:], a2[:, dim:]
        c = a0[:, :dim] / w0
        c1 = (a1[:, :dim] - w1 * c) / w0
        c2 = (a2[:, :dim] - 2 * w1 * c1 - w2 * c) / w0
        return c, c1, c2

    return evaluate


def geomdl_evaluator(curve):
    from geomdl import NURBS

    g = NURBS.Curve()
    g.degree = curve.degree
    g.ctrlptsw = [list(p * w) + [w] for p, w in zip(curve.control_points, curve.weights)]
    g.knotvector = list(curve.knots)
    return lambda u: [g.derivatives(float(x), order=2) for x in u]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--points", type=int, default=1_000_000)
    parser.add_argument("--geomdl-points", type=int, default=2000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()

    rng = np.random.default_rng(0)
    print(f"C, C', C'' throughput (points/s), {args.points:,} sorted random parameters "
          f"(geomdl: {args.geomdl_points:,}), best of {args.repeat}")
    print(f"{'shape':<10} {'fuzzyfeed':>12} {'scipy':>12} {'geomdl':>10} {'us/pt ff':>9} "
          f"{'x scipy':>8} {'x geomdl':>9}")
    ratios_scipy, ratios_geomdl = [], []
    for name in shape_names():
        curve = load_shape(name).curve
        u = np.sort(rng.uniform(*curve.domain, args.points))
        ug = u[:: max(1, args.points // args.geomdl_points)][: args.geomdl_points]
        curve.evaluate(u[:10])  # compile / load the cached kernel outside the timing
        scipy_eval = scipy_evaluator(curve)
        ref = scipy_eval(u[:1000])
        ours = curve.evaluate(u[:1000])
        for k in range(3):  # the figures compare equal work: same values
            np.testing.assert_allclose(ours[k], ref[k], rtol=1e-8, atol=1e-8 * np.abs(ref[k]).max())
        t_ff = best_time(lambda: curve.evaluate(u), args.repeat)
        t_sp = best_time(lambda: scipy_eval(u), args.repeat)
        geomdl_eval = geomdl_evaluator(curve)
        t_gd = best_time(lambda: geomdl_eval(ug), max(1, args.repeat // 2))
        ff, sp, gd = args.points / t_ff, args.points / t_sp, ug.size / t_gd
        ratios_scipy.append(ff / sp)
        ratios_geomdl.append(ff / gd)
        print(f"{name:<10} {ff:>12,.0f} {sp:>12,.0f} {gd:>10,.0f} {1e6 / ff:>9.3f} "
              f"{ff / sp:>8.2f} {ff / gd:>9.0f}")
    print(f"ratio_vs_scipy={min(ratios_scipy):.2f} ratio_vs_geomdl={min(ratios_geomdl):.0f}")


if __name__ == "__main__":
    main()
