"""The uniform slowdown on every library program (issue 36, item 3): found or a bound, the factor,
the trials, the whole checking run, and the places set apart (no factor holds the tolerance there).

    python benchmarks/bench_uniform.py [--machine reference] [--only SUBSTR] [--raster-lines N ...]
        [--no-library]

Per program (every program of benchmarks/library the MANIFEST says fuzzyfeed reads, in size order;
then the raster of benchmarks/make_raster.py at each ``--raster-lines``, one cut): lines, the
largest error as written, the status (``holds``: as written within the tolerance, factor 1;
``found``: the factor, checked by a whole run; ``found*``: found on the hot stretches, its whole run
past the tick budget; ``bound``: the search ran out), the factor, the trials (hot-stretch and whole
runs), the checking run's largest error outside the places set apart and over all, the places set
apart (count, largest error at F x 0.01, first line) and the CPU s of the uniform search (the
written run apart). Programs the machine model refuses are listed with the reason. Last line: the
count of each status.
"""

from __future__ import annotations

import argparse
import csv
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
LIBRARY = HERE / "library"


def programs(only: str | None) -> list[Path]:
    with open(LIBRARY / "MANIFEST.csv", newline="") as handle:
        rows = [r for r in csv.DictReader(handle) if r["kind"] == "program" and r["fuzzyfeed_reads"] == "ok"]
    rows.sort(key=lambda r: int(r["bytes"]))
    return [LIBRARY / r["file"] for r in rows if only is None or only in r["file"]]


def one(path: Path, machine, label: str) -> str:
    from fuzzyfeed.errors import FuzzyfeedError
    from fuzzyfeed.program.read import read_program
    from fuzzyfeed.program.reference import uniform_slowdown
    from fuzzyfeed.program.run import program_path, run_program

    try:
        program = read_program(path)
        pp = program_path(program, machine.chord_tol_mm)
        written = run_program(pp, machine)
    except FuzzyfeedError as exc:
        return f"{label} | refused: {str(exc)[:100]}"
    t0 = time.process_time()
    u = uniform_slowdown(pp, machine, written)
    cpu = time.process_time() - t0
    if written.max_um <= machine.contour_tol_um:
        status = "holds"
    elif u.bounded:
        status = "bound"
    else:
        status = "found" if u.run is not None else "found*"
    whole = f"{u.run.max_um:.1f}" if u.run is not None else "-"
    apart = (f"{len(u.apart)} (max {max(p.floor_um for p in u.apart):.1f} um at F x 0.01, first line "
             f"{u.apart[0].line + 1})" if u.apart else "0")
    return (f"{label} | {len(program.lines)} | {written.max_um:.1f} | {status} | "
            f"{'<' if u.bounded else ''}{u.factor:.4g} | {u.runs} | {u.max_um:.1f} | {whole} | {apart} | {cpu:.1f}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--machine", default="reference")
    parser.add_argument("--only", default=None, help="library programs whose path contains this")
    parser.add_argument("--raster-lines", nargs="*", type=int, default=[])
    parser.add_argument("--no-library", action="store_true")
    args = parser.parse_args(argv)
    from fuzzyfeed.machine.description import load_machine

    machine = load_machine(args.machine)
    print(f"machine {machine.name!r}, contour tolerance {machine.contour_tol_um:g} um")
    print("program | lines | written max um | status | factor | trials | max um (outside set apart) | "
          "whole run max um | set apart | uniform CPU s", flush=True)
    counts: dict[str, int] = {}
    todo = [] if args.no_library else [(p, str(p.relative_to(LIBRARY / "programs"))) for p in programs(args.only)]
    with tempfile.TemporaryDirectory(prefix="ff_bench_uniform_") as tmp:
        sys.path.insert(0, str(HERE))
        from make_raster import write_raster

        for n in args.raster_lines:
            out = Path(tmp) / f"raster_{n}.ngc"
            with open(out, "w") as handle:
                write_raster(handle, lines=n)
            todo.append((out, f"raster {n} lines"))
        for path, label in todo:
            line = one(path, machine, label)
            status = line.split(" | ")[3] if " | refused" not in line else "refused"
            counts[status] = counts.get(status, 0) + 1
            print(line, flush=True)
    print("programs " + str(sum(counts.values())) + ": " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
