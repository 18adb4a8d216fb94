"""Every block of the look-ahead window checked against the path before release, and repaired.

The profile is sampled at half servo periods (compiled, slw/_kernels.py); the feed is checked
against the pointwise limit at the samples and at the reference points, and the axial
accelerations a_t·T_j + v²·κN_j (+ v·|ΔT_j|/Ts at a kink) against A_j. A feed above the limit
adds a junction there; an axial acceleration above its limit lowers the block's tangential
acceleration (on unequal axes only that of the transition at fault, the rise's or the fall's: the
per-point interval |a_t·T_j + v²·κN_j| ≤ A_j where it broke, not the block's worst direction), or
caps the feed of a new junction when the centripetal part alone nearly uses the axis up, or (unequal
axes) adds a junction where the transition's worst point allows far less than the rest of its
stretch (:func:`stretch_acc`).
"""

from __future__ import annotations

import math

import numpy as np

from fuzzyfeed.slw.preprocess import Reference, _evaluate, evaluate_reference
from fuzzyfeed.slw.profile import block_segments, lowest_end_speed, peak_acceleration, transition_time
from fuzzyfeed.slw.window_blocks import _Junction

_EMPTY = np.empty(0)

#: Relative slack accepted by the profile check (the remaining 0.5 % budget is the measurement's).
CHECK_RTOL = 1e-6
#: Blocks shorter than this fraction of one servo period's travel at the command feed are not
#: checked against the limits (the ticks around them are what the machine sees).
SUB_TICK = 1e-3
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
#: A block's top feed is lowered (instead of a junction) at most this many times; then the crossing
#: gets its junction (each lowering is strict, so the repairs end).
TOP_REPAIRS = 3
#: An axis-acceleration breach whose centripetal part alone uses more than this share of the axis
#: gets a junction (zero tangential acceleration) at a feed that brings it back within the limit.
CEN_SPLIT = 0.9
#: A block whose acceleration an axis-acceleration repair would take below this share of the
#: machine's tangential acceleration gets a junction at the offending point instead (a 28 mm
#: block crawled at 17 % of it for one point of one axis; random curve 199 of bench_slw).
ACC_KEEP = 0.5
#: On unequal axes (approach 2), a transition whose acceleration an axis-acceleration repair would
#: take below this share of what its own stretch allows (the median over its samples of the largest
#: tangential acceleration each leaves the axes, :func:`stretch_acc`) gets a junction at the
#: offending point instead: the rest of the rise or fall keeps the acceleration its directions
#: allow (issue 38: nurbs41 slow-Y, a 17 mm fall at 287 mm/s² where most of it allows 742).
STRETCH_KEEP = 0.6
#: … and only where the whole transition at what its stretch allows would take this share less
#: time than at the lowered acceleration (a jerk-bound change gains little from a higher
#: acceleration and loses a junction's zero acceleration: nurbs48 slow-Y cosine, a 16 mm/s rise).
STRETCH_GAIN = 0.25
#: Skip the blocks checked at their current key by their ``clean`` flag (False: by comparing the
#: whole key, :meth:`BlockCheck._checked_at_key`; the same blocks are checked, tests compare).
FAST_SKIP = True
#: Samples of a block's profile within this share of a limit (axis acceleration or feed) are
#: checked against the path evaluated at the samples themselves, not interpolated between points.
EXACT_NEAR = 0.99


def stretch_acc(sign: float, tan: np.ndarray, cen: np.ndarray, axis_acc: np.ndarray) -> np.ndarray:
    """Per sample, the largest α ≥ 0 with |sign·α·T_j + c_j| ≤ A_j on every axis (c_j = v²·κN_j
    the centripetal part; ``sign`` +1 a rise, −1 a fall): with u_j = sign·T_j, α ≤ (A_j − c_j)/u_j
    where u_j > 0 and α ≤ (A_j + c_j)/|u_j| where u_j < 0 (0 where the centripetal part alone
    breaks the axis)."""
    u = sign * np.asarray(tan, dtype=float)
    acc = np.asarray(axis_acc, dtype=float)[None, :u.shape[1]]
    with np.errstate(divide="ignore", invalid="ignore"):
        lim = np.where(u > 0.0, (acc - cen) / u, np.where(u < 0.0, (acc + cen) / -u, np.inf))
    return np.clip(np.nan_to_num(np.min(lim, axis=1), nan=0.0), 0.0, float(acc.max()))


