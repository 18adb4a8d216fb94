"""Issue 38 (compute, cpu9): the chained u(s) of the chord-exact interpolator's whole inversions
(geometry/_arc_jit.param_at with ``chain`` > 0: each tick's first residual from the last tick's
converged point by the 3-point rule) against the unchained inversion it replaces (every residual
from the table interval's start by the 8-point rule). The judge is s(u) by a quadrature 16 times
finer than the table's (the table's own rule is accurate to ARC_LENGTH_RTOL of the scale only):
the chained parameters are no further from their targets than the unchained ones plus the Newton
tolerance 1e-14·max(L, 1), on random NURBS, a cusp, butterfly and a fitted polyline, at steps
from coarse (a step a large part of a table interval) to fine (thousands of ticks an interval)."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import slw_cases
from fuzzyfeed.geometry import interpolate as I
from fuzzyfeed.geometry._kernels import arc_kernel
from fuzzyfeed.geometry.arc_length import _gl_lengths
from fuzzyfeed.geometry.polyline_fit import fit_polyline
from fuzzyfeed.io.shapes import load_shape


def _ticks(total, steps, rng):
    """Non-decreasing arc-length targets 0 … L, steps varying tenfold, a few repeated."""
    ds = (total / steps) * rng.uniform(0.1, 1.0, steps)
    ds[rng.integers(0, steps, max(steps // 50, 1))] = 0.0
    s = np.concatenate([[0.0], np.cumsum(ds)]) * (total / ds.sum())
    s[-1] = total
    return np.maximum.accumulate(s)


def _fine_length(curve, u, pieces=16):
    """s(u): the table's length at the interval's start plus the 8-point rule over 16 pieces."""
    table = curve.arc_table
    k = table._interval(u)
    a = table.breaks[k]
    acc = table.cumulative[k].copy()
    for i in range(pieces):
        acc += _gl_lengths(curve, a + (u - a) * (i / pieces), a + (u - a) * ((i + 1) / pieces))
    return acc


def _as_accurate(curve, s):
    arc_kernel()
    exact = curve.param_at_length(s)
    chained = curve.param_at_length(s, chain=I.CHAIN)
    assert np.all(np.isfinite(chained))
    tol = 1e-14 * max(curve.length, 1.0)
    off_exact = np.abs(_fine_length(curve, exact) - s).max()
    off_chained = np.abs(_fine_length(curve, chained) - s)
    assert off_chained.max() <= off_exact + tol, (float(off_chained.max()), float(off_exact), tol,
                                                  int(np.argmax(off_chained)))
    assert np.array_equal(curve.param_at_length(s, chain=0.0), exact)   # chain 0: the old floats
    return exact, chained


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), steps=st.sampled_from([300, 3_000, 30_000, 100_000]))
def test_chained_param_at_random_nurbs(seed, steps):
    curve = slw_cases.random_nurbs(seed)[0]
    _as_accurate(curve, _ticks(curve.length, steps, np.random.default_rng(seed)))


@pytest.mark.parametrize("name", ["cusp", "butterfly", "polyline"])
def test_chained_param_at_hard_curves(name):
    curve = {"cusp": lambda: slw_cases.cusp_cubic(),
             "butterfly": lambda: load_shape("butterfly").curve,
             "polyline": lambda: fit_polyline(slw_cases.cam_polyline(1500)).curve}[name]()
    for steps in (1_000, 100_000):
        exact, chained = _as_accurate(curve, _ticks(curve.length, steps, np.random.default_rng(steps)))
        assert not np.array_equal(exact, chained)     # the chain was taken (not the same floats)


def test_chain_fraction_matters():
    """The judge can fail: a chain over a quarter of an interval (the 3-point rule's error above
    the table's) breaks it on a random curve at coarse steps."""
    arc_kernel()
    curve = slw_cases.random_nurbs(2)[0]
    s = _ticks(curve.length, 300, np.random.default_rng(2))
    off_exact = np.abs(_fine_length(curve, curve.param_at_length(s)) - s).max()
    off_loose = np.abs(_fine_length(curve, curve.param_at_length(s, chain=0.25)) - s).max()
    assert off_loose > off_exact + 1e-14 * max(curve.length, 1.0)
