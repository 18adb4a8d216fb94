"""G-code for LinuxCNC: export a feed profile as ``G1`` moves, a NURBS as a ``G5.2`` block, and
import G0/G1 polylines and G5.2 blocks back as paths.

Export (:func:`write_gcode`)
    Preamble ``G17 G21 G90 G94`` (XY plane, mm, absolute, feed per minute), a ``G0`` rapid to the
    first sample, then one ``G1`` per sampled segment. X and Y are written on every move, Z (3-D
    paths only) when it changes. The F word is written only when its text changes.

    *Feed of a segment.* A profile gives one feed per sample; the move from sample i to i+1 runs at
    the mean of the two end feeds, (v_i + v_{i+1}) / 2 — the same trapezoid
    :meth:`FeedProfile.travel_time_s` uses. So an SLW profile that starts and ends at rest (feed 0
    at the first and last sample) still gets a positive F on its first and last move (half the
    neighbour's feed). A segment whose two end feeds are both 0 takes the feed of the next segment
    with a positive feed (the previous one at the end of the path). F is never 0 or NaN: a profile
    that is 0 everywhere is refused.

    *Quantisation.* With ``feed_step_mm_min`` the feed is rounded *down* to a multiple of the step
    (never faster than advised), with one step as the floor, so a smooth profile gives a few F
    words instead of one per line.

    Coordinates are rounded to ``decimals`` (≥ 3) places; a move that rounds onto the previous
    point is dropped (its feed carries to the next move). The file is written atomically.

G5.2 (:func:`write_gcode_nurbs`)
    LinuxCNC's G5.2 takes the current position as the first control point, weights as P, the
    order as L (default 3, L is used only when > 3) and builds the knot vector itself: uniform and
    clamped (``nurbs_G5_knot_vector_creator``: k zeros, 1 … n−k+1, k times n−k+2). With
    ``split="whole"`` the curve is one block; a curve whose knots are not uniform (after scaling
    the domain) cannot be written that way and is refused, naming the first knot that breaks the
    rule. With ``split="spans"`` the curve is cut by knot insertion into rational Bézier pieces,
    one block per knot span — their knot vectors are uniform clamped, so any knot vector is
    written exactly, and each block carries the slowest advised feed over its span. Refused in
    both modes: a degree-1 curve (order 2 < 3) and a curve that is not planar at one Z (G5.2 is
    XY only). Control points are rounded to ``decimals``, weights to ``weight_decimals``.

Import (:func:`load_gcode_shapes`)
    G0/G1/G2/G3 (modal), G90/G91, G90.1/G91.1, G20/G21 and G5.2 … G5.3 blocks. Feed moves (G1,
    G2/G3, G5.2) form a chain; a G0 that moves ends it, so a file gives one path per chain. A chain
    of G1 moves becomes a polyline shape (curvature by the three-point estimate of seed 002,
    eq. 4–9); G2/G3 arcs (XY plane, I/J or R, helical Z, P turns) are flattened into points on
    the exact arc within :data:`ARC_TOLERANCE_MM` of it; a chain that is
    one G5.2 block becomes that NURBS exactly (degree L−1, LinuxCNC's knot vector on [0, 1]); a
    chain mixing both samples each G5.2 block at :data:`NURBS_IMPORT_POINTS_PER_SPAN` points per
    knot span into the polyline. Zero-length moves are skipped. The machine starts at X0 Y0 Z0,
    as LinuxCNC does.

    Policy for other words: codes that do not change the XYZ path (spindle, coolant, tool change,
    dwell, path-control mode, cancel codes, F, S, T, N, comments) are accepted and ignored. Any
    word that would change the geometry and is not implemented (G5/G5.1 splines, arcs outside
    the XY plane, G18/G19, G92 and work offsets other than G54, canned cycles, cutter
    compensation, A/B/C/U/V/W axes, parameters and expressions, O-word subroutines, unknown M
    codes) is **rejected** with ``file:line``, the word and the reason: a path silently read wrong
    is worse than no path.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fuzzyfeed import __version__
from fuzzyfeed.errors import ExportError, NurbsError, PathFormatError
from fuzzyfeed.io.atomic import atomic_write
from fuzzyfeed.nurbs import Nurbs
from fuzzyfeed.profile import FeedProfile
from fuzzyfeed.sampling import MAX_POINTS

#: Default number of decimals for mm coordinates (rs274 prints 4).
DEFAULT_DECIMALS = 4
#: Fewest decimals allowed for mm coordinates.
MIN_DECIMALS = 3
#: Default number of decimals of the F word (mm/min).
DEFAULT_FEED_DECIMALS = 1
#: Points per knot span when a G5.2 block is sampled into a polyline on import.
NURBS_IMPORT_POINTS_PER_SPAN = 32
#: File suffixes read as G-code.
GCODE_SUFFIXES = (".ngc", ".nc", ".gcode", ".gc", ".tap", ".cnc")

MM_PER_INCH = 25.4


# --------------------------------------------------------------------------------------- export
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
    """A G-code comment: parentheses cannot nest, so they are replaced."""
    return "(" + text.replace("(", "[").replace(")", "]").replace("\n", " ") + ")"


def gcode_program(profile: FeedProfile, *, decimals: int = DEFAULT_DECIMALS,
                  feed_decimals: int = DEFAULT_FEED_DECIMALS, feed_step_mm_min: float | None = None,
                  line_numbers: bool = False, title: str | None = None) -> GcodeProgram:
    """The ``G1`` program for a feed profile (see the module docstring for the rules)."""
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
    feeds = quantise_feed_mm_min(segment_feeds_mm_s(profile.feed_mm_s) * 60.0, feed_step_mm_min,
                                 feed_decimals)
    text = np.array([[_fmt(c, decimals) for c in row] for row in xyz.tolist()])

    out = _Lines(line_numbers)
    name = title or f"{profile.method} feed profile"
    out.add(_comment(f"fuzzyfeed {__version__}: {name}; {len(samples)} samples, "
                     f"{samples.length:.3f} mm"), numbered=False)
    out.add(_comment("units mm and mm/min; F of a move = mean of its two end-point feeds"
                     + (f", rounded down to {feed_step_mm_min:g} mm/min steps" if feed_step_mm_min else "")),
            numbered=False)
    out.add("G17 G21 G90 G94")
    start = text[0]
    out.add("G0 X" + start[0] + " Y" + start[1] + (" Z" + start[2] if with_z else ""))
    last = start
    last_f = None
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


# ------------------------------------------------------------------------------------- G5.2
def linuxcnc_knots(n_control_points: int, order: int) -> np.ndarray:
    """The knot vector LinuxCNC builds for G5.2, scaled to [0, 1]: uniform and clamped
    (``nurbs_G5_knot_vector_creator``: order zeros, 1 … n−order+1, order times n−order+2, with
    n = number of control points − 1)."""
    n, k = n_control_points - 1, order
    raw = np.array([0 if i < k else (i - k + 1 if i <= n else n - k + 2) for i in range(n + k + 1)],
                   dtype=float)
    return raw / raw[-1]


def check_g52_curve(curve: Nurbs, rtol: float = 1e-9) -> None:
    """Raise :class:`ExportError` unless LinuxCNC's G5.2 can carry ``curve`` exactly."""
    if curve.degree < 2:
        raise ExportError(f"NURBS degree {curve.degree}: G5.2 needs order L = degree + 1 >= 3; "
                          "write a degree-1 path as G1 moves")
    lo, hi = curve.domain
    expected = lo + (hi - lo) * linuxcnc_knots(curve.n_control_points, curve.degree + 1)
    bad = np.abs(np.asarray(curve.knots) - expected) > rtol * (hi - lo)
    if bad.any():
        i = int(np.argmax(bad))
        raise ExportError(f"knots[{i}] = {float(curve.knots[i])!r}, uniform clamped needs "
                          f"{float(expected[i])!r}: LinuxCNC G5.2 builds a uniform clamped knot "
                          "vector, so this curve cannot be one G5.2 block; write one block per knot "
                          "span (split='spans'; on the command line, leave out --g52-whole) or G1 moves")
    if curve.dim == 3:
        z = curve.control_points[:, 2]
        tol = 1e-9 * max(1.0, float(np.abs(z).max()))
        if np.ptp(z) > tol:
            i = int(np.argmax(np.abs(z - z[0]) > tol))
            raise ExportError(f"control_points[{i}] z = {float(z[i])!r} differs from z = {float(z[0])!r}: G5.2 is "
                              "planar (XY); export a 3-D curve as G1 moves")


