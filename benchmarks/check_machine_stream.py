"""Issue 36 over the whole library: the streamed machine model against the whole-array tick
reference (time, max contour error), and the uniform slowdown found on every program.

    python benchmarks/check_machine_stream.py [--machine reference] [--no-reference] [--only SUBSTR]

Per program: planned time, max contour error of the stream and of the reference
(:func:`fuzzyfeed.machine.trace.trace_motion`, every tick in memory: a few GB on the longest
programs), the uniform factor, how many trials it took, whether its whole checking run was made,
and the CPU seconds of each. The tests (tests/test_machine_stream.py) do the same comparison on the
programs up to 400 s; this script covers the rest.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--library", type=Path, default=HERE / "library")
    ap.add_argument("--machine", default="reference")
    ap.add_argument("--no-reference", action="store_true", help="skip the whole-array reference")
    ap.add_argument("--only", default="", help="programs whose path contains this")
    ap.add_argument("--skip", type=int, default=0, help="leave out the first N programs read")
    args = ap.parse_args(argv)

    from fuzzyfeed.errors import FuzzyfeedError
    from fuzzyfeed.machine.description import load_machine
    from fuzzyfeed.machine.trace import trace_motion
    from fuzzyfeed.program.read import read_program
    from fuzzyfeed.program.reference import uniform_slowdown
    from fuzzyfeed.program.run import program_path, run_program

    machine = load_machine(args.machine)
    with open(args.library / "MANIFEST.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["kind"] == "program" and r["fuzzyfeed_reads"] == "ok"
                and args.only in r["file"]][args.skip:]
    print("program | time s | stream max um | reference max um | |diff| um | stream CPU s | reference CPU s "
          "| uniform x | trials | whole check | uniform CPU s")
    worst_diff, found, n = 0.0, 0, 0
    for row in rows:
        try:
            program = read_program(args.library / row["file"])
        except FuzzyfeedError as exc:
            print(f"{row['file']} | not read: {exc}")
            continue
        path = program_path(program, machine.chord_tol_mm)
        if not path.chains:
            continue
        n += 1
        t0 = time.process_time()
        run = run_program(path, machine)
        t_stream = time.process_time() - t0
        ref_max, t_ref = float("nan"), float("nan")
        if not args.no_reference:
            t0 = time.process_time()
            ref_max = max(trace_motion(c.motion, machine, c.seg_measured).max_mm for c in path.chains) * 1e3
            t_ref = time.process_time() - t0
            worst_diff = max(worst_diff, abs(ref_max - run.max_um))
        t0 = time.process_time()
        u = uniform_slowdown(path, machine, run)
        t_uni = time.process_time() - t0
        found += not u.bounded
        print(f"{row['file']} | {run.time_s:.1f} | {run.max_um:.3f} | {ref_max:.3f} | "
              f"{abs(ref_max - run.max_um):.2e} | {t_stream:.2f} | {t_ref:.2f} | "
              f"{'<' if u.bounded else ''}{u.factor:.4g} | {u.runs} | {u.run is not None} | {t_uni:.2f}", flush=True)
    print(f"programs {n}; uniform factor found (not a bound) on {found}; largest |stream - reference| max {worst_diff:.2e} um")
    return 0


if __name__ == "__main__":
    sys.exit(main())
