"""Argument helpers shared by the subcommands."""

from __future__ import annotations

import argparse
import math

from fuzzyfeed.errors import MachineLimitsError


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0 (the error names the value and the rule)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number > 0")
    return value


def point_count(text: str) -> int:
    """argparse type: an integer number of sample points >= 3."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 3:
        raise argparse.ArgumentTypeError(f"{value} is too few; use at least 3 points")
    return value


def add_shape_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("shape", metavar="SHAPE",
                        help="a shipped shape's name (see `fuzzyfeed shapes`) or a file: shape "
                             "(.toml/.json), DXF (.dxf: SPLINE, LWPOLYLINE, POLYLINE), G-code "
                             "(.ngc/.nc/.gcode/.gc/.tap/.cnc: whole programs; each cut, a chain of feed "
                             "moves between rapids, is one path) or a CSV "
                             "point list (.csv: x_mm,y_mm[,z_mm] or x,y[,z]). A file with several "
                             "paths needs FILE#SELECTOR: DXF FILE#HANDLE, FILE#layer=NAME or "
                             "FILE#path=N; G-code FILE#N (cut N)")


def check_feed_mm_min(value: float) -> float:
    """The --feed-mm-min value, or a one-line MachineLimitsError."""
    if not math.isfinite(value) or value <= 0:
        raise MachineLimitsError(f"--feed-mm-min = {value:g}; the maximum feed must be a finite "
                                 "number > 0 mm/min")
    return value
