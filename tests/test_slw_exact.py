"""The look-ahead's exact path read (slw/exact.py, compiled in slw/_exact_jit.py) against
preprocess._evaluate, the numpy code it replaces in the check: bit for bit on random NURBS
(2-D, 3-D, rational, a near-cusp), fitted polylines, with and without a feed cap, on machines with
unequal axes; and a derivative that is not finite takes _evaluate's own path."""

import numpy as np
import pytest

import slw_cases
from fuzzyfeed.geometry.polyline_fit import fit_polyline
from fuzzyfeed.io.shapes import load_shape
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.slw.exact import evaluate_exact
from fuzzyfeed.slw.feed_cap import FeedCap, stairs
from fuzzyfeed.slw.preprocess import _evaluate, machine_cap

SLOW_Y = MachineLimits(axis_vel_mm_s=(100, 50, 100), axis_acc_mm_s2=(1000, 250, 1000))


def _same_reference(a, b):
    for f in ("s", "u", "vlim", "tangent", "kn"):
        x, y = getattr(a, f), getattr(b, f)
        assert x.shape == y.shape, f
        # bit for bit (NaN equal to NaN, and the sign of a zero too)
        assert np.array_equal(x.view(np.int64), y.view(np.int64)), (f, np.flatnonzero(x != y)[:5])


def _points(curve, rng, n):
    total = curve.length
    s = np.sort(rng.uniform(0.0, total, n))
    s[0], s[-1] = 0.0, total
    u = np.clip(np.asarray(curve.param_at_length(s)) + rng.normal(0.0, 1e-9, n), *curve.domain)
    return s, u


@pytest.mark.parametrize("seed", range(12))
def test_random_nurbs_bit_for_bit(seed):
    curve, lim = slw_cases.random_nurbs(seed)
    rng = np.random.default_rng(seed)
    s, u = _points(curve, rng, 3000)
    for limits in (lim, SLOW_Y):
        cap = FeedCap(np.array([0.0, curve.length / 3, curve.length / 3, curve.length]),
                      np.array([30.0, 60.0, 20.0, 80.0]), curve.length)
        for c in (None, cap):
            _same_reference(evaluate_exact(curve, limits, s, c, u), _evaluate(curve, limits, s, c, u))


@pytest.mark.parametrize("name", ["cusp", "butterfly", "cam"])
def test_shapes_and_polylines_bit_for_bit(name):
    if name == "cusp":
        curve = slw_cases.cusp_cubic()
    elif name == "butterfly":
        curve = load_shape("butterfly").curve
    else:
        curve = fit_polyline(slw_cases.cam_polyline(2000)).curve
    rng = np.random.default_rng(7)
    s, u = _points(curve, rng, 20000)
    for limits in (MachineLimits(), SLOW_Y):
        cap = stairs(machine_cap(curve, limits), limits.feed_mm_s, limits.tangential_acc_mm_s2,
                     limits.jerk_mm_s3, machine=True)
        for c in (None, cap):
            _same_reference(evaluate_exact(curve, limits, s, c, u), _evaluate(curve, limits, s, c, u))
        # a few points (the numpy form of the NURBS evaluation) and one
        _same_reference(evaluate_exact(curve, limits, s[:5], cap, u[:5]), _evaluate(curve, limits, s[:5], cap, u[:5]))
        _same_reference(evaluate_exact(curve, limits, s[3:4], None, u[3:4]), _evaluate(curve, limits, s[3:4], None, u[3:4]))


def test_stationary_point_and_corner():
    """A polyline's vertex (zero-length derivative side) and a repeated control point (|C′| = 0)."""
    curve = slw_cases.polyline([[0, 0], [10, 0], [10, 10], [0, 10]])
    u = np.array([0.0, 1 / 3, 0.5, 2 / 3, 1.0])
    s = np.asarray(curve.arc_length(u))
    _same_reference(evaluate_exact(curve, SLOW_Y, s, None, u), _evaluate(curve, SLOW_Y, s, None, u))
    from fuzzyfeed.geometry.nurbs import Nurbs

    stop = Nurbs(2, np.array([0, 0, 0, 1, 1, 1.0]), np.array([[0, 0], [0, 0], [5, 5.0]]))
    u = np.array([0.0, 1e-12, 0.5, 1.0])
    s = np.asarray(stop.arc_length(u))
    _same_reference(evaluate_exact(stop, SLOW_Y, s, None, u), _evaluate(stop, SLOW_Y, s, None, u))
