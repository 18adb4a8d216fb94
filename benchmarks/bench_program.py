"""Whole-program advice on a large CAM-style program vs a plain Python read of the same file.

    python benchmarks/bench_program.py [--lines 100000] [--repeat 3]

Writes a program of --lines lines (a wavy spiral of short G1 moves with modal words, F changes
every 50 lines, comments, a tool change and rapids — what a CAM post writes), then times, best of
--repeat runs, in the same process (CPU time, the machine is shared):

- ``plain``: the anchor — Python reads the file, splits every line into words and parses every
  number with ``float`` (no G-code meaning at all);
- ``parse``: :func:`fuzzyfeed.program.read.read_program` (modal state, positions, cuts);
- ``advise -o x.csv``: read + advice of every cut + the per-sample CSV (full-precision floats):
  what ``fuzzyfeed advise PROGRAM -o x.csv`` computes, the issue's figure;
- ``advise --gcode``: read + advice + the program written back with its F words
  (``fuzzyfeed advise PROGRAM --gcode OUT``);
- ``both``: read + advice + CSV + program written back.

In-process (the command's start-up, imports and compiled kernels loaded once, is
benchmarks/bench_first_run.py's). The last line: ``ratio_vs_plain_read=...`` (advise -o x.csv /
plain), ``parse_ratio=...``, ``gcode_ratio=...`` and ``both_ratio=...``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np


def make_program(path: Path, n: int) -> None:
    t = np.linspace(0, 60 * np.pi, n)
    r = 20 + 30 * t / t[-1]
    x = r * np.cos(t) * (1 + 0.1 * np.sin(9 * t))
    y = r * np.sin(t)
    lines = ["%", "(benchmark program)", "G21 G90 G17 G94", "T1 M6", "G43 H1", "S12000 M3",
             "G0 X%.4f Y%.4f Z5" % (x[0], y[0]), "G1 Z-1 F300"]
    for i in range(1, n):
        if i % 50 == 1:
            lines.append("G1 X%.4f Y%.4f F%d" % (x[i], y[i], 1200 + 200 * ((i // 50) % 3)))
        elif i % 1000 == 0:
            lines.append("X%.4f Y%.4f (pass %d)" % (x[i], y[i], i // 1000))
        else:
            lines.append("X%.4f Y%.4f" % (x[i], y[i]))
    lines += ["G0 Z5", "M5", "M30", "%"]
    path.write_text("\n".join(lines[:n]) + "\n" if len(lines) > n else "\n".join(lines) + "\n")


def plain_read(path: Path) -> int:
    count = 0
    with open(path) as handle:
        for line in handle:
            for word in line.split():
                try:
                    float(word[1:])
                    count += 1
                except ValueError:
                    pass
    return count


def best(fn, repeat: int) -> float:
    out = float("inf")
    for _ in range(repeat):
        start = time.process_time()
        fn()
        out = min(out, time.process_time() - start)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--lines", type=int, default=100_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    from fuzzyfeed.fuzzy.rule_reader import load_rule_table
    from fuzzyfeed.io.csv import write_columns
    from fuzzyfeed.program.read import read_program
    from fuzzyfeed.program.rewrite import rewrite_program
    from fuzzyfeed.program.feeds import advice_columns, advise_program

    table = load_rule_table(None)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.ngc"
        make_program(path, args.lines)

        def read_advise():
            program = read_program(path)
            return program, advise_program(program, table)

        def write_csv(pa):
            write_columns(Path(tmp) / "out.csv", advice_columns(pa))

        def write_gcode(program, pa):
            text = rewrite_program(program, pa.piece_move, pa.piece_end, pa.piece_feed_mm_min)
            (Path(tmp) / "out.ngc").write_text(text)

        def csv_command():
            write_csv(read_advise()[1])

        def gcode_command():
            write_gcode(*read_advise())

        def both():
            program, pa = read_advise()
            write_csv(pa)
            write_gcode(program, pa)

        both()                                     # warm-up (imports, compiled kernels)
        t_plain = best(lambda: plain_read(path), args.repeat)
        t_parse = best(lambda: read_program(path), args.repeat)
        t_csv = best(csv_command, args.repeat)
        t_gcode = best(gcode_command, args.repeat)
        t_both = best(both, args.repeat)
        program, pa = read_advise()
        samples = sum(len(c.samples) for c in pa.cuts)
        print(f"program: {args.lines} lines, {pa.program.kind.size} moves, {pa.program.n_cuts} cut(s), "
              f"{samples} samples, {pa.piece_move.size} pieces")
        for name, t in (("plain read-split-float", t_plain), ("parse (read_program)", t_parse),
                        ("advise -o x.csv (read+advice+CSV)", t_csv),
                        ("advise --gcode (read+advice+write back)", t_gcode), ("both outputs", t_both)):
            print(f"{name:40s} {t:8.3f} s CPU  {args.lines / t / 1e3:9.1f} k lines/s  "
                  f"{t / t_plain:6.2f} x plain")
        print(f"ratio_vs_plain_read={t_csv / t_plain:.2f} parse_ratio={t_parse / t_plain:.2f} "
              f"gcode_ratio={t_gcode / t_plain:.2f} both_ratio={t_both / t_plain:.2f}")

if __name__ == "__main__":
    main()
