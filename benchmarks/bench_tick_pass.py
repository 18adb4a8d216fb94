"""The machine model's tick pass alone, the plain scan against the fast path, in one process.

    python benchmarks/bench_tick_pass.py P [P ...] [--machine reference]

For every program: read, program_path, plan every chain (not timed), then
:func:`fuzzyfeed.machine.stream.stream_plan` over every chain with the nearest segment found by
scanning the window (``block=0``: the anchor) and by the pruned search (the default), CPU s each
(``time.process_time``; the compilation is paid before, on a small run), their ratio, and whether
the summaries are equal (max, p99 histogram, per-segment maxima, events): they must be bit for bit.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.machine.planner import Motion, plan_motion
from fuzzyfeed.machine.stream import stream_plan
from fuzzyfeed.program.read import read_program
from fuzzyfeed.program.run import program_path


def _same(a, b) -> bool:
    return (a.max_mm == b.max_mm and a.max_time_s == b.max_time_s or (np.isnan(a.max_time_s) and np.isnan(b.max_time_s))) \
        and np.array_equal(a.hist_bins, b.hist_bins) and np.array_equal(a.hist_counts, b.hist_counts) \
        and np.array_equal(a.seg_max_mm, b.seg_max_mm) and np.array_equal(a.contour_mm, b.contour_mm) \
        and np.array_equal(a.nearest_segment, b.nearest_segment) and a.air_max_mm == b.air_max_mm


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("programs", nargs="+")
    ap.add_argument("--machine", default="reference")
    args = ap.parse_args(argv)
    machine = load_machine(args.machine)
    warm = Motion(np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0.0]]), np.array([20.0, 20.0]),
                  np.zeros(2, bool), np.full(3, np.nan))
    for block in (0, 8):
        stream_plan(plan_motion(warm, machine), machine, block=block)
    print("program | segments | ticks | scan CPU s | fast CPU s | fast/scan | equal")
    for p in args.programs:
        path = program_path(read_program(p), machine.chord_tol_mm)
        plans = [(c, plan_motion(c.motion, machine)) for c in path.chains]
        segs = sum(pl.length.size for _, pl in plans)
        ticks = sum(pl.time_s for _, pl in plans) / machine.ts_s
        cpu, runs = {}, {}
        for block in (0, 8):
            t0 = time.process_time()
            runs[block] = [stream_plan(pl, machine, c.seg_measured, block=block) for c, pl in plans]
            cpu[block] = time.process_time() - t0
        equal = all(_same(a, b) for a, b in zip(runs[0], runs[8]))
        print(f"{p} | {segs} | {ticks:.3g} | {cpu[0]:.2f} | {cpu[8]:.2f} | {cpu[8] / cpu[0]:.3f} | {equal}",
              flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
