"""SLW scheduler benchmark: cycle time against the time-optimal bound on every shipped shape,
scheduling speed, feed fluctuation of the interpolators, and WM's critical points and blocks.

Machine: the issue's efficiency limits (6000 mm/min, 100 mm/s and 1000 mm/s² per axis,
10 000 mm/s³, 1 µm, 1 ms). Anchors printed side by side in the same run: the phase-plane bound
(ours) and toppra 0.6 on the infinity path (4.9008 s quoted in DESIGN §6), and seed 000's
fluctuation figures (6.691 % first order, 0.035 % with parameter compensation, WM shape).

Run: /work/venv/bin/python benchmarks/bench_slw.py
Last line: infinity_ratio_to_bound=X worst_ratio_to_bound=W speed_x_realtime=Y
"""

from __future__ import annotations

import time

import numpy as np

from fuzzyfeed.interpolate import feed_fluctuation, interpolate_u
from fuzzyfeed.io.shapes import load_shape, shape_names
from fuzzyfeed.limits import MachineLimits, curvature_vectors, feed_limits
from fuzzyfeed.sampling import sample_by_arc_length
from fuzzyfeed.slw import measure, schedule, time_optimal_bound

BOUND_STEP_MM = 0.05
REPEATS = 3


def toppra_bound(curve, limits: MachineLimits, step_mm: float = BOUND_STEP_MM,
                 grid_points: int = 4000) -> float | None:
    """toppra 0.6 on the same path: a cubic spline through arc-length samples of (x, y, z, s), with
    per-axis velocity/acceleration limits on x, y, z and the command feed as the velocity limit of
    the fourth coordinate s (so s' ≤ F). The chord-error limit is not passed to toppra (it does not
    bind on infinity under these limits). None when toppra is not installed."""
    try:
        import toppra as ta
        import toppra.algorithm as algo
        import toppra.constraint as constraint
    except ImportError:
        return None
    ta.setup_logging("WARNING")
    samples = sample_by_arc_length(curve, step_mm=step_mm)
    s = np.asarray(samples.s)
    way = np.column_stack([np.asarray(samples.xyz), s])
    path = ta.SplineInterpolator(s, way)
    vel = np.array([[-v, v] for v in limits.axis_vel_mm_s] + [[-limits.feed_mm_s, limits.feed_mm_s]])
    acc = np.array([[-a, a] for a in limits.axis_acc_mm_s2] + [[-1e12, 1e12]])
    instance = algo.TOPPRA([constraint.JointVelocityConstraint(vel),
                            constraint.JointAccelerationConstraint(acc)], path,
                           gridpoints=np.linspace(0.0, s[-1], grid_points),
                           parametrizer="ParametrizeConstAccel")
    traj = instance.compute_trajectory(0, 0)
    return None if traj is None else float(traj.duration)


def fluctuation_row(traj) -> dict[str, float]:
    curve, s = traj.curve, traj.s_mm
    out = {}
    for method in ("taylor1", "taylor2", "compensated", "arc", "best"):
        u = interpolate_u(curve, s, method)
        out[method] = float(np.nanmax(feed_fluctuation(curve, u, s)) * 100.0)
    return out


def main() -> None:
    limits = MachineLimits.default()
    print(f"machine: {limits}")
    print()
    header = (f"{'shape':<10} {'length mm':>9} {'SLW s':>8} {'bound s':>8} {'ratio':>6} {'crit':>5} "
              f"{'blocks':>6} {'feed':>6} {'ax vel':>6} {'ax acc':>6} {'chord':>6} {'jerk':>6} "
              f"{'term um':>7} {'sched s':>8} {'x real':>7} {'ratio ap.2':>10}")
    print(header)
    print("-" * len(header))
    ratios, speeds, trajs = {}, {}, {}
    for name in shape_names():
        curve = load_shape(name).curve
        schedule(curve, limits)  # warm-up (numba caches, arc-length table)
        t0 = time.perf_counter()
        for _ in range(REPEATS):
            traj = schedule(curve, limits)
        elapsed = (time.perf_counter() - t0) / REPEATS
        m = measure(traj)
        _, bound_s = time_optimal_bound(sample_by_arc_length(curve, step_mm=BOUND_STEP_MM), limits)
        ratios[name] = traj.cycle_time_s / bound_s
        traj2 = schedule(curve, limits, approach=2)
        assert max(measure(traj2)[k] for k in ("feed", "axis_vel", "axis_acc", "chord", "jerk")) <= 1.005
        ratio2 = traj2.cycle_time_s / bound_s
        speeds[name] = traj.cycle_time_s / elapsed
        trajs[name] = traj
        print(f"{name:<10} {curve.length:9.3f} {traj.cycle_time_s:8.4f} {bound_s:8.4f} {ratios[name]:6.3f} "
              f"{traj.n_critical:5d} {traj.n_blocks:6d} {m['feed']:6.3f} {m['axis_vel']:6.3f} "
              f"{m['axis_acc']:6.3f} {m['chord']:6.3f} {m['jerk']:6.3f} "
              f"{1000 * m['terminal_error_mm']:7.1e} {elapsed:8.4f} {speeds[name]:7.1f} {ratio2:10.3f}")
    print("(feed .. jerk: worst ratio to the limit; feed, axis velocity/acceleration and chord error "
          "measured from the interpolated positions at Ts, jerk from the scheduled profile;\n"
          " ratio ap.2: the same schedule with Table 1's approach 2 for short blocks, `--approach 2`)")
    print()
    inf = load_shape("infinity").curve
    _, ours = time_optimal_bound(sample_by_arc_length(inf, step_mm=BOUND_STEP_MM), limits)
    t0 = time.perf_counter()
    theirs = toppra_bound(inf, limits)
    t_toppra = time.perf_counter() - t0
    theirs_txt = "not installed" if theirs is None else f"{theirs:.4f} s ({t_toppra:.1f} s to compute)"
    print(f"time-optimal bound on infinity: phase-plane pass {ours:.4f} s | toppra 0.6 {theirs_txt} | "
          f"DESIGN §6 anchor 4.9008 s")
    print()
    print("feed fluctuation max |chord/ΔL - 1| in % (positions at Ts against the commanded step):")
    print(f"{'shape':<10} {'taylor1':>10} {'taylor2':>10} {'compens.':>10} {'arc-exact':>10} {'best':>10}")
    for name, traj in trajs.items():
        row = fluctuation_row(traj)
        print(f"{name:<10} " + " ".join(f"{row[k]:10.3g}" for k in
                                          ("taylor1", "taylor2", "compensated", "arc", "best")))
    print("seed 000 (WM, its own limits): first order 6.691 %, parameter compensation 0.035 %")
    print()
    wm = trajs["wm"]
    print(f"WM shape: {wm.n_critical} critical points, {wm.n_blocks} blocks under these limits "
          f"(seed 000: 15 and 16 under its Table 3 limits, which the seed text lost); "
          f"critical points at s = {np.round(wm.critical_s_mm, 3).tolist()} mm")
    worst_name = max(ratios, key=ratios.get)
    print(f"worst ratio: {worst_name}")
    print()
    print(f"infinity_ratio_to_bound={ratios['infinity']:.4f} "
          f"worst_ratio_to_bound={ratios[worst_name]:.4f} "
          f"speed_x_realtime={min(speeds.values()):.1f}")


if __name__ == "__main__":
    main()
