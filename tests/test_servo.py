"""Servo model and contour error: closed-form cases, scipy's continuous-time simulation, geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from conftest import circle_nurbs
from fuzzyfeed.errors import MachineLimitsError
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.machine.profile import FeedProfile
from fuzzyfeed.geometry.sampling import sample_uniform_u
from fuzzyfeed.machine.servo import ServoModel, following_errors, nearest_on_curve, steady_circle_error_mm
from fuzzyfeed.machine.simulate import simulate_profile

#: A machine whose limits never bind here (the servo is what is tested).
LOOSE = MachineLimits(feed_mm_s=200.0, axis_vel_mm_s=1e4, axis_acc_mm_s2=1e6, jerk_mm_s3=1e9, chord_tol_mm=1.0)


def line_nurbs(end=(100.0, 100.0)) -> Nurbs:
    return Nurbs(1, [0, 0, 1, 1], [(0.0, 0.0), end], [1, 1])


def run_constant(curve: Nurbs, feed: float, servo: ServoModel, points: int = 200):
    samples = sample_uniform_u(curve, points)
    profile = FeedProfile(samples, np.full(len(samples), feed), "constant", feed)
    return simulate_profile(profile, LOOSE, servo=servo)


def steady(sim, kv: float, settle: float = 12.0) -> np.ndarray:
    """Ticks after the start transient (e^-12 ≈ 6e-6 of the initial lag) and before the end."""
    t = sim.law.t_s
    return (t > settle / kv) & (t < t[-1] - 2 * sim.law.ts_s)


@pytest.mark.parametrize("radius, feed, kv", [(10.0, 50.0, 30.0), (2.0, 20.0, 30.0), (20.0, 100.0, 30.0),
                                              (40.0, 150.0, 60.0), (3.0, 10.0, 15.0)])
def test_circle_steady_radial_error_first_order(radius, feed, kv):
    """Seed 002's tracking error on a circle, first order without feed-forward: r(1 − 1/√(1 + (v/(r·Kv))²))."""
    sim = run_constant(circle_nurbs(radius), feed, ServoModel(kv_1_s=kv), points=400)
    expected = radius * (1.0 - 1.0 / math.sqrt(1.0 + (feed / (radius * kv)) ** 2))
    contour = sim.tracking.contour_mm[steady(sim, kv)]
    assert contour.size > 50
    np.testing.assert_allclose(contour, expected, rtol=0.01)
    assert sim.metrics.contour_err_max_um == pytest.approx(expected * 1e3, rel=0.01)
    # the axes lag v/Kv behind (first order): the following error is the chord of that arc lag
    assert steady_circle_error_mm(ServoModel(kv_1_s=kv), radius, feed) == pytest.approx(expected, rel=1e-12)


def test_circle_steady_radial_error_feedforward():
    """With feed-forward α the axes settle on a circle of radius r·|G(jω)|, G = (Kv + αs)/(s + Kv)."""
    radius, feed, kv, ff = 5.0, 80.0, 30.0, 0.6
    w = feed / radius
    expected = radius * (1.0 - math.sqrt((kv**2 + (ff * w) ** 2) / (kv**2 + w**2)))
    sim = run_constant(circle_nurbs(radius), feed, ServoModel(kv_1_s=kv, feedforward=ff), points=400)
    np.testing.assert_allclose(sim.tracking.contour_mm[steady(sim, kv)], expected, rtol=0.01)


def test_equal_gains_straight_line_has_no_contour_error():
    sim = run_constant(line_nurbs(), 100.0, ServoModel(kv_1_s=30.0))
    assert sim.metrics.following_err_max_um == pytest.approx(100.0 / 30.0 * 1e3, rel=1e-3)
    assert sim.metrics.contour_err_max_um < 1e-6


@pytest.mark.parametrize("kv", [(20.0, 40.0, 30.0), (45.0, 25.0, 30.0)])
def test_unequal_gains_on_a_45_degree_line(kv):
    """Lag mismatch: e_x = v_x/Kx, e_y = v_y/Ky; the distance from the 45° line is
    |e_x − e_y|/√2 = (v/2)·|1/Kx − 1/Ky|."""
    feed = 60.0
    sim = run_constant(line_nurbs(), feed, ServoModel(kv_1_s=kv))
    expected = 0.5 * feed * abs(1.0 / kv[0] - 1.0 / kv[1])
    contour = sim.tracking.contour_mm[steady(sim, min(kv[:2]))]
    np.testing.assert_allclose(contour, expected, rtol=1e-4)


def test_full_feedforward_on_a_line():
    # from rest, accelerating, cruising and stopping: the first-order loop with α = 1 tracks exactly
    curve = line_nurbs((80.0, 30.0))
    samples = sample_uniform_u(curve, 300)
    feed = np.minimum(100.0, np.sqrt(2 * 500.0 * np.minimum(samples.s, samples.length - samples.s)))
    profile = FeedProfile(samples, feed, "trapezoid", 100.0)
    full = simulate_profile(profile, LOOSE, servo=ServoModel(kv_1_s=(20.0, 50.0, 30.0), feedforward=1.0))
    assert full.metrics.contour_err_max_um < 1e-6 and full.metrics.following_err_max_um < 1e-6
    none = simulate_profile(profile, LOOSE, servo=ServoModel(kv_1_s=(20.0, 50.0, 30.0)))
    assert none.metrics.contour_err_max_um > 100.0   # the mismatch without feed-forward is 100s of µm


