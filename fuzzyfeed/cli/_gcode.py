"""G-code flags shared by ``advise`` and ``schedule``: ``--gcode OUT.ngc`` and friends.

Usage in a subcommand: ``add_gcode_arguments(parser)`` in ``register``; in ``run``, call
``gcode = prepare_gcode(args, profile, shape)`` *before* writing any output (it builds the program
text and raises the one-line error if it cannot be written), then ``gcode.write()`` after the other
outputs. So bad G-code options leave no file at all.
"""

from __future__ import annotations

import argparse

from fuzzyfeed.advice.gcode import DEFAULT_SAFE_Z_MM, PreparedGcode
from fuzzyfeed.cli._common import positive_float


def _decimals(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if not 3 <= value <= 9:
        raise argparse.ArgumentTypeError(f"{value}: use 3 to 9 decimals for mm coordinates")
    return value


def add_gcode_arguments(parser: argparse.ArgumentParser) -> None:
    g = parser.add_argument_group("G-code export (LinuxCNC; checked with its rs274 interpreter)")
    g.add_argument("--gcode", metavar="OUT.ngc", default=None,
                   help="also write the feed as a program. A shape: header comments (method, "
                        "rules, F, source), G17 G21 G90 G94, G0 to the safe height and over the "
                        "first point, a plunge at the plunge feed, one 'G1 X Y [Z]' per sampled "
                        "segment with F in mm/min written only when it changes, a retract, M2. A "
                        "G-code program (advise): the same program, every line kept, with the "
                        "advised F words")
    g.add_argument("--safe-z-mm", type=float, default=None, metavar="Z",
                   help="shapes: safe height for the rapids before and after the cut, above the "
                        f"path (default: {DEFAULT_SAFE_Z_MM:g} mm, or that much above the path's "
                        "highest point if it is higher)")
    g.add_argument("--plunge-feed-mm-min", type=positive_float, default=None, metavar="F",
                   help="shapes: feed of the plunge from the safe height to the path "
                        "(default: the slowest feed of the program)")
    g.add_argument("--feed-step-mm-min", type=positive_float, default=None, metavar="STEP",
                   help="round every F down to a multiple of STEP mm/min (floor: one STEP), so "
                        "the program has few F words and never runs faster than advised")
    g.add_argument("--line-numbers", action="store_true", help="number the G-code blocks N10, N20, ...")
    g.add_argument("--gcode-decimals", type=_decimals, default=4, metavar="D",
                   help="decimals of the mm coordinates (3-9, default: %(default)s)")
    g.add_argument("--gcode-g52", metavar="OUT.ngc", default=None,
                   help="also write the NURBS itself as LinuxCNC G5.2 blocks, one per knot span "
                        "(exact for any knot vector), each with the slowest advised feed of its "
                        "span; NURBS shapes of degree >= 2 in the XY plane only")
    g.add_argument("--g52-whole", action="store_true",
                   help="with --gcode-g52: one G5.2 block for the whole curve (one F, the slowest); "
                        "only for uniform clamped knot vectors, refused otherwise")


def prepare_gcode(args: argparse.Namespace, profile, shape=None, notes: tuple[str, ...] = (),
                  segment_feed_mm_min=None) -> PreparedGcode:
    """Build the programs the G-code flags ask for (none without --gcode/--gcode-g52), see
    :func:`fuzzyfeed.advice.gcode.prepare_gcode`."""
    from fuzzyfeed.advice import gcode as export

    settings = export.GcodeSettings(
        feed_step_mm_min=args.feed_step_mm_min, line_numbers=args.line_numbers, g52_whole=args.g52_whole,
        gcode_decimals=args.gcode_decimals, safe_z_mm=args.safe_z_mm, plunge_feed_mm_min=args.plunge_feed_mm_min)
    return export.prepare_gcode(settings, profile, shape, notes, segment_feed_mm_min,
                                output=getattr(args, "output", None), gcode=getattr(args, "gcode", None),
                                gcode_g52=getattr(args, "gcode_g52", None))
