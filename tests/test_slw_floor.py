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
        traj = schedule(curve, lim, transition="seven-phase", planner="window")
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
    traj = schedule(curve, lim, planner="window", transition="cosine")
    bound = path_bound(traj.curve, lim, halve=False)
    s_p, _ = fl.chain_points(traj.curve, lim)
    s = np.unique(np.concatenate([[0.0], s_p, [traj.curve.length]]))
    share = fl.bound_gap_times(bound, s)
    assert share.sum() == pytest.approx(bound.time_s, rel=1e-9)
    both = fl.corner_chain_s(traj.curve, lim, bound)
    assert both >= max(bound.time_s, fl.corner_chain_s(traj.curve, lim)) * (1 - 1e-12)
    assert fl.jerk_floor(traj.curve, lim, bound) == max(both, fl.legs_s(traj.curve, lim))
    assert both <= traj.cycle_time_s


def _motion_from_rest(rng, acc, jerk, steps=3000):
    """A motion from rest (v = a = 0) with |a| ≤ A, |j| ≤ J, piecewise constant jerk integrated
    exactly, kept at v ≥ 0 by braking a deceleration in time (jerk +J where a step would end with
    a² > 1.9·J·v: it keeps v − a²/(2J) > 0): arrays t, s, v, a at the steps."""
    dt = rng.uniform(2e-4, 2e-3)
    t, s, v, a = [0.0], [0.0], [0.0], [0.0]
    sign = 1.0
    for _ in range(steps):
        if rng.random() < 0.05:
            sign = -sign
        j = sign * jerk if rng.random() < 0.8 else rng.uniform(-jerk, jerk)
        a0, v0 = a[-1], v[-1]
        j = float(np.clip(j, (-acc - a0) / dt, (acc - a0) / dt))
        v1, a1 = v0 + a0 * dt + j * dt * dt / 2.0, a0 + j * dt
        if v1 < 0.0 or (a1 < 0.0 and a1 * a1 > 1.9 * jerk * v1):
            # brake the deceleration: under j = +J, v − a²/(2J) is constant while a < 0
            j = float(min(jerk, (acc - a0) / dt))
            v1, a1 = v0 + a0 * dt + j * dt * dt / 2.0, a0 + j * dt
        s.append(s[-1] + v0 * dt + a0 * dt * dt / 2.0 + j * dt ** 3 / 6.0)
        v.append(v1)
        a.append(a1)
        t.append(t[-1] + dt)
    t, s, v, a = (np.array(x) for x in (t, s, v, a))
    return t, s, v, a


@pytest.mark.parametrize("seed", range(4))
def test_point_acceleration_holds_on_motions_that_stay_forward(seed):
    """|s̈| ≤ √(2·J·v) wherever v ≥ 0 before and after: from rest, a(t) ≤ √(2J·v(t)) (the past);
    the same motion read backwards (a → −a) gives the other side."""
    rng = np.random.default_rng(40 + seed)
    acc, jerk = rng.uniform(200.0, 2000.0), rng.uniform(2e3, 1e5)
    t, s, v, a = _motion_from_rest(rng, acc, jerk)
    assert (v >= -1e-9).all()
    assert (a <= fl.point_acceleration(v, jerk) * (1 + 1e-9) + 1e-9).all()
    # read backwards from its end: a motion that comes to rest with v ≥ 0 all along
    ok = a >= -fl.point_acceleration(v, jerk) * (1 + 1e-9) - 1e-9
    # (braking by jerk +J keeps every state able to stop without reversing)
    assert ok.all()
    # and the bound is reached: some states near it (it is not slack)
    near = a / np.maximum(fl.point_acceleration(v, jerk), 1e-12)
    assert np.max(near[v > 1e-6]) > 0.7


@pytest.mark.parametrize("seed", range(5))
def test_held_chain_below_random_forward_motions(seed):
    """The held chain with the points' accelerations within √(2·J·v): cut a random motion (from
    rest, v ≥ 0, able to stop) at random times, give each point the motion's own feed there
    (the chain's feed bound), each gap A: the chain's time may not exceed the motion's."""
    rng = np.random.default_rng(60 + seed)
    acc, jerk = rng.uniform(200.0, 2000.0), rng.uniform(2e3, 1e5)
    t, s, v, a = _motion_from_rest(rng, acc, jerk, steps=1500)
    k = np.unique(np.concatenate([[0], np.sort(rng.choice(np.arange(1, t.size - 1), 12, replace=False)),
                                  [t.size - 1]]))
    gaps = np.diff(s[k])
    keep = gaps > 1e-9
    k = np.concatenate([[k[0]], k[1:][keep]])
    gaps = np.diff(s[k])
    feed = float(v.max()) * (1 + 1e-9) + 1e-12
    chain = fl.held_chain_s(gaps, v[k] * (1 + 1e-9) + 1e-12, np.full(gaps.size, acc), feed, jerk)
    assert chain <= t[k[-1]] - t[k[0]], (chain, t[k[-1]] - t[k[0]])


