"""The sliding look-ahead window (SLW) of seed 000: junction feeds, corrections and repairs.

Blocks from the preprocessor are pushed into a window. In the window the junction feeds are set by
a backward scan (each junction no faster than what still stops — or reaches the next junction's
feed — within its block) and a forward scan (no faster than what is reachable from the previous
junction), both with bisection on the transition's distance (seed 000's cosine, or the seven-phase ramp): the type-4 corrections of
seed 000 ("Feedrate correction for non-schedulable blocks", Heng & Erkorkmaz's bisection). The
window assumes a stop at its far end; the first block is released only when its end feed is the
same whether or not that stop is assumed, which needs at least a full stop from the command feed
of look-ahead (eq. (22)) — so the released profile equals the one the whole path would give.

Every block's profile is checked against the path before release (slw/window_check.py; how blocks
enter the window, merged or cut by direction: slw/window_blocks.py): the feed against the pointwise
limit at the reference points, and the axial accelerations a_t·T_j + v²·κN_j against A_j. A feed
above the limit inside a block adds a junction there (the limit curve rose slower than the
profile); an axial acceleration above its limit lowers the block's tangential acceleration, or the
feed of the junction it approaches when the centripetal part alone nearly uses the axis up. On a
machine whose axes differ, a block's rises and falls have each their own tangential acceleration
(started at the largest its directions allow, lowered only for the transition at fault); on equal
axes one per block, as seed 000.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Iterable, Iterator

import numpy as np

from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.slw.feed_cap import FeedCap
from fuzzyfeed.slw.preprocess import Block, corner_plan, joins
from fuzzyfeed.slw.profile import (BISECTION_STEPS, COSINE, SEVEN_PHASE, check_shape, lowest_end_speed,
                                   max_end_speed, max_start_speed, stop_distance, transition_distance)
from fuzzyfeed.slw.window_blocks import (KINK_MIN, LookaheadStats, ScheduledBlock,  # noqa: F401
                                         WindowContent, _Junction, _WBlock)
from fuzzyfeed.slw.window_check import BlockCheck, CHECK_RTOL  # noqa: F401

#: Failed checks in a row, beyond the blocks to release, after which the look beyond them stops.
MAX_REPAIRS = 400
#: Repairs in one window before the path is refused (each repair is progress; never reached on
#: the benchmark's paths).
MAX_SETTLE = 100_000
#: Blocks at the front of the window checked at the feeds of a continuing path before a release.
FRONT_BLOCKS = 3
#: Look-ahead length as a multiple of the full-stop distance from the command feed.
WINDOW_STOPS = 1.5


def _first_beyond(blocks: list, reach: float, lo: int) -> int:
    """The first index ≥ ``lo`` of a block starting beyond ``reach`` (len(blocks) if none): the
    blocks are in path order (s0 increasing), so a bisection, not a scan of the window."""
    if lo >= len(blocks):
        return len(blocks)
    return bisect_right(blocks, reach, lo, key=_start)


def _start(block) -> float:
    return block.s0


class SlidingWindow(WindowContent, BlockCheck):
    """Schedules blocks progressively; iterate :meth:`run` to get :class:`ScheduledBlock` s."""

    def __init__(self, limits: MachineLimits, curve: Nurbs | None = None, approach: int = 2,
                 cap: FeedCap | None = None, transition: str = COSINE):
        if approach not in (1, 2):
            raise ValueError(f"approach = {approach!r}; seed 000 Table 1 has approaches 1 and 2")
        self.approach = approach
        # the window of issue 38 (a block's feed held below the centripetal limit only where the
        # axis check needs it, the path's start a junction a merge may drop); approach 1 keeps
        # the paper's window (seed 000's figures)
        self.carry = approach == 2
        self.shape = check_shape(transition)
        self.cap = cap
        self.curve = curve
        self.limits = limits
        self.jerk = limits.jerk_mm_s3
        self.acc = limits.tangential_acc_mm_s2
        self.axis_acc = np.asarray(limits.axis_acc_mm_s2)
        # unequal axes: a block's rises and falls each at the acceleration of the directions
        # they run in (window_blocks, window_check); equal axes: seed 000's one per block
        self.per_direction = bool(self.axis_acc.min() < self.axis_acc.max())
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
        # called with the window at the top of its loop (slw/resume.py keeps states there)
        self.keep = None
        self._planned = None   # _final_blocks' two plans, for _front_holds

    # ------------------------------------------------------------------ junction feeds
    def _backward(self, end_feed: float) -> list[float]:
        n = len(self.blocks)
        v = [0.0] * (n + 1)
        v[n] = min(self.juncs[n].cap, end_feed)
        for i in range(n - 1, -1, -1):
            b = self.blocks[i]
            v[i] = max_start_speed(v[i + 1], b.length, self.juncs[i].cap, b.acc_down, self.jerk, self.shape)
        return v

    def _plan(self, end_feed: float) -> np.ndarray:
        """Junction feeds of the window: a backward scan (each junction no faster than what
        reaches the next within its block) and a forward scan from the committed first junction
        (compiled: _kernels.plan_window, the arithmetic of :meth:`_plan_python`); set on the
        junctions and returned."""
        import fuzzyfeed.slw._kernels as kernels

        blocks, juncs = self.blocks, self.juncs
        v = kernels.plan_window(np.array([b.length for b in blocks]), np.array([b.acc for b in blocks]),
                                np.array([j.cap for j in juncs]), float(juncs[0].v), float(end_feed),
                                float(self.jerk), self.shape == SEVEN_PHASE, BISECTION_STEPS,
                                np.array([b.acc_down for b in blocks]))
        self._set_feeds(v.tolist())
        return v

    def _plan_python(self, end_feed: float) -> None:
        """The reference of :meth:`_plan` in Python (profile.py's functions; tests compare)."""
        v = self._backward(end_feed)
        v[0] = self.juncs[0].v  # committed
        for i, b in enumerate(self.blocks):
            if v[i + 1] < v[i] and transition_distance(v[i], v[i + 1], b.acc_down, self.jerk, self.shape) > b.length:
                # a committed junction may be faster than a junction found later allows: brake as
                # hard as the block lets (the check then repairs the block before it is released)
                v[i + 1] = lowest_end_speed(v[i], b.length, v[i + 1], b.acc_down, self.jerk, self.shape)
            else:
                v[i + 1] = max_end_speed(v[i], b.length, v[i + 1], b.acc, self.jerk, self.shape)
        self._set_feeds(v)

    def _set_feeds(self, feeds: list[float]) -> None:
        """Set the junction feeds (every assignment of a junction's feed goes through here): a
        block whose end feed changed value is no longer clean (its check's key changed)."""
        juncs = self.juncs
        before = [j.v for j in juncs]
        for j, v in zip(juncs, feeds):
            j.v = v  # always assigned, as before (0.0 == -0.0: the sign is the new one's)
        if before == feeds:  # most plans (one comparison in C)
            return
        blocks, n = self.blocks, len(self.blocks)
        for i, (old, new) in enumerate(zip(before, feeds)):
            if old != new:
                if i:
                    blocks[i - 1].clean = False
                if i < n:
                    blocks[i].clean = False

    def _settle(self, end_feed: float, full: bool = False) -> None:
        """Plan and repair until every block in the window passes its check. Every repair adds a
        junction or lowers an acceleration, so this ends; past MAX_SETTLE repairs in one window
        the path is refused (RuntimeError) rather than released over a limit."""
        # only blocks within a full stop of the first junction ahead can lower it: the others
        # are checked when they come to the front (bounded work per released block)
        reach = self.blocks[0].s1 + 1.05 * self.stop if self.blocks and not full else math.inf
        for _ in range(MAX_SETTLE):
            self._plan(end_feed)
            last = _first_beyond(self.blocks, reach, FRONT_BLOCKS + 1)
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
            if self.keep is not None and not exhausted:
                self.keep(self)
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
        go_on = self._plan(math.inf)
        # n: the junctions 1 … n before the first one faster without the stop
        faster = np.flatnonzero(go_on[1:] > np.array(stop[1:]) * (1 + 1e-12) + 1e-12)
        n = int(faster[0]) if faster.size else len(self.juncs) - 1
        self._set_feeds(stop)
        # both plans, for _front_holds right after (nothing changes between: the same feeds)
        self._planned = (go_on.tolist(), stop)
        return n

    def _front_holds(self, n_final: int) -> bool:
        """Check the blocks to release and a few after them with the feeds they get when the path
        goes on (no stop at the window's end): a limit crossing that only shows at those feeds is
        repaired now, while the junction it needs can still be reached. The blocks to release are
        always checked; the look beyond them stops after MAX_REPAIRS failures in a row."""
        planned, self._planned = self._planned, None
        if planned is None:
            self._plan(math.inf)
        else:   # _final_blocks' plan without the stop (the same window)
            self._set_feeds(planned[0])
        # every block a full stop beyond the released ones: a repair there (a junction with zero
        # acceleration) could otherwise need a lower feed than the released one can reach
        reach = self.juncs[n_final].s + 1.05 * self.stop
        n = len(self.blocks)
        last = n_final if self._front_checks >= MAX_REPAIRS else _first_beyond(self.blocks, reach,
                                                                               n_final + FRONT_BLOCKS)
        if not self._check_all(range(min(max(last, n_final), n))):
            self._front_checks += 1
            return False
        self._front_checks = 0
        if planned is None:
            self._plan(0.0)
        else:   # the plan with the stop that _settle left (a passed check repairs nothing)
            self._set_feeds(planned[1])
        return True

    def _release(self) -> ScheduledBlock:
        b = self.blocks[0]
        kind, segs = self._segments(0)
        j0, j1 = self.juncs[0], self.juncs[1]
        out = ScheduledBlock(b.s0, b.s1, j0.v, j1.v, kind, tuple(segs), b.acc, critical_end=True,
                             acc_down_mm_s2=b.acc_down)
        self.blocks.pop(0)
        self.juncs.pop(0)
        self.stats.blocks_out += 1
        if self.blocks:
            self.stats.critical_s.append(j1.s)
        return out
