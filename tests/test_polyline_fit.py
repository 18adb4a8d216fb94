"""The path a blending controller follows along a polyline (fuzzyfeed.geometry.polyline_fit), and the SLW
schedule on it: true corners stop, rounding-level kinks are blended within the path tolerance P."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzyfeed.errors import InputError
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.geometry.polyline_fit import fit_polyline
from fuzzyfeed.slw import measure, path_bound, schedule
from slw_cases import polyline

RATIOS = ("feed", "axis_vel", "axis_acc", "chord", "jerk")


def rounded_arc(radius=10.0, sweep_deg=350.0, chord=0.05, decimals=3, center=(0.0, 0.0)):
    """An arc as a CAM post writes it: G1 moves of ``chord`` mm, coordinates rounded."""
    n = int(np.radians(sweep_deg) * radius / chord)
    a = np.linspace(0.0, np.radians(sweep_deg), n + 1)
    pts = np.column_stack([center[0] + radius * np.cos(a), center[1] + radius * np.sin(a)])
    return np.round(pts, decimals)


def distance_to_polyline(q: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Brute-force distance of points q to the segments of pts (independent of the fit)."""
    a, b = pts[:-1], pts[1:]
    d = b - a
    out = np.empty(len(q))
    for i0 in range(0, len(q), 500):
        qq = q[i0:i0 + 500, None, :]
        t = np.clip(np.einsum("qsk,sk->qs", qq - a[None], d) / np.einsum("sk,sk->s", d, d)[None], 0, 1)
        near = a[None] + t[..., None] * d[None]
        out[i0:i0 + 500] = np.linalg.norm(qq - near, axis=2).min(axis=1)
    return out


def dense(curve: Nurbs, n: int = 20000) -> np.ndarray:
    u0, u1 = curve.domain
    return curve(np.linspace(u0, u1, n))


def test_rounded_arc_is_one_smooth_piece_within_tolerance():
    pts = rounded_arc()
    fit = fit_polyline(polyline(pts))
    assert (fit.corners, fit.fitted, fit.kept) == (0, 1, 0)
    assert fit.path_tolerance_mm == 0.01
    # checked independently: every point of the fit near the polyline, every vertex near the fit
    assert distance_to_polyline(dense(fit.curve), pts).max() <= fit.path_tolerance_mm
    assert distance_to_polyline(pts, dense(fit.curve, 60000)).max() <= fit.path_tolerance_mm
    assert fit.max_deviation_mm <= fit.path_tolerance_mm
    # its curvature is the circle's, not the rounding's (a few % at most, away from the open ends)
    u0, u1 = fit.curve.domain
    k = fit.curve.curvature(np.linspace(u0, u1, 4000)[200:-200])
    assert np.abs(k * 10.0 - 1.0).max() < 0.05


def test_corners_are_kept_exactly():
    pts = np.array([[0, 0], [40, 0], [40, 25.3], [0, 25.3], [0, 0.5]])
    curve = polyline(pts)
    fit = fit_polyline(curve)
    assert (fit.corners, fit.fitted, fit.kept) == (3, 0, 4)
    assert fit.max_deviation_mm == 0.0
    assert np.allclose(fit.curve(curve.knots[1:-1] * fit.curve.domain[1]), pts, atol=1e-12)
    assert fit.curve.length == pytest.approx(curve.length, rel=1e-12)


def test_rounded_helix_in_3d():
    a = np.linspace(0.0, 4 * np.pi, 2500)
    pts = np.round(np.column_stack([8 * np.cos(a), 8 * np.sin(a), 0.5 * a]), 3)
    fit = fit_polyline(polyline(pts))
    assert (fit.corners, fit.kept) == (0, 0)
    assert distance_to_polyline(dense(fit.curve), pts).max() <= fit.path_tolerance_mm
    k = fit.curve.curvature(np.linspace(*fit.curve.domain, 3000)[100:-100])
    assert np.abs(k / (8 / (64 + 0.25)) - 1.0).max() < 0.05  # the helix's κ = r/(r² + c²)


def test_true_corner_after_a_fine_arc_is_a_stop():
    arc = np.round(np.column_stack([10.0 * np.cos(np.linspace(0, np.pi / 2, 800)),
                                    10.0 * np.sin(np.linspace(0, np.pi / 2, 800))]), 3)
    leg = np.column_stack([np.linspace(0.0, 30.0, 7)[1:], np.full(6, 10.0)])  # 90° turn at (0, 10)
    pts = np.vstack([arc, leg])
    traj = schedule(polyline(pts), MachineLimits(), planner="window", transition="cosine")
    fit = traj.polyline_fit
    assert fit.corners == 1 and fit.fitted == 2  # the arc and the straight leg
    m = measure(traj)
    assert max(m[k] for k in RATIOS) <= 1.005
    s_corner = float(np.sum(np.linalg.norm(np.diff(arc, axis=0), axis=1)))
    at = np.argmin(np.abs(traj.s_mm - s_corner * traj.s_mm[-1] / fit.source.length))
    assert traj.feed_mm_s[at] < 1.0


def test_blending_makes_a_rounded_finishing_pass_fast_and_keeps_every_limit():
    curve = polyline(rounded_arc(radius=30.0, sweep_deg=350.0, chord=0.02))
    lim = MachineLimits()
    blended = schedule(curve, lim, planner="window", transition="cosine")
    vertices = schedule(curve, lim, blend=False, planner="window", transition="cosine")
    for traj in (blended, vertices):
        m = measure(traj)
        assert max(m[k] for k in RATIOS) <= 1.005
    bound = path_bound(blended.curve, lim).time_s
    assert blended.cycle_time_s <= 1.15 * bound  # start and stop: jerk-limited
    assert vertices.polyline_fit is None and vertices.curve is curve
    assert vertices.cycle_time_s > 1.5 * blended.cycle_time_s  # each rounding kink a corner


def test_path_tolerance_is_passed_through():
    traj = schedule(polyline(rounded_arc(chord=0.1)), MachineLimits(), path_tolerance_mm=0.05, planner="window", transition="cosine")
    assert traj.polyline_fit.path_tolerance_mm == 0.05
    assert traj.polyline_fit.max_deviation_mm <= 0.05


def test_fit_refuses_a_curve_that_is_no_polyline():
    cubic = Nurbs(3, [0, 0, 0, 0, 1, 1, 1, 1], [[0, 0], [1, 1], [2, -1], [3, 0]])
    with pytest.raises(InputError, match="degree-1"):
        fit_polyline(cubic)
