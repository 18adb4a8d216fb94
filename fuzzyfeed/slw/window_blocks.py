"""The look-ahead window's blocks and junctions, and how a block from the preprocessor enters the
window: merged into the last block when the critical point between them is closer than a
transition needs (no forced zero acceleration there), or cut where the tangential acceleration its
directions allow changes (seed 000, eq. (13)-(14), per block)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fuzzyfeed.slw.preprocess import Block, Reference
from fuzzyfeed.slw.profile import Segment, transition_distance

#: Crawl feed (fraction of the command feed) through a block whose limit is 0 everywhere.
CRAWL = 1e-3
#: Share of each axis's acceleration a true corner passed inside a merged block may use (the rest
#: is the tangential acceleration's); the preprocessor's corner caps use CORNER_MARGIN of it.
CORNER_SHARE = 0.45
CORNER_MARGIN = 0.9
#: The path's first critical point is merged away when a rise from rest reaches less than this
#: share of its cap within the first block (the window of issue 38; not with approach 1).
START_REACH = 0.5
#: A join whose unit tangent jumps by less than this (per axis) is no kink.
KINK_MIN = 1e-9
#: A block is cut where the tangential acceleration its directions allow changes by this factor …
DIRECTION_STEP = 0.6
#: … into pieces no shorter than this share of a full stop from the command feed.
DIRECTION_MIN = 0.1


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
    # True only while ``checked`` is the block's current key (its end junctions' feeds, acc,
    # acc_down, vmax, length): cleared wherever one of them changes (SlidingWindow._set_feeds,
    # window_check's repairs; a split or merge makes new blocks), so the check skips it unread
    clean: bool = False
    pending: tuple | None = None  # (key, samples …) of a check not yet judged (_sample)
    # the tangential acceleration of the block's falls (``acc``: of its rises); seed 000's one
    # acceleration per block when equal (the default)
    acc_down: float | None = None
    # where the check (or a corner passed inside the block) lowered an acceleration, to what, and
    # which (0 the rises', 1 the falls', 2 both): a split gives each piece its own direction's
    # acceleration and only the ceilings inside it
    ceilings: tuple[tuple[float, float, int], ...] = ()
    # the feed limit the check holds at the reference points (window_check.BlockCheck._feed_limit:
    # the centripetal part lifted, the axis check holds it with the tangential part); set on
    # first check
    vfeed: np.ndarray | None = None
    # how many times the check lowered ``vmax`` instead of adding a junction (window_check)
    tops: int = 0
    # the ends and length, read ~10⁷ times on a long program: kept, not recomputed (ref is never
    # replaced: a split or merge makes new blocks)
    s0: float = field(init=False)
    s1: float = field(init=False)
    length: float = field(init=False)

    def __post_init__(self) -> None:
        if self.acc_down is None:
            self.acc_down = self.acc
        self.s0 = float(self.ref.s[0])
        self.s1 = float(self.ref.s[-1])
        self.length = self.s1 - self.s0


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
    acc_down_mm_s2: float | None = None  # the falls' (None: acc_mm_s2)

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


class WindowContent:
    """The window's content (mixed into :class:`fuzzyfeed.slw.lookahead.SlidingWindow`, whose
    constructor sets limits, curve, shape, acc, jerk, axis_acc, stop, blocks, juncs, stats)."""

    def _push(self, block: Block) -> None:
        self.stats.blocks_in += 1
        if self._merge(block):
            return
        # a stretch with a zero limit everywhere (a micro-kink between two near-stationary
        # points) is crawled through at a tiny feed rather than being impassable
        crawl = CRAWL * self.limits.feed_mm_s
        for ref in self._by_direction(block.ref):
            vmax = min(self.limits.feed_mm_s, max(float(ref.vlim.max()), crawl))
            up, down = self._start_acc(ref)
            self.blocks.append(_WBlock(ref, up, vmax, acc_down=down))
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
        if not self.blocks:
            return False
        last, prev = self.juncs[-1], self.juncs[-2]
        if not last.critical:
            return False
        if len(self.juncs) == 2 and prev.s == 0.0 and self.carry:
            # the path's first critical point, when a rise from rest reaches less than
            # START_REACH of its cap within the first block: a zero acceleration there would cut
            # the start's rise at a low feed (nurbs88 slow-Y: 14 mm/s at 0.59 mm, cap 49)
            if last.cap < block.cap1 or self.blocks[-1].length >= transition_distance(
                    0.0, START_REACH * last.cap, self.acc, self.jerk, self.shape):
                return False
        else:
            if not prev.critical or len(self.juncs) - 1 <= 1:
                return False
            if last.cap < prev.cap or last.cap < block.cap1:
                return False
            lo = min(prev.cap, block.cap1)
            if self.blocks[-1].length >= transition_distance(lo, last.cap, self.acc, self.jerk, self.shape):
                return False
        b = self.blocks[-1]
        up, down = self._start_acc(block.ref)
        head, acc, acc_down = b.ref, min(b.acc, up), min(b.acc_down, down)
        ceilings = b.ceilings
        if self._corner_s.size and np.isin(last.s, self._corner_s):
            # a true corner passed inside a block, not at rest on its tangential acceleration:
            # the corner's turn may use CORNER_SHARE of each axis, the tangential acceleration
            # the rest
            vlim = head.vlim.copy()
            vlim[-1] *= CORNER_SHARE / CORNER_MARGIN
            head = Reference(head.s, head.u, vlim, head.tangent, head.kn)
            acc = min(acc, (1.0 - CORNER_SHARE) * self.acc)
            acc_down = min(acc_down, (1.0 - CORNER_SHARE) * self.acc)
            ceilings = ceilings + ((float(last.s), (1.0 - CORNER_SHARE) * self.acc, 2),)
        ref = Reference.concat([head, block.ref.slice(1, len(block.ref) - 1)]) if len(block.ref) > 1 else head
        vmax = min(self.limits.feed_mm_s, max(float(ref.vlim.max()), CRAWL * self.limits.feed_mm_s))
        self.blocks[-1] = _WBlock(ref, acc, vmax, acc_down=acc_down, ceilings=ceilings)
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

    def _start_acc(self, ref: Reference) -> tuple[float, float]:
        """(rise, fall) tangential accelerations a new block starts from. Equal axes: seed 000's
        one, :meth:`_direction_acc` for both. Unequal axes: the largest a with |a·T_j| ≤ A_j at
        any of its reference points (at most max A_j) for both — the direction a block's rise
        or fall actually runs in is known only from its profile, so the check
        (slw/window_check.py) lowers the one at fault to what the per-point interval
        |a·T_j + v²·κN_j| ≤ A_j leaves where it breaks, not the whole block to its worst
        direction's."""
        low = self._direction_acc(ref)
        if not self.per_direction:
            return low, low
        t = np.abs(ref.tangent)
        with np.errstate(divide="ignore"):
            per_point = np.min(np.where(t > 0.0, self.axis_acc[None, :] / t, np.inf), axis=1)
        high = float(np.clip(per_point.max(), low, float(self.axis_acc.max())))
        return high, high

    def _direction_acc(self, ref: Reference) -> float:
        """Tangential acceleration of a new block: the largest a with |a·T_j| ≤ A_j at each of its
        reference points (seed 000, eq. (13)-(14), per block instead of for every direction), at
        least the machine's smallest A_j. On unequal axes a block along a fast axis accelerates
        as that axis can; the profile check lowers it where the centripetal part needs room."""
        t = np.abs(ref.tangent)
        with np.errstate(divide="ignore"):
            per_point = np.min(np.where(t > 0.0, self.axis_acc[None, :] / t, np.inf), axis=1)
        return float(max(self.acc, min(float(per_point.min()), float(self.axis_acc.max()))))

    def _piece(self, ref: Reference, parent: _WBlock) -> _WBlock:
        """A piece of ``parent`` (a split). On unequal axes (``per_direction``): a new block's
        accelerations (:meth:`_start_acc`), lowered by the parent's ceilings that lie inside it
        (a ceiling at the cut goes to both pieces), never below the parent's; on equal axes the
        parent's (seed 000)."""
        crawl = CRAWL * self.limits.feed_mm_s
        vmax = min(self.limits.feed_mm_s, max(float(ref.vlim.max()), crawl))
        if not self.per_direction:
            return _WBlock(ref, parent.acc, vmax, acc_down=parent.acc_down)
        s0, s1 = float(ref.s[0]), float(ref.s[-1])
        ceilings = tuple(c for c in parent.ceilings if s0 <= c[0] <= s1)
        up, down = self._start_acc(ref)
        up = min([up] + [c[1] for c in ceilings if c[2] != 1])
        down = min([down] + [c[1] for c in ceilings if c[2] != 0])
        return _WBlock(ref, max(up, parent.acc), vmax, acc_down=max(down, parent.acc_down), ceilings=ceilings)

    def _ahead_mm(self) -> float:
        """Look-ahead beyond the first block's end."""
        if not self.blocks:
            return 0.0
        return self.blocks[-1].s1 - self.blocks[0].s1
