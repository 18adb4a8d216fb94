"""The numpy run search of the polyline curvature (fuzzyfeed.geometry.polyline_runs, cuts under
COMPILED_MIN_VERTICES vertices) on the searches a real ``advise`` makes, against another version of
the module, bit for bit.

    git show main:fuzzyfeed/geometry/polyline_runs.py > /tmp/main_runs.py
    python benchmarks/bench_run_search.py PROGRAM.ngc [--against /tmp/main_runs.py] [--repeat 2]

Runs ``fuzzyfeed advise PROGRAM -o <scratch>.csv`` once with the search's inputs recorded, then times
the recorded searches (CPU, best of --repeat), interleaved with the same searches of the --against
module, and counts the searches whose runs (first, last, κ, centre, axis) differ in any bit.
The last line is ``speedup=X differing=N``.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import io
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import fuzzyfeed.geometry.polyline_runs as runs
from fuzzyfeed.cli import main as cli_main


def recorded_searches(program: str) -> list[tuple]:
    """The inputs of every numpy run search of ``advise program``."""
    calls = []
    plain = runs._runs_numpy

    def record(pts, turn, maybe, tol, path_tol):
        calls.append((pts.copy(), turn.copy(), maybe.copy(), tol, path_tol))
        return plain(pts, turn, maybe, tol, path_tol)

    runs._runs_numpy = record
    try:
        with tempfile.TemporaryDirectory() as tmp, contextlib.redirect_stdout(io.StringIO()):
            cli_main(["advise", program, "-o", str(Path(tmp) / "advice.csv")])
    finally:
        runs._runs_numpy = plain
    return calls


def load_module(path: str):
    spec = importlib.util.spec_from_file_location("polyline_runs_against", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def cpu_of(search, calls, repeat: int):
    best, out = float("inf"), None
    for _ in range(repeat):
        t = time.process_time()
        out = [search(*c) for c in calls]
        best = min(best, time.process_time() - t)
    return best, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("program")
    ap.add_argument("--against", help="another polyline_runs.py (e.g. main's) to time and compare with")
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args()
    calls = recorded_searches(args.program)
    print(f"{args.program}: {len(calls)} numpy run searches, {sum(len(c[0]) for c in calls)} vertices")
    mine, found = cpu_of(runs._runs_numpy, calls, args.repeat)
    print(f"this tree: {mine:.2f} s CPU")
    if args.against:
        other, theirs = cpu_of(load_module(args.against)._runs_numpy, calls, args.repeat)
        differing = sum(any(np.asarray(a).tobytes() != np.asarray(b).tobytes() or np.shape(a) != np.shape(b)
                            for a, b in zip(x, y)) for x, y in zip(found, theirs))
        print(f"{args.against}: {other:.2f} s CPU")
        print(f"speedup={other / mine:.2f} differing={differing}")


if __name__ == "__main__":
    main()
