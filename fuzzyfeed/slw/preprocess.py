"""NURBS preprocessing for the SLW scheduler: reference points, critical points, blocks (seed 000).

The path is pre-interpolated into reference points at a constant arc-length step (the distance the
pre-interpolation feed covers in one servo period, seed 000 "Real-time NURBS curve preprocessing"),
and the feasible feed of :func:`fuzzyfeed.machine.limits.feed_limits` (eq. (8)-(12)) is computed at each.
Three consecutive points whose middle one is a local minimum below the command feed form a critical
region (eq. (15)); the region is pre-interpolated again, ten times finer, until the minimum is
located to ``1e-3`` of the coarse step (local fine pre-interpolation, Algorithm 1). The minima are
the critical points; the path is cut into blocks between them. Everything runs chunk by chunk
along the path, so blocks come out progressively (a generator) and the scheduler never needs the
whole path preprocessed.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from fuzzyfeed.base.cache import per_curve
from fuzzyfeed.errors import InputError
from fuzzyfeed.machine.limits import MachineLimits, curvature_vectors, feed_limits
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.geometry.sampling import samples_at
from fuzzyfeed.slw.exact import exact_arrays
from fuzzyfeed.slw.feed_cap import STAIR_RATIO, FeedCap
from fuzzyfeed.slw.profile import transition_distance

#: Points per refinement level and levels of the local fine pre-interpolation (Algorithm 1).
FINE_POINTS = 11
FINE_LEVELS = 3
#: Coarse reference points handled per chunk of the streaming preprocessor.
CHUNK_POINTS = 1024
#: Halvings of the step where the tangent turns more than the sampled curvature explains.
RESOLVE_LEVELS = 8
#: Extra reference points per knot span, uniform in the parameter (features at the spans' scale).
SPAN_POINTS = 8
#: Bounds on the number of coarse reference points over the whole path.
MIN_POINTS, MAX_POINTS = 200, 400_000


@dataclass(frozen=True, eq=False)
class Reference:
    """Reference points (sorted by s): s, u, feed limit, unit tangent (n, 3), κN (n, 3)."""

    s: np.ndarray
    u: np.ndarray
    vlim: np.ndarray
    tangent: np.ndarray
    kn: np.ndarray

    def __len__(self) -> int:
        return int(self.s.size)

    def slice(self, i0: int, i1: int) -> Reference:
        """Points i0 … i1 inclusive."""
        sl = slice(i0, i1 + 1)
        return Reference(self.s[sl], self.u[sl], self.vlim[sl], self.tangent[sl], self.kn[sl])

    @staticmethod
    def concat(parts: list[Reference]) -> Reference:
        return Reference(*(np.concatenate([getattr(p, f) for p in parts])
                           for f in ("s", "u", "vlim", "tangent", "kn")))

    def sorted_unique(self) -> Reference:
        """The same points sorted by s, one per distinct s."""
        order = np.argsort(self.s, kind="stable")
        s = self.s[order]
        keep = np.concatenate([[True], np.diff(s) > 0])
        idx = order[keep]
        return Reference(*(getattr(self, f)[idx] for f in ("s", "u", "vlim", "tangent", "kn")))


@dataclass(frozen=True, eq=False)
class Block:
    """A stretch of path between two critical points (or a path end) with its reference points.

    ``cap0``/``cap1`` are the feed limits at the two ends (0 at the path's ends: start and stop at
    rest); ``critical0``/``critical1`` say whether an end is a critical point.
    """

    s0: float
    s1: float
    cap0: float
    cap1: float
    ref: Reference

    @property
    def length_mm(self) -> float:
        return self.s1 - self.s0

    @property
    def peak_limit(self) -> float:
        """Largest feed limit inside the block (the cruise feed can never exceed it)."""
        return float(self.ref.vlim.max())


def reference_step(curve: Nurbs, limits: MachineLimits) -> float:
    """Coarse pre-interpolation step: F·Ts, kept between L/MAX_POINTS and L/MIN_POINTS."""
    total = curve.length
    return float(np.clip(limits.feed_mm_s * limits.ts_s, total / MAX_POINTS, total / MIN_POINTS))


def machine_cap(curve: Nurbs, limits: MachineLimits) -> FeedCap:
    """The machine's own feed limit (eq. (8)-(12), at most F) on the coarse reference grid, as a
    :class:`FeedCap`: what the staircase of the default approach is built on. Evaluated chunk by
    chunk; a limit of 0 (a stationary point) is kept at 1e-3·F here — the preprocessor still
    holds the limit itself."""
    total = curve.length
    n = max(int(np.ceil(total / reference_step(curve, limits) - 1e-9)), 2)
    s = np.linspace(0.0, total, n + 1)
    v = np.empty(s.size)
    for c0 in range(0, s.size, CHUNK_POINTS):
        part = slice(c0, c0 + CHUNK_POINTS)
        v[part] = _evaluate(curve, limits, s[part]).vlim
    floor = 1e-3 * limits.feed_mm_s
    return FeedCap(s, np.clip(np.nan_to_num(v, nan=floor), floor, limits.feed_mm_s), total)


def evaluate_reference(curve: Nurbs, limits: MachineLimits, s: np.ndarray,
                       resolve: bool = False, cap: FeedCap | None = None) -> Reference:
    """Reference data at arc lengths ``s`` (sorted).

    With ``resolve``, intervals where the tangent turns by more than the sampled curvature
    explains (a feature narrower than the step: a near-cusp, a tight spike) are subdivided until
    the turn is resolved (at most RESOLVE_LEVELS halvings of the step). ``cap``, if given, is one
    more pointwise feed limit.
    """
    s = np.asarray(s, dtype=float)
    ref = _evaluate(curve, limits, s, cap)
    if not resolve or s.size < 2:
        return ref
    for _ in range(RESOLVE_LEVELS):
        t = ref.tangent
        cosang = np.clip(np.einsum("ij,ij->i", t[:-1], t[1:]), -1.0, 1.0)
        turn = np.arccos(cosang)
        ds = np.diff(ref.s)
        kappa = np.linalg.norm(np.where(np.isfinite(ref.kn), ref.kn, 0.0), axis=1)
        explained = 1.5 * ds * np.maximum(kappa[:-1], kappa[1:]) + 0.02
        bad = (turn > explained) & (ds > 1e-9 * max(float(ref.s[-1]), 1.0))
        if not bad.any():
            break
        lo, hi = ref.s[:-1][bad], ref.s[1:][bad]
        frac = np.array([0.25, 0.5, 0.75])
        extra = (lo[:, None] + (hi - lo)[:, None] * frac[None, :]).ravel()
        ref = Reference.concat([ref, _evaluate(curve, limits, extra, cap)]).sorted_unique()
    return ref


def _evaluate(curve: Nurbs, limits: MachineLimits, s: np.ndarray, cap: FeedCap | None = None,
              u: np.ndarray | None = None) -> Reference:
    """Reference data at arc lengths ``s``; at parameters ``u`` instead of u(s) when given (the
    caller's estimate of u(s): no arc-length inversion)."""
    u = np.asarray(curve.param_at_length(s) if u is None else u, dtype=float)
    fast = exact_arrays(curve, limits, np.asarray(s, dtype=float), cap, u)  # compiled, same values
    if fast is not None:
        return Reference(np.asarray(s, dtype=float), u, *fast)
    smp = samples_at(curve, u, s=np.asarray(s, dtype=float))
    tangent = np.nan_to_num(np.asarray(smp.tangent), nan=0.0)
    kn = np.nan_to_num(curvature_vectors(smp), nan=np.inf)
    vlim = feed_limits(smp, limits)
    if cap is not None:
        vlim = np.minimum(vlim, cap(np.asarray(s, dtype=float)))
    return Reference(np.asarray(s, dtype=float), u, vlim, tangent, kn)


def _refine(curve: Nurbs, limits: MachineLimits, lo: np.ndarray, hi: np.ndarray, cap: FeedCap | None = None):
    """Local fine pre-interpolation of critical regions [lo, hi] (Algorithm 1): returns the extra
    reference points visited and, per region, the arc length of the located minimum."""
    extras = []
    best = 0.5 * (lo + hi)
    for _ in range(FINE_LEVELS):
        frac = np.linspace(0.0, 1.0, FINE_POINTS)
        grid = lo[:, None] + (hi - lo)[:, None] * frac[None, :]
        ref = evaluate_reference(curve, limits, grid.ravel(), cap=cap)
        extras.append(ref)
        v = ref.vlim.reshape(grid.shape)
        k = np.argmin(v, axis=1)
        rows = np.arange(grid.shape[0])
        best = grid[rows, k]
        step = (hi - lo) / (FINE_POINTS - 1)
        lo, hi = np.maximum(best - step, lo), np.minimum(best + step, hi)
    return extras, best


def joins(curve: Nurbs) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The interior span joins of ``curve``: arc lengths (n,), unit tangents just before and just
    after each ((2n, 3): the n before, then the n after), the larger |κn_j| of the two sides
    (n, 3) and the kink |ΔT_j| (n, 3): the tangents' difference less what the curve turns over
    the 2h between the sides (2h|κn| with a factor 2 of margin; on a long path h is microns and
    a smooth join turns that; h is at most a quarter of the way to the next join). Cached per curve; arrays read-only."""
    return per_curve(curve, "joins", lambda: _joins(curve))


def _joins(curve: Nurbs):
    breaks = curve.span_breaks[1:-1]
    total = curve.length
    s_b = np.atleast_1d(curve.arc_length(breaks)) if breaks.size else np.empty(0)
    # each side at most a quarter of the distance to the next distinct join (or path end): a span
    # shorter than 2h (a 0.3 um move in Y of coordinates rounded to 0.1 um, inside a diagonal run)
    # was stepped over, its two turns unseen, and passed at 2.2 x A_y (cncjs tball-pocket.gcode#1)
    ends = np.unique(np.concatenate([[0.0], s_b, [total]]))
    i = np.searchsorted(ends, s_b)
    gap = np.minimum(s_b - ends[np.maximum(i - 1, 0)], ends[np.minimum(i + 1, ends.size - 1)] - s_b)
    h = np.minimum(1e-7 * total, 0.25 * gap)
    keep = (h > 0) & (s_b - h > 0) & (s_b + h < total)
    s_b, h = s_b[keep], h[keep]
    if s_b.size == 0:
        out = (np.empty(0), np.empty((0, 3)), np.empty((0, 3)), np.empty((0, 3)))
    else:
        side = np.concatenate([s_b - h, s_b + h])
        smp = samples_at(curve, np.atleast_1d(curve.param_at_length(side)), s=side)
        t = np.asarray(smp.tangent)
        if t.shape[1] == 2:
            t = np.hstack([t, np.zeros((t.shape[0], 1))])
        # the curve's own κn on each side (a stationary side is a stop: its cap is 0 in corners)
        kn = np.nan_to_num(np.abs(curvature_vectors(smp)), nan=0.0, posinf=0.0)
        if kn.shape[1] == 2:
            kn = np.hstack([kn, np.zeros((kn.shape[0], 1))])
        c2 = np.maximum(kn[: s_b.size], kn[s_b.size:])
        jump = np.maximum(np.nan_to_num(np.abs(t[s_b.size:] - t[: s_b.size]), nan=0.0) - 4.0 * h[:, None] * c2, 0.0)
        out = (s_b, t, c2, jump)
    for arr in out:
        arr.flags.writeable = False
    return out


def corners(curve: Nurbs, limits: MachineLimits) -> tuple[np.ndarray, np.ndarray]:
    """Tangent breaks at span joins (C0 knots, zero-length spans) and the feed allowed through them.

    Passing a corner of unit-tangent jump ΔT at feed v turns the motion within one servo period:
    the axial acceleration measured from positions is v·|ΔT_j|/Ts (with the joins within one
    servo step v·Ts of it, which the same periods pass, weighted by their distance), on top of the
    centripetal v²·|κn_j| of the curve on either side (a line meeting an arc with a small kink of
    rounded coordinates: the arc alone may already use the whole budget), so
    v²·|κn_j| + v·|ΔT_j|/Ts ≤ A_j, v ≤ 2A_j / (c₁ + √(c₁² + 4c₂A_j)) with c₁ = |ΔT_j|/Ts,
    c₂ = max |κn_j|; and the corner lies
    (v·Ts/2)·sin(θ/2) from the chord (≤ δ). The cap is the smaller of the two, with 10 % margin,
    less J·Ts²/2 (what the feed rises within a tick of a junction); a
    reversal or a stationary point gives 0 (a stop). Smooth joins give caps far above the feed.
    Returns arc lengths and caps of the joins whose cap is below the command feed.
    """
    s_b, t, c2, jump = joins(curve)
    if s_b.size == 0:
        return np.empty(0), np.empty(0)
    t_in, t_out = t[: s_b.size], t[s_b.size:]
    zero = np.zeros((1, 3))
    cum = np.vstack([zero, np.cumsum(jump, axis=0)])
    cum_s = np.vstack([zero, np.cumsum(jump * s_b[:, None], axis=0)])
    acc = np.asarray(limits.axis_acc_mm_s2)
    here = np.searchsorted(s_b, s_b, side="right")

    def allowed(v: np.ndarray) -> np.ndarray:
        # joins within one servo step L = v·Ts turn the motion in the same periods: the second
        # difference of the positions at a tick at s is v/Ts · Σ ΔT_m (1 − |σ_m − s|/L)+, largest
        # at a join (a sum of tents peaks at a tent's peak) — an arc flattened into short lines
        reach = (v * limits.ts_s)[:, None]
        lo = np.searchsorted(s_b, s_b - reach[:, 0], side="left")
        hi = np.searchsorted(s_b, s_b + reach[:, 0], side="right")
        s_i = s_b[:, None]
        left0, left1 = cum[here] - cum[lo], cum_s[here] - cum_s[lo]
        right0, right1 = cum[hi] - cum[here], cum_s[hi] - cum_s[here]
        with np.errstate(divide="ignore", invalid="ignore"):
            tents = (left0 - (s_i * left0 - left1) / reach) + (right0 - (right1 - s_i * right0) / reach)
        c1 = np.maximum(np.nan_to_num(tents, nan=0.0), jump) / limits.ts_s
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.min(2.0 * acc[None, :] / (c1 + np.sqrt(c1 * c1 + 4.0 * c2 * acc[None, :])), axis=1)

    # the largest v ≤ F that the joins within v·Ts allow (the allowance falls as v, and with it
    # the reach, grows): bisection between a feed that holds and F
    command = np.full(s_b.size, limits.feed_mm_s)
    at_command = allowed(command)
    good, bad = np.minimum(at_command, command), command.copy()
    for _ in range(40):
        mid = 0.5 * (good + bad)
        holds = allowed(mid) >= mid
        good, bad = np.where(holds, mid, good), np.where(holds, bad, mid)
    both = np.where(at_command >= command, np.inf, good)   # F itself holds: no cap
    with np.errstate(divide="ignore", invalid="ignore"):
        curve_only = np.min(np.sqrt(acc[None, :] / c2), axis=1)
    # a join counts when its kink lowers the curve's own limit (held at the reference points)
    cap_acc = np.where(both < 0.99 * curve_only, both, np.inf)
    half = np.linalg.norm(t_out - t_in, axis=1) / 2.0  # sin(θ/2)
    with np.errstate(divide="ignore", invalid="ignore"):
        cap_chord = np.where(half > 0, 2.0 * limits.chord_tol_mm / (limits.ts_s * half), np.inf)
    # a junction has zero acceleration, but the ticks either side of it are up to Ts away, where
    # the feed is up to J·Ts²/2 higher; the ticks' chords turn at that feed (a corner capped at
    # 0.156 mm/s under J·Ts²/2 = 0.099 was crossed at 0.2 mm/s: 107 % of A_y)
    cap = np.maximum(0.9 * np.minimum(cap_acc, cap_chord) - 0.5 * limits.jerk_mm_s3 * limits.ts_s ** 2, 0.0)
    cap = np.where(np.isfinite(t).all(axis=1)[: s_b.size] & np.isfinite(t).all(axis=1)[s_b.size:],
                   cap, 0.0)
    sel = cap < limits.feed_mm_s
    return s_b[sel], cap[sel]


def corner_plan(curve: Nurbs, limits: MachineLimits) -> tuple[np.ndarray, np.ndarray, FeedCap | None]:
    """:func:`_corner_plan`, computed once per curve and limits (the schedule, its blocks and
    its look-ahead all ask; arrays read-only)."""
    return per_curve(curve, ("corner plan", limits), lambda: _corner_plan(curve, limits))


def _corner_plan(curve: Nurbs, limits: MachineLimits) -> tuple[np.ndarray, np.ndarray, FeedCap | None]:
    """How the scheduler passes the corners of :func:`corners`: (arc lengths and caps of the
    corners that are critical points, the cap of the others or None).

    A critical point has zero acceleration. Corners closer together than the profile needs to
    rise one stair step (×1/STAIR_RATIO) from the lower of their two caps are linked: an arc
    written as short chords (0.024 mm in a plasma program) made a block per chord, and the
    profile could neither rise nor brake across them (3 x the bound on a slot). A run of linked
    corners is a pointwise cap instead — linear between its corners, a step at either end, the
    command feed elsewhere — which the schedule follows in stairs
    (:func:`fuzzyfeed.slw.feed_cap.stairs`). A run shorter than that rise from its lowest cap is
    one corner: a critical point at its lowest cap, one stair lower (the profile passes the
    run's other corners before it has risen one stair). Sharp corners a few mm apart (a zig-zag)
    stay critical points; the profile peaks between them."""
    s, cap = corners(curve, limits)
    if s.size < 2:
        s.flags.writeable = cap.flags.writeable = False
        return s, cap, None
    acc, jerk = limits.tangential_acc_mm_s2, limits.jerk_mm_s3

    def rise(v: np.ndarray) -> np.ndarray:
        return np.array([transition_distance(x, x / STAIR_RATIO, acc, jerk) for x in v.tolist()])

    link = np.diff(s) < rise(np.minimum(cap[:-1], cap[1:]))
    first = np.flatnonzero(link & ~np.concatenate([[False], link[:-1]]))   # runs of corners
    last = np.flatnonzero(link & ~np.concatenate([link[1:], [False]])) + 1  # first … last
    lone = np.ones(s.size, dtype=bool)
    keep_s, keep_cap = [], []
    pts, vals = [np.array([0.0])], [np.array([limits.feed_mm_s])]
    for a, b in zip(first.tolist(), last.tolist()):
        lone[a:b + 1] = False
        k = a + int(np.argmin(cap[a:b + 1]))
        if s[b] - s[a] < rise(cap[k:k + 1])[0]:   # one corner
            keep_s.append(s[k])
            keep_cap.append(STAIR_RATIO * cap[k])
            continue
        pts += [s[a:a + 1], s[a:b + 1], s[b:b + 1]]
        vals += [np.array([limits.feed_mm_s]), cap[a:b + 1], np.array([limits.feed_mm_s])]
    crit_s = np.concatenate([s[lone], keep_s])
    crit_cap = np.concatenate([cap[lone], keep_cap])
    order = np.argsort(crit_s)
    dense = None
    if len(pts) > 1:
        pts.append(np.array([curve.length]))
        vals.append(np.array([limits.feed_mm_s]))
        dense = FeedCap(np.concatenate(pts), np.concatenate(vals), curve.length)
    crit_s, crit_cap = crit_s[order], crit_cap[order]
    crit_s.flags.writeable = crit_cap.flags.writeable = False
    return crit_s, crit_cap, dense


def iter_blocks(curve: Nurbs, limits: MachineLimits, step_mm: float | None = None,
                cap: FeedCap | None = None) -> Iterator[Block]:
    """Blocks between critical points, in path order, produced chunk by chunk (seed 000);
    ``cap`` is an optional extra pointwise feed limit (:class:`FeedCap`). The corners that
    :func:`corner_plan` makes critical points are; its cap of the others is the caller's to
    include in ``cap``."""
    total = curve.length
    if not np.isfinite(total) or total <= 0.0:
        raise InputError(f"path length {total!r} mm; a path to schedule must have a positive length")
    step = reference_step(curve, limits) if step_mm is None else float(step_mm)
    n = max(int(np.ceil(total / step - 1e-9)), 2)
    grid = np.linspace(0.0, total, n + 1)
    breaks = curve.span_breaks
    u_span = (breaks[:-1, None] + np.diff(breaks)[:, None]
              * np.linspace(0.0, 1.0, SPAN_POINTS + 1)[None, :-1]).ravel()
    # and just before every interior knot: the curvature may jump there (a C1 join), and the
    # left-hand limit is where the feed limit is lowest
    s_knots = np.atleast_1d(curve.arc_length(breaks[1:-1]))
    left = s_knots - 1e-9 * max(total, 1.0)
    # the cap's own points (the limit between reference points is linear: a kink of the cap
    # between two of them would be cut), and a point either side of each of its steps (one on it
    # has the lower side's feed), so a step stays a step
    steps = np.empty(0) if cap is None else cap.steps_mm
    at_steps = (steps[:, None] + np.array([-1e-9, 1e-9])[None, :] * max(total, 1.0)).ravel()
    if cap is not None:
        at_steps = np.concatenate([at_steps, cap.s_mm])
    grid = np.unique(np.concatenate([grid, np.atleast_1d(curve.arc_length(u_span)), left, at_steps]))
    grid = grid[(grid >= 0.0) & (grid <= total)]
    grid[0], grid[-1] = 0.0, total
    command = limits.feed_mm_s
    pending: list[Reference] = []   # reference points since the last critical point
    cap0 = 0.0                      # start at rest
    s_start = 0.0
    prev_tail: Reference | None = None  # last two coarse points of the previous chunk
    corner_s, corner_caps, _ = corner_plan(curve, limits)
    for c0 in range(0, grid.size, CHUNK_POINTS):
        # the machine's own limit first: its minima are critical points even where a flat cap
        # hides them between two reference points (a curvature spike under a cap's plateau)
        chunk = evaluate_reference(curve, limits, grid[c0:min(c0 + CHUNK_POINTS + 1, grid.size)],
                                   resolve=True)
        if c0 + CHUNK_POINTS + 1 <= grid.size:  # the next chunk starts with the shared point
            chunk = chunk.slice(0, int(np.searchsorted(chunk.s, grid[c0 + CHUNK_POINTS])) - 1)
        last_chunk = c0 + CHUNK_POINTS >= grid.size
        hi_s = grid[min(c0 + CHUNK_POINTS, grid.size - 1)]
        in_chunk = (corner_s >= grid[c0]) & ((corner_s < hi_s) | last_chunk)
        forced: dict[float, float] = {}   # corner arc length -> its cap (a critical point)
        if in_chunk.any():
            # the corners on the grid with the machine's limit (its minima are found without the
            # corner caps: a capped corner is a critical point already), their caps held apart
            cref = evaluate_reference(curve, limits, corner_s[in_chunk])
            chunk = Reference.concat([cref, chunk]).sorted_unique()
            held = _capped(cref, cap).vlim
            forced = dict(zip(corner_s[in_chunk].tolist(), np.minimum(held, corner_caps[in_chunk]).tolist()))
        if prev_tail is not None:
            ctx_machine = Reference.concat([prev_tail, chunk])
            offset = len(prev_tail)
        else:
            ctx_machine, offset = chunk, 0
        ctx = _capped(ctx_machine, cap)
        # middle points decidable now: indices 1 … len-2 of the context, new ones only
        mid = np.arange(max(1, offset - 1), len(ctx) - 1)
        crit_machine = mid[_is_min(ctx_machine.vlim, mid, command)]
        extras_by_region: list[Reference] = []
        located = np.empty(0)
        if crit_machine.size:
            extras, located = _refine(curve, limits, ctx.s[crit_machine - 1], ctx.s[crit_machine + 1])
            extras_by_region = [_capped(e, cap) for e in extras]
        if cap is not None:  # and the minima of min(machine, cap) that are the cap's
            crit = np.setdiff1d(mid[_is_min(ctx.vlim, mid, command)], crit_machine)
            if crit.size:
                extras, at = _refine(curve, limits, ctx.s[crit - 1], ctx.s[crit + 1], cap)
                extras_by_region += extras
                located = np.concatenate([located, at])
        fine = Reference.concat(extras_by_region) if extras_by_region else None
        # new coarse points of this chunk (context minus the carried tail), a corner at its cap:
        # merged into a block by the look-ahead, the block must still hold it
        new = _hold(ctx.slice(offset, len(ctx) - 1) if offset else ctx, forced)
        merged = [new] if fine is None else [new, fine]
        pending.append(Reference.concat(merged))
        # cut blocks at every located minimum that is now final (all of them are: their
        # neighbours are known)
        cuts = np.unique(np.concatenate([located, np.array(list(forced), dtype=float)]))
        if cuts.size:
            allref = Reference.concat(pending).sorted_unique()
            for s_c in cuts:
                i = int(np.searchsorted(allref.s, s_c))
                i = min(i, len(allref) - 1)
                if s_c <= s_start or s_c >= total:
                    continue
                if allref.s[i] <= s_start:
                    continue
                cap1 = float(min(allref.vlim[i], forced.get(float(s_c), np.inf)))
                head = allref.slice(0, i)
                yield Block(s_start, float(allref.s[i]), cap0, cap1, head)
                cap0 = cap1
                s_start = float(allref.s[i])
                allref = allref.slice(i, len(allref) - 1)
            pending = [allref]
        prev_tail = ctx_machine.slice(len(ctx_machine) - 2, len(ctx_machine) - 1)
    rest = Reference.concat(pending).sorted_unique()
    yield Block(s_start, total, cap0, 0.0, rest)


def _is_min(v: np.ndarray, mid: np.ndarray, command: float) -> np.ndarray:
    """Which of the points ``mid`` (interior indices of ``v``) are local minima below the command
    feed (eq. (15)); on a plateau, its first and last points."""
    below = v[mid] < command * (1 - 1e-12)
    return below & (((v[mid] < v[mid - 1]) & (v[mid] <= v[mid + 1]))
                    | ((v[mid] <= v[mid - 1]) & (v[mid] < v[mid + 1])))


def _hold(ref: Reference, caps: dict[float, float]) -> Reference:
    """``ref`` with the feed limit at the arc lengths of ``caps`` lowered to their caps."""
    if not caps:
        return ref
    s = np.fromiter(caps, dtype=float)
    v = np.fromiter(caps.values(), dtype=float)
    i = np.minimum(np.searchsorted(ref.s, s), len(ref) - 1)
    on = ref.s[i] == s
    vlim = ref.vlim.copy()
    vlim[i[on]] = np.minimum(vlim[i[on]], v[on])
    return Reference(ref.s, ref.u, vlim, ref.tangent, ref.kn)


def _capped(ref: Reference, cap: FeedCap | None) -> Reference:
    """``ref`` with its feed limit lowered to ``cap`` (if any)."""
    if cap is None:
        return ref
    return Reference(ref.s, ref.u, np.minimum(ref.vlim, cap(ref.s)), ref.tangent, ref.kn)
