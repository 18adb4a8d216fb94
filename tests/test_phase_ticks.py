"""Servo ticks from a feed profile x(s) = v² on a grid (fuzzyfeed.slw.phase_ticks), checked against
closed forms it does not use: the constant-jerk start s = J·t³/6, the seven-phase rest-to-rest move
(slw/profile's segments and floor.rest_to_rest_s), and the tick check's own finite differences
(slw/check.tick_ratios on a straight line)."""

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from fuzzyfeed.errors import InputError
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.slw.check import tick_ratios
from fuzzyfeed.slw.floor import rest_to_rest_s
from fuzzyfeed.slw.phase_ticks import _linear_durations, _linear_state, nodal_accelerations, ticks_from_phase
from fuzzyfeed.slw.profile import SEVEN_PHASE, block_segments
from slw_cases import profile_at

TS = 1e-3
LIMITS = MachineLimits(feed_mm_s=100.0, axis_vel_mm_s=200.0, axis_acc_mm_s2=1000.0, jerk_mm_s3=1e4,
                       ts_s=TS)
#: What the ticks of a sampled seven-phase profile may realise over its limits: with its nodal
#: accelerations (a_grid) every interval is one or two constant jerks, found exactly (rounding);
#: without them (three-point a from x alone, no J) the jerk is measured up to 2.8 x J on a 0.3 mm move
#: (0.0375 mm grid), 1.06-1.42 x on longer ones, and the time up to 2.4 % long.
FACTOR = 1.0 + 1e-6
JERK_FACTOR_NO_A, ACC_FACTOR_NO_A, TIME_RTOL_NO_A = 3.0, 1.3, 0.03


def _on_line(s):
    """Positions along the x axis (the check's straight-line xyz)."""
    return np.stack([s, np.zeros_like(s), np.zeros_like(s)], axis=1)


def _sampled(segs, s_grid):
    """x = v² and a at arc lengths ``s_grid`` of a profile of slw/profile segments, at rest at both
    ends, and its time."""
    v, a, T = profile_at(segs, s_grid)
    v[0] = v[-1] = 0.0
    return v * v, a, T


#: A machine whose jerk phase ends inside the first 0.25 mm (t_j = A/J = 25 ms, 0.026 mm): the first
#: interval holds a switch of jerk (J, then 0 at the acceleration limit).
LOW_ACC = MachineLimits(feed_mm_s=100.0, axis_vel_mm_s=200.0, axis_acc_mm_s2=250.0, jerk_mm_s3=1e4, ts_s=TS)


def _seven_phase(length, limits=LIMITS):
    kind, segs = block_segments(length, 0.0, 0.0, limits.feed_mm_s, limits.tangential_acc_mm_s2,
                                limits.jerk_mm_s3, shape=SEVEN_PHASE)
    return segs


