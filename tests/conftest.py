"""Shared fixtures: shipped shapes and random valid NURBS definitions."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzyfeed.io.shapes import load_shape, shape_names
from fuzzyfeed.geometry.nurbs import Nurbs

SQRT_HALF = np.sqrt(0.5)


def circle_nurbs(radius: float, center=(0.0, 0.0)) -> Nurbs:
    """The 9-point rational quadratic full circle (The NURBS Book, Ex. 7.2)."""
    cx, cy = center
    r = radius
    pts = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1), (1, 0)]
    points = [(cx + r * x, cy + r * y) for x, y in pts]
    weights = [1, SQRT_HALF, 1, SQRT_HALF, 1, SQRT_HALF, 1, SQRT_HALF, 1]
    knots = [0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1]
    return Nurbs(2, knots, points, weights)


def random_nurbs_definition(rng: np.random.Generator) -> dict:
    """Degree 1-5, 2-D or 3-D, random positive weights, interior knots possibly repeated (≤ p)."""
    p = int(rng.integers(1, 6))
    dim = int(rng.choice([2, 3]))
    n_interior_distinct = int(rng.integers(0, 6))
    interior: list[float] = []
    for value in np.sort(rng.uniform(0.05, 0.95, n_interior_distinct)):
        interior += [float(value)] * int(rng.integers(1, p + 1))
    knots = [0.0] * (p + 1) + interior + [1.0] * (p + 1)
    n = len(knots) - p - 1
    points = rng.uniform(-50, 50, (n, dim))
    weights = rng.uniform(0.2, 5.0, n)
    return {"degree": p, "knots": knots, "points": points, "weights": weights}


@pytest.fixture(params=shape_names())
def shipped_shape(request):
    return load_shape(request.param)
