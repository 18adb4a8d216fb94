"""The look-ahead check skips a block by its ``clean`` flag (issue 38, chk9): the flag must be set
only while the block's last checked key is its current key (its end junctions' feeds, acc,
acc_down, vmax, length), so the window checks the same blocks as when it compared every key.

Checked two ways on random polylines and NURBS, equal and unequal axes, both transitions: at every
check of the window no clean block has a key other than its checked one (the invariant, read
from the blocks themselves), and the schedule is bit for bit the one of the whole-key comparison
(``FAST_SKIP = False``, main's test)."""

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import slw_cases
import fuzzyfeed.slw.window_check as window_check
from fuzzyfeed.slw import schedule
from fuzzyfeed.slw.lookahead import SlidingWindow

SETTINGS = settings(max_examples=30, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
TICK_ARRAYS = ("t_s", "s_mm", "u", "xyz", "feed_mm_s", "acc_mm_s2", "jerk_mm_s3")


def _case(seed: int, kind: str, equal: bool):
    rng = np.random.default_rng(seed)
    if kind == "polyline":
        curve, lim = slw_cases.corner_polyline(rng), slw_cases.ratio_machine(rng)
    else:
        curve, lim = slw_cases.random_nurbs(seed)
    if equal:
        lim = replace(lim, axis_acc_mm_s2=(min(lim.axis_acc_mm_s2),) * len(lim.axis_acc_mm_s2))
    return curve, lim


def _stale_clean_blocks(window) -> list[int]:
    """Blocks of the window flagged clean whose current key is not their checked one."""
    return [i for i, b in enumerate(window.blocks) if b.clean and not window._checked_at_key(i)]


def _watch(monkeypatch) -> list[int]:
    """Record every stale clean block the window holds when a check starts."""
    stale: list[int] = []
    original = SlidingWindow._check_all

    def checked(self, indices):
        stale.extend(_stale_clean_blocks(self))
        return original(self, indices)

    monkeypatch.setattr(SlidingWindow, "_check_all", checked)
    return stale


def _schedules_agree(monkeypatch, curve, lim, transition):
    stale = _watch(monkeypatch)
    fast = schedule(curve, lim, transition=transition, planner="window")
    assert stale == []
    monkeypatch.setattr(window_check, "FAST_SKIP", False)
    slow = schedule(curve, lim, transition=transition, planner="window")
    for name in TICK_ARRAYS:
        assert np.array_equal(getattr(fast, name), getattr(slow, name)), name
    assert fast.blocks == slow.blocks and fast.stats == slow.stats


@SETTINGS
@given(st.integers(0, 2**32 - 1), st.sampled_from(["polyline", "nurbs"]), st.booleans(),
       st.sampled_from(["cosine", "seven-phase"]))
def test_the_clean_flag_skips_only_blocks_checked_at_their_key(monkeypatch, seed, kind, equal, transition):
    curve, lim = _case(seed, kind, equal)
    with monkeypatch.context() as m:
        _schedules_agree(m, curve, lim, transition)


def test_a_missed_feed_change_is_caught(monkeypatch):
    """The invariant's reader can fail: junction feeds set without clearing the flags leave clean
    blocks whose end feeds moved (a repair re-plans the window)."""
    def unflagged(self, feeds):
        for j, v in zip(self.juncs, feeds):
            j.v = v

    monkeypatch.setattr(SlidingWindow, "_set_feeds", unflagged)
    stale = _watch(monkeypatch)
    curve, lim = slw_cases.random_nurbs(1)  # 120 stale clean blocks so
    schedule(curve, lim, transition="cosine", planner="window")
    assert stale


@pytest.mark.parametrize("name", ["zigzag", "rectangle"])
def test_cam_shapes_agree(monkeypatch, name):
    lim = slw_cases.random_limits(np.random.default_rng(7))
    _schedules_agree(monkeypatch, getattr(slw_cases, name)(), lim, "cosine")