def insert_knot(p: int, knots: np.ndarray, pw: np.ndarray, u: float) -> tuple[np.ndarray, np.ndarray]:
    """Insert ``u`` once into a curve of degree ``p`` with homogeneous control points ``pw``
    (Boehm's knot insertion, The NURBS Book A5.1 with r = 1)."""
    k = int(np.searchsorted(knots, u, side="right")) - 1        # knots[k] <= u < knots[k+1]
    q = np.empty((pw.shape[0] + 1, pw.shape[1]))
    q[:k - p + 1] = pw[:k - p + 1]
    for i in range(k - p + 1, k + 1):
        alpha = (u - knots[i]) / (knots[i + p] - knots[i])
        q[i] = alpha * pw[i] + (1.0 - alpha) * pw[i - 1]
    q[k + 1:] = pw[k:]
    return np.insert(knots, k + 1, u), q


def bezier_segments(curve: Nurbs) -> list[Nurbs]:
    """The curve split at every interior knot into rational Bézier pieces (degree p, p + 1
    control points, knots a^(p+1) b^(p+1)): each interior knot is inserted until its multiplicity
    is p (knot refinement, The NURBS Book §5.3). Each piece equals the curve on its span, and its
    knot vector is the uniform clamped one LinuxCNC's G5.2 builds."""
    p = curve.degree
    knots = np.asarray(curve.knots, dtype=float)
    w = np.asarray(curve.weights, dtype=float)
    pw = np.column_stack([curve.control_points * w[:, None], w])
    lo, hi = curve.domain
    interior, counts = np.unique(knots[(knots > lo) & (knots < hi)], return_counts=True)
    for u, m in zip(interior, counts):
        for _ in range(p - int(m)):
            knots, pw = insert_knot(p, knots, pw, float(u))
    breaks = np.concatenate([[lo], interior, [hi]])
    pieces = []
    for j in range(breaks.size - 1):
        block = pw[j * p: j * p + p + 1]
        pieces.append(Nurbs(p, [breaks[j]] * (p + 1) + [breaks[j + 1]] * (p + 1),
                            block[:, :-1] / block[:, -1:], block[:, -1]))
    return pieces