@pytest.mark.parametrize("servo", [
    ServoModel(kv_1_s=(25.0, 40.0, 30.0), feedforward=(0.0, 0.5, 0.0)),
    ServoModel(natural_freq_hz=8.0, damping=0.7),
    ServoModel(natural_freq_hz=(5.0, 12.0, 9.0), damping=(0.4, 1.2, 0.7), feedforward=0.8),
])
def test_following_error_matches_scipy_continuous_simulation(servo):
    """The exact discretisation equals scipy's lsim of the continuous loop on the linearly
    interpolated command (first-order hold), at every tick."""
    ts = 0.001
    t = np.arange(0, 1.2, ts)
    cmd = np.stack([20 * np.sin(3 * t) + 5 * t**2, 10 * (1 - np.cos(7 * t)), np.zeros_like(t)], axis=1)
    ours = following_errors(servo, cmd, ts)
    for j in range(2):
        kv, ff = servo.kv_1_s[j], servo.feedforward[j]
        if servo.order == 1:
            system = signal.lti(np.trim_zeros([ff, kv], "f"), [1.0, kv])
        else:
            wn, z = 2 * np.pi * servo.natural_freq_hz[j], servo.damping[j]
            system = signal.lti(np.trim_zeros([2 * z * wn * ff, wn * wn], "f"), [1.0, 2 * z * wn, wn * wn])
        # scipy's state starts at 0; a loop at rest on the first point is a shift of the input
        _, x, _ = signal.lsim(system, cmd[:, j] - cmd[0, j], t, interp=True)
        np.testing.assert_allclose(ours[:, j], cmd[:, j] - cmd[0, j] - x, rtol=0, atol=1e-9)


def test_second_order_gain_and_circle():
    servo = ServoModel(natural_freq_hz=10.0, damping=0.8)
    assert servo.kv_1_s == pytest.approx((2 * np.pi * 10 / 1.6,) * 3)
    # a constant feed lags v/Kv, as for the first order with the same gain (after an overshoot)
    sim = run_constant(line_nurbs(), 50.0, servo)
    np.testing.assert_allclose(sim.tracking.following_mm[steady(sim, servo.kv_1_s[0], settle=20)],
                               50.0 / servo.kv_1_s[0], rtol=1e-6)
    assert sim.metrics.following_err_max_um > 50.0 / servo.kv_1_s[0] * 1e3
    radius, feed = 4.0, 60.0
    circle = run_constant(circle_nurbs(radius), feed, servo, points=400)
    np.testing.assert_allclose(circle.tracking.contour_mm[steady(circle, servo.kv_1_s[0], settle=20)],
                               steady_circle_error_mm(servo, radius, feed), rtol=0.01)


def test_heidenhain_gain_and_validation():
    assert ServoModel.from_kv_m_min_mm(1.8).kv_1_s == pytest.approx((30.0,) * 3)
    assert ServoModel().kv_1_s == (30.0, 30.0, 30.0) and ServoModel().feedforward == (0.0, 0.0, 0.0)
    with pytest.raises(MachineLimitsError, match=r"servo feedforward\[y\] = 1.5; must be a finite number >= 0"):
        ServoModel(feedforward=(0.0, 1.5, 0.0))
    with pytest.raises(MachineLimitsError, match=r"servo kv_1_s = 0"):
        ServoModel(kv_1_s=0)
    with pytest.raises(MachineLimitsError, match=r"servo kv_1_s = nan"):
        ServoModel(kv_1_s=float("nan"))
    with pytest.raises(MachineLimitsError, match="exactly 3"):
        ServoModel(kv_1_s=(30.0, 30.0))
    with pytest.raises(MachineLimitsError, match="give one or the other"):
        ServoModel(kv_1_s=30.0, natural_freq_hz=10.0)
    with pytest.raises(ValueError):  # also a builtin
        ServoModel(damping=-1)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 2 * np.pi), st.floats(-3.0, 3.0)), min_size=1, max_size=30))
def test_nearest_on_circle_is_exact(polar):
    """Distance from a circle is ||p − c| − r| (points inside and outside, up to 3 mm off)."""
    radius = 5.0
    curve = circle_nurbs(radius, center=(1.0, -2.0))
    ang = np.array([a for a, _ in polar])
    off = np.array([o for _, o in polar])
    pts = np.stack([1.0 + (radius + off) * np.cos(ang), -2.0 + (radius + off) * np.sin(ang),
                    np.zeros_like(ang)], axis=1)
    u, dist = nearest_on_curve(curve, pts)
    np.testing.assert_allclose(dist, np.abs(off), rtol=0, atol=1e-9)
    foot = curve(u)
    np.testing.assert_allclose(np.linalg.norm(foot - pts[:, :2], axis=1), dist, atol=1e-12)
    # the foot point itself: on the ray from the centre through the point (off the centre)
    rays = np.abs(radius + off) > 0.5
    want = 1.0 + radius * np.cos(ang), -2.0 + radius * np.sin(ang)
    sign = np.sign(radius + off)
    np.testing.assert_allclose(foot[rays, 0], (1.0 + sign * (want[0] - 1.0))[rays], atol=1e-10)
    np.testing.assert_allclose(foot[rays, 1], (-2.0 + sign * (want[1] + 2.0))[rays], atol=1e-10)


def test_nearest_is_global_on_a_hairpin():
    """A point across a tight hairpin is nearest to the other branch; brute force agrees."""
    curve = Nurbs(2, [0, 0, 0, 1, 1, 1], [(0.0, 0.0), (20.0, 0.5), (0.0, 1.0)], [1, 1, 1])
    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.uniform(-1, 12, 200), rng.uniform(-0.5, 1.5, 200)])
    _, dist = nearest_on_curve(curve, pts)
    dense = curve(np.linspace(0, 1, 400_001))
    brute = np.min(np.linalg.norm(dense[None, :, :] - pts[:20, None, :], axis=-1), axis=1)
    np.testing.assert_allclose(dist[:20], brute, atol=2e-6)
    assert np.all(dist[:20] <= brute + 1e-12)
