"""Peak memory of the G1-run fit of a one-cut 3-D raster's vertices (issue 36): the whole fit
(:func:`fuzzyfeed.geometry.polyline.polyline_curvature` on one array) against the fit in chunks
(:func:`fuzzyfeed.geometry.polyline_stream.fit_chunks`, the rows made again on every pass, as a
program's windows would be read again). Both print a hash of κ, tangents and corners: equal hashes,
the same result bit for bit. Run each under ``/usr/bin/time -v`` (one process per mode: max RSS).

    python benchmarks/bench_fit_memory.py --points 1000000 --mode stream
"""

from __future__ import annotations

import argparse
import hashlib
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_raster import MAX_STEP_MM, MIN_STEP_MM, STEPOVER_MM, row_x, surface  # noqa: E402


def raster_rows(points: int, seed: int = 1):
    """The raster's zig-zag (make_raster.py's rows, one cut) row by row, coordinates to 4 decimals."""
    rng = np.random.default_rng(seed)
    steps, total = [], 0
    while total < points or len(steps) < 2:
        steps.append(rng.uniform(MIN_STEP_MM, MAX_STEP_MM))
        total += row_x(steps[-1]).size
    direction = 1
    for r, step in enumerate(steps):
        x = row_x(step)[::direction]
        y = np.full(x.size, r * STEPOVER_MM)
        z = surface(x, y, seed)
        yield np.round(np.column_stack([x, y, z]), 4) + 0.0
        direction = -direction


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--points", type=int, default=1_000_000)
    parser.add_argument("--mode", choices=["whole", "stream"], required=True)
    args = parser.parse_args(argv)
    from fuzzyfeed.geometry.polyline import polyline_curvature
    from fuzzyfeed.geometry.polyline_stream import fit_chunks

    t0 = time.process_time()
    hashes = [hashlib.sha256() for _ in range(3)]
    if args.mode == "whole":
        pts = np.concatenate(list(raster_rows(args.points)))
        fit = polyline_curvature(pts)
        n, m, bounded = len(pts), -1, False
        parts = [(fit.curvature, fit.tangent, fit.corner)]
    else:
        streamed = fit_chunks(lambda: raster_rows(args.points))
        n, m, bounded = streamed.n, streamed.m, streamed.bounded
        parts = streamed.pieces()
    corners = 0
    for part in parts:
        for h, a in zip(hashes, part):
            h.update(np.ascontiguousarray(a).tobytes())
        corners += int(np.count_nonzero(part[2]))
    print(f"{args.mode}: {n} points, {m} vertices (bounded {bounded}), {corners} corners, "
          f"hash {'-'.join(h.hexdigest()[:12] for h in hashes)}, {time.process_time() - t0:.1f} s CPU")


if __name__ == "__main__":
    main()