def _span_feeds_mm_min(curve: Nurbs, pieces: list[Nurbs], profile: FeedProfile) -> np.ndarray:
    """Per piece: the slowest segment feed (mm/min) of the profile's samples over its span."""
    samples = profile.samples
    lo, hi = curve.domain
    u = np.asarray(samples.u, dtype=float)
    if samples.curve is None or u[0] < lo - 1e-12 or u[-1] > hi + 1e-12 or np.any(np.diff(u) < 0):
        raise ExportError("profile: its samples must be parameters of this curve (a NURBS "
                          "sampling such as sample_uniform_u); a point-sequence profile has none")
    seg = segment_feeds_mm_s(profile.feed_mm_s) * 60.0
    out = []
    for piece in pieces:
        a, b = piece.domain
        inside = (u[1:] > a) & (u[:-1] < b)
        out.append(seg[inside].min() if inside.any() else seg[np.searchsorted(u, a) - 1])
    return np.array(out)


def nurbs_gcode_program(curve: Nurbs, feed: float | FeedProfile, *, split: str = "whole",
                        decimals: int = DEFAULT_DECIMALS, feed_decimals: int = DEFAULT_FEED_DECIMALS,
                        weight_decimals: int = 6, feed_step_mm_min: float | None = None,
                        line_numbers: bool = False, title: str | None = None) -> list[str]:
    """Lines of a program that runs ``curve`` as LinuxCNC ``G5.2`` blocks.

    ``split="whole"``: one block, only for uniform clamped knots (else :class:`ExportError`); F is
    ``feed`` (mm/min) or, for a :class:`FeedProfile`, its slowest segment feed.
    ``split="spans"``: one block per knot span (rational Bézier pieces, see
    :func:`bezier_segments`), so any knot vector can be written exactly; with a profile each
    block gets the slowest segment feed over its span (F written only when it changes).
    """
    if split not in ("whole", "spans"):
        raise ExportError(f"split = {split!r}; use 'whole' or 'spans'")
    if split == "whole":
        check_g52_curve(curve)
        pieces = [curve]
    else:
        if curve.degree < 2:
            check_g52_curve(curve)  # refuses with the reason
        pieces = bezier_segments(curve)
        for piece in pieces:
            check_g52_curve(piece)
    decimals = _check_decimals(decimals)
    feed_decimals = _check_decimals(feed_decimals, "feed_decimals", low=0)
    if isinstance(feed, FeedProfile):
        if split == "whole":
            feeds = np.array([np.min(segment_feeds_mm_s(feed.feed_mm_s)) * 60.0])
        else:
            feeds = _span_feeds_mm_min(curve, pieces, feed)
    else:
        if not (isinstance(feed, (int, float, np.floating)) and math.isfinite(feed) and feed > 0):
            raise ExportError(f"feed_mm_min = {feed!r}; must be a finite number > 0")
        feeds = np.full(len(pieces), float(feed))
    feeds = quantise_feed_mm_min(feeds, feed_step_mm_min, feed_decimals)
    out = _Lines(line_numbers)
    what = ("one G5.2 block" if split == "whole" else f"{len(pieces)} G5.2 blocks, one per knot span")
    out.add(_comment(f"fuzzyfeed {__version__}: {title or 'NURBS'} as {what}, degree "
                     f"{curve.degree}, {curve.n_control_points} control points"), numbered=False)
    out.add("G17 G21 G90 G94")
    pts = curve.control_points
    start = f"G0 X{_fmt(pts[0, 0], decimals)} Y{_fmt(pts[0, 1], decimals)}"
    if curve.dim == 3:
        start += f" Z{_fmt(pts[0, 2], decimals)}"
    out.add(start)
    last_f = None
    for piece, f in zip(pieces, feeds):
        w_text = [_fmt(wi, weight_decimals) for wi in piece.weights]
        if any(float(t) <= 0 for t in w_text):
            raise ExportError(f"a weight rounds to {min(w_text, key=float)} at {weight_decimals} "
                              "decimals; G5.2 needs every P > 0 (raise weight_decimals)")
        f_text = f"{f:.{feed_decimals}f}"
        words = f"G5.2 P{w_text[0]} L{piece.degree + 1}"
        if f_text != last_f:
            words += f" F{f_text}"
            last_f = f_text
        out.add(words)
        for q, wt in zip(piece.control_points[1:], w_text[1:]):
            out.add(f"X{_fmt(q[0], decimals)} Y{_fmt(q[1], decimals)} P{wt}")
        out.add("G5.3")
    out.add("M2")
    return out.lines


