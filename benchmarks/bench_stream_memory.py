"""Memory of the plain advice in pieces beyond the program model, on rasters of several sizes.

    python benchmarks/bench_stream_memory.py [--lines 250000 1000000] [--cuts 1 100]

Per raster (benchmarks/make_raster.py, seed 1) one child process reads the program, then advises
it as ``advise -o`` does (fuzzyfeed.program.stream, the CSV written piece by piece). It prints the
RSS after the read (the program model: per-line and per-move arrays, every line's text), the peak
RSS of the read, and the peak RSS during the advice (VmHWM, reset after the read through
/proc/self/clear_refs) above the RSS after the read, split into the cut's run geometry (the G1
runs fitted once per cut on their vertices: per-move arrays) and the pieces. Linux only.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent

CHILD = r"""
import sys, time, resource
from fuzzyfeed.base.memory import fix_mmap_threshold
fix_mmap_threshold()
def status(key):
    for line in open('/proc/self/status'):
        if line.startswith(key):
            return int(line.split()[1]) / 1024.0
def reset():
    open('/proc/self/clear_refs', 'w').write('5')
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.program.read import read_program
from fuzzyfeed.program.cuts import cut_moves, run_geometry
from fuzzyfeed.program.stream import stream_program_advice
from fuzzyfeed.io.csv import ColumnStream
table = load_rule_table()
t0 = time.process_time()
program = read_program(sys.argv[1])
read_peak, after_read = status('VmHWM'), status('VmRSS')
reset()
longest = max(range(program.n_cuts), key=lambda k: program.cut_moves(k).size)
m, kd, c = cut_moves(program, longest)
geo = run_geometry(program, m, kd)
del geo, m, kd, c
geo_peak = status('VmHWM')
reset()
t1 = time.process_time()
pieces = 0
with open(sys.argv[2], 'w', newline='') as handle:
    out = ColumnStream(handle, sys.argv[2])
    for piece in stream_program_advice(program, table):
        out.write(piece.columns)
        pieces += 1
advice_peak = status('VmHWM')
print(f"{program.kind.size} {program.n_cuts} {pieces} {read_peak:.0f} {after_read:.0f} "
      f"{geo_peak - after_read:.0f} {advice_peak - after_read:.0f} {t1 - t0:.1f} {time.process_time() - t1:.1f}")
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--lines", type=int, nargs="+", default=[250_000, 1_000_000])
    parser.add_argument("--cuts", type=int, nargs="+", default=[1, 100])
    args = parser.parse_args()
    spec = __import__("importlib.util").util.spec_from_file_location("make_raster", HERE / "make_raster.py")
    mod = __import__("importlib.util").util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    print("lines      cuts  moves    pieces  read peak MB  after read MB  run geometry +MB  advice +MB  "
          "read CPU s  advice CPU s")
    with tempfile.TemporaryDirectory(prefix="ff_stream_mem_") as tmp:
        for n in args.lines:
            for cuts in args.cuts:
                path = Path(tmp) / f"r_{n}_{cuts}.ngc"
                with open(path, "w", newline="\n") as handle:
                    mod.write_raster(handle, n, cuts, 1)
                done = subprocess.run([sys.executable, "-c", CHILD, str(path), str(Path(tmp) / "x.csv")],
                                      capture_output=True, text=True)
                if done.returncode:
                    sys.exit(done.stderr)
                moves, ncuts, pieces, rp, ar, geo, adv, tr, ta = done.stdout.split()
                print(f"{n:<10d} {ncuts:>5s} {moves:>8s} {pieces:>6s}  {rp:>12s}  {ar:>13s}  {geo:>16s}  "
                      f"{adv:>10s}  {tr:>10s}  {ta:>12s}", flush=True)
                path.unlink()


if __name__ == "__main__":
    main()
