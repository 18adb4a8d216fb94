"""Transitions between states that carry an acceleration, (v0, a0) → (v1, a1) (slw/acc_profile.py),
held to a numerical integration of their own jerk, to the zero-acceleration transitions of
slw/profile.py, and to a brute-force search for the seven-phase's shortest time."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzyfeed.slw.acc_profile import (AccSegment, acc_transition, acc_transition_distance, acc_transition_time,
                                       speed_range, stop_distance_from)
from fuzzyfeed.slw.profile import (COSINE, SEVEN_PHASE, segment_state, stop_distance, transition_distance,
                                   transition_time)

A, J = 1000.0, 10_000.0
SHAPES = (SEVEN_PHASE, COSINE)


def _integrate_jerk(seg: AccSegment, n: int = 20_000):
    """v, a, s on a grid through the transition by integrating its jerk (segment_state's j only,
    at the cells' midpoints; the phase ends are grid points, so a constant jerk is integrated
    exactly), then a and v by the trapezoid rule: independent of the closed forms."""
    ends = np.cumsum([0.0, seg.t1, seg.t2, seg.t3])
    tau = np.unique(np.concatenate([np.linspace(ends[k], ends[k + 1], 400 + int(n * (ends[k + 1] - ends[k])
                                                                                / seg.duration_s))
                                    for k in range(3) if ends[k + 1] > ends[k]]))
    dt = np.diff(tau)
    _, _, _, j = segment_state(seg, 0.5 * (tau[1:] + tau[:-1]))
    a = seg.a0 + np.concatenate([[0.0], np.cumsum(j * dt)])
    v = seg.v0 + np.concatenate([[0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * dt)])
    s = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
    return tau, v, a, s, np.abs(j).max()


@settings(deadline=None, max_examples=300)
@given(st.sampled_from(SHAPES), st.floats(0, 150), st.floats(-1, 1), st.floats(0, 150), st.floats(-1, 1),
       st.floats(100, 5000), st.floats(1000, 1e5))
def test_transition_ends_where_its_integrated_jerk_says(shape, v0, r0, v1, r1, acc, jerk):
    seg = acc_transition(v0, r0 * acc, v1, r1 * acc, acc, jerk, shape)
    if seg.duration_s == 0.0:
        assert v1 == pytest.approx(v0, abs=1e-9) and r1 * acc == pytest.approx(r0 * acc, abs=1e-9)
        return
    tau, v, a, s, j_max = _integrate_jerk(seg)
    scale_v = max(abs(v0), abs(v1), acc * seg.duration_s, 1.0)
    assert v[-1] == pytest.approx(v1, abs=1e-6 * scale_v)
    assert a[-1] == pytest.approx(r1 * acc, abs=1e-6 * acc)
    assert s[-1] == pytest.approx(seg.length_mm, abs=1e-6 * scale_v * seg.duration_s)
    # the bounds: jerk at most J, acceleration at most A, on the whole transition
    assert j_max <= jerk * (1 + 1e-9)
    assert np.abs(a).max() <= acc * (1 + 1e-6)
    # the closed-form state agrees with the integration everywhere
    s_c, v_c, a_c, _ = segment_state(seg, tau)
    assert np.allclose(v_c, v, atol=1e-6 * scale_v) and np.allclose(a_c, a, atol=1e-6 * acc)
    assert np.allclose(s_c, s, atol=1e-6 * scale_v * seg.duration_s)
    lo, hi = speed_range(seg)
    assert lo <= v.min() + 1e-6 * scale_v and hi >= v.max() - 1e-6 * scale_v
    assert acc_transition_time(v0, r0 * acc, v1, r1 * acc, acc, jerk, shape) == seg.duration_s
    assert acc_transition_distance(v0, r0 * acc, v1, r1 * acc, acc, jerk, shape) == seg.length_mm


@given(st.sampled_from(SHAPES), st.floats(0, 300), st.floats(0, 300), st.floats(50, 5000), st.floats(500, 1e5))
def test_zero_boundary_accelerations_give_the_zero_acceleration_transition(shape, v0, v1, acc, jerk):
    seg = acc_transition(v0, 0.0, v1, 0.0, acc, jerk, shape)
    if shape == SEVEN_PHASE or math.pi * math.sqrt(abs(v1 - v0) / (2 * jerk)) >= math.pi * abs(v1 - v0) / (2 * acc):
        # the seven-phase ramp always; seed 000's cosine where it is jerk-bound (eq. (20))
        assert seg.duration_s == pytest.approx(transition_time(v0, v1, acc, jerk, shape), rel=1e-9, abs=1e-15)
        assert seg.length_mm == pytest.approx(transition_distance(v0, v1, acc, jerk, shape), rel=1e-9, abs=1e-12)
    else:  # acceleration-bound cosine: holds A between its ramps instead of stretching the sine
        assert seg.duration_s <= transition_time(v0, v1, acc, jerk, shape) * (1 + 1e-12)


def _brute_force_time(v0, a0, v1, a1, acc, jerk, n=4001):
    """Shortest ramp-hold-ramp at constant jerk over a grid of peak accelerations a_p in [−A, A]:
    ramps a0 → a_p, a_p → a1 (feed change (a² differences)/2J), a hold at a_p for the rest."""
    best = math.inf
    for a_p in np.concatenate([np.linspace(-acc, acc, n), [a0, a1]]):
        ramps = (abs(a_p - a0) + abs(a_p - a1)) / jerk
        dv_r = 0.5 * (a0 + a_p) * abs(a_p - a0) / jerk + 0.5 * (a_p + a1) * abs(a_p - a1) / jerk
        rest = (v1 - v0) - dv_r
        if a_p == 0.0:
            if rest == 0.0:
                best = min(best, ramps)
            continue
        hold = rest / a_p
        if hold >= -1e-15:
            best = min(best, ramps + max(hold, 0.0))
    return best


@settings(deadline=None, max_examples=60)
@given(*[st.integers(0, 15_000).map(lambda k: k / 100.0), st.integers(-1000, 1000).map(lambda k: k / 1000.0)] * 2)
def test_seven_phase_is_the_shortest_ramp_hold_ramp(v0, r0, v1, r1):
    t = acc_transition_time(v0, r0 * A, v1, r1 * A, A, J, SEVEN_PHASE)
    # the grid's step (A/2000) costs at most ~2 steps of ramp time (2·(A/2000)/J) against the optimum
    best = _brute_force_time(v0, r0 * A, v1, r1 * A, A, J)
    assert t <= best + 1e-9
    if math.isfinite(best):  # (a grid may miss every exact balance of a tiny change)
        assert t >= best - 4 * A / 2000 / J


@pytest.mark.parametrize("shape", SHAPES)
def test_stop_distance_from_a_state(shape):
    # at zero acceleration: seed 000's eq. (22) (jerk-bound cosine, the seven-phase always)
    assert stop_distance_from(10.0, 0.0, A, J, shape) == pytest.approx(stop_distance(10.0, A, J, shape))
    # accelerating costs distance, decelerating saves it
    assert stop_distance_from(10.0, 300.0, A, J, shape) > stop_distance_from(10.0, 0.0, A, J, shape)
    assert stop_distance_from(10.0, -300.0, A, J, shape) < stop_distance_from(10.0, 0.0, A, J, shape)
    # a deceleration too strong to undo before the feed reaches zero: no stop keeps the feed ≥ 0
    assert stop_distance_from(1.0, -A, A, J, shape) == math.inf


def test_bad_states_are_refused():
    with pytest.raises(ValueError, match="over acc"):
        acc_transition(0.0, 1.5 * A, 10.0, 0.0, A, J)
    with pytest.raises(ValueError, match="finite"):
        acc_transition(math.nan, 0.0, 10.0, 0.0, A, J)
    with pytest.raises(ValueError, match="transition"):
        acc_transition(0.0, 0.0, 10.0, 0.0, A, J, "trapezoid")
    with pytest.raises(ValueError, match="≥ 0"):
        AccSegment(0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0)


@pytest.mark.parametrize("shape", SHAPES)
def test_ticks_through_a_junction_that_keeps_its_acceleration(shape):
    """The interpolator's per-tick sampling (trajectory._sample_profile) takes transitions with a
    junction acceleration as they are: a rise 0 → 50 mm/s ending at 400 mm/s², one going on from
    there to 100 mm/s, a cruise and a stop; ticks continuous in a (jerk ≤ J) and ending at the length."""
    from fuzzyfeed.slw.profile import Segment, transition_time
    from fuzzyfeed.slw.trajectory import _sample_profile
    from fuzzyfeed.slw.window_blocks import ScheduledBlock

    ts = 1e-3
    first = acc_transition(0.0, 0.0, 50.0, 400.0, A, J, shape)
    second = acc_transition(50.0, 400.0, 100.0, 0.0, A, J, shape)
    stop = Segment(100.0, 0.0, transition_time(100.0, 0.0, A, J, shape), J if shape == SEVEN_PHASE else None)
    segs = (first, second, Segment(100.0, 100.0, 0.1), stop)
    total = sum(g.length_mm for g in segs)
    blocks = [ScheduledBlock(0.0, first.length_mm, 0.0, 50.0, 2, segs[:1], A, True),
              ScheduledBlock(first.length_mm, total, 50.0, 0.0, 1, segs[1:], A, True)]
    t, s, v, a, j = _sample_profile(blocks, ts, total)
    assert s[-1] == pytest.approx(total) and v[-1] == 0.0
    assert np.abs(np.diff(a)).max() <= J * ts * (1 + 1e-9)
    assert np.abs(a).max() <= A * (1 + 1e-9) and np.abs(j).max() <= J * (1 + 1e-9)
    # at the junction's tick the acceleration is the kept one, not zero
    k = int(np.argmin(np.abs(t - first.duration_s)))
    assert a[k] == pytest.approx(400.0, abs=J * ts)
    # positions agree with the feed integrated over the ticks (trapezoid, second order in Ts)
    assert np.allclose(s, np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * ts)]), atol=1e-3)