class BlockCheck:
    """The check and its repairs (mixed into :class:`fuzzyfeed.slw.lookahead.SlidingWindow`)."""

    def _segments(self, i: int):
        b = self.blocks[i]
        return block_segments(b.length, self.juncs[i].v, self.juncs[i + 1].v, b.vmax, b.acc, self.jerk,
                              self.approach, self.shape, b.acc_down)

    def _sample(self, i: int):
        """Block i's profile sampled at half servo periods with the path's data interpolated from
        its reference points: (key, segments, s, v, a, segment index, vlim, T, κN, near), where
        ``near`` indexes the samples within EXACT_NEAR of a limit (read exactly before judging);
        None when the block needs no check (already checked with this key, or crossed within a
        small part of one servo period). Kept on the block with its key until judged."""
        b = self.blocks[i]
        key = (self.juncs[i].v, self.juncs[i + 1].v, b.acc, b.acc_down, b.vmax, b.length)
        if b.checked == key:
            return None
        if b.pending is not None and b.pending[0] == key:
            return b.pending
        if b.length < SUB_TICK * self.limits.feed_mm_s * self.limits.ts_s:
            b.checked, b.clean = key, True  # crossed within a small part of one servo period
            return None
        kind, segs = self._segments(i)
        if not segs:
            b.checked, b.clean = key, True
            return None
        import fuzzyfeed.slw._kernels as kernels

        seg_arr = np.array([(g.v0, g.v1, g.duration_s, math.nan if g.jerk_mm_s3 is None else g.jerk_mm_s3)
                            for g in segs])
        s, v, a, seg_id = kernels.sample_segments(seg_arr[:, 0], seg_arr[:, 1], seg_arr[:, 2], seg_arr[:, 3],
                                                  b.s0, 0.5 * self.limits.ts_s)
        ref = b.ref
        if b.vfeed is None:
            b.vfeed = self._feed_limit(ref.s, ref.vlim, ref.tangent, ref.kn)
        vlim, tan, kn = kernels.interp_reference(s, ref.s, b.vfeed, ref.tangent, ref.kn)
        r, _, _ = kernels.axis_ratio(v, a, tan, kn, self.axis_acc)
        near = kernels.near_limits(v, vlim, r, float(self.limits.feed_mm_s), EXACT_NEAR)
        if self.curve is None:
            near = near[:0]
        b.pending = (key, segs, s, v, a, seg_id, vlim, tan, kn, near)
        return b.pending

    def _check_all(self, indices) -> bool:
        """Check blocks ``indices`` in order, repairing the first that breaks a limit (False).
        The samples within reach of a limit of every block still to judge are read from the path
        in one evaluation (one call instead of one per block: the calls' overhead was half of
        a long program's scheduling), compiled (slw/exact.py)."""
        blocks = self.blocks
        # a clean block was checked at its current key (_sample would say so): skipped unread
        # (~3·10⁶ calls on a long program, most of them for blocks checked before); a block not
        # clean whose key came back to the checked one is skipped by _sample (None)
        if FAST_SKIP:
            data = [(i, self._sample(i)) for i in indices if not blocks[i].clean]
        else:
            data = [(i, self._sample(i)) for i in indices if not self._checked_at_key(i)]
        todo = [d for _, d in data if d is not None and d[9].size]
        if todo:
            s_all = np.concatenate([d[2][d[9]] for d in todo])
            u_all = np.concatenate([np.interp(d[2][d[9]], self.blocks[i].ref.s, self.blocks[i].ref.u)
                                    for i, d in data if d is not None and d[9].size])
            exact = _evaluate(self.curve, self.limits, s_all, self.cap, u_all)
            # pointwise: one call for every block's samples (the same values as one per block)
            lifted = self._feed_limit(exact.s, exact.vlim, exact.tangent, exact.kn)
            at = 0
            for i, d in data:
                if d is None or not d[9].size:
                    continue
                near = d[9]
                part = slice(at, at + near.size)
                at += near.size
                vlim, tan, kn = d[6].copy(), d[7].copy(), d[8].copy()
                vlim[near] = np.minimum(vlim[near], lifted[part])
                tan[near], kn[near] = exact.tangent[part], exact.kn[part]
                self.blocks[i].pending = d[:6] + (vlim, tan, kn, near[:0])
        for i, d in data:
            # a block with nothing to judge (None) stays so: no block changes before a failed check
            if d is not None and not self._check(i):
                return False
        return True

    def _checked_at_key(self, i: int) -> bool:
        """Block i checked with these feeds already, by its whole key (v0, v1, acc, acc_down, vmax,
        length, as :meth:`_sample`): the reference of the ``clean`` flag (tests compare)."""
        b, c = self.blocks[i], self.blocks[i].checked
        return c is not None and c[0] == self.juncs[i].v and c[1] == self.juncs[i + 1].v and c[2] == b.acc \
            and c[3] == b.acc_down and c[4] == b.vmax and c[5] == b.length

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
            vlim[near] = np.minimum(vlim[near], self._feed_limit(exact.s, exact.vlim, exact.tangent, exact.kn))
            tan[near], kn[near] = exact.tangent, exact.kn
        r, worst_axis, cen = self._axis_ratio(v, a, tan, kn)
        n_samples = s.size
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
        over_ref = np.interp(ref.s[inner], s, v) - b.vfeed[inner] * (1.0 + POINT_RTOL) - 1e-12
        if over_ref.size and over_ref.max() > 0.0 and over_v.max() <= 0.0:
            k = int(inner[np.argmax(over_ref / np.maximum(b.vfeed[inner], 1e-12))])
            self._split(i, float(ref.s[k]), cap=float(ref.vlim[k]))
            self.stats.caps_lowered += 1
            return False
        if over_v.max() <= 0.0 and r.max() <= 1.0 + CHECK_RTOL:
            b.checked, b.clean = key, True
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
            low_v = float(vlim[a_idx:b_idx + 1].min())
            top, rest_v = int(np.argmax(v)), float(vlim[a_idx:].min())
            if self.carry and b.tops < TOP_REPAIRS and a_idx <= top <= b_idx \
                    and rest_v >= SPLIT_ROOM * float(v[top]) and rest_v < b.vmax * (1.0 - 1e-9) \
                    and rest_v >= max(self.juncs[i].v, self.juncs[i + 1].v):
                # the block's top over a limit that falls a little under it (a run along a slow
                # axis, its limit 50.09 falling to 50.00): the block's top feed lowered to the
                # lowest limit from the crossing on, no junction (a split there, 3 % under the
                # limit, began a sawtooth of junctions at zero acceleration: nurbs5 slow-Y, 10
                # over 11 mm); each such repair lowers the top (never below an end feed)
                b.vmax, b.clean = rest_v, False
                b.tops += 1
                self.stats.caps_lowered += 1
                return False
            # a junction where the profile first crosses the limit, capped at the lowest limit of
            # the crossing: a ramp is then followed in few, large steps
            cap = SPLIT_ROOM * low_v
            at = a_idx
            low = a_idx + int(np.argmin(vlim[a_idx:b_idx + 1]))
            if self.per_direction and (
                    all(segs[int(g)].v1 < segs[int(g)].v0 for g in np.unique(seg_id[a_idx:b_idx + 1]))
                    or (self.carry and low < b_idx and segs[int(seg_id[low])].v1 < segs[int(seg_id[low])].v0)):
                # a fall (at its own, higher acceleration on unequal axes) late for a limit
                # that falls faster: the junction where that limit is lowest, so the feed stays
                # high up to there instead of dropping at the crossing's start (nurbs25 slow-Y);
                # also when the crossing starts in the cruise before that fall (issue 38: a
                # junction at the cruise's end capped at the fall's lowest limit, 39 mm/s where
                # the limit is 92 — nurbs25 slow-Y seven-phase), if that lowest limit is inside
                # the crossing (at its end the limit still falls: a chain of splits towards the
                # block's end, nurbs98 slow-Y)
                at = low
            self._split(i, s[at], cap=cap)
            return False
        k = int(np.argmax(r))
        j = int(worst_axis[k])
        cen_ratio = abs(cen[k, j]) / self.axis_acc[j]
        tan_ratio = abs(a[k] * tan[k, j]) / self.axis_acc[j]
        seg = segs[int(seg_id[k])]
        if cen_ratio > CEN_SPLIT or tan_ratio < 0.05:
            # the centripetal part nearly uses the axis up: a junction here (zero tangential
            # acceleration), as much slower than the profile as the excess needs (NEAR_ROOM)
            room = max(SPLIT_ROOM, NEAR_ROOM / math.sqrt(float(r[k])))  # r[k] > 1 here
            self._split(i, s[k], cap=room * float(v[k]))
            self.stats.caps_lowered += 1
            return False
        # on unequal axes only the acceleration of the transition at fault is lowered (a rise
        # and a fall of one block run in different directions, and the centripetal part of an
        # axis helps one of them), on equal axes both (seed 000)
        side = (0 if seg.v1 > seg.v0 else 1) if self.per_direction else 2
        current = b.acc if side == 0 else b.acc_down if side == 1 else min(b.acc, b.acc_down)
        peak = max(peak_acceleration(seg), 1e-9) if seg.duration_s else current
        need = 1.0 - (r[k] - 1.0) / max(tan_ratio, 1e-3)
        acc = max(min(current, peak) * min(max(need, 0.5), 0.995), 1e-3 * self.acc)
        if self.carry and self.per_direction and seg.duration_s and seg.v1 != seg.v0 and k < n_samples:
            here = np.flatnonzero(seg_id[:n_samples] == seg_id[k])
            allows = float(np.median(stretch_acc(1.0 if seg.v1 > seg.v0 else -1.0, tan[here], cen[here],
                                                 self.axis_acc)))
            allows = min(allows, float(self.axis_acc.max()))
            slow = transition_time(seg.v0, seg.v1, acc, self.jerk, self.shape)
            if acc < STRETCH_KEEP * allows and \
                    transition_time(seg.v0, seg.v1, allows, self.jerk, self.shape) < (1.0 - STRETCH_GAIN) * slow:
                # the transition's worst point allows far less than the rest of its stretch: a
                # junction there (zero tangential acceleration), the rest keeps its acceleration
                self._split(i, s[k], cap=float(v[k]))
                self.stats.caps_lowered += 1
                return False
        if acc < ACC_KEEP * self.acc:
            # the whole block would crawl for one point: a junction there instead (zero
            # tangential acceleration), the rest of the block keeps its acceleration
            self._split(i, s[k], cap=SPLIT_ROOM * float(v[k]))
            self.stats.caps_lowered += 1
            return False
        if side != 1:
            b.acc = acc
        if side != 0:
            b.acc_down = acc
        b.clean = False
        b.ceilings = b.ceilings + ((float(s[k]), acc, side),)
        self.stats.acc_lowered += 1
        self._invalidate()
        return False

    def _feed_limit(self, s: np.ndarray, vlim: np.ndarray, tan: np.ndarray, kn: np.ndarray) -> np.ndarray:
        """The feed limit a block's profile is held to between its junctions: ``vlim`` (eq. (8)-(12),
        capped), except where its centripetal part v ≤ √(A_j/|κN_j|) binds exactly (no corner's or
        cap's lower value there), which is lifted to the other parts (command, axial velocity,
        chord, cap): inside a block the axis check holds |a_t·T_j + v²·κN_j| ≤ A_j itself, and a
        fall whose tangential part opposes the centripetal one passes a bend faster than at zero
        acceleration (issue 38: nurbs88 slow-Y, 53 mm/s against 38). A junction (zero
        acceleration) keeps the full limit (:meth:`_split` caps at ``vlim``). Unchanged (the
        paper's window) with approach 1."""
        if not self.carry:
            return vlim
        import fuzzyfeed.slw._exact_jit as kernel

        lim = self.limits
        tan, kn = np.asarray(tan, dtype=float), np.asarray(kn, dtype=float)
        d = tan.shape[1]
        if not hasattr(self, "_feed_args"):
            self._feed_args = (self.axis_acc[:d].astype(float), np.asarray(lim.axis_vel_mm_s, dtype=float)[:d],
                               float(lim.feed_mm_s), float(lim.chord_tol_mm), 2.0 / lim.ts_s)
        acc, vel, feed, delta, two_over_ts = self._feed_args
        if acc.size == d:
            # compiled: the numpy form below point by point, the same floats (tests/test_slw_exact.py)
            cap_s, cap_v = (self.cap.s_mm, self.cap.feed_mm_s) if self.cap is not None else (_EMPTY, _EMPTY)
            out = np.empty(tan.shape[0])
            kernel.window_feed_limit(np.asarray(s, dtype=float), np.asarray(vlim, dtype=float), tan, kn,
                                     acc, vel, feed, delta, two_over_ts, cap_s, cap_v, out)
            return out
        return self._feed_limit_numpy(s, vlim, tan, kn)

    def _feed_limit_numpy(self, s: np.ndarray, vlim: np.ndarray, tan: np.ndarray, kn: np.ndarray) -> np.ndarray:
        """The reference of :meth:`_feed_limit` in numpy (the compiled kernel's floats; tests compare)."""
        if not self.carry:
            return vlim
        lim = self.limits
        vlim = np.asarray(vlim, dtype=float)
        tan, kn = np.abs(np.asarray(tan, dtype=float)), np.abs(np.asarray(kn, dtype=float))
        d = tan.shape[1]
        acc, vel = self.axis_acc[:d].astype(float), np.asarray(lim.axis_vel_mm_s, dtype=float)[:d]
        with np.errstate(divide="ignore", invalid="ignore"):
            cen = np.min(np.where(kn > 0.0, np.sqrt(acc[None, :] / kn), np.inf), axis=1)
            other = np.min(np.where(tan > 0.0, vel[None, :] / tan, np.inf), axis=1)
            kappa = np.sqrt(np.sum(kn * kn, axis=1))
            rho = np.where(kappa > 0.0, 1.0 / kappa, np.inf)
            delta = lim.chord_tol_mm
            chord = np.where(np.isinf(rho) | (2.0 * rho <= delta), np.inf,
                             2.0 / lim.ts_s * np.sqrt(np.maximum(2.0 * rho * delta - delta * delta, 0.0)))
        other = np.minimum(np.minimum(other, chord), lim.feed_mm_s)
        if self.cap is not None:
            other = np.minimum(other, self.cap(np.asarray(s, dtype=float)))
        lift = (np.isfinite(kn).all(axis=1) & (cen > 0.0) & (cen < other)
                & (np.abs(vlim - cen) <= 1e-9 * cen))
        return np.where(lift, np.maximum(vlim, other), vlim) if lift.any() else vlim

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
        import fuzzyfeed.slw._kernels as kernels

        return kernels.axis_ratio(v, a, tan, kn, self.axis_acc)

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
            cap = lowest_end_speed(self.juncs[0].v, float(ref.s[k]) - b.s0, cap, b.acc_down, self.jerk, self.shape)
        self.blocks[i:i + 1] = [self._piece(left, b), self._piece(right, b)]
        self.juncs.insert(i + 1, _Junction(float(ref.s[k]), cap))
        self.stats.junctions_added += 1
        self._invalidate()
