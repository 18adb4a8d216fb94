"""The corner-chain term of the jerk-limited floor (fuzzyfeed.slw.floor): an upper bound on the
distance any jerk-limited motion covers, checked against motions integrated exactly, and a
lower bound on time checked against the seven-phase rest-to-rest profile (a feasible motion) and
against the schedules themselves."""

import numpy as np
import pytest

import slw_cases
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.slw import schedule
from fuzzyfeed.slw import floor as fl


def random_motion(rng, acc, jerk, steps=400, with_accelerations=False):
    """A motion with |a| ≤ A, |j| ≤ J (piecewise constant jerk, integrated exactly), mostly
    bang-bang: (T, v(0), v(T), distance, max feed[, a(0), a(T), least feed])."""
    dt = rng.uniform(1e-4, 2e-3)
    a, v, s, vmax = rng.uniform(-acc, acc), rng.uniform(0.0, 50.0), 0.0, 0.0
    v0, a_start, vmin = v, a, v
    sign = rng.choice([-1.0, 1.0])
    for _ in range(steps):
        if rng.random() < 0.03:
            sign = -sign
        j = sign * jerk if rng.random() < 0.9 else rng.uniform(-jerk, jerk)
        j = float(np.clip(j, (-acc - a) / dt, (acc - a) / dt))
        s += v * dt + a * dt * dt / 2.0 + j * dt ** 3 / 6.0
        v += a * dt + j * dt * dt / 2.0
        a += j * dt
        vmax = max(vmax, v + acc * dt)
        vmin = min(vmin, v - acc * dt)
    if with_accelerations:
        return steps * dt, v0, v, s, vmax, a_start, a, vmin
    return steps * dt, v0, v, s, vmax


@pytest.mark.parametrize("seed", range(4))
def test_no_motion_covers_more_than_the_bound(seed):
    rng = np.random.default_rng(seed)
    acc, jerk = rng.uniform(200.0, 2000.0), rng.uniform(2e3, 1e5)
    rows = [random_motion(rng, acc, jerk) for _ in range(150)]
    T, v0, v1, dist, vmax = (np.array(c) for c in zip(*rows))
    feed = float(vmax.max())
    bound = fl.max_distance(T, v0, v1, feed, acc, jerk)
    assert (dist <= bound * (1 + 1e-9) + 1e-12).all(), np.max(dist / bound)
    # and the bound is near the best of them where they are bang-bang (it can fail: not slack)
    assert np.max(dist / bound) > 0.8


