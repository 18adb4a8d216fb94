"""`fuzzyfeed batch` on a library of 1000 programs against a shell loop of `fuzzyfeed advise`.

    python benchmarks/bench_batch.py [--files 1000] [--public DIR ...] [--shell-sample 50]

The library: every public program under the --public folders (default: benchmarks/library/programs
and LinuxCNC's /usr/share/linuxcnc/ncfiles when present; files with the same bytes once), the rest
generated (seeded) with the dialect writers of tests/programs/make_corpus.py: FreeCAD, Fusion,
GRBL and LinuxCNC styles, random shapes, sizes and feeds, one to three operations. Refused public
programs stay in: a real library has them.

Measured as a user runs them, wall-clock, each command in a fresh process on a fresh RESULTS_DIR:

- ``shell``: the serial loop ``for f in ...; do fuzzyfeed advise $f -o OUT.csv --gcode OUT; done``
  on --shell-sample files of the same mix (every k-th file in order of its work in the one-worker
  batch), extrapolated to all files (sample mean × files);
- ``batch --workers 1`` and ``batch`` on all cores, on all files;
- the growth: ``batch`` on all cores on 100 files of the same mix (every tenth file in order of
  its work) against all files: time per file after the start-up (the command's start to its
  "running on" line) and the exponent of the total times.
- the costs a cluster beyond this machine is made of: per worker (a worker process started and
  fuzzyfeed loaded into it), per task (the scheduler's round trip of an empty task, chunk of
  files), per file (its work; the bytes it reads and writes, what a shared folder carries).

Each phase prints its wall time, its CPU seconds (the command's with its worker processes') and the
load average around it: on a shared machine the wall-clock ratios move with the load of the
moment, the CPU seconds much less. The last line: ``shell_over_batch=... cores_over_one=...
growth_exponent=...`` (goals: ≥ 5, ≥ 1.8 on 2 cores, 1: time after start-up proportional to the
files) and the same ratios in CPU seconds.
"""

from __future__ import annotations

import argparse
import hashlib
import math
import os
import random
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
FUZZYFEED = str(Path(sys.executable).with_name("fuzzyfeed"))
SUFFIXES = (".ngc", ".nc", ".gcode", ".gc", ".tap", ".cnc")


def public_programs(folders: list[Path]) -> list[Path]:
    """Every program under ``folders``, each distinct content once."""
    seen, found = set(), []
    for folder in folders:
        for path in sorted(folder.rglob("*")):
            if path.is_file() and path.suffix.lower() in SUFFIXES:
                digest = hashlib.sha256(path.read_bytes()).hexdigest()
                if digest not in seen:
                    seen.add(digest)
                    found.append(path)
    return found


def generated_program(rng: random.Random, k: int) -> str:
    """A program in one of the corpus's four dialects: 1-3 operations of random shapes."""
    sys.path.insert(0, str(ROOT / "tests" / "programs"))
    import make_corpus as mc

    ops = []
    for op in range(rng.randint(1, 3)):
        geometry = rng.choice(mc.GEOMETRIES)
        ops.append((1 + op, rng.choice([400, 600, 800, 1000, 1200, 1500, 2000]),
                    rng.choice([100, 150, 200, 300]), geometry(rng.uniform(0.6, 2.5))))
    dialect = k % 4
    if dialect == 0:
        lines = mc.freecad(ops, f"part {k}")
    elif dialect == 1:
        lines = mc.fusion(ops, f"part {k}", use_r=rng.random() < 0.5, numbers=rng.random() < 0.6)
    elif dialect == 2:
        lines = mc.grbl(ops, f"part {k}", style=rng.choice(["lower", "packed", "plain"]))
    else:
        lines = mc.lcnc(ops[:2], f"part {k}", rng.randrange(12))
    return "\n".join(lines) + "\n"


def make_library(folder: Path, files: int, public: list[Path], seed: int = 31) -> tuple[int, int]:
    """``files`` programs under ``folder`` (jobs of 25): the public ones, then generated ones."""
    rng = random.Random(seed)
    count = 0
    for path in public[:files]:
        target = folder / "public" / f"job{count // 25:03d}" / path.name
        if target.exists():
            target = target.with_name(f"{count}_{path.name}")
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(path, target)
        count += 1
    n_public = count
    while count < files:
        target = folder / "generated" / f"job{count // 25:03d}" / f"part{count:04d}{rng.choice(SUFFIXES[:4])}"
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(generated_program(rng, count))
        count += 1
    return n_public, count - n_public


