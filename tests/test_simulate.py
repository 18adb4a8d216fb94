"""The one simulator: analytic values for a constant feed on a circle, time-law construction."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import circle_nurbs
from fuzzyfeed.errors import InputError
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.machine.profile import FeedProfile
from fuzzyfeed.geometry.sampling import sample_uniform_u
from fuzzyfeed.machine.simulate import simulate_profile, time_law_from_profile


@pytest.mark.parametrize("radius, feed", [(10.0, 50.0), (2.0, 20.0), (40.0, 100.0)])
def test_constant_feed_on_circle_matches_analytic(radius, feed):
    samples = sample_uniform_u(circle_nurbs(radius), 400)
    profile = FeedProfile(samples, np.full(len(samples), feed), "constant", feed)
    limits = MachineLimits(feed_mm_s=100.0, axis_acc_mm_s2=1e6, ts_s=0.001)
    sim = simulate_profile(profile, limits)
    m = sim.metrics
    length = 2 * np.pi * radius
    assert m.cycle_time_s == pytest.approx(length / feed, rel=1e-12)
    chord = feed * limits.ts_s
    sagitta_um = (radius - np.sqrt(radius**2 - chord**2 / 4)) * 1e3
    assert m.chord_err_max_um == pytest.approx(sagitta_um, rel=1e-4)
    assert m.chord_err_mean_um == pytest.approx(sagitta_um, rel=1e-2)
    assert m.feed_max_mm_s == pytest.approx(feed, rel=1e-5)
    assert m.feed_fluct_max_pct < 1e-3
    # centripetal acceleration v²/r shows on the axes between the ticks, with the speed on x and y
    inner = np.diff(sim.xyz[:-1], 2, axis=0) / limits.ts_s**2
    assert np.abs(inner[:, :2]).max() == pytest.approx(feed**2 / radius, rel=1e-3)
    # the start from rest and the stop at rest count too: a jump to F within one servo period
    assert max(m.axis_acc_max_mm_s2[:2]) == pytest.approx(feed / limits.ts_s, rel=1e-3)
    assert max(m.axis_vel_max_mm_s[:2]) == pytest.approx(feed, rel=1e-5)
    assert m.axis_vel_max_mm_s[2] == 0.0
    assert m.tan_acc_max_mm_s2 == 0.0 and m.tan_jerk_max_mm_s3 == 0.0
    assert all(count == 0 for count, _ in m.violations.values())


def test_violations_are_counted():
    samples = sample_uniform_u(circle_nurbs(1.0), 400)
    profile = FeedProfile(samples, np.full(len(samples), 100.0), "constant", 100.0)
    m = simulate_profile(profile, MachineLimits()).metrics
    count, worst = m.violations["axis_acc_x"]
    assert count > 0 and worst == pytest.approx(100.0**2 / 1.0 / 1000.0, rel=1e-2)
    count, worst = m.violations["chord_error"]
    assert count > 0 and worst == pytest.approx(1.25, rel=1e-3)  # sagitta 1.25 µm vs 1 µm


def test_time_law_constant_acceleration_segments():
    samples = sample_uniform_u(circle_nurbs(5.0), 101)
    v = np.linspace(0.0, 50.0, 101)  # ramp from rest: v² is not linear in s, T = Σ 2Δs/(va+vb)
    profile = FeedProfile(samples, v, "ramp", 50.0)
    law = time_law_from_profile(profile, 0.001)
    ds = np.diff(samples.s)
    assert law.duration_s == pytest.approx(np.sum(2 * ds / (v[:-1] + v[1:])), rel=1e-12)
    assert law.s_mm[0] == 0.0 and law.s_mm[-1] == samples.length
    assert np.all(np.diff(law.s_mm) >= 0)
    assert (law.s_mm.size - 2) * 0.001 < law.duration_s <= (law.s_mm.size - 1) * 0.001 + 1e-12
    # the feed at each tick is the derivative of s: compare with central differences
    mid = slice(5, -5)
    np.testing.assert_allclose(np.gradient(law.s_mm, 0.001)[mid], law.feed_mm_s[mid], rtol=2e-2, atol=0.2)


def test_stalled_profile_is_an_error():
    samples = sample_uniform_u(circle_nurbs(5.0), 11)
    feed = np.ones(11)
    feed[4:6] = 0.0
    with pytest.raises(InputError, match=r"feed is 0 at both samples 4 and 5"):
        time_law_from_profile(FeedProfile(samples, feed, "bad", 1.0), 0.001)


def test_a_trajectory_simulates_the_same_with_its_own_positions():
    """Trajectory.simulate hands its u and positions to the simulator (no second evaluation, no
    copies): the metrics equal a simulation that evaluates them itself; positions of the wrong
    shape, or without their u, are refused."""
    from fuzzyfeed.machine.simulate import simulate
    from fuzzyfeed.slw import schedule

    curve = circle_nurbs(10.0)
    traj = schedule(curve, MachineLimits(), planner="window", transition="cosine")
    shared = traj.simulate()
    own = simulate(traj.curve, traj.time_law(), traj.limits, "slw", u=traj.u)
    a, b = shared.metrics.row(), own.metrics.row()
    assert a.keys() == b.keys()
    assert all(a[k] == b[k] or (a[k] != a[k] and b[k] != b[k]) for k in a)  # nan == nan here
    assert traj.time_law().s_mm is traj.s_mm  # read-only: shared, not copied
    with pytest.raises(InputError, match="xyz"):
        simulate(traj.curve, traj.time_law(), traj.limits, "slw", u=traj.u, xyz=traj.xyz[:-1])
    with pytest.raises(InputError, match="xyz"):
        simulate(traj.curve, traj.time_law(), traj.limits, "slw", xyz=traj.xyz)
    bad = traj.xyz.copy()
    bad[3, 1] = np.nan
    with pytest.raises(InputError, match=r"xyz\[3\] is not finite"):
        simulate(traj.curve, traj.time_law(), traj.limits, "slw", u=traj.u, xyz=bad)
