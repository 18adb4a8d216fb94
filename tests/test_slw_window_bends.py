"""The look-ahead window's junctions at bends and at the path's start (issue 38).

Inside a block the feed is held below the centripetal limit √(A_j/|κN_j|) only by the axis check
|a_t·T_j + v²·κN_j| ≤ A_j (a junction, at zero tangential acceleration, keeps the full limit), so a
fall whose tangential part opposes the centripetal one passes a bend faster than a zero
acceleration allows; the path's first critical point is no junction when a rise from rest reaches
less than half its limit within the first block; a feed crossing that starts in a cruise gets its
junction where the fall's limit is lowest, not at the cruise's end capped at that lowest limit.
The limits are computed here from the machine module (eq. (8)-(12)) and the ticks measured from the
positions; approach 1 keeps the paper's window.
"""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import slw_cases
from fuzzyfeed.geometry.sampling import samples_at
from fuzzyfeed.machine.limits import MachineLimits, feed_limit_components, feed_limits
from fuzzyfeed.slw import schedule
from test_slw_properties import assert_keeps_limits

SLOW_Y = MachineLimits(axis_vel_mm_s=(100, 50, 100), axis_acc_mm_s2=(1000, 250, 1000))
EQUAL = MachineLimits()


def junction_share(traj, limits):
    """Each interior junction's feed over the pointwise feed limit at its place."""
    ends = np.array([b.s1 for b in traj.blocks[:-1]])
    feeds = np.array([b.v_end for b in traj.blocks[:-1]])
    lim = feed_limits(samples_at(traj.curve, traj.curve.param_at_length(ends), s=ends), limits)
    return feeds / lim


def test_a_fall_passes_a_bend_faster_than_a_zero_acceleration_allows():
    # nurbs88 on the slow-Y machine: the acceleration-limited bound passes the bend at s ≈ 24 mm
    # at ~53 mm/s braking against Y's centripetal part, where a zero acceleration allows 38 mm/s;
    # the window held every sample below 38 (main: at most 0.993 of it)
    traj = schedule(slw_cases.random_nurbs(88)[0], SLOW_Y, transition="seven-phase", planner="window")
    cen = feed_limit_components(samples_at(traj.curve, traj.u, s=traj.s_mm), SLOW_Y)[3]
    assert (traj.feed_mm_s / np.maximum(cen, 1e-9)).max() > 1.02
    assert_keeps_limits(traj)


@pytest.mark.parametrize("transition", ["cosine", "seven-phase"])
def test_the_first_junction_is_one_a_rise_from_rest_reaches(transition):
    # main: the path's first critical point (0.59 mm, limit 48.7 mm/s) was a junction at zero
    # acceleration reached at 14-15 mm/s (0.29-0.31 of its limit), the start's rise cut there
    traj = schedule(slw_cases.random_nurbs(88)[0], SLOW_Y, transition=transition, planner="window")
    assert junction_share(traj, SLOW_Y)[0] >= 0.5
    assert_keeps_limits(traj)
    # the paper's window (approach 1) keeps that junction
    paper = schedule(slw_cases.random_nurbs(88)[0], SLOW_Y, transition=transition, approach=1, planner="window")
    assert paper.blocks[0].s1 < 1.0 and junction_share(paper, SLOW_Y)[0] < 0.5


@pytest.mark.parametrize("seed, transition", [(25, "cosine"), (88, "cosine"), (88, "seven-phase")])
def test_every_junction_is_at_least_half_its_limit(seed, transition):
    # main, nurbs25 cosine: a crossing that started at a cruise's end got its junction there at
    # 0.97 x the fall's lowest limit (0.39 of the limit there; nurbs88: the first junction at
    # 0.29-0.31); now ≥ 0.66. (nurbs25 seven-phase keeps main's 0.35: its crossing's lowest limit
    # is at the crossing's end, where the junction is not moved — a chain of splits towards a
    # block's end, nurbs98 slow-Y)
    traj = schedule(slw_cases.random_nurbs(seed)[0], SLOW_Y, transition=transition, planner="window")
    assert junction_share(traj, SLOW_Y).min() >= 0.5
    assert_keeps_limits(traj)