def write_gcode_nurbs(path: str | os.PathLike, curve: Nurbs, feed: float | FeedProfile,
                      **kwargs) -> list[str]:
    """Write ``curve`` as G5.2 block(s) (see :func:`nurbs_gcode_program`), atomically."""
    lines = nurbs_gcode_program(curve, feed, **kwargs)
    with atomic_write(path, "w", newline="\n") as handle:
        handle.write("\n".join(lines) + "\n")
    return lines


# --------------------------------------------------------------------------------------- import
_WORD = re.compile(r"([A-Z])([+-]?(?:\d+\.?\d*|\.\d+))")
#: G codes that change nothing in the XYZ path (accepted and ignored).
_IGNORED_G = {"4", "40", "49", "54", "61", "61.1", "64", "80", "94", "97", "98", "99"}
_IGNORED_M = {"0", "1", "2", "3", "4", "5", "6", "7", "8", "9", "30", "48", "49", "50", "51", "52",
              "53", "60"}
_REJECTED_G = {
    "5": "cubic spline", "5.1": "quadratic spline",
    "18": "XZ plane", "19": "YZ plane", "17.1": "UV plane", "18.1": "WU plane", "19.1": "VW plane",
    "92": "coordinate offset", "92.1": "coordinate offset", "92.2": "coordinate offset",
    "92.3": "coordinate offset", "93": "inverse-time feed", "95": "feed per revolution",
    "28": "move to home", "30": "move to home", "10": "offset table", "43": "tool length offset",
    "41": "cutter compensation", "42": "cutter compensation", "41.1": "cutter compensation",
    "42.1": "cutter compensation", "33": "spindle-synchronised motion", "38.2": "probing",
    "53": "machine coordinates", "52": "local offset", "7": "lathe diameter mode",
}
_ENDS = {"2", "30"}
_MOTIONS = ("0", "1", "2", "3", "5.2", "5.3")
#: Largest distance between a G2/G3 arc and the chords it is read as (mm).
ARC_TOLERANCE_MM = 1e-4
#: Largest difference between the start and end radius of a G2/G3 arc (mm); LinuxCNC's own
#: check is of the same order.
ARC_RADIUS_TOLERANCE_MM = 0.002


