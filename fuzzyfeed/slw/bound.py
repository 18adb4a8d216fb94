"""The time-optimal reference: an acceleration-limited forward/backward phase-plane pass.

With x = v² and a = dx/(2ds) the tangential acceleration, the fastest feed without a jerk limit
keeps, at every point of the path, exactly the machine's limits:

* v ≤ F (command), v·|T_j| ≤ V_j (axial velocity), v ≤ (2/Ts)·√(2ρδ − δ²) (chord error);
* |a·T_j + v²·κN_j| ≤ A_j on every axis — the whole axial acceleration, tangential plus
  centripetal (braking may offset the centripetal part; there is no separate rule for it);
* at a true corner of the path (a tangent break), the feed the scheduler passes it at: the turn
  happens within one servo period, v·|ΔT_j|/Ts ≤ A_j and the corner within δ of the chord
  (:func:`fuzzyfeed.slw.preprocess.corners`); the same rule for every planner;
* rest at both ends.

The forward pass accelerates as hard as allowed, the backward pass brakes as hard as allowed
(the classic phase-plane construction; toppra's TOPP-RA gives the same time). :func:`path_bound`
computes it on an adaptive arc-length grid: uniform, refined where the tangent turns or the
limit changes faster than the step resolves, with every knot and corner on the grid; it reports
the change of the time when the grid is halved (its discretisation error). ``schedule`` and
``compare`` both use it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.machine.limits import MachineLimits, curvature_vectors, feed_limit_components
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.machine.profile import FeedProfile
from fuzzyfeed.geometry.sampling import PathSamples, samples_at

#: Largest grid step (mm) and least number of intervals of the base grid.
MAX_STEP_MM = 0.25
MIN_INTERVALS = 2000
#: Refinement: the tangent turns at most this much (rad) per step, the limit changes at most this
#: fraction per step; at most REFINE_LEVELS halvings, never below MIN_STEP_REL of the length.
TURN_RAD = 0.01
LIMIT_CHANGE = 0.02
REFINE_LEVELS = 14
MIN_STEP_REL = 1e-7
#: Points evaluated per call (bounds the memory of long paths).
CHUNK = 200_000


def pointwise_limit(samples: PathSamples, limits: MachineLimits) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x = v² allowed at every sample by the command, axial velocity, chord error and the
    maximum-velocity curve of the axial accelerations; with the unit tangents and κN (both
    finite, (n, 3)) that the passes need."""
    import fuzzyfeed.slw._kernels as _kernels

    comp = feed_limit_components(samples, limits)
    v = comp[:3].min(axis=0)  # command, axial velocity, chord error (not the centripetal row)
    tangent = np.ascontiguousarray(np.nan_to_num(np.asarray(samples.tangent, dtype=float), nan=0.0))
    kn = curvature_vectors(samples)
    bad = ~np.isfinite(kn).all(axis=1)
    kn = np.ascontiguousarray(np.where(np.isfinite(kn), kn, 0.0))
    x_acc = np.empty(len(samples))
    _kernels.mvc(tangent, kn, np.asarray(limits.axis_acc_mm_s2, dtype=float), x_acc)
    x = np.minimum(v * v, x_acc)
    x[bad] = 0.0  # a stationary point: stop
    return x, tangent, kn


def _passes(s: np.ndarray, x_lim: np.ndarray, tangent: np.ndarray, kn: np.ndarray,
            limits: MachineLimits, x_cap: np.ndarray | None = None) -> tuple[np.ndarray, float, np.ndarray]:
    """The passes' feed at the grid points, the time and each interval's time: the envelope of
    the passes inside each interval (:func:`fuzzyfeed.slw._kernels.interval_times`), under
    ``x_cap`` (the pointwise limit without the corners' caps; default ``x_lim``) between points."""
    import fuzzyfeed.slw._kernels as _kernels

    ds = np.diff(s)
    acc = np.asarray(limits.axis_acc_mm_s2, dtype=float)
    x = _kernels.phase_plane_passes(ds, np.ascontiguousarray(x_lim), tangent, kn, acc)
    v = np.sqrt(np.maximum(x, 0.0))
    dt = np.empty(ds.size)
    cap = x_lim if x_cap is None else x_cap
    _kernels.interval_times(ds, x, np.ascontiguousarray(cap, dtype=float), tangent, kn, acc, dt)
    return v, float(dt.sum()), dt


