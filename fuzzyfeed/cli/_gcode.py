"""G-code flags shared by ``advise`` and ``schedule``: ``--gcode OUT.ngc`` and friends.

Usage in a subcommand: ``add_gcode_arguments(parser)`` in ``register``; in ``run``, call
``gcode = prepare_gcode(args, profile, shape)`` *before* writing any output (it builds the program
text and raises the one-line error if it cannot be written), then ``gcode.write()`` after the other
outputs. So bad G-code options leave no file at all.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field

from fuzzyfeed.cli._common import positive_float
from fuzzyfeed.errors import ExportError


def _decimals(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if not 3 <= value <= 9:
        raise argparse.ArgumentTypeError(f"{value}: use 3 to 9 decimals for mm coordinates")
    return value


#: Default safe height (mm), and the clearance above a path that reaches it.
DEFAULT_SAFE_Z_MM = 5.0


def safe_z(args: argparse.Namespace, profile) -> float:
    """--safe-z-mm, or 5 mm (5 mm above the path's highest point when that is higher)."""
    if args.safe_z_mm is not None:
        return args.safe_z_mm
    top = float(profile.samples.xyz[:, 2].max()) if profile.samples.dim == 3 else 0.0
    return max(DEFAULT_SAFE_Z_MM, top + DEFAULT_SAFE_Z_MM)


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


@dataclass
class PreparedGcode:
    """Program texts checked and ready to write (path, text) pairs."""

    files: list[tuple[str, str]] = field(default_factory=list)

    def write(self) -> list[str]:
        from fuzzyfeed.base.atomic import atomic_write

        for path, text in self.files:
            with atomic_write(path, "w", newline="\n") as handle:
                handle.write(text)
        return [path for path, _ in self.files]

    def __bool__(self) -> bool:
        return bool(self.files)


def prepare_gcode(args: argparse.Namespace, profile, shape=None, notes: tuple[str, ...] = (),
                  segment_feed_mm_min=None) -> PreparedGcode:
    """Build the programs the G-code flags ask for (none without --gcode/--gcode-g52).

    ``profile`` is a :class:`~fuzzyfeed.machine.profile.FeedProfile` or a function returning one (called
    only when a program is asked for); ``notes`` go into the header comment;
    ``segment_feed_mm_min`` (or a function returning it) gives the feed of every segment."""
    gcode = getattr(args, "gcode", None)
    g52 = getattr(args, "gcode_g52", None)
    if not gcode and not g52:
        for flag, value in (("--feed-step-mm-min", args.feed_step_mm_min),
                            ("--line-numbers", args.line_numbers), ("--g52-whole", args.g52_whole)):
            if value:
                raise ExportError(f"{flag} is a G-code option; add --gcode OUT.ngc or --gcode-g52 OUT.ngc")
        return PreparedGcode()
    if args.g52_whole and not g52:
        raise ExportError("--g52-whole needs --gcode-g52 OUT.ngc")
    from fuzzyfeed.io.gcode import gcode_program, nurbs_gcode_program

    outputs = [p for p in (getattr(args, "output", None), gcode, g52) if p]
    if len(set(outputs)) != len(outputs):
        raise ExportError(f"output files must differ: {', '.join(outputs)}")
    if callable(profile):
        profile = profile()
    title = f"{profile.method} feed on {shape.name}" if shape is not None else None
    prepared = PreparedGcode()
    if gcode:
        if callable(segment_feed_mm_min):
            segment_feed_mm_min = segment_feed_mm_min()
        source = None
        if shape is not None:
            where = shape.path.name if shape.path is not None else shape.name
            source = f"source: {where}" + (f" - {shape.source}" if shape.source else "")
        program = gcode_program(profile, decimals=args.gcode_decimals,
                                feed_step_mm_min=args.feed_step_mm_min,
                                line_numbers=args.line_numbers, title=title,
                                safe_z_mm=safe_z(args, profile), plunge_feed_mm_min=args.plunge_feed_mm_min,
                                notes=tuple(notes) + ((source,) if source else ()),
                                segment_feed_mm_min=segment_feed_mm_min)
        prepared.files.append((gcode, program.text))
    if g52:
        curve = profile.samples.curve if profile.samples.curve is not None else None
        if curve is None:
            raise ExportError("--gcode-g52 needs a NURBS shape; this path is a point sequence "
                              "(write it with --gcode)")
        where = shape.path.name if shape is not None and shape.path is not None else getattr(shape, "name", "")
        lines = nurbs_gcode_program(curve, profile, split="whole" if args.g52_whole else "spans",
                                    decimals=args.gcode_decimals,
                                    feed_step_mm_min=args.feed_step_mm_min,
                                    line_numbers=args.line_numbers, title=title,
                                    safe_z_mm=safe_z(args, profile), plunge_feed_mm_min=args.plunge_feed_mm_min,
                                    notes=tuple(notes) + ((f"source: {where}",) if where else ()))
        prepared.files.append((g52, "\n".join(lines) + "\n"))
    return prepared
