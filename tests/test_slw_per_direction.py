"""The window's tangential acceleration per direction on a machine whose Y axis is slower (issue 38).

A block's rises and falls each run at the tangential acceleration of the direction they run in
(slw/window_blocks.py ``_start_acc``, slw/window_check.py lowering only the transition at fault),
not at the worst direction's: a straight X line and a straight Y line on the slow-Y machine each
take their own axis's closed-form rest-to-rest time (written out here, not read from profile.py),
and random curves on that machine keep every limit at every tick, measured from the positions.
"""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import slw_cases
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.slw import measure, schedule
from fuzzyfeed.slw.profile import block_segments, peak_speed
from test_slw_properties import TICK_RTOL, assert_keeps_limits

SLOW_Y = MachineLimits(axis_vel_mm_s=(100, 50, 100), axis_acc_mm_s2=(1000, 250, 1000))
EQUAL = MachineLimits()


def cosine_time(dv: float, acc: float, jerk: float) -> float:
    """Seed 000's cosine transition over Δv: T = max(πΔv/(2A), π√(Δv/(2J)))."""
    return max(math.pi * dv / (2 * acc), math.pi * math.sqrt(dv / (2 * jerk)))


def seven_phase_time(dv: float, acc: float, jerk: float) -> float:
    """The trapezoidal-acceleration ramp over Δv: Δv/A + A/J, or 2√(Δv/J) when A is not reached."""
    return dv / acc + acc / jerk if dv * jerk >= acc * acc else 2 * math.sqrt(dv / jerk)


def rest_to_rest(length: float, feed: float, acc: float, jerk: float, transition: str) -> float:
    """Rise 0 → F, cruise, fall F → 0 (the line is long enough to cruise): 2T + (L − F·T)/F."""
    t = (cosine_time if transition == "cosine" else seven_phase_time)(feed, acc, jerk)
    assert feed * t <= length  # both transitions cover F·T/2 each
    return 2 * t + (length - feed * t) / feed


@pytest.mark.parametrize("transition", ["cosine", "seven-phase"])
@pytest.mark.parametrize("axis", [0, 1])
def test_straight_line_runs_at_its_own_axis_acceleration(axis, transition):
    """80 mm along X: A_x = 1000, 100 mm/s; along Y: A_y = 250, 50 mm/s (the worst direction's
    250 mm/s² on the X line would take 0.41 s longer with the cosine)."""
    end = [0.0, 0.0]
    end[axis] = 80.0
    traj = schedule(slw_cases.polyline([[0.0, 0.0], end]), SLOW_Y, transition=transition, planner="window")
    feed, acc = SLOW_Y.axis_vel_mm_s[axis], SLOW_Y.axis_acc_mm_s2[axis]
    want = rest_to_rest(80.0, feed, acc, SLOW_Y.jerk_mm_s3, transition)
    assert abs(traj.cycle_time_s - want) <= 2 * SLOW_Y.ts_s, (traj.cycle_time_s, want)
    m = measure(traj)
    assert m["axis_acc"] <= 1 + TICK_RTOL
    if axis == 1:  # the Y line is acceleration-limited: it reaches A_y
        assert m["axis_acc"] >= 0.99
    # and an X line is not held to the slow axis's acceleration
    slow = rest_to_rest(80.0, feed, SLOW_Y.axis_acc_mm_s2[1], SLOW_Y.jerk_mm_s3, transition)
    assert axis == 1 or traj.cycle_time_s < slow - 0.05


def test_block_rises_and_falls_each_under_their_own_acceleration():
    """A block from rest to rest: the rise's duration is the closed form under the rise's
    acceleration, the fall's under the fall's, and the pieces cover the block exactly; the
    approach-2 peak of a short block spends the length on the two transitions."""
    jerk = 10000.0
    for shape, closed in (("cosine", cosine_time), ("seven-phase", seven_phase_time)):
        kind, segs = block_segments(50.0, 0.0, 0.0, 100.0, 1000.0, jerk, 2, shape, acc_down=250.0)
        assert kind == 1
        rise, cruise, fall = segs
        assert rise.duration_s == pytest.approx(closed(100.0, 1000.0, jerk), rel=1e-12)
        assert fall.duration_s == pytest.approx(closed(100.0, 250.0, jerk), rel=1e-12)
        assert sum(g.length_mm for g in segs) == pytest.approx(50.0, rel=1e-12)
        v_p = peak_speed(10.0, 5.0, 8.0, 100.0, 1000.0, jerk, shape, acc_down=250.0)
        d = (0.5 * (10.0 + v_p) * closed(v_p - 10.0, 1000.0, jerk)
             + 0.5 * (v_p + 5.0) * closed(v_p - 5.0, 250.0, jerk))
        assert d == pytest.approx(8.0, rel=1e-9)
        # and the default is seed 000's one acceleration
        assert block_segments(50.0, 0.0, 0.0, 100.0, 1000.0, jerk, 2, shape) == \
            block_segments(50.0, 0.0, 0.0, 100.0, 1000.0, jerk, 2, shape, acc_down=1000.0)


def assert_keeps_limits_on_slow_y(curve, transition):
    assert_keeps_limits(schedule(curve, SLOW_Y, transition=transition, planner="window"))


@settings(max_examples=8, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1), st.sampled_from(["cosine", "seven-phase"]))
def test_random_curves_on_the_slow_y_machine_keep_every_limit(seed, transition):
    assert_keeps_limits_on_slow_y(slw_cases.general_nurbs(np.random.default_rng(seed)), transition)


@pytest.mark.parametrize("seed", [12, 25, 88])  # bench_slw's worst slow-Y random curves
def test_bench_worst_slow_y_curves_keep_every_limit(seed):
    for transition in ("cosine", "seven-phase"):
        assert_keeps_limits_on_slow_y(slw_cases.random_nurbs(seed)[0], transition)
