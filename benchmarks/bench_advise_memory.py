"""Peak memory (RSS) of `fuzzyfeed advise butterfly --points N -o x.csv` at 2.5·10⁵ and 10⁶ points
(10⁶ is the largest sampling `advise` accepts: fuzzyfeed.geometry.sampling.MAX_POINTS).

    python benchmarks/bench_advise_memory.py [--points 250000 1000000]

Each run is one child process; its own peak RSS comes from os.wait4. Printed beside two floors
measured in the same run: the start-up floor (`advise infinity`, 2000 points: interpreter, numpy,
pyarrow) and the output table itself (the CSV's float64 columns: 8 B × columns per point). The
last line: mb_per_million_points=X, the growth between the two largest runs per 10⁶ points, and
table_floor_mb_per_million_points=Y (the columns alone).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path


def run_child(cmd: list[str]) -> tuple[float, float]:
    """Peak RSS (MB) and CPU seconds of one child process."""
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    err = proc.stderr.read().decode()
    proc.stderr.close()
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode:
        sys.exit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{err}")
    scale = 1024.0 if sys.platform != "darwin" else 1.0   # ru_maxrss: KiB on Linux, bytes on macOS
    return usage.ru_maxrss * scale / 1e6, usage.ru_utime + usage.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--points", type=int, nargs="+", default=[250_000, 1_000_000])
    args = parser.parse_args()
    sizes = sorted(args.points)
    with tempfile.TemporaryDirectory(prefix="ff_bench_mem_") as tmp:
        out = Path(tmp) / "x.csv"
        base = [sys.executable, "-m", "fuzzyfeed", "advise"]
        floor_mb, floor_cpu = run_child(base + ["infinity", "-o", str(out)])
        print(f"start-up floor (advise infinity, 2000 points): {floor_mb:7.0f} MB  {floor_cpu:6.2f} s CPU")
        rows = []
        for n in sizes:
            mb, cpu = run_child(base + ["butterfly", "--points", str(n), "-o", str(out)])
            with open(out) as handle:
                columns = len(handle.readline().split(","))
            out.unlink()
            table_mb = 8.0 * columns * n / 1e6
            rows.append((n, mb))
            print(f"advise butterfly --points {n:>9}: peak {mb:7.0f} MB  {cpu:6.2f} s CPU  "
                  f"(above start-up {(mb - floor_mb) / (n / 1e6):6.0f} MB per 1e6 points; "
                  f"the {columns} output columns alone {table_mb:6.0f} MB)")
    if len(rows) >= 2:
        (n0, m0), (n1, m1) = rows[-2], rows[-1]
        per = (m1 - m0) / ((n1 - n0) / 1e6)
    else:
        per = (rows[0][1] - floor_mb) / (rows[0][0] / 1e6)
    print(f"mb_per_million_points={per:.0f} table_floor_mb_per_million_points={8.0 * columns:.0f}")


if __name__ == "__main__":
    main()
