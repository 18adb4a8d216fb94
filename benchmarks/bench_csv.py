"""`fuzzyfeed advise butterfly --points N -o x.csv` (whole command, CPU of the child process) beside
pyarrow's own CSV writer writing a table of the same number of float columns and rows, in one run.

    python benchmarks/bench_csv.py [--points 1000000] [--csv-module]

The anchor writes random float64 columns (random magnitudes, so the digit counts are realistic)
with pyarrow.csv.write_csv, timed in this process after pyarrow is imported. --csv-module also times
Python's csv module writing the same table (repr floats, the writer fuzzyfeed had before).
Last line: ratio_vs_pyarrow=X (goal ≤ 3).
"""

from __future__ import annotations

import argparse
import csv
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np


def self_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def child_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--points", type=int, default=1_000_000)
    parser.add_argument("--csv-module", action="store_true", help="also time Python's csv module")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="ff_bench_csv_") as tmp:
        out = Path(tmp) / "x.csv"
        start = child_cpu()
        subprocess.run([sys.executable, "-m", "fuzzyfeed", "advise", "butterfly", "--points", str(args.points),
                        "-o", str(out)], check=True, stdout=subprocess.DEVNULL)
        advise_cpu = child_cpu() - start
        with open(out) as handle:
            names = handle.readline().strip().split(",")
        rows = args.points
        size_mb = out.stat().st_size / 1e6

        import pyarrow as pa
        import pyarrow.csv as pacsv

        rng = np.random.default_rng(0)
        table = {n: rng.standard_normal(rows) * 10.0 ** rng.integers(-4, 5, rows) for n in names}
        start = self_cpu()
        pacsv.write_csv(pa.table(table), str(Path(tmp) / "anchor.csv"))
        anchor_cpu = self_cpu() - start

        print(f"advise butterfly --points {rows}: {len(names)} columns, {size_mb:.0f} MB")
        print(f"  fuzzyfeed advise (whole command)  {advise_cpu:7.2f} s CPU")
        print(f"  pyarrow write_csv, same shape     {anchor_cpu:7.2f} s CPU")
        if args.csv_module:
            start = self_cpu()
            with open(Path(tmp) / "csvmod.csv", "w", newline="") as handle:
                writer = csv.writer(handle, lineterminator="\n")
                writer.writerow(names)
                writer.writerows(zip(*[table[n].tolist() for n in names]))
            print(f"  Python csv module, same shape     {self_cpu() - start:7.2f} s CPU")
    print(f"ratio_vs_pyarrow={advise_cpu / anchor_cpu:.2f}")


if __name__ == "__main__":
    main()
