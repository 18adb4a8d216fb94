"""SLW scheduler benchmark: does it work wherever users go, and how near the bound is it?

Paths (tests/slw_cases.py, the same families the tests draw from): the shipped shapes on the issue's
machine (6000 mm/min, 100 mm/s and 1000 mm/s² per axis, 10 000 mm/s³, 1 µm, 1 ms); random smooth
NURBS (degree 2-5, 2-D and 3-D, random weights, random and unequal per-axis limits); polylines
(rectangles, zig-zags, square passes, CAM-style chains of 10³-10⁵ segments) on the default machine
and on one with unequal axes.

Per path: failure or not; the worst ratio to every limit measured from the interpolated positions
at Ts (feed, axis velocity, axis acceleration, chord error; jerk from the profile); the cycle time
over the acceleration-limited time-optimal bound (path_bound, adaptive grid) of the path followed
(a polyline is followed as blended within G64 P0.01, fuzzyfeed.geometry.polyline_fit); the cycle time over a
jerk-limited floor (jerk_floor: legs between true corners as rest-to-rest moves) — where the floor
alone is over 1.5x the bound, no jerk-limited planner meets the issue's 1.5; on the shipped
shapes, the time the same blocks would take with seven-phase transitions instead of seed 000's
cosine ones (what the cosine shape costs, scurve_same_blocks); the CPU time of
``schedule``. Anchors in the same run: the bound against toppra 0.6 on infinity (DESIGN §6:
4.9008 s) and seed 000's approach 1 beside the default approach 2 on the shipped shapes.

Run: python benchmarks/bench_slw.py [--random N] [--no-huge]
Last line: median_ratio_to_bound=M worst_ratio_to_bound=W worst_compute_s=C speed_x_realtime=Y
(M and W over paths longer than one full stop; C the largest CPU time of one schedule; Y the
smallest cycle time / CPU time.)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import slw_cases  # noqa: E402

from fuzzyfeed.io.shapes import load_shape, shape_names  # noqa: E402
from fuzzyfeed.machine.limits import MachineLimits  # noqa: E402
from fuzzyfeed.slw import measure, path_bound, schedule  # noqa: E402
from fuzzyfeed.slw.profile import stop_distance  # noqa: E402

LIMITS = ("feed", "axis_vel", "axis_acc", "chord", "jerk")


def toppra_bound(curve, limits: MachineLimits, grid_points: int = 4000) -> float | None:
    """toppra 0.6 on the same path (a spline through arc-length samples of x, y, z, s; per-axis
    velocity/acceleration limits, the command feed as the velocity limit of s). None if absent."""
    try:
        import toppra as ta
        import toppra.algorithm as algo
        import toppra.constraint as constraint
    except ImportError:
        return None
    from fuzzyfeed.geometry.sampling import sample_by_arc_length

    ta.setup_logging("WARNING")
    smp = sample_by_arc_length(curve, n=4 * grid_points)
    path = ta.SplineInterpolator(smp.s, np.column_stack([smp.xyz, smp.s]))
    vel = np.array([[-v, v] for v in limits.axis_vel_mm_s] + [[-limits.feed_mm_s, limits.feed_mm_s]])
    acc = np.array([[-a, a] for a in limits.axis_acc_mm_s2] + [[-1e12, 1e12]])
    inst = algo.TOPPRA([constraint.JointVelocityConstraint(vel), constraint.JointAccelerationConstraint(acc)],
                       path, gridpoints=np.linspace(0.0, smp.s[-1], grid_points),
                       parametrizer="ParametrizeConstAccel")
    traj = inst.compute_trajectory(0, 0)
    return None if traj is None else float(traj.duration)


def seven_phase_s(dv: float, acc: float, jerk: float) -> float:
    """Duration of the fastest change of feed by |dv| under |a| ≤ acc, |j| ≤ jerk (the classic
    seven-phase ramp; symmetric, so it covers (v0 + v1)·T/2)."""
    dv = abs(dv)
    return dv / acc + acc / jerk if dv >= acc * acc / jerk else 2.0 * np.sqrt(dv / jerk)


def rest_to_rest_s(length: float, vel: float, acc: float, jerk: float) -> float:
    """Least time of a rest-to-rest move of ``length`` mm under |v| ≤ vel, |a| ≤ acc, |j| ≤ jerk
    (the classic seven-phase profile: the peak feed found by bisection)."""

    def ramp(v: float) -> float:  # duration of 0 → v
        return seven_phase_s(v, acc, jerk)

    lo, hi = 0.0, vel
    if hi * ramp(hi) > length:
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if mid * ramp(mid) <= length else (lo, mid)
    v = lo if hi * ramp(hi) > length else hi
    return 2.0 * ramp(v) + (length - v * ramp(v)) / v


def jerk_floor(curve, limits: MachineLimits, stop_fraction: float = 0.01) -> float:
    """A floor under every jerk-limited schedule (the tangential jerk ≤ J): the path cut where it
    turns a true corner passed at ≤ ``stop_fraction``·F (a stop up to that), each leg a
    rest-to-rest move under the feed and the tangential acceleration its axes allow — on a
    straight leg along T, min_j A_j/|T_j| and min(F, V_j/|T_j|), on a curved one |A|₂ and F.
    With the acceleration-limited bound it brackets what any jerk-limited planner can reach."""
    from fuzzyfeed.slw.preprocess import corners

    s_c, cap = corners(curve, limits)
    cuts = np.concatenate([[0.0], s_c[cap <= stop_fraction * limits.feed_mm_s], [curve.length]])
    acc = np.asarray(limits.axis_acc_mm_s2[:curve.dim])
    vel = np.asarray(limits.axis_vel_mm_s[:curve.dim])
    total = 0.0
    for a, b in zip(cuts[:-1], cuts[1:]):
        if b <= a:
            continue
        s = np.linspace(a, b, 9)[1:-1]
        t = np.abs(curve.evaluate(np.atleast_1d(curve.param_at_length(s)), order=1)[1])
        t /= np.linalg.norm(t, axis=1, keepdims=True)
        if np.ptp(t, axis=0).max() < 1e-9:  # straight
            with np.errstate(divide="ignore"):
                a_leg = float(np.min(np.where(t[0] > 0, acc / t[0], np.inf)))
                v_leg = float(min(limits.feed_mm_s, np.min(np.where(t[0] > 0, vel / t[0], np.inf))))
        else:
            a_leg, v_leg = float(np.linalg.norm(acc)), limits.feed_mm_s
        total += rest_to_rest_s(b - a, v_leg, a_leg, limits.jerk_mm_s3)
    return total


def scurve_same_blocks(traj, limits: MachineLimits) -> float:
    """The cycle time the same blocks would take with seven-phase (trapezoidal-acceleration)
    transitions instead of seed 000's cosine ones: each block from its junction feed to the next,
    through a peak no higher than the SLW's own, under the block's acceleration and the jerk J.
    What the cosine shape (required by the issue) costs on a path: its jerk is J only at the
    transition's ends, the seven-phase profile's all through its ramps."""
    jerk = limits.jerk_mm_s3

    def ramp(dv: float, acc: float) -> float:
        return seven_phase_s(dv, acc, jerk)

    total = 0.0
    for b in traj.blocks:
        top = max([seg.v1 for seg in b.segments] + [b.v_start, b.v_end])
        length = b.s1 - b.s0

        def dist(v: float) -> float:
            return 0.5 * (b.v_start + v) * ramp(v - b.v_start, b.acc_mm_s2) + \
                0.5 * (v + b.v_end) * ramp(v - b.v_end, b.acc_mm_s2)

        lo, hi = max(b.v_start, b.v_end), top
        if dist(hi) > length:
            for _ in range(80):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if dist(mid) <= length else (lo, mid)
            hi = lo
        total += ramp(hi - b.v_start, b.acc_mm_s2) + ramp(hi - b.v_end, b.acc_mm_s2) + \
            max(length - dist(hi), 0.0) / max(hi, 1e-12)
    return total


def run_case(name: str, curve, limits: MachineLimits, approach: int = 2) -> dict:
    t0 = time.process_time()
    try:
        traj = schedule(curve, limits, approach=approach)
    except Exception as exc:  # noqa: BLE001 - a benchmark reports every failure
        return {"name": name, "fail": f"{type(exc).__name__}: {exc}"[:200],
                "cpu": time.process_time() - t0}
    cpu = time.process_time() - t0
    bound = path_bound(traj.curve, limits)  # the path followed (a polyline: blended, module docstring)
    floor = max(jerk_floor(traj.curve, limits), bound.time_s)
    m = measure(traj)
    stop = stop_distance(limits.feed_mm_s, limits.tangential_acc_mm_s2, limits.jerk_mm_s3)
    return {"name": name, "length": curve.length, "cpu": cpu, "time": traj.cycle_time_s,
            "bound": bound.time_s, "grid_change": bound.grid_change,
            "ratio": traj.cycle_time_s / bound.time_s, "floor": floor,
            "ratio_floor": traj.cycle_time_s / floor, "worst": max(m[k] for k in LIMITS),
            "limit": max(LIMITS, key=lambda k: m[k]), "crit": traj.n_critical,
            "long": curve.length > 2 * stop, "scurve": scurve_same_blocks(traj, limits)}


def line(r: dict) -> str:
    if "fail" in r:
        return f"{r['name']:<26} FAILED after {r['cpu']:.2f} s: {r['fail']}"
    return (f"{r['name']:<26} {r['length']:9.1f} {r['time']:9.3f} {r['bound']:9.3f} {r['ratio']:6.3f} "
            f"{r['floor']:9.3f} {r['ratio_floor']:6.3f} "
            f"{r['grid_change']:8.1e} {r['worst']:6.4f} {r['limit']:>8} {r['crit']:6d} {r['cpu']:7.2f} "
            f"{'yes' if r['long'] else 'no':>5}")


HEADER = (f"{'path':<26} {'length mm':>9} {'SLW s':>9} {'bound s':>9} {'ratio':>6} {'floor s':>9} {'/floor':>6} "
          f"{'grid Δ':>8} "
          f"{'worst':>6} {'limit':>8} {'crit':>6} {'cpu s':>7} {'long':>5}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--random", type=int, default=220, help="random NURBS (default: %(default)s)")
    ap.add_argument("--no-huge", action="store_true", help="leave out the 10^5-segment polyline")
    args = ap.parse_args()
    default = MachineLimits()
    results = []
    print(f"machine (shipped shapes, default polylines): {default}")
    print(HEADER)
    print("-" * len(HEADER))
    for name in shape_names():
        curve = load_shape(name).curve
        schedule(curve, default)  # warm-up: numba caches, arc-length tables
        r = run_case(name, curve, default)
        r1 = run_case(f"{name} (approach 1)", curve, default, approach=1)
        results.append(r)
        print(line(r))
        print(line(r1))
    cases = [(n, c, lim) for n, c, lim in slw_cases.polyline_cases()]
    unequal = slw_cases.polyline_cases()[-1][2]
    for segments in (10_000, 100_000):
        if segments == 100_000 and args.no_huge:
            continue
        cases.append((f"cam{segments}/default", slw_cases.cam_polyline(segments), default))
    cases.append(("cam10000/unequal", slw_cases.cam_polyline(10_000, seed=1), unequal))
    for name, curve, lim in cases:
        r = run_case(name, curve, lim)
        results.append(r)
        print(line(r), flush=True)
    for seed in range(args.random):
        curve, lim = slw_cases.random_nurbs(seed)
        r = run_case(f"nurbs{seed} p{curve.degree} {curve.dim}-D", curve, lim)
        results.append(r)
        print(line(r), flush=True)
    print()
    inf = load_shape("infinity").curve
    ours = path_bound(inf, default)
    t0 = time.perf_counter()
    theirs = toppra_bound(inf, default)
    theirs_txt = "not installed" if theirs is None else f"{theirs:.4f} s ({time.perf_counter() - t0:.1f} s)"
    print(f"bound on infinity: ours {ours.time_s:.4f} s (grid halved: {100 * ours.grid_change:.4f} % change) | "
          f"toppra 0.6 {theirs_txt} | DESIGN §6 anchor 4.9008 s")
    ok = [r for r in results if "fail" not in r]
    fails = [r for r in results if "fail" in r]
    long_ = [r for r in ok if r["long"]]
    ratios = np.array([r["ratio"] for r in long_])
    worst = max(ok, key=lambda r: r["ratio"] if r["long"] else 0.0)
    over = [r for r in ok if r["worst"] > 1.005]
    slow = max(ok, key=lambda r: r["cpu"])
    per_100 = max(ok, key=lambda r: r["cpu"] / r["length"])
    speed = min(r["time"] / max(r["cpu"], 1e-9) for r in ok)
    print(f"paths: {len(results)}, failed: {len(fails)}, over a limit by > 0.5 %: {len(over)}, "
          f"longer than one full stop: {len(long_)}")
    print(f"ratio to the bound (paths longer than one full stop): median {np.median(ratios):.3f}, "
          f"90th percentile {np.percentile(ratios, 90):.3f}, worst {worst['ratio']:.3f} ({worst['name']}); "
          f"share ≤ 1.5: {np.mean(ratios <= 1.5) * 100:.1f} %")
    floors = np.array([r["ratio_floor"] for r in long_])
    worst_f = max(long_, key=lambda r: r["ratio_floor"])
    inherent = [r["name"] for r in long_ if r["ratio"] > 1.5 and r["floor"] > 1.5 * r["bound"]]
    print(f"ratio to the jerk-limited floor max(bound, legs rest-to-rest): median {np.median(floors):.3f}, "
          f"worst {worst_f['ratio_floor']:.3f} ({worst_f['name']}); paths over 1.5x the bound whose floor "
          f"alone is over 1.5x (no jerk-limited planner reaches 1.5): {len(inherent)} {inherent[:8]}")
    shapes = [r for r in results[:len(shape_names())] if "fail" not in r]
    print("seed 000's cosine transitions against seven-phase ones on the same blocks (ratio to the bound): "
          + ", ".join(f"{r['name']} {r['ratio']:.3f} -> {r['scurve'] / r['bound']:.3f}" for r in shapes))
    print(f"compute: worst {slow['cpu']:.2f} s ({slow['name']}, {slow['length']:.0f} mm); worst per 100 mm "
          f"{100 * per_100['cpu'] / per_100['length']:.2f} s ({per_100['name']})")
    print()
    print(f"median_ratio_to_bound={np.median(ratios):.4f} worst_ratio_to_bound={worst['ratio']:.4f} "
          f"worst_compute_s={slow['cpu']:.2f} speed_x_realtime={speed:.1f}")


if __name__ == "__main__":
    main()
