"""The sliding look-ahead window (SLW) of seed 000: junction feeds, corrections and repairs.

Blocks from the preprocessor are pushed into a window. In the window the junction feeds are set by
a backward scan (each junction no faster than what still stops — or reaches the next junction's
feed — within its block) and a forward scan (no faster than what is reachable from the previous
junction), both with bisection on the transition's distance (seed 000's cosine, or the seven-phase ramp): the type-4 corrections of
seed 000 ("Feedrate correction for non-schedulable blocks", Heng & Erkorkmaz's bisection). The
window assumes a stop at its far end; the first block is released only when its end feed is the
same whether or not that stop is assumed, which needs at least a full stop from the command feed
of look-ahead (eq. (22)) — so the released profile equals the one the whole path would give.

Every block's profile is checked against the path before release: the feed against the pointwise
limit at the reference points, and the axial accelerations a_t·T_j + v²·κN_j against A_j. A feed
above the limit inside a block adds a junction there (the limit curve rose slower than the
profile); an axial acceleration above its limit lowers the block's tangential acceleration, or the
feed of the junction it approaches when the centripetal part alone nearly uses the axis up.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field

import numpy as np

from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.slw.feed_cap import FeedCap
from fuzzyfeed.slw.preprocess import Block, Reference, _evaluate, corner_plan, evaluate_reference, joins
from fuzzyfeed.slw.profile import (COSINE, Segment, block_segments, check_shape, lowest_end_speed,
                                   max_end_speed, max_start_speed, peak_acceleration, stop_distance,
                                   transition_distance)

#: Relative slack accepted by the profile check (the remaining 0.5 % budget is the measurement's).
CHECK_RTOL = 1e-6
#: Crawl feed (fraction of the command feed) through a block whose limit is 0 everywhere.
CRAWL = 1e-3
#: Blocks shorter than this fraction of one servo period's travel at the command feed are not
#: checked against the limits (the ticks around them are what the machine sees).
SUB_TICK = 1e-3
#: Failed checks in a row, beyond the blocks to release, after which the look beyond them stops.
MAX_REPAIRS = 400
#: Repairs in one window before the path is refused (each repair is progress; never reached on
#: the benchmark's paths).
MAX_SETTLE = 100_000
#: A junction added where the profile crosses the feed limit is capped this far below the limit:
#: the next profile has room to rise, so a slowly rising limit is followed in stairs of a few per
#: cent (a bounded number of splits) instead of a staircase of tiny steps.
SPLIT_ROOM = 0.97
#: The profile read at a block's reference points may exceed their limit by this fraction: the
#: samples hold the limit between them (CHECK_RTOL); the points catch a limit held at one point
#: (a corner's cap, far below its neighbours), not the 1e-5 by which a sampled profile passes a
#: smooth minimum (a junction for each cost a random curve 4 %).
POINT_RTOL = 1e-3
#: A junction added where the centripetal part nearly uses an axis up is capped at the feed that
#: brings that axis back within its limit (centripetal ∝ v²), with this much room, and at most a
#: SPLIT_ROOM lower: a profile leaving a minimum brushed the limit by 0.04 % and the minimum's
#: junctions fell a whole stair (trident2: 3 % at two of its five minima).
NEAR_ROOM = 0.999
#: A block whose acceleration an axis-acceleration repair would take below this share of the
#: machine's tangential acceleration gets a junction at the offending point instead (a 28 mm
#: block crawled at 17 % of it for one point of one axis; random curve 199 of bench_slw).
ACC_KEEP = 0.5
#: Share of each axis's acceleration a true corner passed inside a merged block may use (the rest
#: is the tangential acceleration's); the preprocessor's corner caps use CORNER_MARGIN of it.
CORNER_SHARE = 0.45
CORNER_MARGIN = 0.9
#: Samples of a block's profile within this share of a limit (axis acceleration or feed) are
#: checked against the path evaluated at the samples themselves, not interpolated between points.
EXACT_NEAR = 0.99
#: A join whose unit tangent jumps by less than this (per axis) is no kink.
KINK_MIN = 1e-9
#: Blocks at the front of the window checked at the feeds of a continuing path before a release.
FRONT_BLOCKS = 3
#: A block is cut where the tangential acceleration its directions allow changes by this factor …
DIRECTION_STEP = 0.6
#: … into pieces no shorter than this share of a full stop from the command feed.
DIRECTION_MIN = 0.1
#: Look-ahead length as a multiple of the full-stop distance from the command feed.
WINDOW_STOPS = 1.5


@dataclass
class _Junction:
    s: float
    cap: float
    v: float = 0.0
    critical: bool = False  # a critical point of the preprocessor (not a repair's junction)


@dataclass
class _WBlock:
    ref: Reference
    acc: float
    vmax: float
    checked: tuple | None = None
    pending: tuple | None = None  # (key, samples …) of a check not yet judged (_sample)

    @property
    def s0(self) -> float:
        return float(self.ref.s[0])

    @property
    def s1(self) -> float:
        return float(self.ref.s[-1])

    @property
    def length(self) -> float:
        return self.s1 - self.s0


@dataclass(frozen=True)
class ScheduledBlock:
    """A released block: where it is, its junction feeds, its type (1-3) and its segments."""

    s0: float
    s1: float
    v_start: float
    v_end: float
    kind: int
    segments: tuple[Segment, ...]
    acc_mm_s2: float
    critical_end: bool

    @property
    def duration_s(self) -> float:
        return sum(seg.duration_s for seg in self.segments)


@dataclass
class LookaheadStats:
    """Counters of one scheduling run (for the summary and the tests)."""

    blocks_in: int = 0
    blocks_out: int = 0
    junctions_added: int = 0
    caps_lowered: int = 0
    acc_lowered: int = 0
    unresolved: int = 0
    max_window_blocks: int = 0
    max_window_mm: float = 0.0
    merged: int = 0
    critical_s: list[float] = field(default_factory=list)


class SlidingWindow:
    """Schedules blocks progressively; iterate :meth:`run` to get :class:`ScheduledBlock` s."""

    def __init__(self, limits: MachineLimits, curve: Nurbs | None = None, approach: int = 2,
                 cap: FeedCap | None = None, transition: str = COSINE):
        if approach not in (1, 2):
            raise ValueError(f"approach = {approach!r}; seed 000 Table 1 has approaches 1 and 2")
        self.approach = approach
        self.shape = check_shape(transition)
        self.cap = cap
        self.curve = curve
        self.limits = limits
        self.jerk = limits.jerk_mm_s3
        self.acc = limits.tangential_acc_mm_s2
        self.axis_acc = np.asarray(limits.axis_acc_mm_s2)
        self.stop = stop_distance(limits.feed_mm_s, self.acc, self.jerk, self.shape)
        self.window_mm = WINDOW_STOPS * self.stop
        self.juncs: list[_Junction] = [_Junction(0.0, 0.0, 0.0)]
        # the corners that are critical points (the junctions a merge may drop)
        self._corner_s = corner_plan(curve, limits)[0] if curve is not None else np.empty(0)
        # every kink (tangent break) of the path: arc lengths, tangents, |κn|, |ΔT| (joins)
        self._kinks = None
        if curve is not None:
            s_j, t_j, c2, jump = joins(curve)
            sel = jump.max(axis=1, initial=0.0) > KINK_MIN if s_j.size else np.zeros(0, dtype=bool)
            if sel.any():
                self._kinks = (s_j[sel], np.vstack([t_j[:s_j.size][sel], t_j[s_j.size:][sel]]),
                               c2[sel], jump[sel])
        self.blocks: list[_WBlock] = []
        self.stats = LookaheadStats()
        self._front_checks = 0

    # ------------------------------------------------------------------ window content
    def _push(self, block: Block) -> None:
        self.stats.blocks_in += 1
        if self._merge(block):
            return
        # a stretch with a zero limit everywhere (a micro-kink between two near-stationary
        # points) is crawled through at a tiny feed rather than being impassable
        crawl = CRAWL * self.limits.feed_mm_s
        for ref in self._by_direction(block.ref):
            vmax = min(self.limits.feed_mm_s, max(float(ref.vlim.max()), crawl))
            self.blocks.append(_WBlock(ref, self._direction_acc(ref), vmax))
            self.juncs.append(_Junction(float(ref.s[-1]), float(ref.vlim[-1])))
        self.juncs[-1].cap, self.juncs[-1].critical = block.cap1, True
        self.stats.max_window_blocks = max(self.stats.max_window_blocks, len(self.blocks))
        self.stats.max_window_mm = max(self.stats.max_window_mm, self.blocks[-1].s1 - self.blocks[0].s0)

    def _merge(self, block: Block) -> bool:
        """Merge ``block`` into the last block when the junction between them is no local minimum
        of the junction caps (cap ≥ the caps on both sides) and the last block is shorter than the
        transition between their caps needs: critical points closer than a transition needs
        (the vertices of a fine polyline) would otherwise each force a zero acceleration. The
        dropped point's limit stays in the block's reference points (the check holds it)."""
        if len(self.blocks) < 2:
            return False
        last, prev = self.juncs[-1], self.juncs[-2]
        if not (last.critical and prev.critical) or len(self.juncs) - 1 <= 1:
            return False
        if last.cap < prev.cap or last.cap < block.cap1:
            return False
        lo = min(prev.cap, block.cap1)
        if self.blocks[-1].length >= transition_distance(lo, last.cap, self.acc, self.jerk, self.shape):
            return False
        b = self.blocks[-1]
        head, acc = b.ref, min(b.acc, self._direction_acc(block.ref))
        if self._corner_s.size and np.isin(last.s, self._corner_s):
            # a true corner passed inside a block, not at rest on its tangential acceleration:
            # the corner's turn may use CORNER_SHARE of each axis, the tangential acceleration
            # the rest
            vlim = head.vlim.copy()
            vlim[-1] *= CORNER_SHARE / CORNER_MARGIN
            head = Reference(head.s, head.u, vlim, head.tangent, head.kn)
            acc = min(acc, (1.0 - CORNER_SHARE) * self.acc)
        ref = Reference.concat([head, block.ref.slice(1, len(block.ref) - 1)]) if len(block.ref) > 1 else head
        vmax = min(self.limits.feed_mm_s, max(float(ref.vlim.max()), CRAWL * self.limits.feed_mm_s))
        self.blocks[-1] = _WBlock(ref, acc, vmax)
        last.s, last.cap, last.v = block.s1, block.cap1, 0.0
        self.stats.merged += 1
        return True

    def _by_direction(self, ref: Reference) -> list[Reference]:
        """``ref`` cut where the tangential acceleration its directions allow changes by more than
        DIRECTION_STEP (a block accelerates as its slowest direction allows: a 23 mm block of a
        random curve on a slow-Y machine at a third of what most of it allows); pieces no
        shorter than DIRECTION_MIN of a full stop."""
        if len(ref) < 3 or ref.s[-1] - ref.s[0] < 2.0 * DIRECTION_MIN * self.stop:
            return [ref]
        t = np.abs(ref.tangent)
        with np.errstate(divide="ignore"):
            per_point = np.min(np.where(t > 0.0, self.axis_acc[None, :] / t, np.inf), axis=1)
        per_point = np.clip(per_point, self.acc, float(self.axis_acc.max()))
        if per_point.min() > DIRECTION_STEP * per_point.max():
            return [ref]
        level = np.floor(np.log(per_point / self.acc) / -np.log(DIRECTION_STEP))
        cuts, last = [], 0
        for k in np.flatnonzero(np.diff(level) != 0) + 1:
            if k < len(ref) - 1 and ref.s[k] - ref.s[last] >= DIRECTION_MIN * self.stop \
                    and ref.s[-1] - ref.s[k] >= DIRECTION_MIN * self.stop:
                cuts.append(int(k))
                last = int(k)
        if not cuts:
            return [ref]
        bounds = [0, *cuts, len(ref) - 1]
        return [ref.slice(a, b) for a, b in zip(bounds[:-1], bounds[1:])]

    def _direction_acc(self, ref: Reference) -> float:
        """Tangential acceleration of a new block: the largest a with |a·T_j| ≤ A_j at each of its
        reference points (seed 000, eq. (13)-(14), per block instead of for every direction), at
        least the machine's smallest A_j. On unequal axes a block along a fast axis accelerates
        as that axis can; the profile check lowers it where the centripetal part needs room."""
        t = np.abs(ref.tangent)
        with np.errstate(divide="ignore"):
            per_point = np.min(np.where(t > 0.0, self.axis_acc[None, :] / t, np.inf), axis=1)
        return float(max(self.acc, min(float(per_point.min()), float(self.axis_acc.max()))))

    def _ahead_mm(self) -> float:
        """Look-ahead beyond the first block's end."""
        if not self.blocks:
            return 0.0
        return self.blocks[-1].s1 - self.blocks[0].s1

    # ------------------------------------------------------------------ junction feeds
    def _backward(self, end_feed: float) -> list[float]:
        n = len(self.blocks)
        v = [0.0] * (n + 1)
        v[n] = min(self.juncs[n].cap, end_feed)
        for i in range(n - 1, -1, -1):
            b = self.blocks[i]
            v[i] = max_start_speed(v[i + 1], b.length, self.juncs[i].cap, b.acc, self.jerk, self.shape)
        return v

    def _plan(self, end_feed: float) -> None:
        v = self._backward(end_feed)
        v[0] = self.juncs[0].v  # committed
        for i, b in enumerate(self.blocks):
            if v[i + 1] < v[i] and transition_distance(v[i], v[i + 1], b.acc, self.jerk, self.shape) > b.length:
                # a committed junction may be faster than a junction found later allows: brake as
                # hard as the block lets (the check then repairs the block before it is released)
                v[i + 1] = lowest_end_speed(v[i], b.length, v[i + 1], b.acc, self.jerk, self.shape)
            else:
                v[i + 1] = max_end_speed(v[i], b.length, v[i + 1], b.acc, self.jerk, self.shape)
        for j, vj in zip(self.juncs, v):
            j.v = vj

    # ------------------------------------------------------------------ profile check & repair
    def _segments(self, i: int):
        b = self.blocks[i]
        return block_segments(b.length, self.juncs[i].v, self.juncs[i + 1].v, b.vmax, b.acc, self.jerk,
                              self.approach, self.shape)

    def _sample(self, i: int):
        """Block i's profile sampled at half servo periods with the path's data interpolated from
        its reference points: (key, segments, s, v, a, segment index, vlim, T, κN, near), where
        ``near`` indexes the samples within EXACT_NEAR of a limit (read exactly before judging);
        None when the block needs no check (already checked with this key, or crossed within a
        small part of one servo period). Kept on the block with its key until judged."""
        b = self.blocks[i]
        key = (self.juncs[i].v, self.juncs[i + 1].v, b.acc, b.vmax, b.length)
        if b.checked == key:
            return None
        if b.pending is not None and b.pending[0] == key:
            return b.pending
        if b.length < SUB_TICK * self.limits.feed_mm_s * self.limits.ts_s:
            b.checked = key  # crossed within a small part of one servo period: nothing to sample
            return None
        kind, segs = self._segments(i)
        if not segs:
            b.checked = key
            return None
        import fuzzyfeed.slw._kernels as kernels

        seg_arr = np.array([(g.v0, g.v1, g.duration_s, math.nan if g.jerk_mm_s3 is None else g.jerk_mm_s3)
                            for g in segs])
        s, v, a, seg_id = kernels.sample_segments(seg_arr[:, 0], seg_arr[:, 1], seg_arr[:, 2], seg_arr[:, 3],
                                                  b.s0, 0.5 * self.limits.ts_s)
        ref = b.ref
        vlim = np.interp(s, ref.s, ref.vlim)
        tan = np.stack([np.interp(s, ref.s, ref.tangent[:, j]) for j in range(3)], axis=1)
        kn = np.stack([np.interp(s, ref.s, ref.kn[:, j]) for j in range(3)], axis=1)
        r, _, _ = self._axis_ratio(v, a, tan, kn)
        near = np.flatnonzero((r > EXACT_NEAR) | ((v > EXACT_NEAR * vlim) & (vlim < self.limits.feed_mm_s)))
        if self.curve is None:
            near = near[:0]
        b.pending = (key, segs, s, v, a, seg_id, vlim, tan, kn, near)
        return b.pending

    def _check_all(self, indices) -> bool:
        """Check blocks ``indices`` in order, repairing the first that breaks a limit (False).
        The samples within reach of a limit of every block still to judge are read from the path
        in one evaluation (one call instead of one per block: the calls' overhead was half of
        a long program's scheduling)."""
        data = [(i, self._sample(i)) for i in indices]
        todo = [d for _, d in data if d is not None and d[9].size]
        if todo:
            s_all = np.concatenate([d[2][d[9]] for d in todo])
            u_all = np.concatenate([np.interp(d[2][d[9]], self.blocks[i].ref.s, self.blocks[i].ref.u)
                                    for i, d in data if d is not None and d[9].size])
            exact = _evaluate(self.curve, self.limits, s_all, self.cap, u_all)
            at = 0
            for i, d in data:
                if d is None or not d[9].size:
                    continue
                near = d[9]
                part = slice(at, at + near.size)
                at += near.size
                vlim, tan, kn = d[6].copy(), d[7].copy(), d[8].copy()
                vlim[near] = np.minimum(vlim[near], exact.vlim[part])
                tan[near], kn[near] = exact.tangent[part], exact.kn[part]
                self.blocks[i].pending = d[:6] + (vlim, tan, kn, near[:0])
        for i, _ in data:
            if not self._check(i):
                return False
        return True

    def _check(self, i: int) -> bool:
        """Check block i; repair it and return False if it broke a limit."""
        d = self._sample(i)
        if d is None:
            return True
        key, segs, s, v, a, seg_id, vlim, tan, kn, near = d
        b = self.blocks[i]
        b.pending = None
        ref = b.ref
        if near.size:
            # within reach of a limit: the path read at the samples themselves, not interpolated
            # between reference points (a product of interpolated T and κN missed a block's
            # peak: wm on a slow Y axis, 100.4 % of A_y between two points 0.1 mm apart)
            # (at u interpolated between the points: no arc-length inversion, second-order close)
            exact = _evaluate(self.curve, self.limits, s[near], self.cap, np.interp(s[near], ref.s, ref.u))
            vlim, tan, kn = vlim.copy(), tan.copy(), kn.copy()
            vlim[near] = np.minimum(vlim[near], exact.vlim)
            tan[near], kn[near] = exact.tangent, exact.kn
        r, worst_axis, cen = self._axis_ratio(v, a, tan, kn)
        kinks = self._kink_samples(s, v, a)
        if kinks is not None:  # a kink's tick, as one more sample (no feed limit of its own)
            s_k, v_k, a_k, tan_k, cen_k, at = kinks
            s, v, a = np.concatenate([s, s_k]), np.concatenate([v, v_k]), np.concatenate([a, a_k])
            vlim = np.concatenate([vlim, 2.0 * v_k + 1.0])
            seg_id = np.concatenate([seg_id, seg_id[at]])
            tan, cen = np.vstack([tan, tan_k]), np.vstack([cen, cen_k])
            ratio = (np.abs(a[:, None] * tan) + np.abs(cen)) / self.axis_acc[None, :]
            ratio[:-s_k.size] = np.abs(a[:-s_k.size, None] * tan[:-s_k.size] + cen[:-s_k.size]) \
                / self.axis_acc[None, :]
            worst_axis = np.argmax(ratio, axis=1)
            r = ratio[np.arange(ratio.shape[0]), worst_axis]
        over_v = v - vlim * (1.0 + CHECK_RTOL) - 1e-12
        # and at the reference points themselves: a corner's cap is one point, and samples either
        # side of it read the limit interpolated towards its neighbours, far above it
        inner = np.flatnonzero((ref.s > s[0]) & (ref.s < s[-1]))
        over_ref = np.interp(ref.s[inner], s, v) - ref.vlim[inner] * (1.0 + POINT_RTOL) - 1e-12
        if over_ref.size and over_ref.max() > 0.0 and over_v.max() <= 0.0:
            k = int(inner[np.argmax(over_ref / np.maximum(ref.vlim[inner], 1e-12))])
            self._split(i, float(ref.s[k]), cap=float(ref.vlim[k]))
            self.stats.caps_lowered += 1
            return False
        if over_v.max() <= 0.0 and r.max() <= 1.0 + CHECK_RTOL:
            b.checked = key
            return True
        if over_v.max() > 0.0:
            k = int(np.argmax(over_v / np.maximum(vlim, 1e-12)))
            bad = over_v > 0.0
            a_idx = k
            while a_idx > 0 and bad[a_idx - 1]:
                a_idx -= 1
            b_idx = k
            while b_idx < bad.size - 1 and bad[b_idx + 1]:
                b_idx += 1
            # a junction where the profile first crosses the limit, capped at the lowest limit of
            # the crossing: a ramp is then followed in few, large steps
            cap = SPLIT_ROOM * float(vlim[a_idx:b_idx + 1].min())
            self._split(i, s[a_idx], cap=cap)
            return False
        k = int(np.argmax(r))
        j = int(worst_axis[k])
        cen_ratio = abs(cen[k, j]) / self.axis_acc[j]
        tan_ratio = abs(a[k] * tan[k, j]) / self.axis_acc[j]
        seg = segs[int(seg_id[k])]
        if cen_ratio > 0.9 or tan_ratio < 0.05:
            # the centripetal part nearly uses the axis up: a junction here (zero tangential
            # acceleration), as much slower than the profile as the excess needs (NEAR_ROOM)
            room = max(SPLIT_ROOM, NEAR_ROOM / math.sqrt(float(r[k])))  # r[k] > 1 here
            self._split(i, s[k], cap=room * float(v[k]))
            self.stats.caps_lowered += 1
            return False
        peak = max(peak_acceleration(seg), 1e-9) if seg.duration_s else b.acc
        need = 1.0 - (r[k] - 1.0) / max(tan_ratio, 1e-3)
        acc = max(min(b.acc, peak) * min(max(need, 0.5), 0.995), 1e-3 * self.acc)
        if acc < ACC_KEEP * self.acc:
            # the whole block would crawl for one point: a junction there instead (zero
            # tangential acceleration), the rest of the block keeps its acceleration
            self._split(i, s[k], cap=SPLIT_ROOM * float(v[k]))
            self.stats.caps_lowered += 1
            return False
        b.acc = acc
        self.stats.acc_lowered += 1
        self._invalidate()
        return False

    def _kink_samples(self, s: np.ndarray, v: np.ndarray, a: np.ndarray):
        """The ticks that pass a kink of the path inside the sampled stretch (a tangent break too
        small to be a corner the profile stops its acceleration for: a join of a blended
        polyline, 0.2°): there the axis sees |a·T_j| + v·|ΔT_j|/Ts + v²·|κn_j| at once (a slow
        Y axis at 109 % of A_y, the tangential part alone using it up). Returns (s, v, a, |T_j|
        of the steeper side, v·|ΔT_j|/Ts + v²·|κn_j|, index of the sample before) or None."""
        if self._kinks is None:
            return None
        s_j, t_j, c2, jump = self._kinks
        lo, hi = np.searchsorted(s_j, [s[0], s[-1]], side="right")
        if hi <= lo:
            return None
        s_k = s_j[lo:hi]
        if s_k[-1] >= s[-1]:
            s_k = s_k[s_k < s[-1]]
            hi = lo + s_k.size
            if not s_k.size:
                return None
        order = np.argsort(s, kind="stable")
        v_k = np.interp(s_k, s[order], v[order])
        a_k = np.interp(s_k, s[order], a[order])
        n = s_j.size
        tan_k = np.maximum(np.abs(t_j[lo:hi]), np.abs(t_j[n + lo:n + hi]))
        cen_k = v_k[:, None] * jump[lo:hi] / self.limits.ts_s + (v_k * v_k)[:, None] * c2[lo:hi]
        at = np.clip(np.searchsorted(s, s_k), 0, s.size - 1)
        return s_k, v_k, a_k, tan_k, cen_k, at

    def _axis_ratio(self, v: np.ndarray, a: np.ndarray, tan: np.ndarray, kn: np.ndarray):
        """Worst |a·T_j + v²·κN_j|/A_j per sample, its axis, and the centripetal parts v²·κN."""
        cen = (v * v)[:, None] * kn
        ratio = np.abs(a[:, None] * tan + cen) / self.axis_acc[None, :]
        worst_axis = np.argmax(ratio, axis=1)
        return ratio[np.arange(ratio.shape[0]), worst_axis], worst_axis, cen

    def _invalidate(self) -> None:
        """Nothing to do: a block's check is keyed by everything its profile depends on (junction
        feeds, acceleration, cruise cap, length), so only changed blocks are
        checked again."""

    def _split(self, i: int, s_at: float, factor: float = 1.0, cap: float | None = None) -> None:
        """Add a junction inside block i at ``s_at`` (its feed limit, times ``factor``, as cap)."""
        b = self.blocks[i]
        ref = b.ref
        span = ref.s[-1] - ref.s[0]
        s_at = float(np.clip(s_at, ref.s[0] + 1e-6 * span, ref.s[-1] - 1e-6 * span))
        k = int(np.searchsorted(ref.s, s_at))
        if self.curve is not None and ref.s[k] != s_at and abs(ref.s[k] - s_at) > 1e-3 * span:
            new = evaluate_reference(self.curve, self.limits, np.array([s_at]), cap=self.cap)
            ref = Reference.concat([ref.slice(0, k - 1), new, ref.slice(k, len(ref) - 1)])
        elif ref.s[k] != s_at:  # split at the nearest interior reference point
            if len(ref) <= 2:
                raise RuntimeError("cannot split a block without interior reference points")
            k = int(np.clip(k, 1, len(ref) - 2))
            if k - 1 >= 1 and abs(ref.s[k - 1] - s_at) < abs(ref.s[k] - s_at):
                k -= 1
        left, right = ref.slice(0, k), ref.slice(k, len(ref) - 1)
        cap = float(ref.vlim[k]) * factor if cap is None else min(cap, float(ref.vlim[k]))
        if i == 0 and cap < self.juncs[0].v:  # the first junction is committed: reachable from it
            cap = lowest_end_speed(self.juncs[0].v, float(ref.s[k]) - b.s0, cap, b.acc, self.jerk, self.shape)
        crawl = CRAWL * self.limits.feed_mm_s
        bl = _WBlock(left, b.acc, min(self.limits.feed_mm_s, max(float(left.vlim.max()), crawl)))
        br = _WBlock(right, b.acc, min(self.limits.feed_mm_s, max(float(right.vlim.max()), crawl)))
        self.blocks[i:i + 1] = [bl, br]
        self.juncs.insert(i + 1, _Junction(float(ref.s[k]), cap))
        self.stats.junctions_added += 1
        self._invalidate()

    def _settle(self, end_feed: float, full: bool = False) -> None:
        """Plan and repair until every block in the window passes its check. Every repair adds a
        junction or lowers an acceleration, so this ends; past MAX_SETTLE repairs in one window
        the path is refused (RuntimeError) rather than released over a limit."""
        # only blocks within a full stop of the first junction ahead can lower it: the others
        # are checked when they come to the front (bounded work per released block)
        reach = self.blocks[0].s1 + 1.05 * self.stop if self.blocks and not full else math.inf
        for _ in range(MAX_SETTLE):
            self._plan(end_feed)
            n = len(self.blocks)
            last = next((i for i in range(FRONT_BLOCKS + 1, n) if self.blocks[i].s0 > reach), n)
            if self._check_all(range(last)):
                return
        self.stats.unresolved += 1
        raise RuntimeError(f"{MAX_SETTLE} repairs in one look-ahead window at s = {self.blocks[0].s0:.6g} mm "
                           "did not bring every block within the limits")

    # ------------------------------------------------------------------ the window loop
    def run(self, blocks: Iterable[Block]) -> Iterator[ScheduledBlock]:
        """Yield scheduled blocks in path order while consuming ``blocks`` progressively."""
        source = iter(blocks)
        exhausted = False

        def pull() -> bool:
            nonlocal exhausted
            if exhausted:
                return False
            try:
                self._push(next(source))
            except StopIteration:
                exhausted = True
                return False
            return True

        while True:
            while not exhausted and (not self.blocks or self._ahead_mm() < self.window_mm):
                pull()
            if not self.blocks:
                return
            self._settle(0.0, full=exhausted)
            if exhausted:  # the stop at the window's end is the path's end: everything is final
                n_final = len(self.blocks)
            else:
                n_final = self._final_blocks()
                if n_final == 0:  # look further: a quarter of a full stop more (bounded re-plans)
                    goal = self._ahead_mm() + 0.25 * self.stop
                    while pull() and self._ahead_mm() < goal:
                        pass
                    continue
                if not self._front_holds(n_final):
                    continue
            for _ in range(n_final):
                yield self._release()

    def _final_blocks(self) -> int:
        """How many leading blocks have the same junction feeds whether or not the window's end is
        a stop: those are final (what the whole path would give) and are released together."""
        stop = [j.v for j in self.juncs]
        self._plan(math.inf)
        n = 0
        for k in range(1, len(self.juncs)):
            if self.juncs[k].v > stop[k] * (1 + 1e-12) + 1e-12:
                break
            n = k
        for j, v in zip(self.juncs, stop):
            j.v = v
        return n

    def _front_holds(self, n_final: int) -> bool:
        """Check the blocks to release and a few after them with the feeds they get when the path
        goes on (no stop at the window's end): a limit crossing that only shows at those feeds is
        repaired now, while the junction it needs can still be reached. The blocks to release are
        always checked; the look beyond them stops after MAX_REPAIRS failures in a row."""
        self._plan(math.inf)
        # every block a full stop beyond the released ones: a repair there (a junction with zero
        # acceleration) could otherwise need a lower feed than the released one can reach
        reach = self.juncs[n_final].s + 1.05 * self.stop
        n = len(self.blocks)
        last = n_final if self._front_checks >= MAX_REPAIRS else next(
            (i for i in range(n_final + FRONT_BLOCKS, n) if self.blocks[i].s0 > reach), n)
        if not self._check_all(range(min(max(last, n_final), n))):
            self._front_checks += 1
            return False
        self._front_checks = 0
        self._plan(0.0)
        return True

    def _release(self) -> ScheduledBlock:
        b = self.blocks[0]
        kind, segs = self._segments(0)
        j0, j1 = self.juncs[0], self.juncs[1]
        out = ScheduledBlock(b.s0, b.s1, j0.v, j1.v, kind, tuple(segs), b.acc, critical_end=True)
        self.blocks.pop(0)
        self.juncs.pop(0)
        self.stats.blocks_out += 1
        if self.blocks:
            self.stats.critical_s.append(j1.s)
        return out
