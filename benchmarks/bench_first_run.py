"""First run after a fresh install against the second (warm) run, CPU seconds of the child processes.

    python benchmarks/bench_first_run.py               # fresh venv, `pip install .` of this checkout
    python benchmarks/bench_first_run.py --reuse-env   # this interpreter, numba cache in an empty dir
    python benchmarks/bench_first_run.py --big-points 0 --fail-above 1.5   # the CI check

The fresh-venv mode installs the package (not editable) into a new virtual environment, so nothing
compiled or cached by earlier runs exists, then runs each command twice in subprocesses and takes
their CPU time from resource.getrusage(RUSAGE_CHILDREN). --reuse-env instead points NUMBA_CACHE_DIR
at an empty temporary folder (quicker; the package's .pyc files are then already there, as pip
writes them at install time anyway).

Commands: `fuzzyfeed advise infinity -o OUT.csv` and `fuzzyfeed shapes` (the goal: first run
≤ 1.5 × the warm one), and, for information, `advise butterfly --points 300000`, a call large
enough for the compiled kernels (its first run compiles them once; the second loads numba's cache).
The last line: first_over_warm=X (the worse of the two goal commands).
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def child_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def timed(cmd: list[str], env: dict, cwd: Path) -> float:
    start = child_cpu()
    done = subprocess.run(cmd, env=env, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if done.returncode:
        sys.exit(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stderr}")
    return child_cpu() - start


def fresh_venv(folder: Path) -> Path:
    """A new venv with this checkout installed (wheel build, dependencies from pip's index/cache)."""
    venv.EnvBuilder(with_pip=True).create(folder)
    python = folder / "bin" / "python"
    subprocess.run([str(python), "-m", "pip", "install", "-q", "--disable-pip-version-check", str(ROOT)],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return folder / "bin" / "fuzzyfeed"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--reuse-env", action="store_true",
                        help="use this interpreter with an empty NUMBA_CACHE_DIR instead of a fresh venv")
    parser.add_argument("--fail-above", type=float, default=None, metavar="R",
                        help="exit with code 1 if first_over_warm exceeds R (for CI, e.g. 1.5)")
    parser.add_argument("--big-points", type=int, default=300_000,
                        help="points of the informational large run (0: skip it)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="ff_first_run_") as tmp:
        tmp = Path(tmp)
        env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
        if args.reuse_env:
            exe = [sys.executable, "-m", "fuzzyfeed"]
            env["NUMBA_CACHE_DIR"] = str(tmp / "numba_cache")
            print(f"interpreter {sys.executable}, NUMBA_CACHE_DIR={env['NUMBA_CACHE_DIR']} (empty)")
        else:
            print("installing this checkout into a fresh venv ...", flush=True)
            exe = [str(fresh_venv(tmp / "venv"))]
        commands = {
            "advise infinity": ["advise", "infinity", "-o", str(tmp / "inf.csv")],
            "shapes": ["shapes"],
        }
        info = {}
        if args.big_points:
            info[f"advise butterfly --points {args.big_points}"] = [
                "advise", "butterfly", "--points", str(args.big_points), "-o", str(tmp / "big.csv")]
        ratios = []
        for label, cmd in {**commands, **info}.items():
            first = timed(exe + cmd, env, tmp)
            warm = timed(exe + cmd, env, tmp)
            ratio = first / warm
            note = "" if label in commands else "   (information: large enough to compile the kernels)"
            print(f"{label:<40} first {first:6.2f} s CPU   warm {warm:6.2f} s CPU   first/warm {ratio:5.2f}{note}")
            if label in commands:
                ratios.append(ratio)
    print(f"first_over_warm={max(ratios):.2f}")
    if args.fail_above is not None and max(ratios) > args.fail_above:
        sys.exit(f"first_over_warm={max(ratios):.2f} > {args.fail_above:g}")


if __name__ == "__main__":
    main()
