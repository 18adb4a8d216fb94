"""A tick repair's schedule resumed from the previous pass's look-ahead state, not redone.

:func:`fuzzyfeed.slw.trajectory.schedule` lowers the feed cap over a few ticks around a breach and
schedules again (camotics flower_mold.nc#1: half of its 50 s). The window is deterministic: from
the same state, fed the same blocks and reading the same cap values, it makes the same decisions
and releases the same blocks. The new cap equals the old one, point for point, up to the last
point they share (``same_until``); the preprocessor's blocks before it are the same. So the pass
again equals the previous one until its window pulls the first block that differs (or reaches the
changed cap): it is resumed from the last state kept before that block (a copy of the window's
blocks, junctions and counters at the top of its loop, about every CHECKPOINT_WINDOWS windows of
path), with the previous pass's blocks released before that state. The result is the released
blocks of a whole new pass (tests/test_slw_resume.py compares the two).
"""

from __future__ import annotations

import copy
import hashlib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, replace
from itertools import chain

import numpy as np

from fuzzyfeed.slw.feed_cap import FeedCap
from fuzzyfeed.slw.preprocess import Block

#: A state is kept when the blocks pulled since the last one span this many window lengths.
CHECKPOINT_WINDOWS = 4.0


def block_print(block: Block) -> tuple:
    """What the window reads of a preprocessor block: its ends, caps and reference points (a
    digest of their bytes)."""
    ref = block.ref
    h = hashlib.blake2b(digest_size=16)
    for arr in (ref.s, ref.u, ref.vlim, ref.tangent, ref.kn):
        h.update(arr.tobytes())
    return (block.s0, block.s1, block.cap0, block.cap1, h.digest())


@dataclass(frozen=True)
class _State:
    """The window at the top of its loop: ``pulled`` blocks read, ``released`` blocks out."""

    pulled: int
    released: int
    s_pulled: float
    blocks: tuple
    juncs: tuple
    stats: object
    n_critical: int
    front_checks: int

    @staticmethod
    def of(window, pulled: int, s_pulled: float) -> _State:
        stats = window.stats
        return _State(pulled, stats.blocks_out, s_pulled, tuple(copy.copy(b) for b in window.blocks),
                      tuple(copy.copy(j) for j in window.juncs), replace(stats, critical_s=[]),
                      len(stats.critical_s), window._front_checks)

    def restore(self, window, critical_s: list[float]) -> None:
        window.blocks = [copy.copy(b) for b in self.blocks]
        window.juncs = [copy.copy(j) for j in self.juncs]
        window.stats = replace(self.stats, critical_s=critical_s[:self.n_critical])
        window._front_checks = self.front_checks


class Recorder:
    """The preprocessor's blocks for one window pass, with their prints, and the window's states
    (:meth:`keep`, the window's hook at the top of its loop)."""

    def __init__(self, source: Iterable[Block], prints: list | None = None, states: list | None = None):
        self.source = iter(source)
        self.prints = [] if prints is None else prints
        self.states = [] if states is None else states
        self.s_pulled = 0.0
        self.done = False

    def __iter__(self) -> Iterator[Block]:
        return self

    def __next__(self) -> Block:
        try:
            block = next(self.source)
        except StopIteration:
            self.done = True
            raise
        self.prints.append(block_print(block))
        self.s_pulled = block.s1
        return block

    def keep(self, window) -> None:
        """Keep the window's state when the blocks pulled since the last kept one span
        CHECKPOINT_WINDOWS window lengths (and always the first)."""
        if self.done:   # the window then plans to the path's end: not a state to resume from
            return
        if self.states and self.s_pulled - self.states[-1].s_pulled < CHECKPOINT_WINDOWS * window.window_mm:
            return
        self.states.append(_State.of(window, len(self.prints), self.s_pulled))


def same_until(old: FeedCap | None, new: FeedCap | None) -> float:
    """An arc length below which ``new`` gives every value ``old`` does, bit for bit: the last
    point of their common leading points (the same points and feeds, so the same interpolation
    below it), or, where ``old`` is flat after that point, the last of the new points that keep
    its value (c + w·(c − c) = c either way: a dip cut into a staircase's plateau); -inf if none."""
    if old is None or new is None or old.length_mm != new.length_mm:
        return -float("inf")
    (os_, of), (ns, nf) = _points(old), _points(new)
    n = min(os_.size, ns.size)
    same = (os_[:n] == ns[:n]) & (of[:n] == nf[:n])
    m = n if same.all() else int(same.argmin())
    if m < 1:
        return -float("inf")
    if m >= os_.size or of[m] != of[m - 1]:
        return float(os_[m - 1])
    c, end, k = of[m - 1], os_[m], m - 1
    while k + 1 < ns.size and nf[k + 1] == c and ns[k + 1] <= end:
        k += 1
    return float(ns[k])


def _points(cap: FeedCap) -> tuple:
    """The cap's points without a point repeated with the same feed (:func:`feed_cap.lower`
    drops those; the interpolation is the same without them: the intervals either side keep
    their ends and values)."""
    s, f = cap.s_mm, cap.feed_mm_s
    keep = np.ones(s.size, dtype=bool)
    keep[1:] = (s[1:] != s[:-1]) | (f[1:] != f[:-1])
    return s[keep], f[keep]


def resume(previous: Recorder, released: list, critical_s: list[float], old_cap: FeedCap | None,
           new_cap: FeedCap | None, window, source: Iterable[Block], total: float):
    """Set up ``window`` (new, on ``new_cap``) to continue as a whole pass over ``source`` (the
    preprocessor's blocks under ``new_cap``) would from the latest state of ``previous`` before
    the first block that differs. Returns (the new pass's Recorder to run ``window`` on, the
    blocks released before that state); ``released`` and ``critical_s`` are the previous pass's."""
    limit = same_until(old_cap, new_cap) - 1e-6 * max(total, 1.0)
    it = iter(source)
    states = previous.states   # in the order kept: by blocks pulled
    at = 0                     # the latest state whose pulled blocks are all the same
    head: list[Block] = []     # the new pass's blocks from states[at].pulled on
    same = 0                   # leading blocks the same as the previous pass's, before the changed cap
    for block in it:
        head.append(block)
        if same >= len(previous.prints) or block.s1 >= limit or block_print(block) != previous.prints[same]:
            break
        same += 1
        while at + 1 < len(states) and states[at + 1].pulled <= same:
            del head[:states[at + 1].pulled - states[at].pulled]
            at += 1
    state = states[at]
    state.restore(window, critical_s)
    rec = Recorder(chain(head, it), previous.prints[:state.pulled], states[:at + 1])
    rec.s_pulled = state.s_pulled
    return rec, list(released[:state.released])