def test_constant_jerk_start_is_the_closed_form():
    # jerk +J for T1, −J for 2·T1, +J for T1: rest to rest; grid points at the phase ends only
    J, T1 = 1e4, 0.05
    s1 = J * T1 ** 3 / 6.0
    v1, a1 = J * T1 ** 2 / 2.0, J * T1
    L = 2.0 * (s1 + v1 * T1 + a1 * T1 ** 2 / 2.0 - J * T1 ** 3 / 6.0)
    grid = np.array([0.0, s1, L - s1, L])
    x = np.array([0.0, v1 * v1, v1 * v1, 0.0])
    t, s, v, a, j = ticks_from_phase(grid, x, TS)
    first = t <= T1
    np.testing.assert_allclose(s[first], J * t[first] ** 3 / 6.0, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(v[first], J * t[first] ** 2 / 2.0, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(a[first], J * t[first], rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(j[t < T1 - 1e-9], J, rtol=1e-12)
    # the stop mirrors it: L − s = J·(T − t)³/6 over the last T1, T read off the last moving tick
    moving = np.flatnonzero(v > 0.0)[-1]
    T = t[moving] + (6.0 * (L - s[moving]) / J) ** (1.0 / 3.0)
    last = (t > T - T1) & (t <= T)
    np.testing.assert_allclose(L - s[last], J * (T - t[last]) ** 3 / 6.0, rtol=1e-9, atol=1e-13)
    assert t[-1] == pytest.approx(np.ceil(T / TS - 1e-9) * TS, abs=1e-12) and s[-1] == L


@pytest.mark.parametrize("length, limits", [(0.3, LIMITS), (4.0, LIMITS), (60.0, LIMITS), (60.0, LOW_ACC)])
@pytest.mark.parametrize("with_a", [True, False])
def test_seven_phase_move_on_a_line(length, limits, with_a):
    segs = _seven_phase(length, limits)
    T = rest_to_rest_s(length, limits.feed_mm_s, limits.tangential_acc_mm_s2, limits.jerk_mm_s3)
    grid = np.linspace(0.0, length, max(int(np.ceil(length / 0.25)), 8) + 1)
    x, a, T_segs = _sampled(segs, grid)
    assert T_segs == pytest.approx(T, rel=1e-9)
    t, s, v, acc, j = ticks_from_phase(grid, x, TS, a_grid=a if with_a else None,
                                       jerk_mm_s3=limits.jerk_mm_s3 if with_a else None)
    np.testing.assert_allclose(np.diff(t), TS, rtol=1e-9)
    assert s[0] == 0.0 and s[-1] == length and np.all(np.diff(s) >= 0.0) and np.all(v >= 0.0)
    r = tick_ratios(_on_line(s), j, limits)
    if with_a:   # the move itself: its time (the last tick the first at or after it), its limits
        assert T - 1e-9 <= t[-1] <= T + TS + 1e-9
        assert r["feed"].max() <= FACTOR and r["acceleration x"].max() <= FACTOR
        assert np.nanmax(r["path jerk"]) <= FACTOR and np.abs(j).max() <= limits.jerk_mm_s3 * FACTOR
    else:
        assert abs(t[-1] - T) <= TS + TIME_RTOL_NO_A * T
        assert r["feed"].max() <= 1.0 + 1e-4 and r["acceleration x"].max() <= ACC_FACTOR_NO_A
        assert np.nanmax(r["path jerk"]) <= JERK_FACTOR_NO_A


def test_interior_full_stop():
    # two seven-phase moves end to end: x = 0 at the grid point between them
    one, two = 3.0, 5.0
    g1 = np.linspace(0.0, one, 13)
    g2 = np.linspace(0.0, two, 21)
    x1, a1, T1 = _sampled(_seven_phase(one), g1)
    x2, a2, T2 = _sampled(_seven_phase(two), g2)
    grid = np.concatenate([g1, one + g2[1:]])
    x = np.concatenate([x1, x2[1:]])
    t, s, v, acc, j = ticks_from_phase(grid, x, TS, a_grid=np.concatenate([a1, a2[1:]]),
                                       jerk_mm_s3=LIMITS.jerk_mm_s3)
    assert np.isfinite(np.stack([t, s, v, acc, j])).all()
    assert np.all(np.diff(s) >= 0.0) and s[-1] == one + two
    # comes to rest there (the nearest tick within half a period of the stop: a jerk-J start)
    k = int(np.argmin(np.abs(s - one)))
    J = LIMITS.jerk_mm_s3
    assert abs(s[k] - one) <= J * (TS / 2) ** 3 / 6.0 * 1.01 and v[k] <= J * (TS / 2) ** 2 / 2.0 * 1.01
    assert np.any(s > one + 1e-3)                             # and starts again
    assert abs(t[-1] - (T1 + T2)) <= 2 * TS + 5e-3 * (T1 + T2)
    r = tick_ratios(_on_line(s), j, LIMITS)
    assert np.nanmax(r["path jerk"]) <= FACTOR and r["acceleration x"].max() <= FACTOR


def _jerk_bounds(grid, x, a):
    """Per interval the bound the module states, recomputed here from the grid values and nodal a:
    the linear-in-s law's √(max x on a half)·|da/ds| over its two halves (max x: the ends and an
    inside extremum; inf where that law's x reaches 0), on a rest interval the constant-jerk
    start's J_r = 2x^{3/2}/(9h²)."""
    h = np.diff(grid)
    out = np.zeros(h.size)
    for k in range(h.size):
        if x[k] == 0.0 or x[k + 1] == 0.0:
            m = max(x[k], x[k + 1])
            out[k] = 2.0 * m ** 1.5 / (9.0 * h[k] ** 2)
            continue
        am = (x[k + 1] - x[k]) / h[k] - 0.5 * (a[k] + a[k + 1])
        xm = x[k] + 0.5 * h[k] * (a[k] + am)
        for x0, a0, a1 in ((x[k], a[k], am), (xm, am, a[k + 1])):
            c = (a1 - a0) / (0.5 * h[k])
            ends = (x0, x0 + h[k] * (a0 + a1) / 2.0)
            inside = [x0 - a0 * a0 / c] if c != 0.0 and 0.0 < -a0 / c < 0.5 * h[k] else []
            if min(*ends, *inside) <= 0.0:
                out[k] = np.inf
                break
            out[k] = max(out[k], np.sqrt(max(*ends, *inside)) * abs(c))
    return out


def _jerk_bound(grid, x, a):
    return _jerk_bounds(grid, x, a).max()


def _within_bounds(grid, s, j, bounds):
    """|j| of the ticks strictly inside each interval ≤ its bound."""
    k = np.searchsorted(grid, s, side="left") - 1
    inside = (k >= 0) & (k < grid.size - 1) & (s > grid[np.clip(k, 0, None)])
    return bool(np.all(np.abs(j[inside]) <= bounds[k[inside]] * (1.0 + 1e-9)))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2 ** 31 - 1), n=st.integers(4, 40), ts=st.sampled_from([5e-4, 1e-3, 2e-3]),
       with_j=st.booleans())
def test_random_profiles(seed, n, ts, with_j):
    rng = np.random.default_rng(seed)
    grid = np.concatenate([[0.0], np.cumsum(rng.uniform(0.01, 0.25, n))])
    J = rng.uniform(2e3, 5e4)
    # random jerk-bounded a(s): x_{k+1} = x_k + h(a_k + a_{k+1}), a linear in s with
    # |Δa|·√(x) ≤ J·h, from a constant-jerk start, ended by a constant-jerk stop
    h = np.diff(grid)
    x, a = np.zeros(n + 1), np.zeros(n + 1)
    x[1] = rng.uniform(0.2, 1.0) * (4.5 * J * h[0] ** 2) ** (2.0 / 3.0)
    a[1] = 2.0 * x[1] / (3.0 * h[0])
    for k in range(1, n - 1):
        for u in (*rng.uniform(-1.0, 1.0, 8), 1.0):   # keep moving: x > 0 all over the interval
            slope = u * J / np.sqrt(x[k]) / 2.0
            a[k + 1] = a[k] + slope * h[k]
            x[k + 1] = x[k] + h[k] * (a[k] + a[k + 1])
            valley = x[k] - a[k] ** 2 / slope if slope > 0.0 and -a[k] / slope < h[k] and a[k] < 0.0 else x[k + 1]
            if min(x[k + 1], valley) > 0.05 * x[k]:
                break
        assume(min(x[k + 1], valley) > 0.05 * x[k])
    a[n - 1] = -2.0 * x[n - 1] / (3.0 * h[n - 1])
    t, s, v, acc, j = ticks_from_phase(grid, x, ts, a_grid=a, jerk_mm_s3=J if with_j else None)
    L = grid[-1]
    assert np.isfinite(np.stack([s, v, acc, j])).all()
    assert np.all(np.diff(s) >= 0.0) and np.all(v >= 0.0) and s[0] == 0.0 and s[-1] == L
    np.testing.assert_allclose(np.diff(t), ts, rtol=1e-9)
    bound = _jerk_bound(grid, x, a)
    assert np.abs(j).max() <= bound * (1.0 + 1e-9)
    if s.size > 4:
        fd = np.abs(np.diff(np.diff(np.diff(np.concatenate([[0.0], s])) / ts) / ts)) / ts
        assert fd.max() <= bound * (1.0 + 1e-6) + 1e-6 * L / ts ** 3


def test_bad_grids_are_one_clear_error():
    with pytest.raises(InputError, match="at rest"):
        ticks_from_phase([0.0, 1.0, 2.0], [1.0, 4.0, 0.0], TS)
    with pytest.raises(InputError, match="whole interval"):
        ticks_from_phase([0.0, 1.0, 2.0, 3.0, 4.0], [0.0, 4.0, 0.0, 0.0, 0.0], TS)
    with pytest.raises(InputError, match="strictly increasing"):
        ticks_from_phase([0.0, 1.0, 1.0], [0.0, 4.0, 0.0], TS)


def test_one_moving_point_between_two_stops():
    t, s, v, a, j = ticks_from_phase([0.0, 1.0, 2.0, 3.0, 4.0], [0.0, 4.0, 0.0, 4.0, 0.0], TS)
    assert np.isfinite(np.stack([s, v, a, j])).all() and np.all(np.diff(s) >= 0.0) and s[-1] == 4.0


def test_linear_law_against_quadrature():
    from scipy.integrate import quad

    rng = np.random.default_rng(7)
    for _ in range(200):
        x0, length = rng.uniform(1e-2, 1e4), rng.uniform(1e-4, 0.2)
        a0, c = rng.uniform(-1.0, 1.0) * x0 / length, rng.uniform(-3.0, 3.0) * x0 / length ** 2
        xs = x0 + 2.0 * a0 * np.linspace(0, length, 201) + c * np.linspace(0, length, 201) ** 2
        if xs.min() <= 0.05 * x0:
            continue
        x1 = x0 + 2.0 * a0 * length + c * length ** 2
        T = _linear_durations(np.array([x0]), np.array([a0]), np.array([c]), np.array([length]))[0]
        want = quad(lambda u: 1.0 / np.sqrt(x0 + 2.0 * a0 * u + c * u * u), 0.0, length, epsabs=0, epsrel=1e-13)[0]
        assert T == pytest.approx(want, rel=1e-10)
        s, v, a, j = _linear_state(np.sqrt(x0), a0, c, np.array([T]))
        assert s[0] == pytest.approx(length, rel=1e-12)
        assert v[0] == pytest.approx(np.sqrt(x1), rel=1e-9)
        assert a[0] == pytest.approx(a0 + c * length, abs=1e-9 * (abs(a0) + abs(c) * length))
        assert j[0] == pytest.approx(c * v[0], rel=1e-12)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2 ** 31 - 1))
