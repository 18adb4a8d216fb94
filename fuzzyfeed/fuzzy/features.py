"""Controller inputs of the fuzzy advisor (seed 002, section 2.6): curvature κ and its windowed
variation Dκ.

Dκᵢ = max(κᵢ, …, κᵢ₊WS₋₁) (seed 002 eq. 10): a forward window, truncated at the end of the path, so
the controller sees the sharp region ahead. Dκ is clipped at ``clip`` (the paper's 3) and min–max
normalised to [0, 1] over the path; a constant Dκ (a straight line, a circle — up to rounding, see
``CONSTANT_RTOL``) normalises to 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.base.checks import expect, float_array
from fuzzyfeed.errors import InputError


def check_curvature(kappa: np.ndarray, name: str = "curvature") -> np.ndarray:
    """κ as a float array; NaN, infinite or negative values are an :class:`InputError`."""
    k = np.ascontiguousarray(float_array(kappa, name), dtype=float)
    if k.ndim != 1 or k.size == 0:
        raise InputError(f"{name}: shape {k.shape}; expected a non-empty 1-D array")
    bad = ~np.isfinite(k)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f"{name}[{i}] = {k[i]}; curvature must be finite (the path has a cusp or "
                         "a zero-speed point there)")
    if (k < 0).any():
        i = int(np.argmax(k < 0))
        raise InputError(f"{name}[{i}] = {k[i]}; curvature must be >= 0")
    return k


def forward_window_max(values: np.ndarray, window_points: int) -> np.ndarray:
    """out[i] = max(values[i : i + window_points]), truncated at the end (seed 002 eq. 10).

    Doubling: after a step of s ≤ w, max(m_w[i], m_w[i + s]) covers [i, i + w + s − 1]; O(N log WS).
    """
    if isinstance(window_points, bool) or not isinstance(window_points, (int, np.integer)) \
            or window_points < 1:
        raise InputError(f"window_points = {window_points!r}; must be an integer >= 1")
    m = np.array(values, dtype=float, copy=True)
    width = 1
    while width < window_points:
        step = min(width, window_points - width)
        if step >= m.size:
            break
        np.maximum(m[:-step], m[step:], out=m[:-step])
        width += step
    if width < window_points and m.size:   # window longer than the path: suffix maxima
        m = np.maximum.accumulate(np.asarray(values, dtype=float)[::-1])[::-1]
    return m


#: Dκ whose spread (max − min) is at most this fraction of its max counts as constant: rounding in
#: the curvature of a circle must not be blown up to [0, 1] by the normalisation.
CONSTANT_RTOL = 1e-9


def normalise(dk: np.ndarray, clip: float, bounds: tuple[float, float] | None = None) -> np.ndarray:
    """Clip at ``clip`` then min–max normalise to [0, 1]; a constant array (spread at most
    ``CONSTANT_RTOL`` of its max, e.g. a circle's κ up to rounding) gives 0. ``bounds``: the
    clipped minimum and maximum over the whole path when ``dk`` is a piece of it."""
    c = np.minimum(dk, clip)
    lo, hi = (float(c.min()), float(c.max())) if bounds is None else bounds
    if hi - lo <= CONSTANT_RTOL * abs(hi):
        return np.zeros_like(c)
    return (c - lo) / (hi - lo)


@dataclass(frozen=True, eq=False)
class Features:
    """The two controller inputs per point, plus Dκ before normalisation (1/mm)."""

    curvature_1_mm: np.ndarray
    window_max_1_mm: np.ndarray
    curvature_variation: np.ndarray


def features(kappa: np.ndarray, window_points: int = 30, clip_1_mm: float = 3.0,
             s: np.ndarray | None = None, window_mm: float | None = None,
             span: tuple[float, float] | None = None, bounds: tuple[float, float] | None = None) -> Features:
    """κ and the normalised Dκ of seed 002 (eq. 10, clip, min–max normalisation).

    With ``window_mm`` (and the arc length ``s`` of the points) the window is a length instead:
    Dκᵢ = max κⱼ over s_i ≤ s_j ≤ s_i + window_mm, the same stretch of path at any sampling.
    On a piece of a path, ``span`` is the path's first and last s and ``bounds`` the clipped Dκ's
    minimum and maximum over the path (:func:`normalise`).
    """
    k = check_curvature(kappa)
    expect(clip_1_mm, (int, float, np.integer, np.floating), "clip_1_mm", "a number of 1/mm")
    if not np.isfinite(clip_1_mm) or clip_1_mm <= 0:
        raise InputError(f"clip_1_mm = {clip_1_mm!r}; must be finite and > 0")
    if window_mm is None:
        raw = forward_window_max(k, window_points)
    else:
        from fuzzyfeed.fuzzy.windows import forward_bounds, range_max

        if s is None or np.shape(s) != k.shape:
            raise InputError("window_mm needs the arc length s of every point")
        raw = range_max(k, *forward_bounds(k.size, s=s, length_mm=window_mm, span=span))
    return Features(curvature_1_mm=k, window_max_1_mm=raw,
                    curvature_variation=normalise(raw, clip_1_mm, bounds))
