"""``fuzzyfeed shapes``: the shipped shapes with their size, length and sharpest curvature."""

from __future__ import annotations

import argparse

from fuzzyfeed.cli import COMMANDS
from fuzzyfeed.io.shapes import load_shape, shape_names
from fuzzyfeed.geometry.sampling import max_curvature


def register(sub) -> None:
    p = sub.add_parser("shapes", help=COMMANDS["shapes"],
                       description="List the shipped shapes: degree, number of control points, arc "
                                   "length (mm, adaptive Gauss-Legendre) and maximum curvature (1/mm: "
                                   "64 samples per knot span, refined around the highest peaks).")
    p.set_defaults(run=run)


def shape_table() -> list[tuple[str, int, int, float, float]]:
    rows = []
    for name in shape_names():
        curve = load_shape(name).curve
        rows.append((name, curve.degree, curve.n_control_points, curve.length,
                     max_curvature(curve)[1]))
    return rows


def run(args: argparse.Namespace) -> int:
    header = f"{'name':<12} {'degree':>6} {'ctrl pts':>8} {'length (mm)':>12} {'max curvature (1/mm)':>21}"
    print(header)
    print("-" * len(header))
    for name, degree, n, length, kmax in shape_table():
        print(f"{name:<12} {degree:>6} {n:>8} {length:>12.3f} {kmax:>21.4f}")
    return 0
