"""SLW scheduling end to end: feasibility, rest at both ends, efficiency, bound, bad input."""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fuzzyfeed.errors import InputError, MachineLimitsError
from fuzzyfeed.io.shapes import load_shape, shape_names
from fuzzyfeed.limits import MachineLimits
from fuzzyfeed.nurbs import Nurbs
from fuzzyfeed.sampling import sample_by_arc_length, sample_uniform_u
from fuzzyfeed.slw import measure, schedule, time_optimal_bound
from fuzzyfeed.slw.preprocess import iter_blocks

TOL = 1.005  # the issue: no limit exceeded by more than 0.5 %
RATIOS = ("feed", "axis_vel", "axis_acc", "chord", "tangential_acc", "jerk")


def assert_feasible(traj) -> dict:
    m = measure(traj)
    for key in RATIOS:
        assert m[key] <= TOL, (key, m[key])
    assert m["start_feed_mm_s"] == 0.0 and m["end_feed_mm_s"] == 0.0
    assert m["start_error_mm"] <= 1e-9
    assert m["terminal_error_mm"] <= 1e-3  # ≤ 1 µm
    assert np.all(np.diff(traj.s_mm) >= 0) and np.all(np.diff(traj.u) >= 0)
    assert np.allclose(np.diff(traj.t_s), traj.limits.ts_s)
    return m


@pytest.fixture(scope="module")
def trajectories():
    return {name: schedule(load_shape(name).curve) for name in shape_names()}


@pytest.mark.parametrize("name", shape_names())
def test_shipped_shapes_are_feasible(trajectories, name):
    assert_feasible(trajectories[name])


@pytest.mark.parametrize("name", shape_names())
def test_approach_2_is_feasible_and_not_slower(trajectories, name):
    traj = schedule(load_shape(name).curve, approach=2)
    assert_feasible(traj)
    assert traj.cycle_time_s <= trajectories[name].cycle_time_s + 1e-9


def test_infinity_within_ten_percent_of_the_bound(trajectories):
    traj = trajectories["infinity"]
    _, bound = time_optimal_bound(sample_by_arc_length(traj.curve, step_mm=0.05), MachineLimits())
    assert bound == pytest.approx(4.9008, abs=2e-3)  # DESIGN §6 (toppra 0.6 and a phase-plane pass)
    assert bound <= traj.cycle_time_s <= 1.10 * bound


def test_bound_agrees_with_toppra():
    toppra = pytest.importorskip("toppra")
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    toppra.setup_logging("WARNING")
    curve = load_shape("infinity").curve
    lim = MachineLimits()
    smp = sample_by_arc_length(curve, step_mm=0.1)
    path = toppra.SplineInterpolator(smp.s, np.column_stack([smp.xyz, smp.s]))
    vel = np.array([[-100, 100]] * 4, dtype=float)
    acc = np.array([[-1000, 1000]] * 3 + [[-1e12, 1e12]], dtype=float)
    inst = algo.TOPPRA([constraint.JointVelocityConstraint(vel), constraint.JointAccelerationConstraint(acc)],
                       path, gridpoints=np.linspace(0, smp.s[-1], 3000), parametrizer="ParametrizeConstAccel")
    theirs = inst.compute_trajectory(0, 0).duration
    _, ours = time_optimal_bound(smp, lim)
    assert ours == pytest.approx(theirs, rel=1e-3)


def test_bound_on_a_straight_line_is_the_trapezoid():
    line = Nurbs(1, [0, 0, 1, 1], [[0, 0], [100, 0]])
    lim = MachineLimits(feed_mm_s=50, axis_acc_mm_s2=500)
    profile, t = time_optimal_bound(sample_by_arc_length(line, n=20001), lim)
    assert t == pytest.approx(100 / 50 + 50 / 500, rel=1e-3)
    assert profile.method == "bound" and profile.feed_mm_s[0] == 0 == profile.feed_mm_s[-1]


def test_feed_at_samples_and_window_is_progressive(trajectories):
    traj = trajectories["infinity"]
    smp = sample_uniform_u(traj.curve, 500)
    prof = traj.feed_at(smp)
    assert prof.method == "slw" and prof.feed_mm_s.shape == (500,)
    assert prof.feed_mm_s[0] == 0 and prof.feed_mm_s[-1] == 0
    assert prof.feed_mm_s.max() <= 100.0 + 1e-9
    # the sliding window never held the whole path
    assert traj.stats.max_window_mm < 0.7 * traj.curve.length
    assert traj.n_blocks == traj.n_critical + 1


