"""A 3D finishing raster as a CAM post writes it: a zig-zag over a freeform surface, for benchmarks.

    python benchmarks/make_raster.py OUT.ngc [--lines 1000000] [--cuts 1] [--seed 1]

The surface is z(x, y) = a sum of seeded Gaussian bumps and two sine waves (mm). Rows run along X,
each row's moves 0.05–0.2 mm long (a seeded step per row, the row's last move shorter so it ends on
the edge), rows 0.1 mm apart, joined by a step-over move on the surface: one continuous G1 chain
per cut. ``--cuts N`` splits the rows into N bands, each its own zig-zag, left and re-entered through
a retract to the safe height, a rapid and a plunge at the plunge feed. Header and footer as a post
writes them: G21 G90 G94 G17, T1 M6, G43 H1, S M3, safe Z, rapids, plunge, M5, M30. Coordinates to
4 decimals; F written on the first cutting move after each plunge (modal afterwards). The same
arguments give the same bytes. ``--lines`` is the least number of feed moves (rows are added until it is reached).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

WIDTH_MM = 100.0            # X extent of every row
STEPOVER_MM = 0.1           # Y distance between rows
SAFE_Z_MM = 5.0
FEED_MM_MIN = 2000.0
PLUNGE_MM_MIN = 300.0
MIN_STEP_MM, MAX_STEP_MM = 0.05, 0.2


def surface(x: np.ndarray, y: np.ndarray, rng_seed: int) -> np.ndarray:
    """z(x, y): seeded Gaussian bumps (heights ±4 mm, widths 6–25 mm) plus two sines, at most a few mm."""
    rng = np.random.default_rng(rng_seed)
    z = 0.8 * np.sin(x / 7.0) * np.cos(y / 11.0) + 0.3 * np.sin((x + 2 * y) / 3.0)
    for _ in range(8):
        cx, cy = rng.uniform(0, WIDTH_MM), rng.uniform(0, 120.0)
        h, w = rng.uniform(-4, 4), rng.uniform(6, 25)
        z = z + h * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2 * w * w))
    return z - 6.0     # below the stock top


def row_x(step: float) -> np.ndarray:
    n = int(np.floor(WIDTH_MM / step))
    x = np.arange(n + 1) * step
    if WIDTH_MM - x[-1] > 1e-9:
        x = np.append(x, WIDTH_MM)
    return x


def fmt(values: np.ndarray) -> list[str]:
    return [f"{v:.4f}" for v in np.round(values, 4) + 0.0]


def write_raster(out, lines: int = 1_000_000, cuts: int = 1, seed: int = 1) -> dict:
    """Write the raster to the text handle ``out``; return its figures (moves, rows, cuts)."""
    if lines < 10 or cuts < 1:
        raise ValueError("lines must be >= 10 and cuts >= 1")
    rng = np.random.default_rng(seed)
    steps, total = [], 0
    while total < lines - 20 or len(steps) < 2:      # rows until the moves reach ``lines``
        steps.append(rng.uniform(MIN_STEP_MM, MAX_STEP_MM))
        total += row_x(steps[-1]).size
    n_rows = len(steps)
    cuts = min(cuts, n_rows)
    w = out.write
    w("%\n(fuzzyfeed benchmark raster: 3D finishing, ball end mill 6 mm)\n")
    w(f"(seed {seed}, {n_rows} rows, {cuts} cuts, stepover {STEPOVER_MM} mm)\n")
    w("G21 G90 G94 G17 G40 G49 G80\nG64 P0.01\nT1 M6\nG43 H1\nS12000 M3\nM8\n")
    w(f"G0 Z{SAFE_Z_MM:.4f}\n")
    bands = np.array_split(np.arange(n_rows), cuts)
    moves = 0
    for band in bands:
        first = True
        direction = 1 if band[0] % 2 == 0 else -1
        for r in band:
            y = r * STEPOVER_MM
            x = row_x(steps[r])[::direction]
            z = surface(x, np.full(x.size, y), seed)
            xs, ys, zs = fmt(x), f"{y:.4f}", fmt(z)
            if first:
                w(f"G0 X{xs[0]} Y{ys}\nG0 Z{float(zs[0]) + 1.0:.4f}\n")
                w(f"G1 Z{zs[0]} F{PLUNGE_MM_MIN:.0f}\n")
                w(f"G1 X{xs[1]} Z{zs[1]} F{FEED_MM_MIN:.0f}\n")
                start = 2
                moves += 2
                first = False
            else:                               # step-over on the surface, then the row
                w(f"G1 X{xs[0]} Y{ys} Z{zs[0]}\n")
                start = 1
                moves += 1
            w("".join(f"G1 X{a} Z{b}\n" for a, b in zip(xs[start:], zs[start:])))
            moves += x.size - start
            direction = -direction
        w(f"G0 Z{SAFE_Z_MM:.4f}\n")
    w("M9\nM5\nG0 X0.0000 Y0.0000\nM30\n%\n")
    return {"moves": moves, "rows": n_rows, "cuts": cuts}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("output", help="program to write (.ngc)")
    parser.add_argument("--lines", type=int, default=1_000_000, help="about this many lines (default: %(default)s)")
    parser.add_argument("--cuts", type=int, default=1, help="zig-zag bands, each its own cut (default: 1)")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    try:
        with open(args.output, "w", newline="\n") as handle:
            info = write_raster(handle, args.lines, args.cuts, args.seed)
    except ValueError as exc:
        sys.exit(f"make_raster: {exc}")
    print(f"wrote {args.output}: {info['moves']} feed moves, {info['rows']} rows, {info['cuts']} cut(s)")


if __name__ == "__main__":
    main()
