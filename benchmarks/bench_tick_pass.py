"""The machine model's tick pass alone: every tick searched against the fast path, in one process.

    python benchmarks/bench_tick_pass.py [P ...] [--library] [--machine reference [hobby-router ...]]

For every program: read, program_path, plan every chain (not timed), then
:func:`fuzzyfeed.machine.stream.stream_plan` over every chain with every measured tick searched
(``fast=False``: the tick pass, the anchor) and with the fast path (the default: ticks proven within
1 µm bounded, not searched; leaps along segments), CPU s each (``time.process_time``, the better of
``--repeat`` alternating runs; the compilation is paid before, on a small run), their ratio, the
share of measured ticks bounded (and of those leapt), and whether the fast path holds to the tick
pass: time and largest error (value and segment) equal, events equal, the p99 of the program equal
(or unsettled: the program run would run the chains again), every segment's largest error at or
above the tick pass's and within the threshold of it. ``--library``: every program of
benchmarks/library its MANIFEST says fuzzyfeed reads, too. Last line: the totals, ``all_hold=`` and
the ratio of the summed CPU.
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.machine.planner import Motion, plan_motion
from fuzzyfeed.machine.stream import percentile_settled, percentile_um, skip_threshold, stream_plan
from fuzzyfeed.program.read import read_program
from fuzzyfeed.program.run import program_path


def _holds(fast, ticks, skip_mm: float) -> bool:
    return bool(fast.plan.time_s == ticks.plan.time_s and abs(fast.max_mm - ticks.max_mm) <= 1e-9
                and fast.max_segment == ticks.max_segment and abs(fast.air_max_mm - ticks.air_max_mm) <= 1e-9
                and fast.part_ticks == ticks.part_ticks
                and np.all(fast.seg_max_mm >= ticks.seg_max_mm - 1e-12)
                and np.all(fast.seg_max_mm <= ticks.seg_max_mm + skip_mm + 1e-12)
                and np.array_equal(fast.tick_segment, ticks.tick_segment)
                and np.allclose(fast.contour_mm, ticks.contour_mm, rtol=0, atol=1e-9))


def _p99(runs) -> tuple[float, np.ndarray, np.ndarray]:
    bins = np.concatenate([r.hist_bins for r in runs]) if runs else np.zeros(0, np.int64)
    counts = np.concatenate([r.hist_counts for r in runs]) if runs else np.zeros(0, np.int64)
    ub, inv = np.unique(bins, return_inverse=True)
    cu = np.bincount(inv, weights=counts, minlength=ub.size).astype(np.int64)
    return (percentile_um(ub, cu, 99.0) if ub.size else 0.0), ub, cu


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("programs", nargs="*")
    ap.add_argument("--library", action="store_true")
    ap.add_argument("--machine", nargs="+", default=["reference"])
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args(argv)
    programs = list(args.programs)
    if args.library:
        lib = Path(__file__).resolve().parent / "library"
        with open(lib / "MANIFEST.csv", newline="") as f:
            programs += [str(lib / r["file"]) for r in csv.DictReader(f)
                         if r["kind"] == "program" and r["fuzzyfeed_reads"] == "ok"]
    totals = {"ticks": 0.0, "fast": 0.0, "part": 0, "skipped": 0, "leapt": 0}
    all_hold = True
    for name in args.machine:
        all_hold &= _bench(load_machine(name), programs, totals, max(args.repeat, 1))
    print(f"all_hold={all_hold} ticks_cpu_s={totals['ticks']:.2f} fast_cpu_s={totals['fast']:.2f} "
          f"fast_over_ticks={totals['fast'] / max(totals['ticks'], 1e-9):.3f} "
          f"bounded={totals['skipped'] / max(totals['part'], 1):.3f} leapt={totals['leapt'] / max(totals['part'], 1):.3f}")
    return 0 if all_hold else 1


def _bench(machine, programs, totals, repeat: int) -> bool:
    from fuzzyfeed.errors import FuzzyfeedError

    warm = Motion(np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0.0]]), np.array([20.0, 20.0]),
                  np.zeros(2, bool), np.full(3, np.nan))
    for fast in (False, True):
        stream_plan(plan_motion(warm, machine), machine, fast=fast)
    skip = skip_threshold(machine)
    print(f"machine {machine.name} (threshold {skip * 1e3:g} um): program | segments | ticks | ticks CPU s | "
          f"fast CPU s | fast/ticks | bounded | leapt | p99 ticks / fast um | holds")
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
        cpu, runs = {False: np.inf, True: np.inf}, {}
        for _ in range(repeat):
            for fast in (False, True):
                t0 = time.process_time()
                runs[fast] = [stream_plan(pl, machine, c.seg_measured, fast=fast) for c, pl in plans]
                cpu[fast] = min(cpu[fast], time.process_time() - t0)
        p_t, _, _ = _p99(runs[False])
        p_f, ub, cu = _p99(runs[True])
        settled = percentile_settled(ub, cu, 99.0, skip)
        holds = all(_holds(f, t, skip) for f, t in zip(runs[True], runs[False])) and (p_f == p_t or not settled)
        ok &= holds
        part = sum(r.part_ticks for r in runs[True])
        skipped = sum(r.skipped_ticks for r in runs[True])
        leapt = sum(r.leapt_ticks for r in runs[True])
        totals["ticks"] += cpu[False]
        totals["fast"] += cpu[True]
        totals["part"] += part
        totals["skipped"] += skipped
        totals["leapt"] += leapt
        p99 = f"{p_t:.3f} / {p_f:.3f}" + ("" if settled else " (unsettled: run again)")
        print(f"{p} | {segs} | {ticks:.3g} | {cpu[False]:.2f} | {cpu[True]:.2f} | "
              f"{cpu[True] / max(cpu[False], 1e-9):.3f} | {skipped / max(part, 1):.3f} | {leapt / max(part, 1):.3f} | "
              f"{p99} | {holds}", flush=True)
    return ok


if __name__ == "__main__":
    raise SystemExit(main())
