"""floor_errors (issue 36 item 3) against the whole-array tick reference at the floor factor, and
the two kinds of place it tells apart: a feed move entered from rapids (the error stays) and a
corner between feed moves (the error goes with the feed)."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzyfeed.errors import InputError
from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.machine.floor_error import floor_errors
from fuzzyfeed.machine.planner import Motion
from fuzzyfeed.machine.stream import WARMUP_TIME_CONSTANTS
from fuzzyfeed.machine.trace import trace_motion

# _from_curve's line 89 in small: retract by rapid, a short rapid across, a plunge from above the
# stock at F 500 mm/min, then a cut; and a fast 90-degree corner between two feed moves
POINTS = np.array([[0, 0, -2.0], [0, 0, 10.0], [-0.12, -0.54, 10.0], [-0.12, -0.54, -0.2],
                   [5.0, -0.54, -0.2], [5.0, 5.0, -0.2]])
RAPID = np.array([True, True, False, False, False])
FEED = np.array([np.nan, np.nan, 8.3312, 80.0, 80.0])


def _motion(scale: float = 1.0) -> Motion:
    return Motion(POINTS, np.where(RAPID, FEED, FEED * scale), RAPID, np.full(POINTS.shape[0], np.nan))


def _reference(scale: float, seg: int) -> float:
    """Largest error in the part on ``seg`` over its first WARMUP_TIME_CONSTANTS time constants,
    from every tick of the whole run (trace_motion)."""
    machine = load_machine("reference")
    tr = trace_motion(_motion(scale), machine, ~RAPID)
    t0 = tr.plan.t_start[seg]
    span = WARMUP_TIME_CONSTANTS * machine.servo.time_constant_s
    pick = (tr.tick_segment == seg) & (tr.tick_time_s <= t0 + span + machine.ts_s)
    return float(tr.contour_mm[pick].max(initial=0.0))


def test_floor_errors_equal_the_tick_reference():
    machine = load_machine("reference")
    got = floor_errors(_motion(), ~RAPID, machine, np.array([2, 4]))
    for seg, value in zip((2, 4), got):
        assert value == pytest.approx(_reference(0.01, seg), abs=1e-3 * 1e-3)


def test_a_rapid_entry_keeps_its_error_a_feed_corner_loses_it():
    machine = load_machine("reference")
    tol = machine.contour_tol_um * 1e-3
    at_one = floor_errors(_motion(), ~RAPID, machine, np.array([2, 4]), floor=1.0)
    at_floor = floor_errors(_motion(), ~RAPID, machine, np.array([2, 4]))
    assert at_one[0] > tol and at_floor[0] > tol            # the plunge after rapids: no factor fixes it
    assert at_floor[0] > 0.5 * at_one[0]
    assert at_one[1] > tol and at_floor[1] < min(tol, 0.1 * at_one[1])   # the feed corner: the factor does


def test_floor_is_checked():
    with pytest.raises(InputError, match="floor = 0"):
        floor_errors(_motion(), ~RAPID, load_machine("reference"), np.array([2]), floor=0.0)


def test_the_floor_is_of_the_feed_the_machine_can_run():
    # an F far above the axes' speed (F1e6: "as fast as the machine goes") runs at that speed: its
    # floor is 1 % of it, where the plunge's lag still shows and the corner's error is gone
    machine = load_machine("reference")
    fast = Motion(POINTS, np.where(RAPID, FEED, 1e6 / 60.0), RAPID, np.full(POINTS.shape[0], np.nan))
    reach = np.minimum(fast.feed_mm_s, machine.speed_along(POINTS))
    slow = Motion(POINTS, np.where(RAPID, FEED, reach), RAPID, np.full(POINTS.shape[0], np.nan))
    got = floor_errors(fast, ~RAPID, machine, np.array([2, 4]))
    assert np.array_equal(got, floor_errors(slow, ~RAPID, machine, np.array([2, 4])))
    assert got[1] < machine.contour_tol_um * 1e-3 < got[0]


def _floor_errors_whole_plan(motion, measured, machine, segments, floor=0.01):
    """floor_errors as main db75ac7 made it: the whole chain planned, its windows run."""
    from fuzzyfeed.machine.planner import plan_motion
    from fuzzyfeed.machine.stream import stream_plan, tick_count, warmup_ticks

    seg = np.unique(np.asarray(segments, dtype=np.int64))
    reachable = np.minimum(motion.feed_mm_s, machine.speed_along(motion.points))
    scaled = Motion(motion.points, np.where(motion.rapid, motion.feed_mm_s, reachable * floor), motion.rapid,
                    motion.arc_radius_mm)
    plan = plan_motion(scaled, machine)
    ts = machine.ts_s
    k_end = tick_count(plan, ts)
    span = int(np.ceil(WARMUP_TIME_CONSTANTS * machine.servo.time_constant_s / ts))
    ka = np.clip(np.floor(plan.t_start[seg] / ts).astype(np.int64), 0, k_end)
    kb = np.minimum(np.clip(np.ceil(plan.t_start[seg + 1] / ts).astype(np.int64), 0, k_end), ka + span)
    windows = []
    for a, b in zip(ka.tolist(), kb.tolist()):
        if windows and a - warmup_ticks(machine) <= windows[-1][1]:
            windows[-1] = (windows[-1][0], max(windows[-1][1], b))
        else:
            windows.append((a, b))
    run = stream_plan(plan, machine, measured, keep_mm=np.inf, windows=windows, fast=False)
    return run.seg_max_mm[np.asarray(segments, dtype=np.int64)]


@pytest.mark.parametrize("size", [3, 50, 4096])
def test_floor_errors_planned_in_windows_are_the_whole_plans(size):
    # the plan made window by window (plan_parts): the same floats as the whole chain's plan, on
    # the raster of test_plan_parts with rapid entries and on the small case, segments unsorted
    import sys
    from pathlib import Path

    from fuzzyfeed.program.read import parse_program
    from fuzzyfeed.program.run import program_path

    sys.path.insert(0, str(Path(__file__).parent))
    from test_chain_pass import _banded_raster

    machine = load_machine("reference")
    chain = max(program_path(parse_program(_banded_raster()), machine.chord_tol_mm).chains,
                key=lambda c: c.motion.n_segments)
    n = chain.motion.n_segments
    entries = np.flatnonzero(~chain.seg_measured[:-1] & chain.seg_measured[1:]) + 1
    segs = np.concatenate([entries, np.random.default_rng(size).choice(n, 12, replace=False), entries[:1]])
    got = floor_errors(chain.motion, chain.seg_measured, machine, segs, size=size)
    want = _floor_errors_whole_plan(chain.motion, chain.seg_measured, machine, segs)
    assert got.tobytes() == want.tobytes() and got.max() > 0
    small = floor_errors(_motion(), ~RAPID, machine, np.array([4, 2]), size=min(size, 2))
    assert small.tobytes() == _floor_errors_whole_plan(_motion(), ~RAPID, machine, np.array([4, 2])).tobytes()