def test_blocks_are_produced_progressively():
    curve = load_shape("butterfly").curve
    gen = iter_blocks(curve, MachineLimits())
    first = next(gen)
    assert 0.0 == first.s0 < first.s1 < curve.length
    rest = list(gen)
    assert rest[-1].s1 == curve.length
    assert all(a.s1 == b.s0 for a, b in zip([first] + rest, rest))


# ---------------------------------------------------------------------- random NURBS
def smooth_curve(seed: int) -> tuple[Nurbs, MachineLimits]:
    """A random smooth NURBS (degree 2-3, 2-D or 3-D, turning ≤ 69° per control leg, weights
    0.7-1.5) and random limits spanning an order of magnitude on every field."""
    rng = np.random.default_rng(seed)
    p = int(rng.integers(2, 4))
    n = int(rng.integers(p + 2, 8))
    dim = int(rng.integers(2, 4))
    pts = [np.zeros(dim)]
    d = rng.normal(size=dim)
    d /= np.linalg.norm(d)
    for _ in range(n - 1):
        r = rng.normal(size=dim)
        r -= (r @ d) * d
        r /= np.linalg.norm(r) + 1e-12
        ang = rng.uniform(-1.2, 1.2)
        d = np.cos(ang) * d + np.sin(ang) * r
        d /= np.linalg.norm(d)
        pts.append(pts[-1] + d * rng.uniform(2, 10))
    inner = np.sort(rng.uniform(0.05, 0.95, n - p - 1))
    knots = np.concatenate([[0] * (p + 1), inner, [1] * (p + 1)])
    curve = Nurbs(p, knots, np.array(pts), rng.uniform(0.7, 1.5, n))
    lim = MachineLimits(feed_mm_s=rng.uniform(10, 200), axis_vel_mm_s=tuple(rng.uniform(20, 200, 3)),
                        axis_acc_mm_s2=tuple(rng.uniform(200, 3000, 3)), jerk_mm_s3=rng.uniform(2000, 50000),
                        chord_tol_mm=10 ** rng.uniform(-4, -2), ts_s=float(rng.choice([0.0005, 0.001, 0.002])))
    return curve, lim


# derandomized: the same 100 curves every run (about 1 in 100 curves of this family still makes
# the look-ahead slow — a staircase of junctions on a slowly varying limit; see the report)
@settings(max_examples=100, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1))
def test_random_nurbs_exceed_no_limit(seed):
    curve, lim = smooth_curve(seed)
    assert_feasible(schedule(curve, lim))


# ---------------------------------------------------------------------- bad input and edge cases
@pytest.mark.parametrize("field", ["feed_mm_s", "axis_vel_mm_s", "axis_acc_mm_s2", "jerk_mm_s3",
                                   "chord_tol_mm", "ts_s"])
@pytest.mark.parametrize("value", [0.0, -1.0])
def test_zero_or_negative_limits_are_refused(field, value):
    with pytest.raises(MachineLimitsError, match=field):
        MachineLimits(**{field: value})


def test_straight_line_is_one_block_at_the_command_feed():
    line = Nurbs(1, [0, 0, 1, 1], [[0, 0, 0], [60, 80, 0]])
    lim = MachineLimits(feed_mm_s=100, axis_vel_mm_s=1000, axis_acc_mm_s2=1000, jerk_mm_s3=10_000)
    traj = schedule(line, lim)
    assert_feasible(traj)
    assert traj.n_blocks == 1 and traj.n_critical == 0
    t_ramp = math.pi * math.sqrt(100 / 20_000)  # jerk-limited cosine 0 -> 100 mm/s
    expected = 100 / 100 + t_ramp  # cruise + two half ramps
    assert traj.cycle_time_s == pytest.approx(expected, abs=2 * lim.ts_s)


def test_path_shorter_than_one_servo_step():
    tiny = Nurbs(1, [0, 0, 1, 1], [[0, 0], [1e-5, 0]])  # 10 nm, well under F*Ts = 0.1 mm
    traj = schedule(tiny, MachineLimits())
    assert traj.t_s.size >= 2
    assert_feasible(traj)


def test_zero_length_span_and_corner_stop():
    # the middle control points coincide: a corner of a degree-1 path and a zero-length span
    pts = [[0, 0], [20, 0], [20, 0], [20, 20]]
    curve = Nurbs(1, [0, 0, 0.3, 0.6, 1, 1], pts)
    traj = schedule(curve, MachineLimits())
    assert_feasible(traj)
    corner = np.argmin(np.abs(traj.s_mm - 20.0))
    assert traj.feed_mm_s[corner] < 1.0  # (nearly) stops at the 90° corner


def test_schedule_rejects_wrong_limits_type():
    with pytest.raises(InputError, match="MachineLimits"):
        schedule(load_shape("wm").curve, {"feed_mm_s": 1})
