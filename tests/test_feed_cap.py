"""The feed cap and its staircase (fuzzyfeed.slw.feed_cap): never above the cap, few steps,
and a schedule under it that holds the cap and every machine limit without a repair storm."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzyfeed.errors import InputError
from fuzzyfeed.io.shapes import load_shape
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.geometry.sampling import sample_uniform_u
from fuzzyfeed.slw import measure, schedule
from fuzzyfeed.slw.feed_cap import MACHINE_ROOM, STAIR_PLATEAU, STAIR_RATIO, FeedCap, lower, stairs
from fuzzyfeed.slw.profile import transition_distance

LIM = MachineLimits()


def test_a_step_is_the_lower_of_its_two_sides():
    cap = FeedCap(np.array([0.0, 5.0, 5.0, 10.0]), np.array([30.0, 30.0, 12.0, 12.0]), 10.0)
    np.testing.assert_array_equal(cap(np.array([4.0, 5.0, 6.0])), [30.0, 12.0, 12.0])
    up = FeedCap(np.array([0.0, 5.0, 5.0, 10.0]), np.array([12.0, 12.0, 30.0, 30.0]), 10.0)
    np.testing.assert_array_equal(up(np.array([4.0, 5.0, 6.0])), [12.0, 12.0, 30.0])
    np.testing.assert_array_equal(up.steps_mm, [5.0])
    # a linear cap is what it was: interpolation between its points
    lin = FeedCap(np.array([0.0, 10.0]), np.array([10.0, 30.0]), 20.0)
    np.testing.assert_allclose(lin(np.array([0.0, 10.0, 20.0])), [10.0, 20.0, 30.0])


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 400), length=st.floats(1.0, 5000.0))
def test_property_staircase_never_above_the_cap(seed, n, length):
    rng = np.random.default_rng(seed)
    s = np.sort(np.concatenate([[0.0, length], rng.uniform(0.0, length, n - 2)]))
    v = np.exp(rng.uniform(np.log(0.5), np.log(300.0), n))
    if n >= 5 and rng.uniform() < 0.3:
        v = np.convolve(v, np.ones(5) / 5, mode="same") + 0.1  # a smooth advice
    cap = FeedCap(s, v, length)
    st_ = stairs(cap, LIM.feed_mm_s, LIM.tangential_acc_mm_s2, LIM.jerk_mm_s3)
    # on a dense grid, at the cap's own points and at both sides of every step
    x = np.concatenate([np.linspace(0.0, length, 20001), cap.s_mm, st_.s_mm])
    assert np.all(st_(x) <= cap(x) * (1 + 1e-12))
    eps = 1e-9 * length
    for side in (-eps, eps):
        y = np.clip(st_.steps_mm + side, 0.0, length)
        assert np.all(st_(y) <= cap(y) * (1 + 1e-12))
    # at most one step per level the cap crosses, and two per cap point
    crossed = np.abs(np.diff(np.log(np.minimum(v, LIM.feed_mm_s)))).sum() / -np.log(STAIR_RATIO)
    assert st_.steps_mm.size <= crossed + 2 * cap.s_mm.size + 2
    # the machine's staircase: never above its (sampled) limit raised by MACHINE_ROOM
    mach = stairs(cap, LIM.feed_mm_s, LIM.tangential_acc_mm_s2, LIM.jerk_mm_s3, machine=True)
    assert np.all(mach(x) <= cap(x) * MACHINE_ROOM * (1 + 1e-12))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 60), m=st.integers(2, 60))
def test_property_lower_of_two_caps_is_their_minimum(seed, n, m):
    rng = np.random.default_rng(seed)

    def random_cap(k: int) -> FeedCap:
        s = np.sort(np.concatenate([[0.0, 10.0], rng.uniform(0.0, 10.0, k - 2)]))
        if k > 3:  # a step: an arc length given twice
            s[k // 2] = s[k // 2 - 1]
        return FeedCap(s, rng.uniform(1.0, 100.0, k), 10.0)

    a, b = random_cap(n), random_cap(m)
    both = lower(a, b)
    x = np.concatenate([np.linspace(0.0, 10.0, 4001), a.s_mm, b.s_mm])
    np.testing.assert_allclose(both(x), np.minimum(a(x), b(x)), rtol=1e-9, atol=1e-9)
    for side in (-1e-9, 1e-9):  # either side of every step of either cap
        y = np.clip(np.concatenate([a.steps_mm, b.steps_mm]) + side, 0.0, 10.0)
        np.testing.assert_allclose(both(y), np.minimum(a(y), b(y)), rtol=1e-6, atol=1e-6)


def _minima(cap: FeedCap) -> int:
    """Local minima of a staircase (a plateau counts once)."""
    v = cap.feed_mm_s[np.concatenate([[True], np.diff(cap.feed_mm_s) != 0.0])]
    inner = (v[1:-1] < v[:-2]) & (v[1:-1] < v[2:])
    return int(inner.sum())


def test_the_machine_staircase_keeps_the_limit_itself_near_the_bottom_of_a_dip():
    # a deep dip of the machine's limit (100 -> 10 -> 100 mm/s over 40 mm): stairs on its flanks
    # near the bottom would be zero accelerations the climb out of the dip cannot use yet
    s = np.linspace(0.0, 200.0, 10001)
    v = np.clip(10.0 + 4.5 * np.abs(s - 100.0), 10.0, 100.0)
    cap = FeedCap(s, v, 200.0)
    st_ = stairs(cap, LIM.feed_mm_s, LIM.tangential_acc_mm_s2, LIM.jerk_mm_s3, machine=True)
    plain = stairs(cap, LIM.feed_mm_s, LIM.tangential_acc_mm_s2, LIM.jerk_mm_s3)
    # within a transition of the bottom (a profile rising from 10 mm/s cannot be above the limit
    # there yet): the limit itself, raised, not stairs under it; the preprocessor holds the limit
    reach = np.array([transition_distance(10.0, x, LIM.tangential_acc_mm_s2, LIM.jerk_mm_s3) for x in v])
    near = (np.abs(s - 100.0) < reach) & (v > 10.0)
    assert near.sum() >= 10
    assert np.all(st_(s[near]) >= v[near])
    assert np.all(st_(s[near]) <= v[near] * MACHINE_ROOM * (1 + 1e-12))
    assert np.any(plain(s[near]) < v[near])  # where the plain staircase has steps
    # one dip, one local minimum: no step up where a plateau meets the limit itself
    assert _minima(st_) == 1
    assert st_.steps_mm.size < plain.steps_mm.size


def test_a_short_shallow_dip_of_the_machine_limit_gets_no_steps():
    # infinity's small dips: 100 -> 97.9 -> 100 mm/s over 3 mm; two 3 % steps would only add
    # two junctions (each a zero acceleration) — default approach slower than seed 000's own
    s = np.linspace(0.0, 100.0, 1001)
    v = np.minimum(100.0, 97.9 + 2.0 * ((s - 50.0) / 1.5) ** 2)
    cap = FeedCap(s, v, 100.0)
    st_ = stairs(cap, LIM.feed_mm_s, LIM.tangential_acc_mm_s2, LIM.jerk_mm_s3, machine=True)
    assert st_.steps_mm.size == 0
    assert np.all(st_(s) >= v)


def test_a_peak_too_short_for_its_transitions_is_lowered():
    need = STAIR_PLATEAU * transition_distance(STAIR_RATIO * 60.0, 60.0, LIM.tangential_acc_mm_s2, LIM.jerk_mm_s3)
    for width, kept in ((0.5 * need, False), (2.0 * need, True)):
        s = np.array([0.0, 100.0, 100.0, 100.0 + width, 100.0 + width, 300.0])
        cap = FeedCap(s, np.array([40.0, 40.0, 60.0, 60.0, 40.0, 40.0]), 300.0)
        st_ = stairs(cap, LIM.feed_mm_s, LIM.tangential_acc_mm_s2, LIM.jerk_mm_s3)
        peak = float(st_(np.array([100.0 + 0.5 * width]))[0])
        if kept:
            assert peak == 60.0 and st_.steps_mm.size == 2
        else:
            assert peak == 40.0 and st_.steps_mm.size == 0


def test_a_dip_faster_than_a_transition_is_kept_as_it_is():
    # an advice's dip at a corner: 80 -> 10 -> 80 mm/s within 1 mm; stairs there would be junctions
    # (zero accelerations) the profile never touches
    s = np.array([0.0, 50.0, 50.5, 51.0, 100.0])
    cap = FeedCap(s, np.array([80.0, 80.0, 10.0, 80.0, 80.0]), 100.0)
    st_ = stairs(cap, LIM.feed_mm_s, LIM.tangential_acc_mm_s2, LIM.jerk_mm_s3)
    x = np.linspace(50.1, 50.9, 81)
    inside = (np.abs(x - 50.5) > 0.15) & (np.abs(x - 50.5) < 0.45)  # the bottom cells are its minimum
    np.testing.assert_allclose(st_(x)[inside], cap(x)[inside], rtol=1e-12)
    assert st_.steps_mm.size <= 4


def test_a_sharp_dip_of_the_cap_is_held_from_the_positions():
    # end to end, from the positions: a V of the cap whose bottom lies between reference points
    from fuzzyfeed.geometry.nurbs import Nurbs

    line = Nurbs(1, [0, 0, 1, 1], [[0.0, 0.0], [100.0, 0.0]])
    s = np.array([0.0, 50.0, 50.5333, 51.1, 100.0])
    v = np.array([80.0, 80.0, 9.0, 80.0, 80.0])
    traj = schedule(line, LIM, feed_cap=(s, v), planner="window", transition="cosine")
    cap = FeedCap(s, v, 100.0)
    step = np.linalg.norm(np.diff(traj.xyz, axis=0), axis=1) / LIM.ts_s
    # the cap's least value over each tick's chord (its ends and any cap point inside)
    lowest = np.minimum(cap(traj.s_mm[:-1]), cap(traj.s_mm[1:]))
    inside = np.searchsorted(traj.s_mm, s[1:-1])
    for k, vk in zip(inside, v[1:-1]):
        if 0 < k < lowest.size + 1:
            lowest[k - 1] = min(lowest[k - 1], vk)
    assert np.all(step <= lowest * 1.005 + 1e-9)
    assert measure(traj)["jerk"] <= 1.0 + 1e-6


def test_a_constant_cap_stays_constant():
    cap = FeedCap(np.array([0.0, 50.0]), np.array([37.5, 37.5]), 50.0)
    st_ = stairs(cap, LIM.feed_mm_s, LIM.tangential_acc_mm_s2, LIM.jerk_mm_s3)
    np.testing.assert_array_equal(st_.feed_mm_s, [37.5, 37.5])
    assert st_.steps_mm.size == 0


def test_a_wandering_advice_is_followed_without_a_repair_storm():
    # the report: compare's fuzzy-safe followed the advice in 3 % stairs, one look-ahead
    # repair each (1429 junctions added on 585 mm); the staircase is planned once instead
    rng = np.random.default_rng(300)
    ang = np.cumsum(rng.uniform(-0.6, 0.6, 80))
    pts = np.cumsum(np.column_stack([np.cos(ang), np.sin(ang)]) * rng.uniform(1.5, 2.5, 80)[:, None], axis=0)
    from fuzzyfeed.geometry.nurbs import Nurbs

    knots = np.concatenate([[0.0] * 4, np.linspace(0, 1, 78)[1:-1], [1.0] * 4])
    curve = Nurbs(3, knots, pts)
    smp = sample_uniform_u(curve, 2000)
    wobble = 25.0 + 8.0 * np.sin(smp.s / 3.0) + 3.0 * np.sin(smp.s * 1.7)
    traj = schedule(curve, LIM, feed_cap=(smp.s, wobble), planner="window", transition="cosine")
    cap = FeedCap(np.asarray(smp.s), wobble, traj.curve.length)
    m = measure(traj)
    for key in ("feed", "axis_vel", "axis_acc", "chord", "jerk"):
        assert m[key] <= 1.005, (key, m)
    # the cap from the positions (chord per tick over Ts), against the cap at the chord's ends
    chord = np.linalg.norm(np.diff(traj.xyz, axis=0), axis=1) / LIM.ts_s
    lowest = np.minimum(cap(traj.s_mm[:-1]), cap(traj.s_mm[1:]))
    assert np.all(chord <= lowest * 1.005)
    assert traj.stats.junctions_added <= 0.05 * traj.stats.blocks_out, traj.stats
    # and no slower than 10 % over the time the cap alone allows (∫ ds / cap)
    x = np.linspace(0.0, traj.curve.length, 200001)
    assert traj.cycle_time_s <= 1.10 * np.trapezoid(1.0 / cap(x), x) + 0.5


def test_a_machine_limit_under_a_flat_cap_is_still_a_critical_point():
    # regression: on butterfly, a cap plateau flattened two reference points either side of a
    # curvature spike, its minimum was never found and the spike was passed at the cap's feed
    # (axis acceleration 2.36x its limit)
    curve = load_shape("butterfly").curve
    plain = schedule(curve, LIM, planner="window", transition="cosine")
    spike = plain.critical_s_mm[np.argmin(np.interp(plain.critical_s_mm, plain.s_mm, plain.feed_mm_s))]
    level = 1.5 * float(np.interp(spike, plain.s_mm, plain.feed_mm_s))
    cap = (np.array([0.0, curve.length]), np.array([level, level]))
    traj = schedule(curve, LIM, feed_cap=cap, planner="window", transition="cosine")
    m = measure(traj)
    assert m["axis_acc"] <= 1.005 and m["feed"] <= 1.005, m
    assert np.min(np.abs(traj.critical_s_mm - spike)) < 0.01


def test_bad_caps_are_refused():
    with pytest.raises(InputError, match="feed_cap"):
        FeedCap(np.array([0.0, 1.0]), np.array([10.0, np.nan]), 1.0)
    with pytest.raises(InputError, match="non-decreasing"):
        FeedCap(np.array([0.0, 2.0, 1.0]), np.array([10.0, 10.0, 10.0]), 2.0)
