"""The machine model's tick pass alone, the plain scan against the fast path, in one process.

    python benchmarks/bench_tick_pass.py [P ...] [--library] [--machine reference [hobby-router ...]]

For every program: read, program_path, plan every chain (not timed), then
:func:`fuzzyfeed.machine.stream.stream_plan` over every chain with the nearest segment found by
scanning the window (``block=0``: the anchor) and by the pruned search (the default), CPU s each
(``time.process_time``; the compilation is paid before, on a small run), their ratio, and whether
the summaries are equal (max, p99 histogram, per-segment maxima, events): they must be bit for bit.
``--library``: every program of benchmarks/library its MANIFEST says fuzzyfeed reads, too. Last line:
the totals, ``all_equal=`` and the ratio of the summed CPU.
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.machine.planner import Motion, plan_motion
from fuzzyfeed.machine.stream import stream_plan
from fuzzyfeed.program.read import read_program
from fuzzyfeed.program.run import program_path


def _same(a, b) -> bool:
    same_time = a.max_time_s == b.max_time_s or (np.isnan(a.max_time_s) and np.isnan(b.max_time_s))
    arrays = ("hist_bins", "hist_counts", "seg_max_mm", "contour_mm", "nearest_segment", "nearest_xyz",
              "tick_segment", "max_xyz")
    return bool(a.max_mm == b.max_mm and same_time and a.air_max_mm == b.air_max_mm
                and all(np.array_equal(getattr(a, k), getattr(b, k)) for k in arrays))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("programs", nargs="*")
    ap.add_argument("--library", action="store_true")
    ap.add_argument("--machine", nargs="+", default=["reference"])
    args = ap.parse_args(argv)
    programs = list(args.programs)
    if args.library:
        lib = Path(__file__).resolve().parent / "library"
        with open(lib / "MANIFEST.csv", newline="") as f:
            programs += [str(lib / r["file"]) for r in csv.DictReader(f)
                         if r["kind"] == "program" and r["fuzzyfeed_reads"] == "ok"]
    totals = {0: 0.0, 8: 0.0}
    all_equal = True
    for name in args.machine:
        all_equal &= _bench(load_machine(name), programs, totals)
    print(f"all_equal={all_equal} scan_cpu_s={totals[0]:.2f} fast_cpu_s={totals[8]:.2f} "
          f"fast_over_scan={totals[8] / max(totals[0], 1e-9):.3f}")
    return 0 if all_equal else 1


def _bench(machine, programs, totals) -> bool:
    from fuzzyfeed.errors import FuzzyfeedError

    warm = Motion(np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0.0]]), np.array([20.0, 20.0]),
                  np.zeros(2, bool), np.full(3, np.nan))
    for block in (0, 8):
        stream_plan(plan_motion(warm, machine), machine, block=block)
    print(f"machine {machine.name}: program | segments | ticks | scan CPU s | fast CPU s | fast/scan | equal")
    ok = True
    for p in programs:
        try:
            path = program_path(read_program(p), machine.chord_tol_mm)
        except FuzzyfeedError as exc:
            print(f"{p} | not read: {exc}")
            continue
        plans = [(c, plan_motion(c.motion, machine)) for c in path.chains]
        segs = sum(pl.length.size for _, pl in plans)
        ticks = sum(pl.time_s for _, pl in plans) / machine.ts_s
        cpu, runs = {}, {}
        for block in (0, 8):
            t0 = time.process_time()
            runs[block] = [stream_plan(pl, machine, c.seg_measured, block=block) for c, pl in plans]
            cpu[block] = time.process_time() - t0
        equal = all(_same(a, b) for a, b in zip(runs[0], runs[8]))
        ok &= equal
        totals[0] += cpu[0]
        totals[8] += cpu[8]
        print(f"{p} | {segs} | {ticks:.3g} | {cpu[0]:.2f} | {cpu[8]:.2f} | {cpu[8] / max(cpu[0], 1e-9):.3f} | {equal}",
              flush=True)
    return ok


if __name__ == "__main__":
    raise SystemExit(main())