@dataclass
class _Chain:
    start_line: int
    points: list = field(default_factory=list)        # list of (3,) mm
    nurbs: list = field(default_factory=list)         # (Nurbs, index in points where it starts)
    kinds: set = field(default_factory=set)
    dim: int = 3


def _num(text: str) -> str:
    """Canonical text of a G/M number: '01' -> '1', '5.20' -> '5.2'."""
    value = float(text)
    return f"{value:g}"


class _Parser:
    def __init__(self, path: Path):
        self.path = path
        self.pos = np.zeros(3)
        self.absolute = True
        self.scale = 1.0
        self.motion = None          # "0", "1", "5.2"
        self.chains: list[_Chain] = []
        self.chain: _Chain | None = None
        self.nurbs_pts: list | None = None
        self.nurbs_w: list | None = None
        self.nurbs_order = 3
        self.nurbs_line = 0
        self.saw_z = False
        self.ended = False
        self.ij_absolute = False  # G91.1: I, J relative to the start (LinuxCNC's default)

    def fail(self, line: int, message: str) -> None:
        raise PathFormatError(f"{self.path}:{line}: {message}")

    # one program line -> words
    def words(self, raw: str, line: int) -> list[tuple[str, str]]:
        if "(" not in raw and ")" not in raw and ";" not in raw:
            return self.tokens(raw.replace(" ", "").replace("\t", "").upper(), raw, line)
        depth = 0
        clean = []
        for ch in raw:
            if ch == ";" and not depth:
                break  # the rest of the line is a comment
            if ch == "(":
                if depth:
                    self.fail(line, "nested comment '(' inside '(...)'")
                depth = 1
            elif ch == ")":
                if not depth:
                    self.fail(line, "')' without '('")
                depth = 0
            elif not depth:
                clean.append(ch)
        if depth:
            self.fail(line, "comment '(' not closed on this line")
        return self.tokens("".join(clean).replace(" ", "").replace("\t", "").upper(), raw, line)

    def tokens(self, body: str, raw: str, line: int) -> list[tuple[str, str]]:
        out = []
        if body.startswith("/"):
            body = body[1:]  # block delete is off, as in LinuxCNC by default
        if body in ("", "%"):
            return out
        special = re.search(r"[#\[<]|^O", body)
        if special:
            self.fail(line, f"'{body[special.start():special.start() + 12]}' in {raw.strip()!r}: "
                            "parameters, expressions and O-words are not supported")
        i = 0
        while i < len(body):
            m = _WORD.match(body, i)
            if m is None:
                bad = body[i:i + 12]
                self.fail(line, f"malformed word at '{bad}' in {raw.strip()!r}; "
                                "expected a letter followed by a number")
            out.append((m.group(1), m.group(2)))
            i = m.end()
        return out

    def start_chain(self, line: int) -> None:
        if self.chain is None:
            self.chain = _Chain(start_line=line, points=[self.pos.copy()])
            self.chains.append(self.chain)

    def end_chain(self) -> None:
        self.chain = None

    def target(self, axes: dict) -> np.ndarray:
        new = self.pos.copy()
        for k, letter in enumerate("XYZ"):
            if letter in axes:
                value = axes[letter] * self.scale
                new[k] = value if self.absolute else new[k] + value
        return new

    def feed_point(self, line: int, new: np.ndarray) -> None:
        self.start_chain(line)
        if not np.array_equal(new, self.chain.points[-1]):
            self.chain.points.append(new.copy())
            self.chain.kinds.add("G1")
        self.pos = new

    def handle(self, words: list[tuple[str, str]], line: int) -> None:
        g_codes, axes, params = [], {}, {}
        for letter, value in words:
            if letter == "G":
                g_codes.append(_num(value))
            elif letter == "M":
                code = _num(value)
                if code not in _IGNORED_M:
                    self.fail(line, f"M{value}: unsupported M code (accepted: "
                                    f"{', '.join('M' + c for c in sorted(_IGNORED_M, key=float))})")
                if code in _ENDS:
                    self.ended = True
            elif letter in "XYZ":
                if letter in axes:
                    self.fail(line, f"{letter} given twice")
                axes[letter] = float(value)
            elif letter in "ABCUVW":
                self.fail(line, f"{letter}{value}: axis {letter} is not supported (X, Y, Z only)")
            elif letter == "K":
                self.fail(line, f"K{value}: arcs are read in the XY plane (G17) only; K is not supported")
            elif letter in "IJRPLQ":
                if letter in params:
                    self.fail(line, f"{letter} given twice")
                params[letter] = float(value)
            elif letter in "FSTNHD":
                pass  # feed, spindle, tool, line number, offsets index: no effect on the path
            else:
                self.fail(line, f"{letter}{value}: unsupported word")
        for code in g_codes:
            if code in _REJECTED_G:
                self.fail(line, f"G{code} ({_REJECTED_G[code]}) is not supported; the path would "
                                "be read wrong")
        for code in g_codes:
            if code in ("20", "21"):
                self.scale = MM_PER_INCH if code == "20" else 1.0
            elif code in ("90", "91"):
                self.absolute = code == "90"
            elif code in ("90.1", "91.1"):
                self.ij_absolute = code == "90.1"
            elif code in _MOTIONS or code == "17" or code in _IGNORED_G:
                continue
            elif code in ("55", "56", "57", "58", "59", "59.1", "59.2", "59.3"):
                self.fail(line, f"G{code}: work offsets other than G54 are not supported")
            elif re.fullmatch(r"(73|76|8[1-9])", code):
                self.fail(line, f"G{code}: canned cycles are not supported")
            else:
                self.fail(line, f"G{code}: unsupported G code")
        motion = [c for c in g_codes if c in _MOTIONS]
        if len(motion) > 1:
            self.fail(line, f"two motion codes G{motion[0]} and G{motion[1]} on one line")
        if self.nurbs_pts is not None:
            self.nurbs_block_line(line, motion, axes, params)
            return
        if motion and motion[0] == "5.3":
            self.fail(line, "G5.3 without an open G5.2 block")
        if motion:
            self.motion = motion[0]
        if self.motion == "5.2" and motion:
            self.open_nurbs(line, axes, params)
            return
        full_circle = self.motion in ("2", "3") and ("I" in params or "J" in params)
        if not axes and not full_circle:
            return
        if "Z" in axes:
            self.saw_z = True
        if self.motion is None:
            self.fail(line, "axis words with no motion mode (G0, G1, G2, G3) in force")
        new = self.target(axes)
        if self.motion == "0":
            if not np.array_equal(new, self.pos):
                self.end_chain()
            self.pos = new
        elif self.motion == "1":
            self.feed_point(line, new)
        elif self.motion in ("2", "3"):
            self.arc(line, new, params, clockwise=self.motion == "2")
        if self.motion in ("0", "1") and any(k in params for k in "IJR"):
            self.fail(line, f"{'/'.join(k for k in 'IJR' if k in params)} with G{self.motion}: arc "
                            "words belong to G2/G3")

    def arc(self, line: int, end: np.ndarray, params: dict, clockwise: bool) -> None:
        """A G2/G3 arc in the XY plane (helical in Z), flattened into points on the exact arc with
        a sagitta of at most ARC_TOLERANCE_MM (LinuxCNC's arc rules: IJ incremental under G91.1,
        absolute under G90.1; R > 0 for at most half a turn, R < 0 for more; P full turns)."""
        start = self.pos
        name = "G2" if clockwise else "G3"
        has_ij = "I" in params or "J" in params
        if has_ij and "R" in params:
            self.fail(line, f"{name} with both R and I/J")
        if has_ij:
            ij = np.array([params.get("I", 0.0), params.get("J", 0.0)]) * self.scale
            center = ij if self.ij_absolute else start[:2] + ij
        elif "R" in params:
            r = params["R"] * self.scale
            chord = end[:2] - start[:2]
            d = float(np.hypot(*chord))
            if d == 0:
                self.fail(line, f"{name} R{params['R']:g}: a full circle needs I/J, not R")
            if abs(r) < d / 2 - 1e-6 * max(1.0, d):
                self.fail(line, f"{name} R{params['R']:g}: radius {abs(r):g} mm is shorter than half "
                                f"the chord ({d / 2:g} mm)")
            h = np.sqrt(max(r * r - d * d / 4, 0.0))
            right = np.array([chord[1], -chord[0]]) / d
            side = 1.0 if clockwise == (r > 0) else -1.0
            center = 0.5 * (start[:2] + end[:2]) + side * h * right
        else:
            self.fail(line, f"{name} needs I/J (centre) or R (radius)")
        r0 = float(np.hypot(*(start[:2] - center)))
        r1 = float(np.hypot(*(end[:2] - center)))
        if r0 == 0 or abs(r1 - r0) > ARC_RADIUS_TOLERANCE_MM + 1e-6 * r0:
            self.fail(line, f"{name}: radius to the end {r1:.6g} mm differs from radius to the start "
                            f"{r0:.6g} mm by more than {ARC_RADIUS_TOLERANCE_MM} mm")
        a0 = np.arctan2(start[1] - center[1], start[0] - center[0])
        a1 = np.arctan2(end[1] - center[1], end[0] - center[0])
        turns = params.get("P", 1.0)
        if turns < 1 or turns != int(turns):
            self.fail(line, f"{name} P{turns:g}: the number of turns must be an integer >= 1")
        if clockwise:
            sweep = -((a0 - a1) % (2 * np.pi))
            sweep = sweep if sweep != 0 else -2 * np.pi
            sweep -= 2 * np.pi * (turns - 1)
        else:
            sweep = (a1 - a0) % (2 * np.pi)
            sweep = sweep if sweep != 0 else 2 * np.pi
            sweep += 2 * np.pi * (turns - 1)
        r_max = max(r0, r1)
        step = 2.0 * np.arccos(1.0 - ARC_TOLERANCE_MM / r_max) if ARC_TOLERANCE_MM < r_max else np.pi / 2
        count = np.ceil(abs(sweep) / step)
        if not count <= MAX_POINTS:
            self.fail(line, f"{name}: {abs(sweep) / (2 * np.pi):.4g} turns of radius {r_max:.4g} mm need "
                            f"{count:.4g} points, more than the budget of {MAX_POINTS:,}")
        m = max(2, int(count))
        f = np.arange(1, m + 1) / m
        a = a0 + sweep * f
        radius = r0 + (r1 - r0) * f
        pts = np.column_stack([center[0] + radius * np.cos(a), center[1] + radius * np.sin(a),
                               start[2] + (end[2] - start[2]) * f])
        pts[-1] = end
        self.start_chain(line)
        for p in pts:
            if not np.array_equal(p, self.chain.points[-1]):
                self.chain.points.append(p)
        self.chain.kinds.add("arc")
        self.pos = end.copy()

    def open_nurbs(self, line: int, axes: dict, params: dict) -> None:
        if "Z" in axes:
            self.fail(line, "Z in a G5.2 block: G5.2 is planar (X, Y only)")
        self.nurbs_line = line
        self.nurbs_order = 3
        first_w = 1.0
        if not axes and params.get("P", 0) > 0:
            first_w = params["P"]
        self.nurbs_pts = [self.pos.copy()]
        self.nurbs_w = [first_w]
        self.nurbs_block_line(line, [], axes, params, first=True)

    def nurbs_block_line(self, line: int, motion: list, axes: dict, params: dict,
                         first: bool = False) -> None:
        if motion and motion[0] == "5.3":
            if axes:
                self.fail(line, "G5.3 with axis words")
            self.close_nurbs(line)
            return
        if motion and motion[0] != "5.2":
            self.fail(line, f"G{motion[0]} inside a G5.2 block (close it with G5.3 first)")
        if "L" in params and params["L"] > 3:
            if params["L"] != int(params["L"]):
                self.fail(line, f"L{params['L']}: the NURBS order must be an integer")
            self.nurbs_order = int(params["L"])
        if "Z" in axes:
            self.fail(line, "Z in a G5.2 block: G5.2 is planar (X, Y only)")
        if ("X" in axes) != ("Y" in axes):
            self.fail(line, "a G5.2 control point needs both X and Y")
        if "X" in axes:
            weight = params.get("P", 0.0)
            if weight <= 0:
                self.fail(line, f"G5.2 control point weight P = {weight:g}; every control point "
                                "needs a positive weight P")
            new = self.target(axes)
            self.nurbs_pts.append(new)
            self.nurbs_w.append(weight)
        elif not first and params:
            self.fail(line, "P without X and Y is allowed only on the first G5.2 line")

    def close_nurbs(self, line: int) -> None:
        pts, w, k = np.array(self.nurbs_pts), np.array(self.nurbs_w), self.nurbs_order
        self.nurbs_pts = self.nurbs_w = None
        self.motion = None
        if len(pts) < k:
            self.fail(line, f"G5.2 block from line {self.nurbs_line}: {len(pts)} control points "
                            f"(with the start point) but order L = {k} needs at least {k}")
        try:
            curve = Nurbs(k - 1, linuxcnc_knots(len(pts), k), pts, w)
        except NurbsError as exc:
            self.fail(line, f"G5.2 block from line {self.nurbs_line}: {exc}")
        self.start_chain(self.nurbs_line)
        self.chain.nurbs.append((curve, len(self.chain.points) - 1))
        self.chain.kinds.add("G5.2")
        self.chain.points.append(pts[-1].copy())
        self.pos = pts[-1].copy()

    def finish(self, nlines: int) -> None:
        if self.nurbs_pts is not None:
            self.fail(nlines, f"G5.2 block from line {self.nurbs_line} is not closed by G5.3")