@pytest.mark.parametrize("name", ["rectangle", "zigzag", "square_passes"])
def test_floor_below_seven_phase_polylines(name):
    """The built-in polylines' corners pass at 0.1-0.9 mm/s, not at rest: their seven-phase
    schedules (0.996, 0.996 and 0.990 × the floor that took those corners as full stops on
    main) keep every limit and may not beat the floor."""
    from fuzzyfeed.slw import measure

    curve = getattr(slw_cases, name)()
    for lim in (MachineLimits(), MachineLimits(axis_vel_mm_s=(100, 50, 100), axis_acc_mm_s2=(1000, 250, 1000))):
        traj = schedule(curve, lim, transition="seven-phase", planner="window")
        m = measure(traj)
        assert max(m[key] for key in ("feed", "axis_vel", "axis_acc", "chord", "jerk")) <= 1 + 5e-5
        assert fl.jerk_floor(traj.curve, lim) <= traj.cycle_time_s


def _piecewise_jerk(phases):
    """(t, s, v, a) at the ends of phases (jerk, duration) from rest, integrated exactly."""
    t, s, v, a = [0.0], [0.0], [0.0], [0.0]
    for j, d in phases:
        s.append(s[-1] + v[-1] * d + a[-1] * d * d / 2.0 + j * d ** 3 / 6.0)
        v.append(v[-1] + a[-1] * d + j * d * d / 2.0)
        a.append(a[-1] + j * d)
        t.append(t[-1] + d)
    return tuple(np.array(x) for x in (t, s, v, a))


@pytest.mark.parametrize("cruise", [0.0, 0.05, 0.4])
def test_held_chain_below_the_seven_phase_cut_where_a_is_sqrt_2jv(cruise):
    """The seven-phase rest-to-rest move (time-optimal) cut where its jerk phases end: there
    a = ±A and v = A²/(2J), so |a| = √(2·J·v) — on the points' bound. The held chain through
    those points stays below the move's time (the middle gap starts at +A, the first ends there:
    the positive window of :func:`signed_gap_times`), and near it."""
    feed, acc, jerk = 200.0, 1000.0, 1e4
    tj, ta = acc / jerk, (feed - acc * acc / jerk) / acc
    t, s, v, a = _piecewise_jerk([(jerk, tj), (0.0, ta), (-jerk, tj), (0.0, cruise),
                                  (-jerk, tj), (0.0, ta), (jerk, tj)])
    assert abs(v[-1]) < 1e-9 and abs(a[-1]) < 1e-9
    assert np.allclose(np.abs(a[[1, 6]]), fl.point_acceleration(v[[1, 6]], jerk))
    k = np.array([0, 1, 6, 7])
    gaps, pts = np.diff(s[k]), v[k] * (1 + 1e-12)
    chain = fl.held_chain_s(gaps, pts, np.full(3, acc), feed, jerk)
    assert chain <= t[-1]
    assert t[-1] == pytest.approx(fl.rest_to_rest_s(s[-1], feed, acc, jerk), rel=1e-9)
    # near the optimum (it can fail: not slack), and above the chain of free accelerations
    assert chain >= 0.75 * t[-1]
    assert chain > float(fl.gap_times(gaps, pts[:-1], pts[1:], feed, np.full(3, acc), jerk).sum())


@pytest.mark.parametrize("seed", range(4))
def test_signed_gap_times_below_random_forward_motions(seed):
    """Stretches of random forward motions with their own end feeds and end accelerations of
    either sign (a negative start and a positive end cost their windows): no stretch is faster
    than signed_gap_times says; with the signs of gap_times it is gap_times."""
    rng = np.random.default_rng(80 + seed)
    acc, jerk = rng.uniform(200.0, 2000.0), rng.uniform(2e3, 1e5)
    t, s, v, a = _motion_from_rest(rng, acc, jerk, steps=1200)
    i = rng.integers(0, t.size - 2, 300)
    k = np.minimum(i + rng.integers(1, 200, 300), t.size - 1)
    keep = s[k] - s[i] > 1e-9
    i, k = i[keep], k[keep]
    feed = float(v.max()) * (1 + 1e-9) + 1e-12
    got = fl.signed_gap_times(s[k] - s[i], v[i] * (1 + 1e-9) + 1e-12, v[k] * (1 + 1e-9) + 1e-12, feed, acc,
                              jerk, a[i] + 1e-9 * acc, a[k] - 1e-9 * acc)
    assert (got <= t[k] - t[i]).all(), np.max(got / (t[k] - t[i]))
    assert ((a[i] < 0) | (a[k] > 0)).sum() > 50  # the windows were exercised
    plain = (a[i] >= 0) & (a[k] <= 0)
    same = fl.gap_times(s[k][plain] - s[i][plain], v[i][plain] * (1 + 1e-9) + 1e-12, v[k][plain] * (1 + 1e-9) + 1e-12,
                        feed, acc, jerk, a[i][plain] + 1e-9 * acc, a[k][plain] - 1e-9 * acc)
    assert np.allclose(got[plain], same, rtol=1e-12)
