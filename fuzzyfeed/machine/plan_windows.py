"""A chain's plan (:func:`~fuzzyfeed.machine.planner.plan_motion`) made window by window, bit for
bit the whole plan's, holding O(window) arrays (issue 36: the uniform trials and the limit
reference's passes plan whole chains at every factor).

What crosses a window's boundary in the whole plan:

- the geometry's limits (:func:`~fuzzyfeed.machine.planner.local_limits`) depend on a segment's
  neighbours and, on LinuxCNC (``corner = "path-tolerance"``), on whole program moves (a move's
  length, its halved or kinked acceleration from the corners at both its ends, its arc's plane):
  windows start and end at move boundaries; the cap at a window's end vertex needs its neighbour
  moves' speed caps, which need their own neighbours: each window is computed with two whole moves
  of context on either side (the chain's true ends keep their rest caps and LinuxCNC's parabolic
  last move);
- the cumulative reach D_k = Σ_{j<k} 2·a_j·L_j (a running sum: carried as one float, the same
  sequential additions as ``np.cumsum``) and, with ``lookahead_moves`` = N, the cap
  min(c_k, D_{min(k+N−1, n)} − D_k): the reach of the N − 1 segments after a window (its context
  extended by them);
- the squared speed w_k = max(0, min(D_k + min_{j≤k}(c_j − D_j), min_{j≥k}(c_j + D_j) − D_k))
  (:func:`~fuzzyfeed.machine.planner.reachable_squared_speed`): a first sweep over the windows
  keeps per window its start D and the minima of c − D and c + D over its vertices (5 floats a
  window); the second sweep takes the forward minimum carried from the windows before and the
  backward one from those after (min is exact in any order);
- the vertex times t_k = Σ_{j<k} T_j (a running sum carried like D).

So each window's arrays are the whole plan's slice, bit for bit (tests/test_plan_windows.py).
Cost: the geometry's limits are computed twice (two sweeps), plus the context moves.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np

from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.planner import Motion, Plan, local_limits, segment_profiles

#: Segments per window (at least; a window ends at a move boundary).
WINDOW_SEGMENTS = 1 << 16
#: Vertices looked at per step when searching a move boundary.
_SCAN = 4096


@dataclass(frozen=True, eq=False)
class PlanWindow(Plan):
    """Segments ``first`` … ``first + n − 1`` of a chain's plan: the :class:`~fuzzyfeed.machine.planner.Plan`
    arrays' slices (``motion`` None: the chain's is the caller's; ``t_start`` and ``s_start``,
    n + 1 entries, the time and arc length at its vertices from the chain's start, so
    :attr:`time_s` is the time at its end)."""

    first: int = 0
    s_start: np.ndarray | None = None

    @property
    def n_segments(self) -> int:
        return self.length.size

    @property
    def stop(self) -> int:
        return self.first + self.length.size

    def segment_arc_start(self) -> np.ndarray:
        return self.s_start


def _boundary(radius: np.ndarray, k: int, n: int) -> bool:
    return k <= 0 or k >= n or not np.isfinite(radius[k])


def next_boundary(radius: np.ndarray, k: int) -> int:
    """The first move boundary vertex ≥ ``k`` (an inner vertex of NaN radius, or the end n)."""
    n = radius.size - 1
    k = max(k, 1)
    while k < n:
        hi = min(k + _SCAN, n)
        hit = np.flatnonzero(~np.isfinite(radius[k:hi]))
        if hit.size:
            return k + int(hit[0])
        k = hi
    return n


def prev_boundary(radius: np.ndarray, k: int) -> int:
    """The last move boundary vertex ≤ ``k`` (an inner vertex of NaN radius, or the start 0)."""
    n = radius.size - 1
    k = min(k, n - 1)
    while k > 0:
        lo = max(k - _SCAN + 1, 1)
        hit = np.flatnonzero(~np.isfinite(radius[lo:k + 1]))
        if hit.size:
            return lo + int(hit[-1])
        k = lo - 1
    return 0


def window_bounds(motion: Motion, size: int = WINDOW_SEGMENTS) -> list[tuple[int, int]]:
    """Segment ranges [a, b) covering the chain, each at least ``size`` segments (the last: what
    is left) and ending at a move boundary."""
    if size < 1:
        raise ValueError(f"window size = {size!r}; must be >= 1")
    r = motion.arc_radius_mm
    n = motion.n_segments
    out, a = [], 0
    while a < n:
        b = next_boundary(r, a + size)
        out.append((a, b))
        a = b
    return out


class _Chain:
    """The geometry's limits of segments [a, b) with their context (two whole moves each side and
    the look-ahead's N − 1 segments after), and the cumulative reach from ``d_a`` at vertex a."""

    def __init__(self, motion: Motion, machine: Machine, feed_scale: float):
        self.motion, self.machine, self.scale = motion, machine, feed_scale
        self.n = motion.n_segments
        self.look = int(machine.lookahead_moves)

    def local(self, a: int, b: int, d_a: float):
        m, r, n = self.motion, self.motion.arc_radius_mm, self.n
        e = max(b, min(b + self.look - 1, n)) if self.look else b      # segments [a, e) exact
        # the move holding segment a − 1 is exact (its speed cap, halved or kinked acceleration
        # come from its corners at both ends) with one more move before it as context; so is the
        # move holding segment e, with one more after it
        p1 = prev_boundary(r, a - 1) if a > 0 else 0
        lo = prev_boundary(r, p1 - 1) if p1 > 0 else 0
        m_end = next_boundary(r, e + 1) if e < n else n
        hi = next_boundary(r, m_end + 1) if m_end < n else n
        feed = m.feed_mm_s[lo:hi]
        if self.scale != 1.0:
            feed = feed * self.scale
        length, unit, acc, nominal, reach, cap = local_limits(m.points[lo:hi + 1], feed, m.rapid[lo:hi],
                                                              r[lo:hi + 1], self.machine, first=lo)
        i, j = a - lo, b - lo
        d = np.cumsum(np.concatenate([[d_a], reach[i:e - lo]]))       # D at vertices a … e
        cap = cap[i:j + 1]
        if self.look:
            k = np.arange(a, b + 1)
            end = np.minimum(k + self.look - 1, n)
            cap = np.minimum(cap, d[end - a] - d[:b - a + 1])
        return (length[i:j], unit[i:j], acc[i:j], nominal[i:j], reach[i:j]), cap, d[:b - a + 1]