def test_grid_values_that_disagree(seed):
    # x and a drawn independently (no planner's relation between them): one clear error, or ticks
    # that move forward within the linear-in-s law's jerk bound
    rng = np.random.default_rng(seed)
    grid = np.concatenate([[0.0], np.cumsum(rng.uniform(0.05, 0.25, 4))])
    x = np.concatenate([[0.0], rng.uniform(50.0, 400.0, 3), [0.0]])
    a_in = np.concatenate([[0.0], rng.uniform(-3000.0, 3000.0, 3), [0.0]])
    try:
        t, s, v, acc, j = ticks_from_phase(grid, x, TS, a_grid=a_in)
    except InputError as exc:
        assert "joins the grid points" in str(exc)
        return
    assert np.isfinite(np.stack([s, v, acc, j])).all() and np.all(np.diff(s) >= 0.0) and s[-1] == grid[-1]
    # away from the rests (there: two constant jerks from rest, no linear law to compare with)
    bounds = _jerk_bounds(grid, x, nodal_accelerations(grid, x, a_in))
    bounds[[0, -1]] = np.inf
    assert _within_bounds(grid, s, j, bounds)


def test_linear_law_where_two_jerks_are_worse():
    # grid values no planner would give (a against the change of x): on the interval from 0.45 to
    # 0.6 mm a linear in s has the smaller jerk, and it is what the ticks follow
    from fuzzyfeed.slw.phase_ticks import _pieces

    grid = np.array([0.0, 0.2, 0.45, 0.6, 0.8])
    x = np.array([0.0, 92.89792839, 140.33957617, 192.01975474, 0.0])
    a_in = np.array([0.0, 2815.10368887, -2026.09725129, 2143.76204134, 0.0])
    a = nodal_accelerations(grid, x, a_in)
    kind = _pieces(grid, x, a)[0]
    assert list(kind[4:6]) == [0, 0] and (kind[:4] == 1).all()
    t, s, v, acc, j = ticks_from_phase(grid, x, TS, a_grid=a_in)
    on = (s > 0.45) & (s < 0.6)
    assert np.abs(j[on]).max() <= _jerk_bound(grid[2:4], x[2:4], a[2:4]) * (1.0 + 1e-9)
    # the linear law passes x at the midpoint knot and reaches the next node's v exactly
    k = int(np.argmin(np.abs(s - 0.6)))
    assert v[k] ** 2 == pytest.approx(x[3] + 2.0 * a[3] * (s[k] - 0.6), rel=1e-3)


