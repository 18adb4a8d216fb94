"""First run after a fresh install against the second (warm) run, and the warm start-up of the
README's main job beside the interpreter's own start-up, measured in the same run.

    python benchmarks/bench_first_run.py               # fresh venv, `pip install .` of this checkout
    python benchmarks/bench_first_run.py --reuse-env   # this interpreter, numba cache in an empty dir
    python benchmarks/bench_first_run.py --big-points 0 --fail-above 1.5   # the CI check

The fresh-venv mode installs the package (not editable) into a new virtual environment, so nothing
compiled or cached by earlier runs exists, then runs each command twice in subprocesses and takes
their CPU time from resource.getrusage(RUSAGE_CHILDREN). --reuse-env instead points NUMBA_CACHE_DIR
at an empty temporary folder (quicker). PYTHONDONTWRITEBYTECODE is dropped from the children's
environment: an installed package has its .pyc files, and without them every run compiles the
sources again.

Commands: `fuzzyfeed advise infinity -o OUT.csv` and `fuzzyfeed shapes` (the goal: first run
≤ 1.5 × the warm one), and, for information, `advise butterfly --points 300000`, a call large
enough for the compiled kernels (its first run compiles them once; the second loads numba's cache).

Warm start-up (issue 29, goal ≤ 0.8 s wall): `fuzzyfeed advise infinity -o OUT.csv` --warm-runs
more times, each run next to the anchors `python -c pass` and `python -c "import numpy"` of the
same interpreter (interleaved, so they share the machine's load); the least wall time and the
least CPU time (user + sys) of each, the ratio of advise to the numpy anchor, and the load average
before and after (on a shared machine the wall time follows the load; the CPU time much less).

The last lines: `warm_wall_s=... warm_cpu_s=... over_import_numpy=...` and `first_over_warm=X`
(the worse of the two goal commands).
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def child_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def timed(cmd: list[str], env: dict, cwd: Path) -> tuple[float, float]:
    """(CPU s, wall s) of one run of ``cmd``."""
    start, wall = child_cpu(), time.perf_counter()
    done = subprocess.run(cmd, env=env, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - wall
    if done.returncode:
        sys.exit(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stderr}")
    return child_cpu() - start, wall


def fresh_venv(folder: Path, env: dict) -> Path:
    """A new venv with this checkout installed (wheel build, dependencies from pip's index/cache)."""
    venv.EnvBuilder(with_pip=True).create(folder)
    python = folder / "bin" / "python"
    subprocess.run([str(python), "-m", "pip", "install", "-q", "--disable-pip-version-check", str(ROOT)],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    return folder / "bin"


def load() -> str:
    return "/".join(f"{x:.2f}" for x in os.getloadavg())


def warm_startup(commands: dict[str, list[str]], runs: int, env: dict, cwd: Path) -> dict[str, tuple[float, float]]:
    """Least (CPU, wall) over ``runs`` interleaved runs of each command (each run once before)."""
    best = {label: (float("inf"), float("inf")) for label in commands}
    for _ in range(runs):
        for label, cmd in commands.items():
            cpu, wall = timed(cmd, env, cwd)
            best[label] = (min(best[label][0], cpu), min(best[label][1], wall))
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--reuse-env", action="store_true",
                        help="use this interpreter with an empty NUMBA_CACHE_DIR instead of a fresh venv")
    parser.add_argument("--fail-above", type=float, default=None, metavar="R",
                        help="exit with code 1 if first_over_warm exceeds R (for CI, e.g. 1.5)")
    parser.add_argument("--big-points", type=int, default=300_000,
                        help="points of the informational large run (0: skip it)")
    parser.add_argument("--warm-runs", type=int, default=7, metavar="N",
                        help="runs of the warm start-up check, least time taken (0: skip it)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="ff_first_run_") as tmp:
        tmp = Path(tmp)
        env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "PYTHONDONTWRITEBYTECODE")}
        if args.reuse_env:
            python = sys.executable
            exe = [python, "-m", "fuzzyfeed"]
            env["NUMBA_CACHE_DIR"] = str(tmp / "numba_cache")
            print(f"interpreter {sys.executable}, NUMBA_CACHE_DIR={env['NUMBA_CACHE_DIR']} (empty)")
        else:
            print("installing this checkout into a fresh venv ...", flush=True)
            bin_dir = fresh_venv(tmp / "venv", env)
            python, exe = str(bin_dir / "python"), [str(bin_dir / "fuzzyfeed")]
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
            first, _ = timed(exe + cmd, env, tmp)
            warm, _ = timed(exe + cmd, env, tmp)
            ratio = first / warm
            note = "" if label in commands else "   (information: large enough to compile the kernels)"
            print(f"{label:<40} first {first:6.2f} s CPU   warm {warm:6.2f} s CPU   first/warm {ratio:5.2f}{note}")
            if label in commands:
                ratios.append(ratio)
        if args.warm_runs:
            before = load()
            best = warm_startup({"python -c pass": [python, "-c", "pass"],
                                 "python -c 'import numpy'": [python, "-c", "import numpy"],
                                 "fuzzyfeed advise infinity -o x.csv": exe + commands["advise infinity"]},
                                args.warm_runs, env, tmp)
            print(f"warm start-up, least of {args.warm_runs} interleaved runs (load average 1/5/15 min: "
                  f"{before} before, {load()} after, {os.cpu_count()} CPUs)")
            for label, (cpu, wall) in best.items():
                print(f"  {label:<36} {wall:6.3f} s wall  {cpu:6.3f} s CPU (user+sys)")
            cpu, wall = best["fuzzyfeed advise infinity -o x.csv"]
            numpy_cpu, numpy_wall = best["python -c 'import numpy'"]
            print(f"warm_wall_s={wall:.3f} warm_cpu_s={cpu:.3f} over_import_numpy={wall / numpy_wall:.2f} "
                  f"(CPU {cpu / numpy_cpu:.2f})")
    print(f"first_over_warm={max(ratios):.2f}")
    if args.fail_above is not None and max(ratios) > args.fail_above:
        sys.exit(f"first_over_warm={max(ratios):.2f} > {args.fail_above:g}")


if __name__ == "__main__":
    main()
