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

The default approach follows the machine's own limit in the same staircase (``machine=True``):
lazily, a limit that rises out of a dip was repaired crossing by crossing too, and the median
cycle of bench_slw's paths was 1.155x the bound. Near the bottom of a dip, and over a short
shallow one, the machine's staircase keeps the limit itself (the profile cannot be above it
there yet; steps would only stop its acceleration). :func:`lower` joins the two staircases.
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
#: Where the staircase of the machine's own limit keeps the limit itself, its sampled copy is
#: raised by this factor: the preprocessor holds the exact limit there.
MACHINE_ROOM = 1.05
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
        v = v.copy()  # read-only copies: a cap is shared (the machine's, cached per curve)
        for arr in (scaled, v):
            arr.flags.writeable = False
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


def stairs(cap: FeedCap, feed_mm_s: float, acc_mm_s2: float, jerk_mm_s3: float,
           machine: bool = False) -> FeedCap:
    """The staircase under ``cap``: levels F·r^k (F the command feed, r = STAIR_RATIO), on cells
    of the path; each cell at the highest level not above the cap anywhere in the cell (the cap is
    linear between its points, so its minimum over a cell is at a cell end or a point inside).
    Raised plateaus shorter than STAIR_PLATEAU transitions (level below → level) are lowered, from
    the highest level down — an opening of each upper level set. Each plateau then takes the cap's
    minimum over it, so the result stays ≤ the cap and a constant cap is kept as it is; steep
    stretches (:func:`_steep`) keep the cap itself, never above a plateau beside them. With
    ``machine`` (the cap is the machine's own limit, sampled) so do the plateaus within a
    transition of the bottom of a dip (:func:`_within_reach`), and there the cap is raised by
    MACHINE_ROOM: the preprocessor holds the machine's limit itself exactly, the sampled copy
    (linear between samples) must not cut under it."""
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
    if machine:
        steep = _machine_keeps(edges[bounds], value, steep, acc_mm_s2, jerk_mm_s3)
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
        raw = cap(x)
        v = raw * (MACHINE_ROOM if machine else 1.0)
        # never above a higher plateau beside it (on that plateau's side of the stretch's lowest
        # point): a step up where a plateau meets the cap would be a local minimum, a critical
        # point (a zero acceleration) in the middle of a fall or a rise; a step down to a lower
        # plateau is no minimum and stays
        low = int(np.argmin(raw))
        left = value[i - 1] if i > 0 and value[i - 1] >= raw[low] else np.inf
        right = value[j + 1] if j + 1 < value.size and value[j + 1] >= raw[low] else np.inf
        x0, v0 = _clip(x[: low + 1], v[: low + 1], left)
        x1, v1 = _clip(x[low:], v[low:], right)
        s_out.append(np.concatenate([x0, x1[1:]]))
        v_out.append(np.concatenate([v0[:-1], [min(v0[-1], v1[0])], v1[1:]]))
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


def _machine_keeps(bounds_mm: np.ndarray, value: np.ndarray, steep: np.ndarray, acc_mm_s2: float,
                   jerk_mm_s3: float) -> np.ndarray:
    """Plateaus of the machine's own staircase kept as the limit itself: those within reach of a
    dip's bottom (:func:`_within_reach`), the bottom of a dip whose sides are kept, and a short
    shallow dip."""
    steep = steep | _within_reach(bounds_mm, value, acc_mm_s2, jerk_mm_s3)
    # and the bottom of a dip whose sides are the cap itself: the whole dip is
    bottom = np.ones(value.size, dtype=bool)
    bottom[1:] &= value[:-1] > value[1:]
    bottom[:-1] &= value[1:] > value[:-1]
    side = np.zeros(value.size, dtype=bool)
    side[1:] |= steep[:-1]
    side[:-1] |= steep[1:]
    # and a short shallow dip (its bottom within one level of both sides and shorter than
    # STAIR_PLATEAU transitions up to them): its two steps would cost more than they save
    beside = np.full(value.size, np.inf)
    beside[1:] = value[:-1]
    beside[:-1] = np.minimum(beside[:-1], value[1:])
    shallow = bottom & (value >= STAIR_RATIO * beside)
    shallow[[0, -1]] = False  # a dip has two sides (a cap low to the path's end is no dip)
    for i in np.flatnonzero(shallow):
        need = STAIR_PLATEAU * transition_distance(value[i], beside[i], acc_mm_s2, jerk_mm_s3)
        shallow[i] = bounds_mm[i + 1] - bounds_mm[i] < need
    return steep | (bottom & side) | shallow


