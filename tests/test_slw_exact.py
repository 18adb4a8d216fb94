"""The scheduler's exact path read (slw/exact.py, compiled in slw/_exact_jit.py, behind
preprocess._evaluate) against the numpy code it replaces (samples_at, curvature_vectors,
feed_limits, the cap): bit for bit on random NURBS (2-D, 3-D, rational, a near-cusp), fitted
polylines, a corner and a stationary point, with and without a feed cap, on machines with unequal
axes; and whole schedules of the preprocessor's reference points with and without it."""

import numpy as np
import pytest

import slw_cases
from fuzzyfeed.geometry.polyline_fit import fit_polyline
from fuzzyfeed.io.shapes import load_shape
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.geometry.sampling import samples_at
from fuzzyfeed.machine.limits import curvature_vectors, feed_limits
from fuzzyfeed.slw.exact import exact_arrays
from fuzzyfeed.slw.feed_cap import FeedCap, stairs
from fuzzyfeed.slw.preprocess import Reference, _evaluate, machine_cap


def _numpy(curve, limits, s, cap, u):
    """preprocess._evaluate as it was, in numpy (the reference)."""
    smp = samples_at(curve, u, s=s)
    tangent = np.nan_to_num(np.asarray(smp.tangent), nan=0.0)
    kn = np.nan_to_num(curvature_vectors(smp), nan=np.inf)
    vlim = feed_limits(smp, limits)
    if cap is not None:
        vlim = np.minimum(vlim, cap(s))
    return Reference(s, u, vlim, tangent, kn)

SLOW_Y = MachineLimits(axis_vel_mm_s=(100, 50, 100), axis_acc_mm_s2=(1000, 250, 1000))


def _same_reference(a, b):
    for f in ("s", "u", "vlim", "tangent", "kn"):
        x, y = getattr(a, f), getattr(b, f)
        assert x.shape == y.shape, f
        # the same floats on the machine they were written on (same float order; numpy's SIMD
        # dispatch of a power may round the last bit differently on another CPU): within 1e-13
        assert np.array_equal(np.isfinite(x), np.isfinite(y)), f
        assert np.allclose(x, y, rtol=1e-13, atol=0.0, equal_nan=True), (f, np.flatnonzero(x != y)[:5])


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
            assert exact_arrays(curve, limits, s, c, u) is not None  # the compiled pass ran
            _same_reference(_evaluate(curve, limits, s, c, u), _numpy(curve, limits, s, c, u))
            # and at u(s) (the preprocessor's reference points)
            _same_reference(_evaluate(curve, limits, s[::7], c), _numpy(curve, limits, s[::7], c,
                                                                        np.asarray(curve.param_at_length(s[::7]))))


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
            _same_reference(_evaluate(curve, limits, s, c, u), _numpy(curve, limits, s, c, u))
        # a few points (the numpy form of the NURBS evaluation) and one
        _same_reference(_evaluate(curve, limits, s[:5], cap, u[:5]), _numpy(curve, limits, s[:5], cap, u[:5]))
        _same_reference(_evaluate(curve, limits, s[3:4], None, u[3:4]), _numpy(curve, limits, s[3:4], None, u[3:4]))


def test_stationary_point_and_corner():
    """A polyline's vertex (zero-length derivative side) and a repeated control point (|C′| = 0)."""
    curve = slw_cases.polyline([[0, 0], [10, 0], [10, 10], [0, 10]])
    u = np.array([0.0, 1 / 3, 0.5, 2 / 3, 1.0])
    s = np.asarray(curve.arc_length(u))
    _same_reference(_evaluate(curve, SLOW_Y, s, None, u), _numpy(curve, SLOW_Y, s, None, u))
    from fuzzyfeed.geometry.nurbs import Nurbs

    stop = Nurbs(2, np.array([0, 0, 0, 1, 1, 1.0]), np.array([[0, 0], [0, 0], [5, 5.0]]))
    u = np.array([0.0, 1e-12, 0.5, 1.0])
    s = np.asarray(stop.arc_length(u))
    _same_reference(_evaluate(stop, SLOW_Y, s, None, u), _numpy(stop, SLOW_Y, s, None, u))


def test_outside_the_domain_is_the_numpy_error():
    """A parameter outside the domain: the compiled pass steps aside, Nurbs.evaluate's error stays."""
    from fuzzyfeed.errors import NurbsError

    curve, lim = slw_cases.random_nurbs(3)
    u = np.array([0.5, curve.domain[1] + 1.0])
    assert exact_arrays(curve, lim, np.array([1.0, 2.0]), None, u) is None
    with pytest.raises(NurbsError):
        _evaluate(curve, lim, np.array([1.0, 2.0]), None, u)


@pytest.mark.parametrize("name", ["random", "butterfly", "cam"])
def test_window_feed_limit_bit_for_bit(name):
    """The window's lifted feed limit (window_check.BlockCheck._feed_limit, compiled in
    _exact_jit.window_feed_limit) against its numpy form: the path's own points (the lift fires
    where the centripetal part binds), random κN with zeros and a non-finite row, with and
    without a cap, on equal and unequal axes."""
    from fuzzyfeed.slw.lookahead import SlidingWindow

    if name == "random":
        curve = slw_cases.random_nurbs(5)[0]
    elif name == "butterfly":
        curve = load_shape("butterfly").curve
    else:
        curve = fit_polyline(slw_cases.cam_polyline(2000)).curve
    rng = np.random.default_rng(11)
    s, u = _points(curve, rng, 5000)
    fired = 0
    for limits in (MachineLimits(), SLOW_Y):
        ref = _evaluate(curve, limits, s, None, u)
        kn = ref.kn * np.where(rng.random((s.size, 1)) < 0.2, 10.0 ** rng.uniform(-3, 3, (s.size, 1)), 1.0)
        kn[rng.random(kn.shape) < 0.05] = 0.0
        kn[::501] = np.inf
        cap = FeedCap(np.array([0.0, curve.length / 3, curve.length / 3, curve.length]),
                      np.array([30.0, 60.0, 20.0, 80.0]), curve.length)
        for c in (None, cap):
            w = SlidingWindow(limits, curve, 2, c)
            for k in (ref.kn, kn):
                with np.errstate(all="ignore"):
                    cen = np.min(np.where(np.abs(k) > 0, np.sqrt(w.axis_acc / np.abs(k)), np.inf), axis=1)
                vlim = np.where(np.isfinite(cen) & (rng.random(s.size) < 0.5), cen, ref.vlim)
                want = w._feed_limit_numpy(s, vlim, ref.tangent, k)
                fired += int((want != vlim).sum())
                assert np.array_equal(w._feed_limit(s, vlim, ref.tangent, k), want, equal_nan=True)
    assert fired > 100  # the lift fired
