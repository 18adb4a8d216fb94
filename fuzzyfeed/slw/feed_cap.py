"""A feed cap per arc length for the SLW scheduler, and its staircase.

The cap (mm/s, e.g. the fuzzy advice) is one more pointwise feed limit. The look-ahead follows a
limit that rises inside a block in stairs: each time the cosine profile crosses it, a junction is
added and the window re-planned. An advice that wanders over the whole path made thousands of such
repairs. :func:`stairs` builds the staircase once, ahead of the look-ahead: levels F·r^k
(r = STAIR_RATIO) at or below the cap everywhere, each raised plateau at least STAIR_PLATEAU
transitions long. Every step is then a critical point of the preprocessor, and the blocks between
them have a constant cap: the look-ahead has nothing left to repair for the cap. Where the cap
falls or rises much faster than a transition (an advice's dip at a corner), the profile passes
under it in one transition anyway; steps there would only add junctions, each a zero
acceleration, so the cap is kept as it is.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.slw.profile import transition_distance

#: Ratio between consecutive levels of the staircase (a step is 3 % of the feed).
STAIR_RATIO = 0.97
#: A raised plateau must be at least this many transitions between its level and the one below
#: long; a shorter one is lowered (it would save less time than its two transitions cost).
STAIR_PLATEAU = 4.0
#: A plateau on a fall or rise of the cap shorter than this share of the transition between its
#: neighbours' feeds is steep: the cap itself is kept there (measured on the shipped shapes and
#: random curves: 0.25 gave the shortest cycles with the fewest look-ahead repairs; 0 - all
#: stairs - was 14 % slower on infinity, 1 added 250 repairs on a 585 mm curve).
STEEP_SHARE = 0.25
#: Cells of the staircase per cap sample interval, and bounds on their number over the path.
CELLS_PER_SAMPLE = 4
MIN_CELLS, MAX_CELLS = 1000, 200_000


@dataclass(frozen=True, eq=False)
class FeedCap:
    """One more pointwise feed limit (mm/s) given at arc lengths (mm), linear in between — e.g.
    a planner's advice, so that the schedule is the jerk-limited one under min(advice, machine).
    The arc lengths are rescaled to the path's length (samples and curve may differ by rounding).
    An arc length given twice is a step; the cap there is the lower of its two sides."""

    s_mm: np.ndarray
    feed_mm_s: np.ndarray
    length_mm: float

    def __post_init__(self) -> None:
        s = np.asarray(self.s_mm, dtype=float)
        v = np.asarray(self.feed_mm_s, dtype=float)
        if s.ndim != 1 or s.shape != v.shape or s.size < 2:
            raise InputError(f"feed_cap: {s.size} arc lengths and {v.size} feeds; need the same number, ≥ 2")
        if not (np.isfinite(s).all() and np.isfinite(v).all()):
            raise InputError("feed_cap: a value is not finite; a feed cap must be finite")
        if (v <= 0).any():
            i = int(np.argmax(v <= 0))
            raise InputError(f"feed_cap[{i}] = {v[i]!r} mm/s; a feed cap must be > 0")
        if (np.diff(s) < 0).any() or s[-1] <= s[0]:
            raise InputError("feed_cap: arc lengths must be non-decreasing and span the path")
        scaled = (s - s[0]) * (self.length_mm / (s[-1] - s[0]))
        scaled[-1] = self.length_mm
        object.__setattr__(self, "s_mm", scaled)
        object.__setattr__(self, "feed_mm_s", v)

    def __call__(self, s: np.ndarray) -> np.ndarray:
        s = np.asarray(s, dtype=float)
        return np.minimum(_interp(s, self.s_mm, self.feed_mm_s, "left"),
                          _interp(s, self.s_mm, self.feed_mm_s, "right"))

    @property
    def steps_mm(self) -> np.ndarray:
        """Arc lengths where the cap jumps (given twice with different feeds)."""
        same = np.diff(self.s_mm) == 0.0
        jump = same & (np.diff(self.feed_mm_s) != 0.0)
        return self.s_mm[:-1][jump]


def _interp(s: np.ndarray, xp: np.ndarray, fp: np.ndarray, side: str) -> np.ndarray:
    """Linear interpolation that takes, at a repeated xp, the value of the ``side`` it is
    approached from ("left": the last interval ending there; "right": the first starting there)."""
    if side == "left":
        j = np.clip(np.searchsorted(xp, s, side="left"), 1, xp.size - 1)
    else:
        j = np.clip(np.searchsorted(xp, s, side="right"), 1, xp.size - 1)
    x0, x1, f0, f1 = xp[j - 1], xp[j], fp[j - 1], fp[j]
    width = x1 - x0
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(width > 0.0, (s - x0) / width, 1.0 if side == "left" else 0.0)
    return f0 + np.clip(w, 0.0, 1.0) * (f1 - f0)


def stairs(cap: FeedCap, feed_mm_s: float, acc_mm_s2: float, jerk_mm_s3: float) -> FeedCap:
    """The staircase under ``cap``: levels F·r^k (F the command feed, r = STAIR_RATIO), on cells
    of the path; each cell at the highest level not above the cap anywhere in the cell (the cap is
    linear between its points, so its minimum over a cell is at a cell end or a point inside).
    Raised plateaus shorter than STAIR_PLATEAU transitions (level below → level) are lowered, from
    the highest level down — an opening of each upper level set. Each plateau then takes the cap's
    minimum over it, so the result stays ≤ the cap and a constant cap is kept as it is; steep
    stretches (:func:`_steep`) keep the cap itself."""
    total = cap.length_mm
    n_cells = int(np.clip(CELLS_PER_SAMPLE * cap.s_mm.size, MIN_CELLS, MAX_CELLS))
    edges = np.linspace(0.0, total, n_cells + 1)
    # cap minimum per cell: over the cell's ends and the cap's own points inside it
    pts = np.concatenate([edges, cap.s_mm])
    vals = np.concatenate([cap(edges), cap.feed_mm_s])
    cell = np.clip(np.searchsorted(edges, pts, side="right") - 1, 0, n_cells - 1)
    low = np.full(n_cells, np.inf)
    np.minimum.at(low, cell, vals)
    # an edge belongs to the cells on both sides
    np.minimum.at(low, np.clip(np.arange(n_cells + 1) - 1, 0, n_cells - 1), vals[: n_cells + 1])
    log_r = -np.log(STAIR_RATIO)
    with np.errstate(divide="ignore"):
        k = np.ceil(np.log(feed_mm_s / low) / log_r - 1e-12)
    k = np.clip(k, 0, None).astype(np.int64)
    level = feed_mm_s * STAIR_RATIO ** np.arange(int(k.max()) + 2)
    k = np.where(level[k] > low, k + 1, k)  # rounding of the log: never above the cap
    width = total / n_cells
    for m in range(int(k.min()), int(k.max())):
        upper = k <= m  # cells at level m or higher
        if upper.all():
            continue
        need = STAIR_PLATEAU * transition_distance(level[m + 1], level[m], acc_mm_s2, jerk_mm_s3)
        starts, ends = _runs(upper)
        short = (ends - starts) * width < need
        if short.any():
            mark = np.zeros(n_cells + 1, dtype=np.int64)
            np.add.at(mark, starts[short], 1)
            np.add.at(mark, ends[short], -1)
            k[np.cumsum(mark[:-1]) > 0] = m + 1
    # each plateau at the cap's own minimum over it (≥ its level: a flat cap is kept exactly)
    change = np.flatnonzero(np.diff(k)) + 1
    bounds = np.concatenate([[0], change, [n_cells]])
    value = np.minimum.reduceat(low, bounds[:-1])
    steep = _steep(edges[bounds], value, acc_mm_s2, jerk_mm_s3)
    # one point at each end of every plateau (a step repeats its arc length); a steep stretch is
    # the cap itself, its own points included
    s_out: list[np.ndarray] = []
    v_out: list[np.ndarray] = []
    i = 0
    while i < value.size:
        if not steep[i]:
            s_out.append(edges[bounds[[i, i + 1]]])
            v_out.append(np.full(2, value[i]))
            i += 1
            continue
        j = i
        while j + 1 < value.size and steep[j + 1]:
            j += 1
        a, b = edges[bounds[i]], edges[bounds[j + 1]]
        inside = cap.s_mm[(cap.s_mm > a) & (cap.s_mm < b)]
        x = np.concatenate([[a], inside, [b]])
        s_out.append(x)
        v_out.append(cap(x))
        i = j + 1
    return FeedCap(np.concatenate(s_out), np.concatenate(v_out), total)


def _steep(bounds_mm: np.ndarray, value: np.ndarray, acc: float, jerk: float) -> np.ndarray:
    """Plateaus between a lower and a higher neighbour shorter than STEEP_SHARE of the transition
    between their neighbours' feeds: the cap falls or rises there much faster than a jerk-limited
    transition follows, so the profile passes under it in one transition, and steps would only
    add junctions (each a zero acceleration). There the cap is kept as it is."""
    steep = np.zeros(value.size, dtype=bool)
    if value.size < 3:
        return steep
    prev, cur, nxt = value[:-2], value[1:-1], value[2:]
    mono = (prev - cur) * (cur - nxt) > 0
    length = np.diff(bounds_mm)[1:-1]
    for i in np.flatnonzero(mono):
        lo, hi = min(prev[i], nxt[i]), max(prev[i], nxt[i])
        steep[i + 1] = length[i] < STEEP_SHARE * transition_distance(lo, hi, acc, jerk)
    return steep


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start (inclusive) and end (exclusive) indices of the runs of True in ``mask``."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)
