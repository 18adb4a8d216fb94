"""NURBS preprocessing for the SLW scheduler: reference points, critical points, blocks (seed 000).

The path is pre-interpolated into reference points at a constant arc-length step (the distance the
pre-interpolation feed covers in one servo period, seed 000 "Real-time NURBS curve preprocessing"),
and the feasible feed of :func:`fuzzyfeed.limits.feed_limits` (eq. (8)-(12)) is computed at each.
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

from fuzzyfeed.errors import InputError
from fuzzyfeed.limits import MachineLimits, curvature_vectors, feed_limits
from fuzzyfeed.nurbs import Nurbs
from fuzzyfeed.sampling import samples_at

#: Points per refinement level and levels of the local fine pre-interpolation (Algorithm 1).
FINE_POINTS = 11
FINE_LEVELS = 3
#: Coarse reference points handled per chunk of the streaming preprocessor.
CHUNK_POINTS = 1024
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


def evaluate_reference(curve: Nurbs, limits: MachineLimits, s: np.ndarray) -> Reference:
    """Reference data at arc lengths ``s`` (sorted)."""
    u = np.asarray(curve.param_at_length(s), dtype=float)
    smp = samples_at(curve, u, s=np.asarray(s, dtype=float))
    tangent = np.nan_to_num(np.asarray(smp.tangent), nan=0.0)
    kn = np.nan_to_num(curvature_vectors(smp), nan=np.inf)
    return Reference(np.asarray(s, dtype=float), u, feed_limits(smp, limits), tangent, kn)


def _refine(curve: Nurbs, limits: MachineLimits, lo: np.ndarray, hi: np.ndarray):
    """Local fine pre-interpolation of critical regions [lo, hi] (Algorithm 1): returns the extra
    reference points visited and, per region, the arc length of the located minimum."""
    extras = []
    best = 0.5 * (lo + hi)
    for _ in range(FINE_LEVELS):
        frac = np.linspace(0.0, 1.0, FINE_POINTS)
        grid = lo[:, None] + (hi - lo)[:, None] * frac[None, :]
        ref = evaluate_reference(curve, limits, grid.ravel())
        extras.append(ref)
        v = ref.vlim.reshape(grid.shape)
        k = np.argmin(v, axis=1)
        rows = np.arange(grid.shape[0])
        best = grid[rows, k]
        step = (hi - lo) / (FINE_POINTS - 1)
        lo, hi = np.maximum(best - step, lo), np.minimum(best + step, hi)
    return extras, best


def iter_blocks(curve: Nurbs, limits: MachineLimits, step_mm: float | None = None) -> Iterator[Block]:
    """Blocks between critical points, in path order, produced chunk by chunk (seed 000)."""
    total = curve.length
    if not np.isfinite(total) or total <= 0.0:
        raise InputError(f"path length {total!r} mm; a path to schedule must have a positive length")
    step = reference_step(curve, limits) if step_mm is None else float(step_mm)
    n = max(int(np.ceil(total / step - 1e-9)), 2)
    grid = np.linspace(0.0, total, n + 1)
    command = limits.feed_mm_s
    pending: list[Reference] = []   # reference points since the last critical point
    cap0 = 0.0                      # start at rest
    s_start = 0.0
    prev_tail: Reference | None = None  # last two coarse points of the previous chunk
    for c0 in range(0, grid.size, CHUNK_POINTS):
        chunk = evaluate_reference(curve, limits, grid[c0:c0 + CHUNK_POINTS])
        if prev_tail is not None:
            ctx = Reference.concat([prev_tail, chunk])
            offset = len(prev_tail)
        else:
            ctx, offset = chunk, 0
        v = ctx.vlim
        # middle points decidable now: indices 1 … len-2 of the context, new ones only
        mid = np.arange(max(1, offset - 1), len(ctx) - 1)
        is_min = (v[mid] < v[mid - 1]) & (v[mid] <= v[mid + 1]) & (v[mid] < command * (1 - 1e-12))
        is_min |= (v[mid] <= v[mid - 1]) & (v[mid] < v[mid + 1]) & (v[mid] < command * (1 - 1e-12))
        crit = mid[is_min]
        extras_by_region: list[Reference] = []
        located = np.empty(0)
        if crit.size:
            extras, located = _refine(curve, limits, ctx.s[crit - 1], ctx.s[crit + 1])
            extras_by_region = extras
        fine = Reference.concat(extras_by_region) if extras_by_region else None
        # new coarse points of this chunk (context minus the carried tail)
        new = ctx.slice(offset, len(ctx) - 1) if offset else ctx
        merged = [new] if fine is None else [new, fine]
        pending.append(Reference.concat(merged))
        # cut blocks at every located minimum that is now final (all of them are: their
        # neighbours are known)
        if located.size:
            allref = Reference.concat(pending).sorted_unique()
            for s_c in np.sort(located):
                i = int(np.searchsorted(allref.s, s_c))
                i = min(i, len(allref) - 1)
                if s_c <= s_start or s_c >= total:
                    continue
                head = allref.slice(0, i)
                yield Block(s_start, float(allref.s[i]), cap0, float(allref.vlim[i]), head)
                cap0 = float(allref.vlim[i])
                s_start = float(allref.s[i])
                allref = allref.slice(i, len(allref) - 1)
            pending = [allref]
        prev_tail = ctx.slice(len(ctx) - 2, len(ctx) - 1)
    rest = Reference.concat(pending).sorted_unique()
    yield Block(s_start, total, cap0, 0.0, rest)


def critical_points(curve: Nurbs, limits: MachineLimits) -> tuple[np.ndarray, np.ndarray]:
    """Arc lengths and feed limits of the critical points found by preprocessing (no ends)."""
    blocks = list(iter_blocks(curve, limits))
    s = np.array([b.s1 for b in blocks[:-1]])
    v = np.array([b.cap1 for b in blocks[:-1]])
    return s, v
