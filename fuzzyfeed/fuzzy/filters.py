"""Smoothing of the controller's feed along the path (the last stage of the fuzzy advisor).

- ``"mean"``: seed 002's average filter (section 2.7.2), a centred moving average of M points.
  At a sharp corner the controller's dip is narrower than M, so the average pulls the corner's feed
  up towards its fast neighbours: on the butterfly's κ ≈ 35 /mm corners the controller asks
  11.7 % and the average gives up to 30 %.
- ``"min-mean"`` (fuzzyfeed's default): a sliding minimum over the same window (a morphological
  erosion), then the same centred average. Each point's average only takes minima whose windows
  contain that point, so the result is never above the controller's output anywhere — in
  particular not at a curvature peak — while the average still removes the ripple of the erosion.
  The slow-down starts up to M − 1 points earlier and ends as much later.

``benchmarks/filter_choice.py`` measures both (and M) on the shipped shapes: the largest
point-to-point change against how much of the controller's slow-down at the κ peaks is kept.
Windows are counted in points (``points``, M) or measured in mm (``length_mm``, needs the arc
length ``s``); in mm each sample is weighted by the length of path it stands for.
"""

from __future__ import annotations

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.fuzzy.windows import cell_lengths, centred_bounds, range_min, window_mean

#: The filters a rule table may name in ``[features] filter``.
FILTER_KINDS = ("min-mean", "mean")
DEFAULT_FILTER = "min-mean"


def smooth_feed(values: np.ndarray, kind: str = DEFAULT_FILTER, points: int | None = 21,
                s: np.ndarray | None = None, length_mm: float | None = None) -> np.ndarray:
    """The controller's feed ``values`` smoothed by filter ``kind`` over a window of ``points``
    samples (M; an even M uses M − 1) or of ``length_mm`` mm of arc length ``s``.

    The averaging window is centred and shrinks symmetrically at the ends (the first and last
    points keep their own value); the erosion of ``"min-mean"`` uses the same half-width, truncated
    at the ends.
    """
    v = np.asarray(values, dtype=float)
    if kind not in FILTER_KINDS:
        raise InputError(f"filter = {kind!r}; must be one of {', '.join(FILTER_KINDS)}")
    n = v.size
    if length_mm is None:
        if isinstance(points, bool) or not isinstance(points, (int, np.integer)) or points < 1:
            raise InputError(f"filter_points = {points!r}; must be an integer >= 1")
        half = dict(half_points=int(points) // 2)
        weights = None
    else:
        length = float(length_mm)
        if not np.isfinite(length) or length <= 0:
            raise InputError(f"filter_mm = {length_mm!r}; must be a finite number > 0 (mm)")
        half = dict(s=s, half_mm=length / 2)
        weights = cell_lengths(s)
    lo, hi = centred_bounds(n, symmetric=True, **half)
    if kind == "min-mean":
        elo, ehi = centred_bounds(n, symmetric=False, **half)
        v = range_min(v, elo, ehi)
    return window_mean(v, lo, hi, weights)


def average_filter(values: np.ndarray, points: int) -> np.ndarray:
    """Seed 002's centred moving average over ``points`` samples; at the ends the window shrinks
    symmetrically (point i averages i − h … i + h with h = min(M // 2, i, N − 1 − i))."""
    return smooth_feed(values, "mean", points)
