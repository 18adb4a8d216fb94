"""NURBS value object: cross-checked against geomdl, analytic circle, validation messages."""

from __future__ import annotations

import numpy as np
import pytest
from geomdl import NURBS as GeomdlNURBS

from conftest import circle_nurbs, random_nurbs_definition
from fuzzyfeed.errors import NurbsError
from fuzzyfeed.geometry.nurbs import Nurbs

RTOL = 1e-9


def geomdl_derivatives(degree, knots, points, weights, u):
    curve = GeomdlNURBS.Curve()
    curve.degree = degree
    curve.ctrlptsw = [list(np.asarray(p) * w) + [w] for p, w in zip(points, weights)]
    curve.knotvector = list(knots)
    return np.transpose(np.array([curve.derivatives(float(x), order=2) for x in u]), (1, 0, 2))


def assert_matches_geomdl(curve: Nurbs, u: np.ndarray) -> None:
    ours = curve.evaluate(u, order=2)
    ref = geomdl_derivatives(curve.degree, curve.knots, curve.control_points, curve.weights, u)
    for order in range(3):
        scale = max(1.0, float(np.abs(ref[order]).max()))
        err = float(np.abs(ours[order] - ref[order]).max()) / scale
        assert err <= RTOL, f"order {order}: relative error {err:.3e}"


def test_shipped_shapes_match_geomdl(shipped_shape):
    curve = shipped_shape.curve
    rng = np.random.default_rng(7)
    u = np.concatenate([[0.0, 1.0], rng.uniform(0, 1, 300)])
    assert_matches_geomdl(curve, u)


def test_random_nurbs_match_geomdl():
    rng = np.random.default_rng(2026)
    degrees, dims, repeated = set(), set(), 0
    for _ in range(220):
        d = random_nurbs_definition(rng)
        curve = Nurbs(d["degree"], d["knots"], d["points"], d["weights"])
        knots = np.asarray(d["knots"])
        u = rng.uniform(0, 1, 40)
        u = u[np.min(np.abs(u[:, None] - knots[None, :]), axis=1) > 1e-6]  # C'' may jump at knots
        assert_matches_geomdl(curve, u)
        degrees.add(curve.degree)
        dims.add(curve.dim)
        interior = knots[curve.degree + 1: -curve.degree - 1]
        repeated += int(interior.size > np.unique(interior).size)
    assert degrees == {1, 2, 3, 4, 5} and dims == {2, 3} and repeated >= 20


def test_circle_curvature_and_length():
    for r in (0.5, 3.0, 250.0):
        curve = circle_nurbs(r, center=(10.0, -4.0))
        u = np.linspace(0, 1, 4001)
        assert np.abs(curve.curvature(u) - 1.0 / r).max() <= 1e-10 / r
        assert abs(curve.length - 2 * np.pi * r) <= 1e-10 * max(1.0, r)
        assert np.abs(np.linalg.norm(curve(u) - [10.0, -4.0], axis=1) - r).max() <= 1e-12 * r


def test_arc_length_inverse_roundtrip(shipped_shape):
    curve = shipped_shape.curve
    s = np.linspace(0, curve.length, 777)
    u = curve.param_at_length(s)
    assert np.all(np.diff(u) > 0)
    assert np.abs(curve.arc_length(u) - s).max() <= 1e-9
    assert curve.param_at_length(0.0) == pytest.approx(curve.domain[0], abs=1e-15)
    assert curve.param_at_length(curve.length) == pytest.approx(curve.domain[1], abs=1e-12)


def test_param_at_length_inverts_arc_length_on_random_curves():
    """u(s) solves s(u) = s to 1e-13 of the length on random NURBS (degrees 2-5, random weights:
    speeds that rise and fall inside a span, where the Hermite first guess is poor), for targets
    dense and sorted (ticks) and scattered; s(u) here is the table's own GL from its breaks, so
    an error of the 3-point update over short Newton steps would show."""
    rng = np.random.default_rng(11)
    for _ in range(8):
        d = random_nurbs_definition(rng)
        curve = Nurbs(d["degree"], d["knots"], d["points"], d["weights"])
        total = curve.length
        for s in (np.linspace(0.0, total, 20_001), np.sort(rng.uniform(0.0, total, 3000))):
            u = curve.param_at_length(s)
            assert np.all(np.diff(u) >= 0)
            assert np.abs(curve.arc_length(u) - s).max() <= 1e-13 * max(total, 1.0)