def child_cpu() -> float:
    """CPU seconds of every finished child process so far (a batch's workers are its children and
    count in it once it has reaped them)."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run_batch(library: Path, out: Path, extra: list[str]) -> tuple[float, float, float, pd.DataFrame]:
    """(wall time of the command, its start-up: start to its "running on" line, its CPU seconds with
    its workers', the summary)."""
    cpu = child_cpu()
    start = time.perf_counter()
    proc = subprocess.Popen([FUZZYFEED, "batch", str(library), "--out", str(out), *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    ready = None
    for line in proc.stdout:
        if ready is None and line.startswith("running on"):
            ready = time.perf_counter() - start
    proc.wait()
    wall = time.perf_counter() - start
    if proc.returncode not in (0, 1):
        sys.exit(f"batch failed ({proc.returncode}): {proc.stderr.read()}")
    return wall, ready or 0.0, child_cpu() - cpu, pd.read_csv(out / "summary.csv", keep_default_na=False)


def shell_loop(paths: list[Path], out: Path) -> tuple[list[float], float]:
    """Each file through its own `fuzzyfeed advise` process, one after the other (wall seconds of
    each, CPU seconds of all)."""
    cpu = child_cpu()
    times = []
    for n, path in enumerate(paths):
        start = time.perf_counter()
        subprocess.run([FUZZYFEED, "advise", str(path), "-o", str(out / f"{n}.csv"), "--gcode",
                        str(out / f"{n}.ngc")], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        times.append(time.perf_counter() - start)
    return times, child_cpu() - cpu


def cluster_costs(workers: int) -> dict[str, float]:
    """Per worker: a local cluster's start and fuzzyfeed loaded into every worker (as a batch's first
    file does); per task: the scheduler's round trip of an empty task (mean of 400)."""
    import logging

    from distributed import Client, LocalCluster, wait

    start = time.perf_counter()
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=logging.CRITICAL) as cluster, Client(cluster) as client:
        started = time.perf_counter() - start
        client.run(_load_fuzzyfeed)
        loaded = time.perf_counter() - start
        for rounds in (50, 400):        # the first round warms the scheduler
            t = time.perf_counter()
            wait([client.submit(_nothing, i, pure=False) for i in range(rounds)])
            per_task = (time.perf_counter() - t) / rounds
    return {"start_s": started, "loaded_s": loaded, "per_task_ms": per_task * 1e3}


def _load_fuzzyfeed() -> None:
    """What a worker's first file loads: the advice pipeline and the program advisor (no parser)."""
    import importlib

    for module in ("fuzzyfeed.advice.pipeline", "fuzzyfeed.advice.program", "fuzzyfeed.program.feeds",
                   "fuzzyfeed.fuzzy.advisor"):
        importlib.import_module(module)


def _nothing(i: int) -> int:
    return i


def busy(out: Path) -> tuple[float, list[float]]:
    """The files' work summed over a run (wall seconds, from their manifest entries) and per worker."""
    import json

    per: dict[str, float] = {}
    for path in (out / ".manifest").rglob("*.json"):
        entry = json.loads(path.read_text())
        per[entry["worker"]] = per.get(entry["worker"], 0.0) + float(entry["compute_s"])
    return sum(per.values()), sorted(per.values())


def folder_bytes(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file() and ".manifest" not in p.parts)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--files", type=int, default=1000)
    parser.add_argument("--small", type=int, default=100, help="files of the growth run (default 100)")
    parser.add_argument("--public", type=Path, action="append", default=None,
                        help="folder of public programs (repeatable)")
    parser.add_argument("--shell-sample", type=int, default=50)
    parser.add_argument("--keep", type=Path, default=None, help="build the library and results here")
    args = parser.parse_args()
    from fuzzyfeed.batch.cluster import machine_cores

    cores = machine_cores()
    public_dirs = args.public or [p for p in (ROOT / "benchmarks" / "library" / "programs",
                                              Path("/usr/share/linuxcnc/ncfiles")) if p.is_dir()]
    work = args.keep or Path(tempfile.mkdtemp(prefix="bench_batch_"))
    library = work / "library"
    if library.exists():
        shutil.rmtree(library)
    n_public, n_generated = make_library(library, args.files, public_programs(public_dirs))
    print(f"cores: {cores} (load average {os.getloadavg()[0]:.1f}); library: {args.files} programs, "
          f"{n_public} public ({', '.join(map(str, public_dirs))}), {n_generated} generated; "
          f"{folder_bytes(library) / 1e6:.1f} MB", flush=True)

    load = os.getloadavg()[0]
    one_wall, one_ready, one_cpu, one = run_batch(library, work / "one", ["--workers", "1"])
    counts = one["status"].value_counts().to_dict()
    print(f"batch --workers 1: {one_wall:.1f} s ({one_ready:.1f} s to start), {one_cpu:.0f} CPU s; load "
          f"{load:.1f} -> {os.getloadavg()[0]:.1f}; {counts}", flush=True)
    load = os.getloadavg()[0]
    all_wall, all_ready, all_cpu, every = run_batch(library, work / "all", [])
    print(f"batch ({cores} workers): {all_wall:.1f} s ({all_ready:.1f} s to start), {all_cpu:.0f} CPU s; "
          f"load {load:.1f} -> {os.getloadavg()[0]:.1f}", flush=True)
    one_busy, _ = busy(work / "one")
    all_busy, per_worker = busy(work / "all")
    print(f"work of the files summed: {one_busy:.0f} s with one worker, {all_busy:.0f} s with {cores} "
          f"(per worker: {', '.join(f'{b:.0f} s' for b in per_worker)} of the run's {all_wall:.0f} s); "
          f"x{all_busy / one_busy:.2f}: the same files take that much longer side by side, what the "
          "cores left free by other jobs allow", flush=True)
    for name in ("one", "all"):     # the same results however many workers
        a = pd.read_csv(work / name / "summary.csv", keep_default_na=False)
        assert list(a["status"]) == list(one["status"])

    # the growth: the same mix of work, 100 files against all
    work_s = one.set_index("file")["compute_s"].replace("", 0).astype(float)
    order = work_s.sort_values().index.tolist()
    small = library.parent / "small"
    if small.exists():
        shutil.rmtree(small)
    for rel in order[:: max(1, len(order) // args.small)][: args.small]:
        (small / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(library / rel, small / rel)
    small_wall, small_ready, _, small_frame = run_batch(small, work / "small_out", [])
    n_small = len(small_frame)
    per_file_small = (small_wall - small_ready) / n_small
    per_file_all = (all_wall - all_ready) / len(every)
    scale = math.log(len(every) / n_small)
    growth = math.log((all_wall - all_ready) / (small_wall - small_ready)) / scale
    print(f"growth: {n_small} files {small_wall:.1f} s, {len(every)} files {all_wall:.1f} s; after start-up "
          f"{per_file_small * 1e3:.0f} ms and {per_file_all * 1e3:.0f} ms per file "
          f"(ratio {per_file_all / per_file_small:.2f}); exponent {growth:.2f} after start-up, "
          f"{math.log(all_wall / small_wall) / scale:.2f} of the totals", flush=True)

    # the shell loop on a sample of the same mix, extrapolated
    step = max(1, len(order) // args.shell_sample)
    sample = order[step // 2::step][: args.shell_sample]
    loop_out = work / "loop"
    loop_out.mkdir(exist_ok=True)
    load = os.getloadavg()[0]
    loop, loop_cpu = shell_loop([library / rel for rel in sample], loop_out)
    loop = np.array(loop)
    shell_wall = float(loop.mean()) * len(order)
    shell_cpu = loop_cpu / len(sample) * len(order)
    print(f"shell loop: {len(sample)} files in {loop.sum():.1f} s ({loop.mean():.2f} s each, "
          f"{loop_cpu / len(sample):.2f} CPU s each; load {load:.1f} -> {os.getloadavg()[0]:.1f}); "
          f"all {len(order)}: {shell_wall:.0f} s, {shell_cpu:.0f} CPU s", flush=True)

    costs = cluster_costs(cores)
    bytes_in = folder_bytes(library) / len(order)
    bytes_out = folder_bytes(work / "all") / len(order)
    from fuzzyfeed.batch.run import CHUNKS_PER_WORKER, MAX_FILES_PER_CHUNK

    chunks = f"up to {MAX_FILES_PER_CHUNK} files per task, about {CHUNKS_PER_WORKER} tasks per worker"
    print(f"per worker: cluster of {cores} started in {costs['start_s']:.1f} s, fuzzyfeed loaded in every "
          f"worker at {costs['loaded_s']:.1f} s; per task: {costs['per_task_ms']:.1f} ms of scheduler round "
          f"trip ({chunks}); per file: {float(work_s.mean()) * 1e3:.0f} ms of work (median "
          f"{float(work_s.median()) * 1e3:.0f} ms), {bytes_in / 1e3:.0f} kB read, {bytes_out / 1e3:.0f} kB "
          "written", flush=True)

    ratios = {"shell_over_batch": shell_wall / all_wall, "cores_over_one": one_wall / all_wall,
              "growth_exponent": growth, "per_file_ratio": per_file_all / per_file_small,
              "cpu_shell_over_batch": shell_cpu / all_cpu, "cpu_one_over_all": one_cpu / all_cpu}
    print(f"ratios: shell loop / batch {ratios['shell_over_batch']:.1f} (goal >= 5; CPU seconds "
          f"{ratios['cpu_shell_over_batch']:.1f}); batch --workers 1 / batch {ratios['cores_over_one']:.2f} "
          f"(goal >= 1.8 on 2 cores; CPU seconds {ratios['cpu_one_over_all']:.2f}: the parallel run's "
          f"extra work); growth exponent {growth:.2f} (linear: 1)")
    print(" ".join(f"{k}={v:.3f}" for k, v in ratios.items()) + f" cores={cores}")
    if args.keep is None:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