def _clip(x: np.ndarray, v: np.ndarray, level: float) -> tuple[np.ndarray, np.ndarray]:
    """min(f, level) of the piecewise-linear f through (x, v), with the crossings as points."""
    if not np.isfinite(level) or x.size < 2:
        return x, np.minimum(v, level)
    d = v - level
    i = np.flatnonzero(d[:-1] * d[1:] < 0.0)
    cross = x[i] + (x[i + 1] - x[i]) * d[i] / (d[i] - d[i + 1])
    # f at the crossing as the cap interpolates it (on a near-vertical piece, the rounding of
    # the crossing's position must not put the point above f)
    at = v[i] + (cross - x[i]) / (x[i + 1] - x[i]) * (v[i + 1] - v[i])
    xs = np.concatenate([x, cross])
    vs = np.concatenate([np.minimum(v, level), np.minimum(at, level)])
    order = np.argsort(xs, kind="stable")
    return xs[order], vs[order]


def _within_reach(bounds_mm: np.ndarray, value: np.ndarray, acc: float, jerk: float) -> np.ndarray:
    """Plateaus on a fall (or rise) closer to the bottom of the dip than the transition from
    their feed to the bottom's. A profile that reaches the bottom's feed is under them anyway: it
    climbs out of the dip on one transition, and steps there would each stop its acceleration
    (a junction is a zero acceleration) — on the machine's own limit this made the climb out of
    deep dips up to 14 % slower."""
    n = value.size
    near = np.zeros(n, dtype=bool)
    if n < 3:
        return near
    start, end = bounds_mm[:-1], bounds_mm[1:]
    ahead = np.concatenate([value[1:] < value[:-1], [False]])     # the next plateau is lower
    behind = np.concatenate([[False], value[:-1] < value[1:]])    # the previous one is lower
    bottom_here = ~ahead & ~behind
    fall = ahead & np.concatenate([[False], value[:-1] > value[1:]])
    rise = behind & np.concatenate([value[1:] > value[:-1], [False]])
    bottom = -1
    for i in range(n - 1, -1, -1):  # a fall's bottom is the next minimum ahead
        if bottom_here[i]:
            bottom = i
        elif fall[i] and bottom >= 0:
            near[i] = start[bottom] - end[i] < transition_distance(value[bottom], value[i], acc, jerk)
    bottom = -1
    for i in range(n):  # a rise's bottom is the last minimum behind
        if bottom_here[i]:
            bottom = i
        elif rise[i] and bottom >= 0:
            near[i] = start[i] - end[bottom] < transition_distance(value[bottom], value[i], acc, jerk)
    return near


def lower(a: FeedCap, b: FeedCap) -> FeedCap:
    """min(a, b) as one cap on the same path: both sides of every step of either, and a point
    where the two cross between their points (the minimum of two linear pieces is not linear)."""
    if a.length_mm != b.length_mm:
        raise InputError(f"feed caps over {a.length_mm!r} and {b.length_mm!r} mm; need the same path")
    s = np.unique(np.concatenate([a.s_mm, b.s_mm]))
    left = np.minimum(_interp(s, a.s_mm, a.feed_mm_s, "left"), _interp(s, b.s_mm, b.feed_mm_s, "left"))
    right = np.minimum(_interp(s, a.s_mm, a.feed_mm_s, "right"), _interp(s, b.s_mm, b.feed_mm_s, "right"))
    # crossings: a − b changes sign between the right side of s_i and the left side of s_i+1
    d0 = _interp(s[:-1], a.s_mm, a.feed_mm_s, "right") - _interp(s[:-1], b.s_mm, b.feed_mm_s, "right")
    d1 = _interp(s[1:], a.s_mm, a.feed_mm_s, "left") - _interp(s[1:], b.s_mm, b.feed_mm_s, "left")
    i = np.flatnonzero(d0 * d1 < 0.0)
    x = s[i] + (s[i + 1] - s[i]) * d0[i] / (d0[i] - d1[i])
    x = x[(x > s[i]) & (x < s[i + 1])]
    step = left != right
    pts = np.concatenate([s, s[step], x])
    vals = np.concatenate([left, right[step], np.minimum(a(x), b(x))])
    side = np.concatenate([np.zeros(s.size), np.ones(int(step.sum())), np.zeros(x.size)])
    order = np.lexsort((side, pts))
    return FeedCap(pts[order], vals[order], a.length_mm)


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start (inclusive) and end (exclusive) indices of the runs of True in ``mask``."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)