def parse_gcode(text: str, path: str | os.PathLike = "<gcode>") -> list[_Chain]:
    """Parse program text into chains of feed moves (see the module docstring)."""
    parser = _Parser(Path(path))
    lines = text.splitlines()
    for number, raw in enumerate(lines, start=1):
        if parser.ended:
            break
        parser.handle(parser.words(raw, number), number)
    parser.finish(len(lines))
    for chain in parser.chains:
        chain.dim = 3 if parser.saw_z or np.any(np.array(chain.points)[:, 2] != 0) else 2
    return [c for c in parser.chains if len(c.points) >= 2]


def _chain_shape(chain: _Chain, path: Path, index: int, total: int):
    from fuzzyfeed.io.points import polyline_shape
    from fuzzyfeed.io.shapes import Shape

    name = path.stem if total == 1 else f"{path.stem}#{index}"
    source = f"{path} (G-code, path {index} of {total}, from line {chain.start_line})"
    dim = chain.dim
    if chain.kinds == {"G5.2"} and len(chain.nurbs) == 1:
        curve = chain.nurbs[0][0]
        if dim == 2 and curve.dim == 3:
            curve = Nurbs(curve.degree, curve.knots, curve.control_points[:, :2], curve.weights)
        return Shape(name=name, curve=curve, source=source, path=path,
                     notes="one G5.2 block, LinuxCNC's uniform clamped knot vector on [0, 1]")
    points = list(chain.points)
    notes = "G1 polyline" + (" with G2/G3 arcs flattened within "
                             f"{ARC_TOLERANCE_MM} mm" if "arc" in chain.kinds else "")
    if chain.nurbs:
        # the move points[i-1] -> points[i] is either a straight/arc piece or a G5.2 block,
        # which is replaced by its samples (they end at points[i])
        starts = {start: curve for curve, start in chain.nurbs}
        expanded = [points[0]]
        for i in range(1, len(points)):
            curve = starts.get(i - 1)
            if curve is None:
                expanded.append(points[i])
                continue
            spans = max(1, curve.span_breaks.size - 1)
            u = np.linspace(*curve.domain, spans * NURBS_IMPORT_POINTS_PER_SPAN + 1)[1:]
            c = curve(u)
            block = np.column_stack([c[:, :2], np.full(len(u), points[i - 1][2])])
            block[-1] = points[i]
            expanded.extend(block)
        points = expanded
        notes = (f"G1 moves and {len(chain.nurbs)} G5.2 block(s) sampled at "
                 f"{NURBS_IMPORT_POINTS_PER_SPAN} points per knot span")
    pts = np.array(points, dtype=float)[:, :dim]
    return polyline_shape(pts, name=name, source=source, path=path, notes=notes)


def load_gcode_shapes(path: str | os.PathLike) -> list:
    """All paths of a G-code file, one :class:`Shape` per chain of feed moves."""
    from fuzzyfeed.io.points import read_text

    path = Path(path)
    text = read_text(path, "G-code")
    chains = parse_gcode(text, path)
    if not chains:
        raise PathFormatError(f"{path}: no feed move (G1 or G5.2) found; nothing to import")
    return [_chain_shape(c, path, i + 1, len(chains)) for i, c in enumerate(chains)]


def load_gcode(path: str | os.PathLike, selector: str | None = None):
    """One path of a G-code file: the only one, or ``selector`` = ``N`` / ``path=N`` (1-based)."""
    from fuzzyfeed.io.points import pick_by_index, read_text

    path = Path(path)
    chains = parse_gcode(read_text(path, "G-code"), path)
    if not chains:
        raise PathFormatError(f"{path}: no feed move (G1 or G5.2) found; nothing to import")
    described = [f"{i + 1} (line {c.start_line})" for i, c in enumerate(chains)]
    index = pick_by_index(path, selector, described)
    return _chain_shape(chains[index], path, index + 1, len(chains))
