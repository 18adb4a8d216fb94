"""The numpy run search's line/circle fit (fuzzyfeed.geometry.polyline_runs._fit_run) held bit for bit
to its plain per-candidate form: the one the search used before it was made cheaper (fewer, fused numpy
calls; LAPACK and BLAS called directly), kept here frozen as the reference. Every float must be the same
(κ, centre, axis, accept/reject), and so must the runs of the whole search on random polylines —
the advice's CSV and G-code depend on them to the last bit."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import fuzzyfeed.geometry.polyline_runs as runs


# --- the reference: _circle_fit_2d and _fit_run as they were (main 9ddd845), not to be edited ----------
def _reference_circle_fit_2d(xy):
    c0 = xy.mean(axis=0)
    p = xy - c0
    scale = np.abs(p).max()
    if scale == 0:
        return None
    x, y = p[:, 0] / scale, p[:, 1] / scale
    z = x * x + y * y
    n = float(len(x))
    sx, sy = x.sum(), y.sum()
    a = np.array([[x @ x, x @ y, sx], [x @ y, y @ y, sy], [sx, sy, n]])
    try:
        sol = np.linalg.solve(a, -np.array([x @ z, y @ z, z.sum()]))
    except np.linalg.LinAlgError:
        return None
    cx, cy = -0.5 * sol[0], -0.5 * sol[1]
    r2 = cx * cx + cy * cy - sol[2]
    if not np.isfinite(r2) or r2 <= 0 or r2 > 1e12:
        return None
    radius = np.sqrt(r2)
    for _ in range(2):
        dx, dy = x - cx, y - cy
        dist = np.sqrt(dx * dx + dy * dy)
        if np.any(dist == 0):
            return None
        jx, jy = -dx / dist, -dy / dist
        res = dist - radius
        jtj = np.array([[jx @ jx, jx @ jy, -jx.sum()], [jx @ jy, jy @ jy, -jy.sum()],
                        [-jx.sum(), -jy.sum(), n]])
        try:
            step = np.linalg.solve(jtj, -np.array([jx @ res, jy @ res, -res.sum()]))
        except np.linalg.LinAlgError:
            break
        cx, cy, radius = cx + step[0], cy + step[1], radius + step[2]
    if not np.isfinite(radius) or radius <= 0:
        return None
    return np.array([cx, cy]) * scale + c0, float(radius * scale)


@dataclass(frozen=True)
class _ReferenceFit:
    kappa: float
    center: np.ndarray | None
    axis: np.ndarray


def _reference_fit_run(pts, tol, path_tol):
    c0 = pts.mean(axis=0)
    q = pts - c0
    _, vecs = np.linalg.eigh(q.T @ q)
    axis, second, normal = vecs[:, 2], vecs[:, 1], vecs[:, 0]
    along = q @ axis
    off_line = np.linalg.norm(q - along[:, None] * axis, axis=1)
    if off_line.max() <= tol:
        return _ReferenceFit(0.0, None, axis)
    if np.abs(q @ normal).max() > tol:
        return None
    xy = np.column_stack([along, q @ second])
    vt = (axis, second)
    fit = _reference_circle_fit_2d(xy)
    if fit is None:
        return None
    center, radius = fit
    if np.abs(np.linalg.norm(xy - center, axis=1) - radius).max() > tol:
        return None
    chords = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    if chords.max() >= 2 * radius:
        return None
    sagitta = radius - np.sqrt(radius * radius - 0.25 * chords * chords)
    if sagitta.max() > path_tol:
        return None
    return _ReferenceFit(1.0 / radius, c0 + center[0] * vt[0] + center[1] * vt[1], normal)
# ----------------------------------------------------------------------------------------------------------


def _bits(fit):
    """Every float of a fit as bytes (None stays None): equal bits, not close values."""
    if fit is None:
        return None
    return (np.float64(fit.kappa).tobytes(), None if fit.center is None else np.asarray(fit.center).tobytes(),
            np.asarray(fit.axis).tobytes())


def _candidate(rng, n: int, shape: str, decimals: int, three_d: bool) -> np.ndarray:
    """``n`` points as a post writes them: on an arc (radius 0.05–500 mm, tilted in 3-D), a line, a
    zig-zag, or a random walk, rounded to ``decimals``; some with a repeated point."""
    step = 10 ** rng.uniform(-2, 0.5)
    if shape == "arc":
        r = 10 ** rng.uniform(-1.3, 2.7)
        t = rng.uniform(0, 2 * np.pi) + np.arange(n) * min(step / r, 0.5) * rng.choice([-1, 1])
        p = np.column_stack([r * np.cos(t), r * np.sin(t), np.zeros(n)])
    elif shape == "line":
        p = np.outer(np.arange(n) * step, rng.normal(size=3))
    elif shape == "zigzag":
        p = np.column_stack([np.arange(n) * step, (np.arange(n) % 2) * step * rng.uniform(0, 0.3), np.zeros(n)])
    else:
        p = np.cumsum(rng.normal(0, step, (n, 3)), axis=0)
    if three_d and shape != "walk":
        rot, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        p = p @ rot
    if not three_d:
        p[:, 2] = 0.0
    p = np.round(p + rng.uniform(-100, 100, 3), decimals)
    if rng.random() < 0.1:
        k = rng.integers(1, n)
        p[k] = p[k - 1]
    return p


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(runs.MIN_RUN, 120),
       shape=st.sampled_from(["arc", "arc", "line", "zigzag", "walk"]), decimals=st.integers(2, 6),
       three_d=st.booleans(), tol_exp=st.floats(-7, -1), path_exp=st.floats(-5, 0))
def test_the_fit_is_the_plain_fit_bit_for_bit(seed, n, shape, decimals, three_d, tol_exp, path_exp):
    """On lines, arcs, zig-zags and walks of 5–120 rounded points (tolerances 1e-7–0.1 mm), the fit
    accepts and rejects what the plain fit does and gives the same κ, centre and axis to the last bit."""
    pts = _candidate(np.random.default_rng(seed), n, shape, decimals, three_d)
    tol, path_tol = 10.0 ** tol_exp, 10.0 ** path_exp
    assert _bits(runs._fit_run(pts, tol, path_tol)) == _bits(_reference_fit_run(pts, tol, path_tol))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), decimals=st.integers(3, 5), three_d=st.booleans())
def test_the_numpy_run_search_finds_the_plain_runs_bit_for_bit(seed, decimals, three_d):
    """The whole numpy search over a polyline of arcs, lines and corners (a few hundred rounded
    vertices) finds the runs, κ, centres and axes that it finds with the plain fit."""
    rng = np.random.default_rng(seed)
    pts = np.concatenate([_candidate(rng, int(rng.integers(3, 60)), str(rng.choice(["arc", "line", "walk"])),
                                     decimals, three_d) for _ in range(8)])
    keep = np.concatenate([[True], np.any(np.diff(pts, axis=0) != 0, axis=1)])
    pts = pts[keep]
    d = np.diff(pts, axis=0)
    cos = np.einsum("ij,ij->i", d[:-1], d[1:]) / (np.linalg.norm(d[:-1], axis=1) * np.linalg.norm(d[1:], axis=1))
    turn = np.concatenate([[0.0], np.arccos(np.clip(cos, -1, 1)), [0.0]])
    tol, path_tol = 0.5 * 10.0 ** -decimals * np.sqrt(3) * runs.FIT_SLACK, 0.01
    maybe = runs._run_candidates(pts, tol)
    found = runs._runs_numpy(pts, turn, maybe, tol, path_tol)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(runs, "_fit_run", _reference_fit_run)
        plain = runs._runs_numpy(pts, turn, maybe, tol, path_tol)
    for name, a, b in zip(found._fields, found, plain):
        assert np.asarray(a).tobytes() == np.asarray(b).tobytes() and np.shape(a) == np.shape(b), name


_NEAR_STRAIGHT = np.column_stack([np.arange(23) * 0.1, 1e-9 * np.random.default_rng(0).normal(size=23),
                                  np.zeros(23)]) + 5.0


@pytest.mark.parametrize("points, tol", [
    (np.array([[0.0, 0, 0], [1, 1, 0], [2, 2, 0], [3, 3, 0], [4, 4, 0]]), 1e-12),            # a line
    (np.array([[0.0, 0, 0], [0, 0, 0], [0, 0, 0], [1e-9, 0, 0], [0, 0, 0]]), 1e-12),         # coincident
    (np.array([[0.0, 0, 0], [0, 0, 0], [0, 0, 0], [1e-9, 0, 0], [0, 0, 0]]), 1e-3),
    (_NEAR_STRAIGHT, 1e-12),                         # off the line by 1e-9: the circle's r² > 1e12
    (np.array([[2.421, 0.0, 0.0], [-2.421, 0.0, 0.0], [2.421, -0.001, 0.0], [-2.421, 0.001, 0.0],
               [2.421, -0.001, 0.0]]), 6.344930888485152e-06),               # a chord as long as 2r
    (np.array([[1.0212, 0.0, 0.0], [-1.0212, 0.0006, 0.0], [1.0212, -0.0012, 0.0], [-1.0212, 0.0018, 0.0],
               [1.0212, -0.0024, 0.0], [-1.0212, 0.003, 0.0], [1.0212, -0.0036, 0.0], [-1.0212, 0.0042, 0.0]]),
     0.00016367766027500653)])
def test_degenerate_candidates_are_judged_as_before(points, tol):
    """Collinear, coincident and near-straight points (the circle's equations singular or its radius
    out of range) and chords across the circle's diameter: judged as the plain fit judges them."""
    assert _bits(runs._fit_run(points, tol, 0.01)) == _bits(_reference_fit_run(points, tol, 0.01))