@settings(max_examples=6, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1), st.sampled_from(["cosine", "seven-phase"]),
       st.sampled_from(["equal", "slow-y"]))
def test_random_curves_keep_every_limit_with_the_lifted_feed_limit(seed, transition, machine):
    limits = EQUAL if machine == "equal" else SLOW_Y
    curve = slw_cases.general_nurbs(np.random.default_rng(seed))
    assert_keeps_limits(schedule(curve, limits, transition=transition, planner="window"))


def test_a_limit_falling_a_little_under_a_blocks_top_adds_no_junctions():
    """nurbs5 slow-Y: its last 12 mm run along Y at a limit falling from 50.09 to 50.00 mm/s (the
    axis velocity). A split 3 % under the limit at each crossing made a sawtooth of junctions
    (10 between s = 87 and 98.5 mm, each a zero acceleration at 48.5 mm/s, 1.949 s in all);
    lowering the block's top to the limit instead leaves 3 there (before it took over), and every
    limit."""
    curve = slw_cases.random_nurbs(5)[0]
    traj = schedule(curve, SLOW_Y, transition="seven-phase", planner="window")
    assert_keeps_limits(traj)
    inside = traj.critical_s_mm[(traj.critical_s_mm > 87.0) & (traj.critical_s_mm < 98.4)]
    assert inside.size <= 3, inside
    assert traj.cycle_time_s < 1.9


@settings(max_examples=40, deadline=None, derandomize=True)
@given(st.integers(0, 2**32 - 1), st.sampled_from([1.0, -1.0]))
def test_stretch_acc_is_the_largest_acceleration_every_axis_allows(seed, sign):
    # independent: the largest α on a fine grid of [0, max A_j] with |sign·α·T_j + c_j| ≤ A_j on
    # every axis (the allowed set of each axis is an interval in α, so the grid's last good α is
    # within one step of the closed form)
    from fuzzyfeed.slw.window_check import stretch_acc

    rng = np.random.default_rng(seed)
    acc = np.array([1000.0, 250.0, 1000.0])
    tan = rng.normal(size=(8, 3))
    tan /= np.linalg.norm(tan, axis=1, keepdims=True)
    cen = rng.uniform(-1.0, 1.0, size=(8, 3)) * acc[None, :] * rng.uniform(0.0, 1.0, size=(8, 1))
    got = stretch_acc(sign, tan, cen, acc)
    grid = np.linspace(0.0, acc.max(), 200_001)
    for k in range(8):
        ok = np.all(np.abs(sign * grid[:, None] * tan[k][None, :] + cen[k][None, :]) <= acc[None, :], axis=1)
        want = grid[ok].max()
        assert abs(got[k] - want) <= acc.max() / 200_000 + 1e-9, (k, got[k], want)


def test_a_fall_keeps_the_acceleration_its_stretch_allows():
    """nurbs41 slow-Y seven-phase: a 27 mm block whose 17 mm fall (97.5 -> 13.7 mm/s) ran at
    287 mm/s² for one point near its end, where the rest of the fall allows up to 742 (main:
    1.992 s); a junction at that point lets the fall before it keep ≥ 400 mm/s²."""
    traj = schedule(slw_cases.random_nurbs(41)[0], SLOW_Y, transition="seven-phase", planner="window")
    falls = [(b.s1 - b.s0, b.acc_down_mm_s2) for b in traj.blocks
             if b.s0 < 50.0 < b.s1 and b.v_start > b.v_end]
    assert falls and falls[0][1] >= 400.0, falls
    assert traj.cycle_time_s < 1.98
    assert_keeps_limits(traj)