def time_optimal_bound(samples: PathSamples, limits: MachineLimits,
                       feed_cap: np.ndarray | None = None) -> tuple[FeedProfile, float]:
    """The bound on the given samples (method "bound", 0 at both ends) and its cycle time (s).

    ``feed_cap`` (mm/s, one value per sample), if given, is one more pointwise limit. The grid is
    the samples' own; use :func:`path_bound` for a grid that resolves the path by itself.
    """
    s = np.asarray(samples.s, dtype=float)
    x_lim, tangent, kn = pointwise_limit(samples, limits)
    if feed_cap is not None:
        cap = np.asarray(feed_cap, dtype=float)
        x_lim = np.minimum(x_lim, cap * cap)
    v, t, _ = _passes(s, x_lim, tangent, kn, limits)
    return FeedProfile(samples, v, "bound", limits.feed_mm_s), t


@dataclass(frozen=True, eq=False)
class Bound:
    """The bound on its own adaptive grid: arc lengths, feed (mm/s), time (s), and the time on the
    grid halved (every interval split in two) when it was asked for."""

    s_mm: np.ndarray
    feed_mm_s: np.ndarray
    time_s: float
    time_halved_s: float = float("nan")
    #: Each grid interval's time (s; the envelope of the passes inside it, summing to time_s), or
    #: None: then 2·ds/(v_i + v_i+1).
    interval_s: np.ndarray | None = None

    @property
    def grid_change(self) -> float:
        """Relative change of the time when the grid is halved (nan if not computed)."""
        return abs(self.time_halved_s - self.time_s) / self.time_s

    def profile_at(self, samples: PathSamples, limits: MachineLimits) -> FeedProfile:
        """The bound's feed at other samples (linear in s; method "bound")."""
        s = np.asarray(samples.s, dtype=float)
        scale = self.s_mm[-1] / s[-1] if s[-1] > 0 else 1.0
        v = np.interp(s * scale, self.s_mm, self.feed_mm_s)
        v[0] = v[-1] = 0.0
        return FeedProfile(samples, v, "bound", limits.feed_mm_s)


def _evaluate(curve: Nurbs, limits: MachineLimits, s: np.ndarray):
    out = []
    for c0 in range(0, s.size, CHUNK):
        part = s[c0:c0 + CHUNK]
        smp = samples_at(curve, np.asarray(curve.param_at_length(part), dtype=float), s=part)
        out.append(pointwise_limit(smp, limits))
    return tuple(np.concatenate([o[k] for o in out]) for k in range(3))


def _grid(curve: Nurbs, limits: MachineLimits, max_step_mm: float | None):
    """Adaptive grid: s, x_lim (the corners' caps applied), tangent, κN; corners and knots on it."""
    s, x, t, k, _ = _grid_raw(curve, limits, max_step_mm)
    return s, x, t, k


def insert_sorted(s: np.ndarray, mid: np.ndarray, *columns: tuple[np.ndarray, np.ndarray]):
    """``s`` with the points ``mid`` put in order, and each (values at s, values at mid) pair of
    ``columns`` put in the same order (a grid's refinement) → (s, [columns])."""
    order = np.argsort(np.concatenate([s, mid]), kind="stable")
    return np.concatenate([s, mid])[order], [np.concatenate([a, b])[order] for a, b in columns]


def uniform_intervals(total_mm: float, max_step_mm: float | None = None) -> int:
    """The grid's uniform intervals over a path of ``total_mm``: steps of min(MAX_STEP_MM,
    L/MIN_INTERVALS), at least 2 (knots, corners and refinements only add points)."""
    h = min(MAX_STEP_MM if max_step_mm is None else max_step_mm, total_mm / MIN_INTERVALS)
    return max(int(np.ceil(total_mm / h)), 2)


