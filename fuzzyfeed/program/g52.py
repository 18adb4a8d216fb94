"""LinuxCNC ``G5.2`` NURBS blocks from a curve.

LinuxCNC's G5.2 takes the current position as the first control point, weights as P, the order
as L (default 3, L is used only when > 3) and builds the knot vector itself: uniform and clamped
(``nurbs_G5_knot_vector_creator``: k zeros, 1 … n−k+1, k times n−k+2). With ``split="whole"``
the curve is one block; a curve whose knots are not uniform (after scaling the domain) cannot be
written that way and is refused, naming the first knot that breaks the rule. With
``split="spans"`` the curve is cut by knot insertion into rational Bézier pieces
(:func:`fuzzyfeed.geometry.nurbs.bezier_segments`), one block per knot span — their knot vectors are
uniform clamped, so any knot vector is written exactly, and each block carries the slowest
advised feed over its span. Refused in both modes: a degree-1 curve (order 2 < 3) and a curve
that is not planar at one Z (G5.2 is XY only). Control points are rounded to ``decimals``,
weights to ``weight_decimals``.
"""

from __future__ import annotations

import math
import os

import numpy as np

from fuzzyfeed import __version__
from fuzzyfeed.errors import ExportError
from fuzzyfeed.base.atomic import atomic_write
from fuzzyfeed.program.write import (DEFAULT_DECIMALS, DEFAULT_FEED_DECIMALS, _check_decimals,
                                      _comment, _fmt, _Lines, quantise_feed_mm_min,
                                      segment_feeds_mm_s)
from fuzzyfeed.geometry.nurbs import Nurbs, bezier_segments
from fuzzyfeed.machine.profile import FeedProfile


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
        raise ExportError(f"--gcode-g52: the path is a NURBS of degree {curve.degree} (a point sequence "
                          "or polyline); G5.2 needs order L = degree + 1 >= 3; write it as G1 moves "
                          "with --gcode")
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
                        line_numbers: bool = False, title: str | None = None,
                        safe_z_mm: float | None = None, plunge_feed_mm_min: float | None = None,
                        notes: tuple[str, ...] = ()) -> list[str]:
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
    for note in notes:
        out.add(_comment(note), numbered=False)
    out.add("G17 G21 G90 G94")
    pts = curve.control_points
    z0 = float(pts[0, 2]) if curve.dim == 3 else 0.0
    start = f"G0 X{_fmt(pts[0, 0], decimals)} Y{_fmt(pts[0, 1], decimals)}"
    last_f = None
    if safe_z_mm is None:
        if curve.dim == 3:
            start += f" Z{_fmt(pts[0, 2], decimals)}"
        out.add(start)
    else:
        if not (np.isfinite(safe_z_mm) and safe_z_mm > z0):
            raise ExportError(f"safe_z_mm = {safe_z_mm!r}; the safe height must be above the path "
                              f"(z = {z0:g} mm)")
        plunge = float(np.min(feeds)) if plunge_feed_mm_min is None else float(plunge_feed_mm_min)
        out.add(f"G0 Z{_fmt(safe_z_mm, decimals)}")
        out.add(start)
        out.add(f"G1 Z{_fmt(z0, decimals)} F{plunge:.{feed_decimals}f}")
        last_f = "plunge"
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
    if safe_z_mm is not None:
        out.add(f"G0 Z{_fmt(safe_z_mm, decimals)}")
    out.add("M2")
    return out.lines


def write_gcode_nurbs(path: str | os.PathLike, curve: Nurbs, feed: float | FeedProfile,
                      **kwargs) -> list[str]:
    """Write ``curve`` as G5.2 block(s) (see :func:`nurbs_gcode_program`), atomically."""
    lines = nurbs_gcode_program(curve, feed, **kwargs)
    with atomic_write(path, "w", newline="\n") as handle:
        handle.write("\n".join(lines) + "\n")
    return lines
