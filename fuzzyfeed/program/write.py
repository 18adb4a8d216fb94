"""G-code for LinuxCNC from a feed profile: one ``G1`` per sampled segment.

Preamble ``G17 G21 G90 G94`` (XY plane, mm, absolute, feed per minute). A program from a shape
starts at a safe height: ``G0 Z<safe>``, a ``G0`` to the first point, a plunge at the plunge
feed, one ``G1`` per sampled segment, a retract to the safe height and ``M2``; a header comment
records the method, the rules, F and the source. X and Y are written on every move, Z (3-D
paths only) when it changes. The F word is written only when its text changes.

*Feed of a segment.* A profile gives one feed per sample; the move from sample i to i+1 runs at
the mean of the two end feeds, (v_i + v_{i+1}) / 2 — the same trapezoid
:meth:`FeedProfile.travel_time_s` uses — unless the caller gives the segment feeds itself (the
SLW schedule gives ds/dt, so the program's time at its F words is the schedule's time). A segment
whose two end feeds are both 0 takes the feed of the next segment with a positive feed (the
previous one at the end of the path). F is never 0 or NaN: a profile that is 0 everywhere is
refused.

*Quantisation.* With ``feed_step_mm_min`` the feed is rounded *down* to a multiple of the step
(never faster than advised), with one step as the floor, so a smooth profile gives a few F words
instead of one per line.

Coordinates are rounded to ``decimals`` (≥ 3) places; a move that rounds onto the previous point
is dropped (its feed carries to the next move). The file is written atomically.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from fuzzyfeed import __version__
from fuzzyfeed.errors import ExportError
from fuzzyfeed.base.atomic import atomic_write
from fuzzyfeed.machine.profile import FeedProfile

#: Default number of decimals for mm coordinates (rs274 prints 4).
DEFAULT_DECIMALS = 4
#: Fewest decimals allowed for mm coordinates.
MIN_DECIMALS = 3
#: Longest comment text written (LinuxCNC's line limit is 255 characters).
MAX_COMMENT = 200
#: Default number of decimals of the F word (mm/min).
DEFAULT_FEED_DECIMALS = 1


@dataclass(frozen=True, eq=False)
class GcodeProgram:
    """A G-code program as text lines plus what it commands, as written (rounded).

    ``start_mm`` (3,) is the G0 target; ``points_mm`` (M, 3) the end point of each G1 move;
    ``feeds_mm_min`` (M,) the F in force for each move (the written value); ``n_feed_words`` how
    many F words the program has.
    """

    lines: tuple[str, ...]
    start_mm: np.ndarray
    points_mm: np.ndarray
    feeds_mm_min: np.ndarray
    n_feed_words: int

    @property
    def text(self) -> str:
        return "\n".join(self.lines) + "\n"


def _check_decimals(decimals: object, name: str = "decimals", low: int = MIN_DECIMALS) -> int:
    if isinstance(decimals, bool) or not isinstance(decimals, (int, np.integer)) or not low <= decimals <= 9:
        raise ExportError(f"{name} = {decimals!r}; must be an integer from {low} to 9")
    return int(decimals)


def _fmt(value: float, decimals: int) -> str:
    text = f"{value:.{decimals}f}"
    if float(text) == 0.0:  # no "-0.0000"
        text = f"{0.0:.{decimals}f}"
    return text


def segment_feeds_mm_s(feed_mm_s: np.ndarray) -> np.ndarray:
    """Feed of each segment between consecutive samples (N−1 values, mm/s), all > 0.

    Mean of the two end feeds; a segment with both ends at 0 takes the next positive segment feed
    (the previous one at the end). Raises :class:`ExportError` when every feed is 0.
    """
    v = np.asarray(feed_mm_s, dtype=float)
    seg = 0.5 * (v[:-1] + v[1:])
    positive = seg > 0
    if not positive.any():
        raise ExportError("feed profile is 0 everywhere; refusing to write a program with F0")
    if not positive.all():
        idx = np.where(positive, np.arange(seg.size), seg.size)
        nxt = np.minimum.accumulate(idx[::-1])[::-1]          # next positive index (or size)
        prv = np.maximum.accumulate(np.where(positive, np.arange(seg.size), -1))
        fill = np.where(nxt < seg.size, nxt, prv)
        seg = seg[fill]
    return seg


def quantise_feed_mm_min(feed_mm_min: np.ndarray, step_mm_min: float | None, feed_decimals: int) -> np.ndarray:
    """Feeds as written: rounded down to ``step_mm_min`` (floor one step) if given, then to the F
    word's decimals, never below one unit of the last written decimal."""
    f = np.asarray(feed_mm_min, dtype=float)
    if step_mm_min is not None:
        if not (isinstance(step_mm_min, (int, float)) and math.isfinite(step_mm_min) and step_mm_min > 0):
            raise ExportError(f"feed_step_mm_min = {step_mm_min!r}; must be a finite number > 0")
        f = np.maximum(np.floor(f / step_mm_min + 1e-9) * step_mm_min, step_mm_min)
    unit = 10.0 ** -feed_decimals
    return np.maximum(np.round(f, feed_decimals), unit)