def test_closed_form_crossing_equals_bisection():
    rng = np.random.default_rng(7)
    n, feed, acc, jerk = 5000, 60.0, 900.0, 2e4
    T = rng.uniform(1e-3, 0.6, n)
    c1, c2 = rng.uniform(0, feed, n) * (rng.random(n) < 0.8), rng.uniform(0, feed, n)
    a = fl.max_distance(T, c1, c2, feed, acc, jerk)
    b = fl._max_distance_bisect(T, c1, c2, feed, acc, jerk)
    assert np.allclose(a, b, rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("gap", [0.05, 0.4, 3.0, 40.0])
def test_gap_time_below_seven_phase_rest_to_rest(gap):
    """Rest to rest the seven-phase profile is feasible (and optimal with zero end accelerations):
    the bound may not exceed it, and the relaxation of free end accelerations costs little."""
    feed, acc, jerk = 100.0, 1000.0, 1e4
    exact = fl.rest_to_rest_s(gap, feed, acc, jerk)
    got = float(fl.gap_times(np.array([gap]), np.zeros(1), np.zeros(1), feed, acc, jerk)[0])
    assert got <= exact
    # free end accelerations let a gap start already accelerating: 0.69-0.83 of it (a relaxation)
    assert got >= 0.65 * exact


@pytest.mark.parametrize("seed", [3, 5, 8])
def test_floor_stays_below_the_schedule(seed):
    """Every schedule keeps its limits, so none may beat the floor (it would not be one)."""
    curve = slw_cases.corner_polyline(np.random.default_rng(seed))
    for lim in (MachineLimits(), MachineLimits(axis_vel_mm_s=(100, 50, 100), axis_acc_mm_s2=(1000, 250, 1000))):
        traj = schedule(curve, lim, transition="seven-phase")
        chain = fl.corner_chain_s(traj.curve, lim)
        assert 0.0 < chain <= traj.cycle_time_s
        assert fl.jerk_floor(traj.curve, lim) <= traj.cycle_time_s


def test_gap_acceleration_is_each_direction_own():
    """Along a straight leg the tangential acceleration is the axes' own (s̈ = a·T): a leg along Y
    of a slow-Y machine gets A_y, a diagonal one A_x|T_x| + A_y|T_y|, a curve at most ‖A‖₂."""
    lim = MachineLimits(axis_vel_mm_s=(100, 50, 100), axis_acc_mm_s2=(1000, 250, 1000))
    along_y = slw_cases.polyline(np.array([[0.0, 0.0], [0.0, 30.0]]))
    assert np.allclose(fl.gap_accelerations(along_y, lim, np.array([0.0, 30.0])), [250.0])
    diagonal = slw_cases.polyline(np.array([[0.0, 0.0], [30.0, 40.0]]))
    got = fl.gap_accelerations(diagonal, lim, np.array([0.0, 20.0, 50.0]))
    assert np.allclose(got, 1000.0 * 0.6 + 250.0 * 0.8)
    # an L: the gap that holds the corner sees both legs, each gap alone its own leg
    ell = slw_cases.polyline(np.array([[0.0, 0.0], [20.0, 0.0], [20.0, 20.0]]))
    from fuzzyfeed.slw.preprocess import corners

    corner = corners(ell, lim)[0]  # the chain cuts at the corner's own arc length
    got = fl.gap_accelerations(ell, lim, np.array([0.0, corner[0], ell.length]))
    assert np.allclose(got, [1000.0, 250.0], rtol=1e-6), got
    assert got[0] <= 1000.0 * (1 + 1e-6) and got.max() <= np.linalg.norm([1000, 250]) * (1 + 1e-9)


def test_slow_axis_leg_floor_is_its_rest_to_rest():
    """A leg along Y alone: the chain's floor is the jerk-limited rest-to-rest time under A_y
    (free end accelerations only relax it), so no more than that time, and above what ‖A‖₂ gives."""
    lim = MachineLimits(axis_vel_mm_s=(100, 50, 100), axis_acc_mm_s2=(1000, 250, 1000))
    leg = slw_cases.polyline(np.array([[0.0, 0.0], [0.0, 5.0], [3.0, 5.0]]))
    s = np.array([0.0, 5.0])
    own = float(fl.gap_times(np.array([5.0]), np.zeros(1), np.zeros(1), 50.0,
                             fl.gap_accelerations(leg, lim, s), lim.jerk_mm_s3)[0])
    loose = float(fl.gap_times(np.array([5.0]), np.zeros(1), np.zeros(1), 50.0,
                               np.linalg.norm([1000, 250]), lim.jerk_mm_s3)[0])
    assert loose < own <= fl.rest_to_rest_s(5.0, 50.0, 250.0, lim.jerk_mm_s3)


def test_reach_is_the_capped_tent_integral():
    """_reach against the integral summed on a fine grid, and A-Lipschitz in t (the tent rule
    of the integration needs it)."""
    rng = np.random.default_rng(11)
    acc, jerk = 800.0, 2e4
    for _ in range(200):
        a0, alpha, t_end = rng.uniform(-acc, acc), rng.uniform(-acc, acc), rng.uniform(1e-3, 0.3)
        sig = np.linspace(0.0, t_end, 200_001)
        a = np.minimum(np.minimum(acc, alpha + jerk * (t_end - sig)), a0 + jerk * sig)
        assert abs(fl._reach(alpha, t_end, a0, acc, jerk) - np.trapezoid(a, sig)) <= 1e-6 * (1 + abs(a).max())
        t = np.linspace(0.0, t_end, 401)
        slope = np.abs(np.diff(fl._reach(alpha, t, a0, acc, jerk))) / np.diff(t)
        assert slope.max() <= acc * (1 + 1e-9)


@pytest.mark.parametrize("seed", range(3))
def test_no_motion_covers_more_than_the_held_bound(seed):
    """Random jerk-limited motions against max_distance_held at their own end accelerations (and
    at looser ones), and the held bound is below the free one (it knows more)."""
    rng = np.random.default_rng(100 + seed)
    acc, jerk = rng.uniform(200.0, 2000.0), rng.uniform(2e3, 1e5)
    rows = [random_motion(rng, acc, jerk, with_accelerations=True) for _ in range(400)]
    rows = [r for r in rows if r[-1] >= 0.0][:150]  # forward motions only (v ≥ 0 is assumed)
    T, v0, v1, dist, vmax, a0, a1, _ = (np.array(c) for c in zip(*rows))
    feed = float(vmax.max())
    held = fl.max_distance_held(T, v0, v1, a0, a1, feed, acc, jerk)
    assert (dist <= held * (1 + 1e-9) + 1e-12).all(), np.max(dist / held)
    looser = fl.max_distance_held(T, v0, v1, np.maximum(a0, 0.0), np.minimum(a1, 0.0), feed, acc, jerk)
    assert (held <= looser * (1 + 1e-12)).all()
    free = fl.max_distance(T, v0, v1, feed, acc, jerk)
    assert (held <= free * (1 + 1e-6)).all()
    assert np.max(dist / held) > 0.8  # near the best of them (it can fail: not slack)


def test_held_chain_through_a_stop_is_two_rest_to_rest_moves():
    """Two gaps meeting at a full stop: any motion has a = 0 there (v has its minimum 0), so the
    truth is two seven-phase rest-to-rest moves. The held chain stays below it (a bound) and
    above the free chain, which lets the first gap brake at −A into the stop and the second
    leave it at +A."""
    feed, acc, jerk = 100.0, 1000.0, 1e4
    for gap in (0.5, 4.0, 30.0):
        gaps, v, a = np.array([gap, gap]), np.zeros(3), np.full(2, acc)
        exact = 2.0 * fl.rest_to_rest_s(gap, feed, acc, jerk)
        free = float(fl.gap_times(gaps, v[:-1], v[1:], feed, a, jerk).sum())
        held = fl.held_chain_s(gaps, v, a, feed, jerk)
        assert free < held <= exact, (gap, free, held, exact)
        finer = fl.held_chain_s(gaps, v, a, feed, jerk, bins=8)
        assert held <= finer * (1 + 1e-9) and finer <= exact


def test_held_chain_of_one_gap_is_rest_to_rest_at_zero_accelerations():
    """One gap from rest to rest: s̈ = 0 at both rests (point_acceleration(0) = 0), so the held
    chain is the gap held at a(0) ≤ 0 ≤ a(T): above the free gap, below the seven-phase move."""
    feed, acc, jerk = 100.0, 1000.0, 1e4
    for gap in (0.05, 3.0, 40.0):
        free = float(fl.gap_times(np.array([gap]), np.zeros(1), np.zeros(1), feed, acc, jerk)[0])
        zero = float(fl.gap_times(np.array([gap]), np.zeros(1), np.zeros(1), feed, acc, jerk,
                                  np.zeros(1), np.zeros(1))[0])
        held = fl.held_chain_s(np.array([gap]), np.zeros(2), np.array([acc]), feed, jerk)
        assert held == pytest.approx(zero, rel=1e-12)
        assert free < held <= fl.rest_to_rest_s(gap, feed, acc, jerk)


def test_gap_times_refuses_end_accelerations_that_break_the_time_scaling():
    with pytest.raises(ValueError, match="a_start >= 0 >= a_end"):
        fl.gap_times(np.array([1.0]), np.zeros(1), np.zeros(1), 100.0, 1000.0, 1e4,
                     np.array([-1.0]), np.array([0.0]))


def test_bound_gap_times_sum_to_the_bound_and_raise_the_chain():
    """Each gap's share of the acceleration-limited bound (the chain points are on its grid) adds
    up to the bound's time; the chain taking the larger per gap is above both the proven chain
    and the bound, and still below the schedule."""
    from fuzzyfeed.slw import path_bound

    curve = slw_cases.corner_polyline(np.random.default_rng(5))
    lim = MachineLimits(axis_vel_mm_s=(100, 50, 100), axis_acc_mm_s2=(1000, 250, 1000))
    traj = schedule(curve, lim)
    bound = path_bound(traj.curve, lim, halve=False)
    s_p, _ = fl.chain_points(traj.curve, lim)
    s = np.unique(np.concatenate([[0.0], s_p, [traj.curve.length]]))
    share = fl.bound_gap_times(bound, s)
    assert share.sum() == pytest.approx(bound.time_s, rel=1e-9)
    both = fl.corner_chain_s(traj.curve, lim, bound)
    assert both >= max(bound.time_s, fl.corner_chain_s(traj.curve, lim)) * (1 - 1e-12)
    assert fl.jerk_floor(traj.curve, lim, bound) == max(both, fl.legs_s(traj.curve, lim))
    assert both <= traj.cycle_time_s
