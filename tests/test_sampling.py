"""Sampling layer: uniform in u, uniform in arc length, three-point curvature convergence."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import circle_nurbs
from fuzzyfeed.errors import InputError
from fuzzyfeed.io.shapes import load_shape
from fuzzyfeed.geometry.sampling import (sample_by_arc_length, sample_uniform_u, samples_from_points,
                                three_point_curvature)


def test_uniform_u_default_is_seed_002_grid():
    samples = sample_uniform_u(load_shape("infinity").curve)
    assert len(samples) == 2000
    np.testing.assert_allclose(np.diff(samples.u), 1 / 1999)
    assert samples.s[0] == 0.0 and samples.length == pytest.approx(475.162, abs=1e-3)
    assert np.all(np.diff(samples.s) > 0)
    np.testing.assert_allclose(np.linalg.norm(samples.tangent, axis=1), 1.0, atol=1e-12)
    assert samples.xyz.shape == (2000, 3) and samples.dim == 3


def test_planar_shape_gets_z_zero():
    samples = sample_uniform_u(load_shape("butterfly").curve, 500)
    assert samples.dim == 2 and np.all(samples.z == 0.0)
    assert set(samples.columns()) == {"u", "x_mm", "y_mm", "z_mm", "s_mm", "curvature_1_mm"}


def test_arc_length_step_sampling():
    curve = load_shape("trident").curve
    samples = sample_by_arc_length(curve, step_mm=0.25)
    ds = np.diff(samples.s)
    assert np.all(ds[:-1] == pytest.approx(0.25, abs=1e-12)) and 0 < ds[-1] <= 0.25 + 1e-12
    assert samples.s[-1] == curve.length
    np.testing.assert_allclose(curve.arc_length(samples.u), samples.s, atol=1e-9)
    assert len(sample_by_arc_length(curve, n=101)) == 101


@pytest.mark.parametrize("name", ["infinity", "trident", "wm"])
def test_three_point_curvature_converges(name):
    curve = load_shape(name).curve
    errors = []
    for n in (1000, 4000, 16000):
        samples = sample_by_arc_length(curve, n=n)
        k3 = three_point_curvature(samples.xyz)
        # κ jumps at the knots of a degree-2 curve (only C1 there): skip stencils that straddle one
        gap = np.diff(samples.u).max()
        inner = np.min(np.abs(samples.u[:, None] - curve.knots[None, :]), axis=1) > gap
        inner[:2] = inner[-2:] = False
        errors.append(np.abs(k3[inner] - samples.curvature[inner]).max() / samples.curvature.max())
    assert errors[2] < errors[1] < errors[0]
    assert errors[2] < 1e-3


def test_points_split_inside_long_segments():
    """Samples added inside long segments lie on the polyline, keep every vertex and its values,
    and carry κ = 0 between two corners and the circle's κ on the chords of a circle run."""
    theta = np.linspace(0.0, np.pi / 2, 31)
    arc = np.column_stack([30.0 + 10.0 * np.sin(theta), 10.0 - 10.0 * np.cos(theta)])
    square = [[0.0, 0.0], [30.0, 0.0]]
    pts = np.round(np.vstack([square, arc[1:], [[40.0, 40.0], [0.0, 40.0]]]), 4)
    plain = samples_from_points(pts)
    split = samples_from_points(pts, max_step_mm=0.25)
    assert split.length == pytest.approx(plain.length, rel=1e-12)
    assert np.diff(split.s).max() <= 0.25 + 1e-9
    at = np.array([int(np.argmin(np.abs(split.s - s_v))) for s_v in plain.s])
    vertex = np.zeros(len(split), dtype=bool)
    vertex[at] = True
    np.testing.assert_array_equal(split.xyz[vertex], plain.xyz)
    np.testing.assert_array_equal(split.curvature[vertex], plain.curvature)
    # every added sample lies on its segment (distance from the chord through its neighbours)
    inner = np.flatnonzero(~vertex)
    a, b = split.xyz[inner - 1], split.xyz[inner + 1]
    cross = np.cross(b - a, split.xyz[inner] - a)
    assert np.abs(cross).max() / np.linalg.norm(b - a, axis=1).min() < 1e-9
    on_first_line = ~vertex & (split.s < 29.0)
    assert split.curvature[on_first_line].max() == 0.0
    on_arc = ~vertex & (split.s > 30.0 + 0.5) & (split.s < 30.0 + 5 * np.pi - 0.5)
    assert split.curvature[on_arc] == pytest.approx(0.1, rel=0.02)
    np.testing.assert_allclose(np.linalg.norm(split.tangent, axis=1), 1.0)
    with pytest.raises(InputError, match="max_step_mm"):
        samples_from_points(pts, max_step_mm=0.0)


def test_three_point_on_circle_converges():
    for n, tol in ((201, 1e-3), (2001, 1e-5)):
        t = np.linspace(0, 2 * np.pi, n)
        kappa = three_point_curvature(np.column_stack([7 * np.cos(t), 7 * np.sin(t)]))
        assert np.abs(kappa - 1 / 7).max() < tol / 7


def test_points_sampling_and_errors():
    samples = samples_from_points([[0, 0], [1, 0], [2, 1], [3, 3]])
    assert samples.curve is None and samples.length == pytest.approx(1 + np.sqrt(2) + np.sqrt(5))
    with pytest.raises(InputError, match=r"points\[2\] repeats points\[1\]"):
        three_point_curvature([[0, 0], [1, 0], [1, 0], [2, 2]])
    with pytest.raises(InputError, match=r"points\[1\] = \[1.0, nan\]; coordinates must be finite"):
        three_point_curvature([[0, 0], [1, np.nan], [2, 0]])
    with pytest.raises(InputError, match="points: 1; the number of sample points must be an integer >= 2"):
        sample_uniform_u(circle_nurbs(1.0), 1)
    with pytest.raises(InputError, match="step_mm"):
        sample_by_arc_length(circle_nurbs(1.0), step_mm=-1.0)
