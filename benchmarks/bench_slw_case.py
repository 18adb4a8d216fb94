"""One bench_slw program case, timed alone: CPU of ``schedule`` (as bench_slw's cpu column), with an
optional cProfile of it, and the tick arrays saved for an array-by-array comparison between trees.

Run: PYTHONPATH=<tree> python benchmarks/bench_slw_case.py OUT PROGRAM MACHINE TRANSITION [--profile]
(PROGRAM a path in the library as bench_slw prints it, e.g. camotics/bear.nc; cut #1; MACHINE equal or
slow-y). Writes OUT.npz (t, s, u, xyz, v, a, j); prints one line "… cpu C ticks K T cycle".
Compare two runs: python benchmarks/bench_slw_case.py --compare A.npz B.npz
"""

from __future__ import annotations

import cProfile
import pstats
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_slw import LIBRARY, MACHINES  # noqa: E402


def compare(a_path: str, b_path: str) -> None:
    a, b = np.load(a_path), np.load(b_path)
    for k in a.files:
        x, y = a[k], b[k]
        if x.shape != y.shape:
            print(k, "shape", x.shape, y.shape)
            continue
        scale = max(float(np.abs(x).max()), 1e-300)
        diff = float(np.abs(x - y).max())
        print(k, "identical" if np.array_equal(x, y) else f"max diff / scale {diff / scale:.3g} (max diff {diff:.3g})")
    if "xyz" in a.files and a["xyz"].shape == b["xyz"].shape:
        apart = np.linalg.norm(a["xyz"] - b["xyz"], axis=1)
        print(f"max |xyz_a - xyz_b| per tick {float(apart.max()):.3g} mm; cycle time T "
              f"{float(a['t'][-1])!r} / {float(b['t'][-1])!r}")


def main() -> None:
    if sys.argv[1] == "--compare":
        compare(sys.argv[2], sys.argv[3])
        return
    import fuzzyfeed
    from fuzzyfeed.cli._limits import program_feed_limits
    from fuzzyfeed.io.shapes import load_shapes
    from fuzzyfeed.slw import schedule
    from fuzzyfeed.slw.warm import warm_kernels

    out, prog, machine, transition = sys.argv[1:5]
    profile = "--profile" in sys.argv[5:]
    shape = load_shapes(LIBRARY / prog)[0]
    limits, cap, _ = program_feed_limits(shape, MACHINES[machine])
    warm_kernels()
    prof = cProfile.Profile(time.process_time) if profile else None  # CPU, not wall: the machine is shared
    t0 = time.process_time()
    if prof:
        prof.enable()
    traj = schedule(shape.curve, limits, transition=transition, feed_cap=cap, planner="window")
    if prof:
        prof.disable()
    cpu = time.process_time() - t0
    print(f"{fuzzyfeed.__file__} {prog} {machine} {transition} cpu {cpu:.2f} ticks {traj.t_s.size} "
          f"T {traj.cycle_time_s:.4f}", flush=True)
    np.savez(out + ".npz", t=traj.t_s, s=traj.s_mm, u=traj.u, xyz=traj.xyz, v=traj.feed_mm_s,
             a=traj.acc_mm_s2, j=traj.jerk_mm_s3)
    if prof:
        pstats.Stats(prof).sort_stats("cumulative").print_stats(40)
        pstats.Stats(prof).sort_stats("tottime").print_stats(30)


if __name__ == "__main__":
    main()