def _grid_raw(curve: Nurbs, limits: MachineLimits, max_step_mm: float | None):
    """:func:`_grid` and the pointwise limit without the corners' caps (the limit on either side
    of a corner, between grid points)."""
    from fuzzyfeed.slw.preprocess import corners

    total = float(curve.length)
    n = uniform_intervals(total, max_step_mm)
    knots = np.atleast_1d(curve.arc_length(curve.span_breaks))
    corner_s, corner_cap = corners(curve, limits)
    left = knots[1:-1] - 1e-9 * max(total, 1.0)  # the left-hand limit at a curvature jump
    s = np.unique(np.clip(np.concatenate([np.linspace(0.0, total, n + 1), knots, left, corner_s]), 0.0, total))
    x, t, k = _evaluate(curve, limits, s)
    min_ds = MIN_STEP_REL * total
    for _ in range(REFINE_LEVELS):
        ds = np.diff(s)
        turn = np.arccos(np.clip(np.einsum("ij,ij->i", t[:-1], t[1:]), -1.0, 1.0))
        kap = np.linalg.norm(k, axis=1)
        turn = np.maximum(turn, ds * np.maximum(kap[:-1], kap[1:]))
        v = np.sqrt(x)
        vmax = np.maximum(v[:-1], v[1:])
        change = np.abs(np.diff(v)) / np.maximum(vmax, 1e-12 * limits.feed_mm_s)
        split = ((turn > TURN_RAD) | (change > LIMIT_CHANGE)) & (ds > 2 * min_ds)
        if corner_s.size:  # a corner's turn is a point: refining next to it resolves nothing
            split &= ~(np.isin(s[:-1], corner_s) | np.isin(s[1:], corner_s))
        if not split.any():
            break
        mid = 0.5 * (s[:-1][split] + s[1:][split])
        xm, tm, km = _evaluate(curve, limits, mid)
        s, (x, t, k) = insert_sorted(s, mid, (x, xm), (t, tm), (k, km))
    raw = x.copy()
    if corner_s.size:
        idx = np.searchsorted(s, corner_s)
        x[idx] = np.minimum(x[idx], corner_cap * corner_cap)
    return s, x, t, k, raw


def path_bound(curve: Nurbs, limits: MachineLimits, feed_cap=None, halve: bool = True,
               max_step_mm: float | None = None) -> Bound:
    """The acceleration-limited time-optimal bound of ``curve`` on an adaptive grid.

    ``feed_cap`` (optional): a pair (s_mm, feed_mm_s) of one more pointwise feed limit,
    interpolated linearly in s. With ``halve``, the passes run again on the grid with every
    interval split in two, and :attr:`Bound.grid_change` says how much the time moved.
    """
    s, x, t, k, raw = _grid_raw(curve, limits, max_step_mm)
    cap_x = None
    if feed_cap is not None:
        cs, cv = (np.asarray(a, dtype=float) for a in feed_cap)
        scale = cs[-1] / s[-1] if s[-1] > 0 else 1.0
        cap_x = lambda q: np.interp(q * scale, cs, cv) ** 2  # noqa: E731
        x = np.minimum(x, cap_x(s))
        raw = np.minimum(raw, cap_x(s))
    v, time_s, dt = _passes(s, x, t, k, limits, raw)
    halved = float("nan")
    if halve:
        mid = 0.5 * (s[:-1] + s[1:])
        xm, tm, km = _evaluate(curve, limits, mid)
        if cap_x is not None:
            xm = np.minimum(xm, cap_x(mid))
        n = s.size
        s2 = np.empty(2 * n - 1)
        s2[0::2], s2[1::2] = s, mid
        x2 = np.empty(2 * n - 1)
        x2[0::2], x2[1::2] = x, xm
        r2 = x2.copy()
        r2[0::2] = raw
        t2 = np.empty((2 * n - 1, 3))
        t2[0::2], t2[1::2] = t, tm
        k2 = np.empty((2 * n - 1, 3))
        k2[0::2], k2[1::2] = k, km
        _, halved, _ = _passes(s2, x2, np.ascontiguousarray(t2), np.ascontiguousarray(k2), limits, r2)
    return Bound(s, v, time_s, halved, dt)