@pytest.mark.parametrize("tiny", [1e-9, 1e-7, 1e-6])
def test_grid_points_a_hair_apart(tiny):
    # a planner's grid puts a point 1e-9·L before every knot: over such a step the fit divides
    # rounding by T² (a piece jerk of 250 × J before those points were merged)
    from fuzzyfeed.slw.phase_ticks import _pieces, merge_close

    L = 20.0
    base = np.linspace(0.0, L, 81)
    grid = np.unique(np.concatenate([base, base[5:-5:3] - tiny * L]))
    x, a, T = _sampled(_seven_phase(L), grid)
    s_m, x_m, a_m = merge_close(grid, x, a)
    assert s_m.size < grid.size and np.diff(s_m).min() >= 1e-5 * L * 0.999 or np.diff(s_m).min() >= 1e-4
    kind, _, _, _, c, _ = _pieces(s_m, x_m, nodal_accelerations(s_m, x_m, a_m, LIMITS.jerk_mm_s3),
                                  LIMITS.jerk_mm_s3)
    assert np.abs(c[kind == 1]).max() <= LIMITS.jerk_mm_s3 * FACTOR
    t, s, v, acc, j = ticks_from_phase(grid, x, TS, a_grid=a, jerk_mm_s3=LIMITS.jerk_mm_s3)
    assert T - 1e-9 <= t[-1] <= T + TS + 1e-9 and np.abs(j).max() <= LIMITS.jerk_mm_s3 * FACTOR


