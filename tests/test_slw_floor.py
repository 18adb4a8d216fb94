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


def random_motion(rng, acc, jerk, steps=400):
    """A motion with |a| ≤ A, |j| ≤ J (piecewise constant jerk, integrated exactly), mostly
    bang-bang: (T, v(0), v(T), distance, max feed)."""
    dt = rng.uniform(1e-4, 2e-3)
    a, v, s, vmax = rng.uniform(-acc, acc), rng.uniform(0.0, 50.0), 0.0, 0.0
    v0 = v
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