class _Lines:
    def __init__(self, line_numbers: bool, step: int = 10):
        self.lines: list[str] = []
        self.number = 0
        self.line_numbers = line_numbers
        self.step = step

    def add(self, text: str, numbered: bool = True) -> None:
        if self.line_numbers and numbered:
            self.number += self.step
            text = f"N{self.number} {text}"
        self.lines.append(text)


def _comment(text: str) -> str:
    """A G-code comment: parentheses cannot nest, so they are replaced; LinuxCNC reads lines of
    at most 255 characters, so a longer text is cut with '...'."""
    text = text.replace("(", "[").replace(")", "]").replace("\n", " ")
    if len(text) > MAX_COMMENT:
        text = text[:MAX_COMMENT - 3] + "..."
    return "(" + text + ")"


def gcode_program(profile: FeedProfile, *, decimals: int = DEFAULT_DECIMALS,
                  feed_decimals: int = DEFAULT_FEED_DECIMALS, feed_step_mm_min: float | None = None,
                  line_numbers: bool = False, title: str | None = None,
                  safe_z_mm: float | None = None, plunge_feed_mm_min: float | None = None,
                  notes: tuple[str, ...] = (),
                  segment_feed_mm_min: np.ndarray | None = None) -> GcodeProgram:
    """The ``G1`` program for a feed profile (see the module docstring for the rules).

    ``safe_z_mm``: start with ``G0 Z<safe>``, rapid over the first point, plunge to it at
    ``plunge_feed_mm_min`` (default: the slowest segment feed) and retract to the safe height at
    the end. ``notes``: more header comment lines (rules, F, source). ``segment_feed_mm_min``:
    the feed of every segment (N−1 values > 0) instead of the mean of its end feeds."""
    if not isinstance(profile, FeedProfile):
        raise ExportError(f"profile: expected a FeedProfile, got {type(profile).__name__}")
    decimals = _check_decimals(decimals)
    feed_decimals = _check_decimals(feed_decimals, "feed_decimals", low=0)
    samples = profile.samples
    xyz = np.asarray(samples.xyz, dtype=float)
    if not np.isfinite(xyz).all():
        i = int(np.argwhere(~np.isfinite(xyz))[0, 0])
        raise ExportError(f"samples.xyz[{i}] = {xyz[i].tolist()}; refusing to write a non-finite point")
    with_z = samples.dim == 3
    if segment_feed_mm_min is None:
        seg = segment_feeds_mm_s(profile.feed_mm_s) * 60.0
    else:
        seg = np.asarray(segment_feed_mm_min, dtype=float)
        if seg.shape != (len(samples) - 1,) or not np.all(np.isfinite(seg) & (seg > 0)):
            raise ExportError(f"segment_feed_mm_min: need {len(samples) - 1} finite feeds > 0")
    feeds = quantise_feed_mm_min(seg, feed_step_mm_min, feed_decimals)
    if safe_z_mm is not None:
        z_top = float(xyz[:, 2].max()) if with_z else 0.0
        if not (np.isfinite(safe_z_mm) and safe_z_mm > z_top):
            raise ExportError(f"safe_z_mm = {safe_z_mm!r}; the safe height must be above the path "
                              f"(highest point z = {z_top:g} mm)")
        plunge = float(np.min(feeds)) if plunge_feed_mm_min is None else float(plunge_feed_mm_min)
        if not (np.isfinite(plunge) and plunge > 0):
            raise ExportError(f"plunge_feed_mm_min = {plunge_feed_mm_min!r}; must be a finite number > 0")
    text = np.array([[_fmt(c, decimals) for c in row] for row in xyz.tolist()])

    out = _Lines(line_numbers)
    name = title or f"{profile.method} feed profile"
    out.add(_comment(f"fuzzyfeed {__version__}: {name}; {len(samples)} samples, "
                     f"{samples.length:.3f} mm"), numbered=False)
    rule = ("F of a move = mean of its two end-point feeds" if segment_feed_mm_min is None
            else "F of a move = its length / the scheduled time between its ends")
    out.add(_comment("units mm and mm/min; " + rule
                     + (f", rounded down to {feed_step_mm_min:g} mm/min steps" if feed_step_mm_min else "")),
            numbered=False)
    for note in notes:
        out.add(_comment(note), numbered=False)
    out.add("G17 G21 G90 G94")
    start = text[0]
    if safe_z_mm is None:
        out.add("G0 X" + start[0] + " Y" + start[1] + (" Z" + start[2] if with_z else ""))
    else:
        safe = _fmt(safe_z_mm, decimals)
        out.add("G0 Z" + safe)
        out.add("G0 X" + start[0] + " Y" + start[1])
        out.add("G1 Z" + (start[2] if with_z else _fmt(0.0, decimals))
                + f" F{max(plunge, 10.0 ** -feed_decimals):.{feed_decimals}f}")
    last = start
    last_f = None if safe_z_mm is None else "plunge"
    points, move_feeds = [], []
    n_f = 0
    pending_f = None  # feed of a dropped (zero-length after rounding) move carries forward
    for i in range(1, len(text)):
        row = text[i]
        f_text = f"{feeds[i - 1]:.{feed_decimals}f}"
        if row[0] == last[0] and row[1] == last[1] and (not with_z or row[2] == last[2]):
            pending_f = pending_f or f_text
            continue
        if pending_f is not None:
            f_text = min(pending_f, f_text, key=float)
            pending_f = None
        words = ["G1", "X" + row[0], "Y" + row[1]]
        if with_z and row[2] != last[2]:
            words.append("Z" + row[2])
        if f_text != last_f:
            words.append("F" + f_text)
            last_f = f_text
            n_f += 1
        out.add(" ".join(words))
        points.append([float(c) for c in row] if with_z else [float(row[0]), float(row[1]), 0.0])
        move_feeds.append(float(last_f))
        last = row
    if not points:
        raise ExportError(f"all {len(text)} points round to the same position at {decimals} decimals; "
                          "nothing to move")
    if safe_z_mm is not None:
        out.add("G0 Z" + _fmt(safe_z_mm, decimals))
    out.add("M2")
    start_mm = np.array([float(c) for c in start] if with_z else [float(start[0]), float(start[1]), 0.0])
    return GcodeProgram(lines=tuple(out.lines), start_mm=start_mm, points_mm=np.array(points),
                        feeds_mm_min=np.array(move_feeds), n_feed_words=n_f)


def write_gcode(path: str | os.PathLike, profile: FeedProfile, *, decimals: int = DEFAULT_DECIMALS,
                feed_decimals: int = DEFAULT_FEED_DECIMALS, feed_step_mm_min: float | None = None,
                line_numbers: bool = False, title: str | None = None) -> GcodeProgram:
    """Write ``profile`` as a LinuxCNC program of ``G1`` moves, atomically; returns what was written."""
    program = gcode_program(profile, decimals=decimals, feed_decimals=feed_decimals,
                            feed_step_mm_min=feed_step_mm_min, line_numbers=line_numbers, title=title)
    with atomic_write(path, "w", newline="\n") as handle:
        handle.write(program.text)
    return program
