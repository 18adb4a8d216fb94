"""``fuzzyfeed plot SHAPE -o FILE.png``: the path coloured by curvature and κ against arc length."""

from __future__ import annotations

import argparse

from fuzzyfeed.cli import COMMANDS
from fuzzyfeed.cli._common import add_shape_argument, point_count
from fuzzyfeed.io.shapes import load_shape, sample_shape
from fuzzyfeed.geometry.sampling import sample_by_arc_length


def register(sub) -> None:
    p = sub.add_parser("plot", help=COMMANDS["plot"],
                       description="Draw the path coloured by curvature (log scale, 1/mm) next to "
                                   "curvature against arc length (mm).")
    add_shape_argument(p)
    p.add_argument("-o", "--output", required=True, metavar="FILE.png", help="PNG file to write")
    p.add_argument("--points", type=point_count, default=4000,
                   help="sample points, uniform in arc length (default: %(default)s)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from fuzzyfeed.report.plot import plot_shape_curvature

    shape = load_shape(args.shape)
    # a NURBS is drawn from points even in arc length; a polyline from its own vertices
    samples = sample_shape(shape) if shape.polyline is not None else sample_by_arc_length(shape.curve, n=args.points)
    plot_shape_curvature(samples, title=shape.name, output=args.output)
    print(f"wrote {args.output}")
    return 0
