"""Argument helpers shared by the subcommands."""

from __future__ import annotations

import argparse
import contextlib
import math
import sys



def positive_float(text: str) -> float:
    """argparse type: a finite number > 0 (the error names the value and the rule)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number > 0")
    from fuzzyfeed.machine.limits import MAX_LIMIT

    if value > MAX_LIMIT:
        raise argparse.ArgumentTypeError(f"{text!r} is too large; at most {MAX_LIMIT:g}")
    return value


def count_at_least(minimum: int, unit: str, maximum: int | None = None):
    """argparse type: an integer count of ``unit`` from ``minimum`` (to ``maximum``), the error
    naming the value and the rule."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"{value} is too few; use at least {minimum} {unit}")
        if maximum is not None and value > maximum:
            raise argparse.ArgumentTypeError(f"{value} is too many; use at most {maximum:,} {unit}")
        return value
    parse.__name__ = unit.replace(" ", "_")
    return parse


def point_count(text: str) -> int:
    """argparse type: an integer number of sample points, 3 to the sampling budget."""
    from fuzzyfeed.geometry.sampling import MAX_POINTS

    return count_at_least(3, "points", MAX_POINTS)(text)


def add_shape_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("shape", metavar="SHAPE",
                        help="a shipped shape's name (see `fuzzyfeed shapes`) or a file: shape "
                             "(.toml/.json), DXF (.dxf: contours chained from LINE, ARC, CIRCLE, "
                             "ELLIPSE, SPLINE, LWPOLYLINE, POLYLINE, also inside blocks), G-code "
                             "(.ngc/.nc/.gcode/.gc/.tap/.cnc: whole programs; each cut, a chain of feed "
                             "moves between rapids, is one path) or a CSV "
                             "point list (.csv: x_mm,y_mm[,z_mm] or x,y[,z]). A file with several "
                             "paths needs FILE#SELECTOR: DXF FILE#HANDLE, FILE#layer=NAME or "
                             "FILE#path=N; G-code FILE#N (cut N)")
    parser.add_argument("--units", choices=("mm", "inch", "m"), default=None,
                        help="units of a DXF drawing's coordinates, overriding its $INSUNITS "
                             "(default: the header's $INSUNITS; a drawing without it is read as mm "
                             "with a notice). Other files state their own units")
    parser.add_argument("--point-tolerance", type=positive_float, default=None, metavar="MM",
                        help="how far the points of a point sequence (G1 chain, CSV, DXF polyline) "
                             "may be from the path they describe, in mm (default: half the "
                             "rounding of their coordinates, read from the decimals they are "
                             "written with). Curvature is estimated within it")
    parser.add_argument("--path-tolerance", type=positive_float, default=None, metavar="MM",
                        help="the controller's blend tolerance at corners of a point sequence, as "
                             "LinuxCNC's G64 P, in mm (default: 0.01); a corner's curvature is "
                             "that of the blend arc within it")


@contextlib.contextmanager
def shape_context(args: argparse.Namespace):
    """While a command runs: ``--units`` applied to DXF loading (refused for other files),
    ``--point-tolerance``/``--path-tolerance`` to point-sequence curvature
    (:func:`fuzzyfeed.advice.options.shape_settings`), and
    :class:`~fuzzyfeed.errors.FuzzyfeedNotice` warnings collected, then printed as
    ``fuzzyfeed: notice: ...`` lines when the command succeeds (an error stays one line)."""
    from fuzzyfeed.advice.options import shape_settings
    from fuzzyfeed.advice.pipeline import collect_notices

    with shape_settings(getattr(args, "shape", None), getattr(args, "units", None),
                        getattr(args, "point_tolerance", None), getattr(args, "path_tolerance", None)):
        with collect_notices() as notices:
            yield
        for text in notices:      # only when the command succeeds: an error stays one line
            print(f"fuzzyfeed: notice: {text}", file=sys.stderr)