def test_a_whole_stop_in_the_last_interval():
    # a short seven-phase move (no plateau): from its peak (a = 0) to rest in one interval, as the
    # window's grid has it before a stop; every split of that interval leaves a = 0 (an excursion
    # of a range of zero width: the fit once overflowed there and took 1.5 x the time)
    L = 0.3
    grid = np.concatenate([np.linspace(0.0, L / 2.0, 5), [L]])
    x, a, T = _sampled(_seven_phase(L), grid)
    t, s, v, acc, j = ticks_from_phase(grid, x, TS, a_grid=a, jerk_mm_s3=LIMITS.jerk_mm_s3)
    assert T - 1e-9 <= t[-1] <= T + TS + 1e-9
    assert np.abs(j).max() <= LIMITS.jerk_mm_s3 * FACTOR
    r = tick_ratios(_on_line(s), j, LIMITS)
    assert np.nanmax(r["path jerk"]) <= FACTOR and r["acceleration x"].max() <= FACTOR


def test_a_planners_trapezoid_value_beside_a_rest_is_replaced():
    # with a linear in s from a rest (a_1 = x_1/h, the trapezoid relation from a_0 = 0) no finite
    # jerk leaves the rest; the nearest two-jerk motion needs 2.94 x J: the constant-jerk start
    # (a_1 = 2x_1/(3h), J_r = 2x_1^{3/2}/(9h²) = 0.98 J here) is taken instead
    J, h = 1e4, 0.25
    x1 = (4.5 * 0.98 * J * h * h) ** (2.0 / 3.0)
    grid = np.arange(6) * h
    x = np.array([0.0, x1, 1.8 * x1, 1.8 * x1, x1, 0.0])
    a_lp = np.array([0.0, x1 / h, 0.0, 0.0, -x1 / h, 0.0])
    a = nodal_accelerations(grid, x, a_lp, J)
    np.testing.assert_allclose(a[[1, 4]], [2.0 * x1 / (3.0 * h), -2.0 * x1 / (3.0 * h)], rtol=1e-12)
    t, s, v, acc, j = ticks_from_phase(grid, x, TS, a_grid=a_lp, jerk_mm_s3=J)
    first = s < h
    assert np.abs(j[first]).max() == pytest.approx(0.98 * J, rel=1e-9)
