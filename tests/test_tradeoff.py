"""The time/accuracy trade-off: claims against a constant feed, equal-error search, Pareto families."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import circle_nurbs
from fuzzyfeed.io.shapes import load_shape, sample_shape
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.geometry.sampling import sample_uniform_u
from fuzzyfeed.machine.servo import ServoModel
from fuzzyfeed.report.tradeoff import claims_vs_constant, equal_error_feed, pareto_points


def test_on_a_circle_the_advice_is_a_constant_feed():
    """Constant curvature: the advice is one feed, so neither claim can show an advantage."""
    samples = sample_uniform_u(circle_nurbs(8.0), 600)
    (claim,) = claims_vs_constant(samples, MachineLimits(), [1200.0])
    assert claim.error_reduction_pct == pytest.approx(0.0, abs=1e-6)
    assert claim.time_reduction_pct == pytest.approx(0.0, abs=0.5)


@pytest.mark.parametrize("radius, target_um, kv", [(8.0, 40.0, 30.0), (3.0, 5.0, 60.0)])
def test_equal_error_feed_inverts_the_circle_formula(radius, target_um, kv):
    """r(1 − 1/√(1 + (v/(r·Kv))²)) = ε  ⇔  v = r·Kv·√(1/(1 − ε/r)² − 1) (first order)."""
    samples = sample_uniform_u(circle_nurbs(radius), 600)
    servo = ServoModel(kv_1_s=kv)
    eps = target_um * 1e-3
    expected = radius * kv * math.sqrt(1.0 / (1.0 - eps / radius) ** 2 - 1.0)
    feed, m = equal_error_feed(samples, MachineLimits(), target_um, start_mm_s=50.0,
                               start_err_um=200.0, servo=servo)
    assert m.contour_err_max_um == pytest.approx(target_um, rel=0.01)
    assert feed == pytest.approx(expected, rel=0.01)


def test_claims_and_pareto_on_trident():
    samples = sample_shape(load_shape("trident"), 600)
    limits = MachineLimits()
    (claim,) = claims_vs_constant(samples, limits, [3000.0])
    # the equal-time constant feed is L / T, and the equal-error one matches the fuzzy error
    assert claim.equal_time_feed_mm_min == pytest.approx(60.0 * samples.length / claim.fuzzy_time_s)
    assert claim.equal_err_time_s == pytest.approx(60.0 * samples.length / claim.equal_err_feed_mm_min)
    assert claim.error_reduction_pct > 0 and claim.time_reduction_pct > 0
    points = pareto_points(samples, limits, [3000.0], tolerances_um=[30.0])
    families = [p.family for p in points]
    assert families == ["fuzzy", "fuzzy-safe", "slw", "constant", "slw-tol"]
    fuzzy = points[0]
    assert fuzzy.cycle_time_s == pytest.approx(claim.fuzzy_time_s)
    assert fuzzy.contour_err_max_um == pytest.approx(claim.fuzzy_err_um)
    # a contour tolerance ε is the centripetal limit A = 2·Kv²·ε: the SLW keeps about ε
    slw_tol = points[-1]
    assert slw_tol.violating_ticks == 0
    assert 0.7 * 30.0 < slw_tol.contour_err_max_um < 1.3 * 30.0
    assert np.isfinite([p.contour_err_mean_um for p in points]).all()
