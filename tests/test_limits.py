"""MachineLimits validation and the pointwise feed limits (seed 000, eq. (8)-(12))."""

import math

import numpy as np
import pytest

from fuzzyfeed.errors import MachineLimitsError
from fuzzyfeed.machine.limits import MachineLimits, feed_limit_components, feed_limits
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.geometry.sampling import sample_by_arc_length, samples_from_points


def circle(radius: float) -> Nurbs:
    w = math.sqrt(0.5)
    pts = np.array([[radius, 0], [radius, radius], [0, radius], [-radius, radius], [-radius, 0]])
    return Nurbs(2, [0, 0, 0, 0.5, 0.5, 1, 1, 1], pts, [1, w, 1, w, 1])


def test_defaults_are_the_issue_machine():
    lim = MachineLimits.default()
    assert lim.feed_mm_s == 100.0 and lim.feed_mm_min == 6000.0
    assert lim.axis_vel_mm_s == (100.0, 100.0, 100.0)
    assert lim.axis_acc_mm_s2 == (1000.0, 1000.0, 1000.0)
    assert (lim.jerk_mm_s3, lim.chord_tol_mm, lim.ts_s) == (10_000.0, 0.001, 0.001)


def test_scalar_is_broadcast_and_tuple_kept():
    lim = MachineLimits(axis_vel_mm_s=50, axis_acc_mm_s2=(100, 200, 300))
    assert lim.axis_vel_mm_s == (50.0, 50.0, 50.0)
    assert lim.axis_acc_mm_s2 == (100.0, 200.0, 300.0)
    assert lim.tangential_acc_mm_s2 == 100.0
    assert MachineLimits.from_feed_mm_min(1200).feed_mm_s == 20.0


@pytest.mark.parametrize("field, value", [
    ("feed_mm_s", 0), ("feed_mm_s", -1), ("jerk_mm_s3", float("nan")), ("chord_tol_mm", float("inf")),
    ("ts_s", 0.0), ("ts_s", 5.0), ("axis_vel_mm_s", (1, 2)), ("axis_acc_mm_s2", (1, -2, 3)),
    ("feed_mm_s", "fast"), ("jerk_mm_s3", True),
])
def test_bad_values_name_field_and_value(field, value):
    with pytest.raises(MachineLimitsError) as err:
        MachineLimits(**{field: value})
    assert field in str(err.value)
    assert isinstance(err.value, ValueError)


def test_circle_limits_match_closed_forms():
    r = 5.0
    lim = MachineLimits(feed_mm_s=1000, axis_vel_mm_s=1000, axis_acc_mm_s2=(400, 900, 900),
                       chord_tol_mm=0.01, ts_s=0.002)
    smp = sample_by_arc_length(circle(r), n=401)
    comp = feed_limit_components(smp, lim)
    chord = 2 / lim.ts_s * math.sqrt(2 * r * lim.chord_tol_mm - lim.chord_tol_mm ** 2)
    assert np.allclose(comp[2], chord, rtol=1e-9)
    # centripetal: v^2/r * |N_j| <= A_j; the normal is along x at the half-circle's ends
    theta = smp.s / r
    nx, ny = np.abs(np.cos(theta)), np.abs(np.sin(theta))
    with np.errstate(divide="ignore"):
        expected = np.minimum(np.sqrt(400 * r / nx), np.sqrt(900 * r / ny))
    assert np.allclose(comp[3], np.minimum(expected, lim.feed_mm_s), rtol=1e-7)
    assert np.allclose(feed_limits(smp, lim), comp.min(axis=0))


def test_straight_line_is_limited_by_feed_and_axis_velocity():
    line = Nurbs(1, [0, 0, 1, 1], [[0, 0, 0], [30, 40, 0]])
    lim = MachineLimits(feed_mm_s=100, axis_vel_mm_s=(60, 100, 100))
    v = feed_limits(sample_by_arc_length(line, n=11), lim)
    assert np.allclose(v, 60 / 0.6)  # v * |T_x| <= 60 with T_x = 0.6
    lim2 = MachineLimits(feed_mm_s=50)
    assert np.allclose(feed_limits(sample_by_arc_length(line, n=11), lim2), 50)


def test_point_sequence_samples_work():
    t = np.linspace(0, np.pi, 200)
    pts = np.column_stack([10 * np.cos(t), 10 * np.sin(t)])
    v = feed_limits(samples_from_points(pts), MachineLimits())
    assert np.all(np.isfinite(v)) and np.all(v > 0) and np.all(v <= 100)
    assert np.median(v) == pytest.approx(100.0)  # r = 10: sqrt(1000*10) = 100