@dataclass(frozen=True)
class Carries:
    """What the first sweep keeps (5 floats a window): per window its segments [a, b)
    (``bounds`` (W, 2)), the cumulative reach D at its start, the minimum of c − D over the
    windows before it (``before``) and of c + D over those from it on (``after``, W + 1: inf past
    the last)."""

    bounds: np.ndarray
    d_start: np.ndarray
    before: np.ndarray
    after: np.ndarray


def first_sweep(motion: Motion, machine: Machine, size: int = WINDOW_SEGMENTS, feed_scale: float = 1.0) -> Carries:
    """The first sweep of :func:`plan_windows` (module docstring)."""
    bounds = window_bounds(motion, size)
    ch = _Chain(motion, machine, feed_scale)
    last = len(bounds) - 1
    d_start, fwd, bwd = [], [], []
    d_a = 0.0
    for w, (a, b) in enumerate(bounds):
        _, cap, d = ch.local(a, b, d_a)
        own = slice(None) if w == last else slice(0, -1)       # vertex b is the next window's
        d_start.append(d_a)
        fwd.append(float(np.min(cap[own] - d[own])))
        bwd.append(float(np.min(cap[own] + d[own])))
        d_a = float(d[-1])
    before = np.minimum.accumulate(np.array([np.inf] + fwd[:-1]))             # min over windows < w
    after = np.minimum.accumulate(np.array([np.inf] + bwd[::-1]))[::-1]   # min over windows ≥ w (inf past the last)
    return Carries(np.array(bounds, np.int64).reshape(-1, 2), np.array(d_start), before, after)


def plan_windows(motion: Motion, machine: Machine, size: int = WINDOW_SEGMENTS, feed_scale: float = 1.0,
                 carries: Carries | None = None, only: list[int] | None = None,
                 starts: tuple[np.ndarray, np.ndarray] | None = None) -> Iterator[PlanWindow]:
    """The plan of ``motion`` (every F times ``feed_scale``) on ``machine`` window by window
    (:func:`window_bounds`): bit for bit :func:`~fuzzyfeed.machine.planner.plan_motion`'s slices
    (module docstring). Two sweeps: the first (:func:`first_sweep`, or ``carries`` from it, with the
    same ``size`` and ``feed_scale``) is made before the first window is yielded. ``only``: just
    those windows (indices, increasing), given ``starts``: the time and arc length at every
    window's start (W + 1 entries, from a whole second sweep)."""
    c = first_sweep(motion, machine, size, feed_scale) if carries is None else carries
    ch = _Chain(motion, machine, feed_scale)
    if only is None:
        only = range(len(c.bounds))
    elif starts is None:
        raise ValueError("plan_windows(only=...) needs the windows' start times and arc lengths")
    t_a, s_a = 0.0, 0.0
    for w in only:
        a, b = int(c.bounds[w, 0]), int(c.bounds[w, 1])
        if starts is not None:
            t_a, s_a = float(starts[0][w]), float(starts[1][w])
        (length, unit, acc, nominal, reach), cap, d = ch.local(a, b, float(c.d_start[w]))
        forward = d + np.minimum.accumulate(np.concatenate([[c.before[w]], cap - d]))[1:]
        backward = np.minimum(np.minimum.accumulate((cap + d)[::-1])[::-1], c.after[w + 1]) - d
        wq = np.maximum(np.minimum(forward, backward), 0.0)
        v0, vp, v1, t_acc, t_cruise, t_dec = segment_profiles(length, acc, nominal, reach, wq)
        t_start = np.cumsum(np.concatenate([[t_a], t_acc + t_cruise + t_dec]))
        s_start = np.cumsum(np.concatenate([[s_a], length]))
        t_a, s_a = float(t_start[-1]), float(s_start[-1])
        yield PlanWindow(motion=None, first=a, length=length, unit=unit, acc=acc, v_entry=v0, v_peak=vp, v_exit=v1,
                         t_acc=t_acc, t_cruise=t_cruise, t_dec=t_dec, t_start=t_start, s_start=s_start)


def planned_time(motion: Motion, machine: Machine, size: int = WINDOW_SEGMENTS, feed_scale: float = 1.0) -> float:
    """The plan's time (s) without holding it: :func:`plan_windows`' last vertex time, bit for bit
    ``plan_motion(...).time_s``."""
    t = 0.0
    for pw in plan_windows(motion, machine, size, feed_scale):
        t = float(pw.t_start[-1])
    return t