def test_arc_length_against_dense_chords():
    """s(u) agrees with the chord length of a very fine polyline (independent estimate)."""
    curve = Nurbs(3, [0, 0, 0, 0, 0.3, 0.3, 0.7, 1, 1, 1, 1],
                  [[0, 0], [5, 9], [12, -3], [20, 4], [25, 25], [30, 0], [40, 2]],
                  [1, 2, 0.5, 1, 3, 1, 1])
    pts = curve(np.linspace(0, 1, 400_001))
    chords = np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()
    assert curve.length == pytest.approx(chords, rel=1e-8)


def test_non_unit_domain_is_reparametrised_copy():
    base = Nurbs(2, [0, 0, 0, 0.5, 1, 1, 1], [[0, 0], [1, 2], [3, 2], [4, 0]], [1, 2, 1, 1])
    scaled = Nurbs(2, [5, 5, 5, 7, 9, 9, 9], base.control_points, base.weights)
    u = np.linspace(0, 1, 101)
    ours = scaled.evaluate(5 + 4 * u)
    ref = base.evaluate(u)
    np.testing.assert_allclose(ours[0], ref[0], atol=1e-12)
    np.testing.assert_allclose(ours[1] * 4, ref[1], atol=1e-11)
    np.testing.assert_allclose(ours[2] * 16, ref[2], atol=1e-10)
    assert scaled.length == pytest.approx(base.length, rel=1e-13)


def test_scalar_and_value_object():
    curve = circle_nurbs(2.0)
    assert curve.evaluate(0.25).shape == (3, 2)
    assert curve(0.0).tolist() == [2.0, 0.0]
    with pytest.raises(ValueError):
        curve.knots[0] = 5.0  # read-only
    with pytest.raises(AttributeError):
        curve.degree = 3  # frozen
    with pytest.raises(NurbsError, match=r"u\[0\] = 1.5 is outside the curve's domain \[0, 1\]"):
        curve.evaluate(np.array([1.5]))


GOOD = {"degree": 2, "knots": [0, 0, 0, 0.5, 1, 1, 1], "points": [[0, 0], [1, 1], [2, 0], [3, 1]],
        "weights": [1, 1, 1, 1]}


@pytest.mark.parametrize("change, message", [
    ({"knots": [0, 0, 0, 0.5, 1, 1]}, r"knots: length 6, expected n \+ p \+ 1 = 4 \+ 2 \+ 1 = 7"),
    ({"knots": [0, 0, 0, 0.7, 0.5, 1, 1]}, r"knots\[4\] = 0.5 < knots\[3\] = 0.7; knots must be non-decreasing"),
    ({"knots": [0, 0, 0.1, 0.5, 1, 1, 1]}, r"knots\[2\] = 0.1; the knot vector must be clamped: the first"),
    ({"knots": [0, 0, 0, 0.5, 0.9, 1, 1]}, r"knots\[4\] = 0.9; the knot vector must be clamped: the last"),
    ({"weights": [1, 0, 1, 1]}, r"weights\[1\] = 0.0; weights must be finite and > 0"),
    ({"weights": [1, 1, -2, 1]}, r"weights\[2\] = -2.0; weights must be finite and > 0"),
    ({"weights": [1, 1, 1, float("nan")]}, r"weights\[3\] = nan; weights must be finite and > 0"),
    ({"weights": [1, 1, 1]}, r"weights: 3 values for 4 control points"),
    ({"points": [[0, 0], [1, float("nan")], [2, 0], [3, 1]]}, r"control_points\[1\]\[1\] = nan; coordinates must be finite"),
    ({"points": [[0], [1], [2], [3]]}, r"control_points: shape \(4, 1\) is not allowed"),
    ({"degree": 0, "knots": [0, 0.3, 0.6, 1]}, r"degree: 0 is not allowed; the degree must be >= 1"),
    ({"degree": 1.5}, r"degree: 1.5 is not an integer"),
    ({"degree": 3, "knots": [0, 0, 0, 0, 1, 1, 1]}, r"control_points: 4 points are too few for degree 3|knots: length"),
    ({"knots": [0, 0, 0, float("inf"), 1, 1, 1]}, r"knots\[3\] = inf; knots must be finite"),
    ({"knots": [1, 1, 1, 1, 1, 1, 1]}, r"knots: all equal to 1; the parameter range must not be empty"),
])
def test_validation_messages(change, message):
    d = {**GOOD, **change}
    with pytest.raises(NurbsError, match=message):
        Nurbs(d["degree"], d["knots"], d["points"], d["weights"])


