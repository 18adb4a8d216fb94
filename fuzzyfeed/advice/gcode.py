"""A shape's feed written as a LinuxCNC program (``--gcode``) and as G5.2 NURBS blocks
(``--gcode-g52``), checked and built before any file is written (:func:`prepare_gcode`), written
by :meth:`PreparedGcode.write` after the other outputs. ``fuzzyfeed advise`` and ``fuzzyfeed
schedule`` share it."""

from __future__ import annotations

from dataclasses import dataclass, field

from fuzzyfeed.errors import ExportError

#: Default safe height (mm), and the clearance above a path that reaches it.
DEFAULT_SAFE_Z_MM = 5.0


def safe_z(safe_z_mm: float | None, profile) -> float:
    """``safe_z_mm``, or 5 mm (5 mm above the path's highest point when that is higher)."""
    if safe_z_mm is not None:
        return safe_z_mm
    top = float(profile.samples.xyz[:, 2].max()) if profile.samples.dim == 3 else 0.0
    return max(DEFAULT_SAFE_Z_MM, top + DEFAULT_SAFE_Z_MM)


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


@dataclass(frozen=True)
class GcodeSettings:
    """The export flags: ``--feed-step-mm-min``, ``--line-numbers``, ``--g52-whole``,
    ``--gcode-decimals``, ``--safe-z-mm``, ``--plunge-feed-mm-min``."""

    feed_step_mm_min: float | None = None
    line_numbers: bool = False
    g52_whole: bool = False
    gcode_decimals: int = 4
    safe_z_mm: float | None = None
    plunge_feed_mm_min: float | None = None


def prepare_gcode(settings: GcodeSettings, profile, shape=None, notes: tuple[str, ...] = (),
                  segment_feed_mm_min=None, *, output=None, gcode=None, gcode_g52=None) -> PreparedGcode:
    """Build the programs asked for (``gcode``, ``gcode_g52``: their paths; none: nothing, and
    the export flags refused).

    ``profile`` is a :class:`~fuzzyfeed.machine.profile.FeedProfile` or a function returning one (called
    only when a program is asked for); ``notes`` go into the header comment;
    ``segment_feed_mm_min`` (or a function returning it) gives the feed of every segment."""
    s = settings
    if not gcode and not gcode_g52:
        for flag, value in (("--feed-step-mm-min", s.feed_step_mm_min),
                            ("--line-numbers", s.line_numbers), ("--g52-whole", s.g52_whole)):
            if value:
                raise ExportError(f"{flag} is a G-code option; add --gcode OUT.ngc or --gcode-g52 OUT.ngc")
        return PreparedGcode()
    if s.g52_whole and not gcode_g52:
        raise ExportError("--g52-whole needs --gcode-g52 OUT.ngc")
    from fuzzyfeed.io.gcode import gcode_program, nurbs_gcode_program

    outputs = [p for p in (output, gcode, gcode_g52) if p]
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
        program = gcode_program(profile, decimals=s.gcode_decimals, feed_step_mm_min=s.feed_step_mm_min,
                                line_numbers=s.line_numbers, title=title,
                                safe_z_mm=safe_z(s.safe_z_mm, profile), plunge_feed_mm_min=s.plunge_feed_mm_min,
                                notes=tuple(notes) + ((source,) if source else ()),
                                segment_feed_mm_min=segment_feed_mm_min)
        prepared.files.append((gcode, program.text))
    if gcode_g52:
        curve = profile.samples.curve if profile.samples.curve is not None else None
        if curve is None:
            raise ExportError("--gcode-g52 needs a NURBS shape; this path is a point sequence "
                              "(write it with --gcode)")
        where = shape.path.name if shape is not None and shape.path is not None else getattr(shape, "name", "")
        lines = nurbs_gcode_program(curve, profile, split="whole" if s.g52_whole else "spans",
                                    decimals=s.gcode_decimals, feed_step_mm_min=s.feed_step_mm_min,
                                    line_numbers=s.line_numbers, title=title,
                                    safe_z_mm=safe_z(s.safe_z_mm, profile), plunge_feed_mm_min=s.plunge_feed_mm_min,
                                    notes=tuple(notes) + ((f"source: {where}",) if where else ()))
        prepared.files.append((gcode_g52, "\n".join(lines) + "\n"))
    return prepared