def test_interior_knot_multiplicity_limit():
    with pytest.raises(NurbsError, match=r"knots\[3\] = 0.5 repeats 3 times; an interior knot may repeat at most p = 2"):
        Nurbs(2, [0, 0, 0, 0.5, 0.5, 0.5, 1, 1, 1], [[0, 0], [1, 1], [2, 0], [3, 1], [4, 4], [5, 0]])


def test_errors_are_value_errors_and_one_line():
    with pytest.raises(ValueError) as info:
        Nurbs(2, [0, 0, 0, 1, 1], [[0, 0], [1, 1], [2, 0], [3, 1]])
    assert "\n" not in str(info.value)


# ---------------------------------------------------------------------- streamed arc length
def test_arc_length_streamed_blocks_do_not_change_results(monkeypatch):
    """Blocks of 3 intervals and blocks of 8192 give the same s(u) and u(s) to 1e-12 relative,
    and both match closed forms: a circle's arcs r·θ and a line's |P1 − P0|·u."""
    from fuzzyfeed.geometry import arc_length

    r = 7.5
    circle = circle_nurbs(r)
    line = Nurbs(1, [0, 0, 1, 1], [[1.0, 2.0, 3.0], [4.0, -2.0, 15.0]])
    rng = np.random.default_rng(11)
    u = np.sort(rng.uniform(0, 1, 2500))
    results = {}
    for block in (8192, 3):
        monkeypatch.setattr(arc_length, "ARC_BLOCK_INTERVALS", block)
        fresh_circle = circle_nurbs(r)
        fresh_line = Nurbs(1, line.knots, line.control_points)
        s_c = fresh_circle.arc_length(u)
        s_l = fresh_line.arc_length(u)
        results[block] = (s_c, s_l, fresh_circle.param_at_length(s_c), fresh_line.param_at_length(s_l))
    for a, b in zip(results[8192], results[3]):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=0)
    s_c, s_l, u_c, u_l = results[3]
    pts = circle(u)
    theta = np.unwrap(np.arctan2(pts[:, 1], pts[:, 0]))
    np.testing.assert_allclose(s_c, r * theta, rtol=1e-12, atol=1e-12 * r)
    np.testing.assert_allclose(s_l, np.linalg.norm([3.0, -4.0, 12.0]) * u, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(u_c, u, atol=1e-12)
    np.testing.assert_allclose(u_l, u, atol=1e-12)


def test_arc_length_matches_adaptive_quadrature_on_random_curves():
    """s(u) against scipy's adaptive quad of |C′| (an independent integrator), random NURBS."""
    from scipy.integrate import quad

    rng = np.random.default_rng(5)
    for _ in range(6):
        d = random_nurbs_definition(rng)
        curve = Nurbs(d["degree"], d["knots"], d["points"], d["weights"])
        speed = lambda x: float(np.linalg.norm(curve.evaluate(x, order=1)[1]))  # noqa: E731
        breaks = curve.span_breaks
        for x in rng.uniform(0, 1, 3):
            pieces = [(a, min(b, x)) for a, b in zip(breaks[:-1], breaks[1:]) if a < x]
            want = sum(quad(speed, a, b, epsabs=1e-13, epsrel=1e-13, limit=200)[0] for a, b in pieces)
            assert curve.arc_length(x) == pytest.approx(want, rel=1e-10, abs=1e-10)
