"""Curvature of point sequences within their rounding (fuzzyfeed.geometry.polyline): rounded circles advised
like the exact NURBS circle, collinear runs, corners as the controller's blend (LinuxCNC G64 P),
reversals, duplicates and jogs — through the API, G-code programs and CSV point lists."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from conftest import circle_nurbs
from fuzzyfeed.fuzzy.advisor import advise_details
from fuzzyfeed.io.shapes import load_shape, sample_shape
from fuzzyfeed.machine.limits import MachineLimits, feed_limits
from fuzzyfeed.geometry.polyline import (DEFAULT_PATH_TOLERANCE_MM, KAPPA_MAX_1_MM, polyline_curvature,
                                rounding_quantum)
from fuzzyfeed.geometry.sampling import sample_by_arc_length, sample_uniform_u, three_point_curvature

F_MM_S = 4000 / 60


def rounded_circle(radius: float, sagitta: float, decimals: int = 3, sweep: float = 2 * np.pi,
                   center=(12.3456, -7.891)) -> np.ndarray:
    """A circle as a CAM post writes it: chords of the given sagitta, rounded to ``decimals``."""
    n = int(np.ceil(sweep / (2 * np.arccos(1 - sagitta / radius))))
    t = np.linspace(0, sweep, n + 1)
    return np.round(np.column_stack([center[0] + radius * np.cos(t),
                                     center[1] + radius * np.sin(t)]), decimals)


def write_ngc(path, pts: np.ndarray, decimals: int = 3) -> None:
    fmt = f"{{:.{decimals}f}}"
    lines = ["%", "(rounded G1 chain, as a CAM post writes it)", "G21 G90 G17 G94",
             f"G0 X{fmt.format(pts[0, 0])} Y{fmt.format(pts[0, 1])}", "G1 F3000"]
    lines += [f"X{fmt.format(x)} Y{fmt.format(y)}" for x, y in pts[1:]]
    lines += ["M2", "%"]
    path.write_text("\n".join(lines) + "\n")


def write_csv(path, pts: np.ndarray, decimals: int = 3) -> None:
    path.write_text("x_mm,y_mm\n" + "".join(f"{x:.{decimals}f},{y:.{decimals}f}\n" for x, y in pts))


@pytest.mark.parametrize("radius", [5.0, 20.0, 50.0])
@pytest.mark.parametrize("sagitta", [0.001, 0.005])
@pytest.mark.parametrize("how", ["ngc", "csv", "open-arc-ngc"])
def test_rounded_circle_is_advised_like_the_exact_nurbs_circle(radius, sagitta, how, tmp_path):
    exact = advise_details(sample_uniform_u(circle_nurbs(radius)), None, F_MM_S).profile.feed_pct
    assert np.ptp(exact) < 1e-9
    sweep = 1.5 * np.pi if how == "open-arc-ngc" else 2 * np.pi
    pts = rounded_circle(radius, sagitta, sweep=sweep)
    path = tmp_path / ("c.csv" if how == "csv" else "c.ngc")
    (write_csv if how == "csv" else write_ngc)(path, pts)
    samples = sample_shape(load_shape(str(path)))
    assert len(samples) == len(pts)
    got = advise_details(samples, None, F_MM_S).profile.feed_pct
    inner = slice(3, -3)
    assert np.all(np.abs(got[inner] / exact[0] - 1) <= 0.03), (got.min(), got.max(), exact[0])
    # κ is the circle's within the rounding; the three-point estimate on the same points is not
    np.testing.assert_allclose(samples.curvature[inner], 1 / radius, rtol=1e-3)
    k3 = three_point_curvature(pts)
    assert np.ptp(k3[inner]) * radius > 0.05


def test_the_paper_three_point_curvature_would_fail_the_same_circle():
    """The failure of issue 9: the seed's estimate on a rounded r = 20 circle, normalised, spreads
    the advice far beyond ±3 % (so the test above can fail)."""
    from fuzzyfeed.geometry.sampling import PathSamples

    pts = rounded_circle(20.0, 0.001)
    ours = sample_shape_points(pts)
    paper = PathSamples(u=ours.u, xyz=ours.xyz, s=ours.s, tangent=ours.tangent,
                        curvature=three_point_curvature(pts), d1=ours.d1, d2=ours.d2, dim=2)
    pct = advise_details(paper, None, F_MM_S).profile.feed_pct
    assert pct.min() < 0.8 * pct.max()


def sample_shape_points(pts):
    from fuzzyfeed.geometry.sampling import samples_from_points
    return samples_from_points(pts)


def test_rounding_quantum_is_read_from_the_values():
    rng = np.random.default_rng(1)
    v = rng.uniform(-100, 100, (200, 2))
    assert rounding_quantum(np.round(v, 3)) == pytest.approx(1e-3)
    assert rounding_quantum(np.round(v, 4)) == pytest.approx(1e-4)
    assert rounding_quantum(np.round(v / 25.4, 4) * 25.4) == pytest.approx(0.00254)
    assert rounding_quantum(v) is None
    assert rounding_quantum(np.round(v)) == pytest.approx(0.01)   # round numbers: 2 decimals at most
    res = polyline_curvature(np.round(v, 3))
    assert res.quantum_mm == pytest.approx(1e-3) and res.tolerance_mm == pytest.approx(0.5e-3 * np.sqrt(2))


def test_inch_program_rounding_is_read_in_mm(tmp_path):
    pts = rounded_circle(10 / 25.4, 0.0001 / 25.4 * 25.4, decimals=4, center=(1.2, 0.4))
    lines = ["G20 G90 G17", f"G0 X{pts[0, 0]:.4f} Y{pts[0, 1]:.4f}", "G1 F40"]
    lines += [f"X{x:.4f} Y{y:.4f}" for x, y in pts[1:]] + ["M2"]
    (tmp_path / "inch.ngc").write_text("\n".join(lines) + "\n")
    samples = sample_shape(load_shape(str(tmp_path / "inch.ngc")))
    res = polyline_curvature(samples.xyz[:, :2])
    assert res.quantum_mm == pytest.approx(0.00254)
    np.testing.assert_allclose(samples.curvature[3:-3], 0.1, rtol=2e-3)


def test_collinear_runs_get_zero_curvature():
    t = np.linspace(0, 1, 400)
    line = np.round(np.column_stack([3.14159 + 73.3 * t, -2.2 + 41.7 * t]), 3)
    assert np.unique(line, axis=0).shape[0] == len(line)
    assert three_point_curvature(line).max() > 0.01           # rounding noise in the paper's estimate
    np.testing.assert_array_equal(polyline_curvature(line).curvature, 0.0)


def blend_radius(theta: float, p: float = DEFAULT_PATH_TOLERANCE_MM) -> float:
    """Closed form: the arc tangent to both legs whose middle is P from the corner."""
    return p * np.cos(theta / 2) / (1 - np.cos(theta / 2))


@pytest.mark.parametrize("angle_deg", [30.0, 90.0, 135.0])
def test_corner_is_the_controllers_blend_not_a_circle(angle_deg, tmp_path):
    a = np.radians(angle_deg)
    pts = np.array([[0, 0], [10, 0], [10 + 10 * np.cos(a), 10 * np.sin(a)],
                    [10 + 10 * np.cos(a) + 10 * np.cos(2 * a), 10 * np.sin(a) + 10 * np.sin(2 * a)]])
    pts = np.round(pts, 3)
    write_ngc(tmp_path / "corner.ngc", pts)
    samples = sample_shape(load_shape(str(tmp_path / "corner.ngc")))
    res = polyline_curvature(pts)
    assert res.corner[1] and res.corner[2]
    d0, d1 = pts[1] - pts[0], pts[2] - pts[1]
    theta = np.arctan2(abs(d0[0] * d1[1] - d0[1] * d1[0]), d0 @ d1)   # the turning angle
    np.testing.assert_allclose(samples.curvature[1], 1 / blend_radius(theta), rtol=1e-9)
    # the three-point circle of the paper is the size of the segments: far too gentle
    assert three_point_curvature(pts)[1] < 0.05 * samples.curvature[1]
    advice = advise_details(samples, None, F_MM_S)
    assert advice.controller_pct[1] < 20      # the rule table's VB row (before the average filter)
    limit = feed_limits(samples, MachineLimits())
    assert limit[1] < 0.5 * MachineLimits().feed_mm_s


def test_square_polyline_4_points_is_not_an_arc():
    pts = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], dtype=float)
    res = polyline_curvature(pts)
    np.testing.assert_allclose(res.curvature[1:3], 1 / blend_radius(np.pi / 2))
    closed = np.vstack([pts, pts[:1]])   # concyclic corners: still corners, seam included
    res = polyline_curvature(closed)
    np.testing.assert_allclose(res.curvature, 1 / blend_radius(np.pi / 2))
    assert res.corner.all()


def test_reversal_jog_and_duplicates_never_give_nan(tmp_path):
    prog = "G21 G90\nG0 X0 Y0\nG1 F1000 X0.99\nX1.00\nX0.99\nX0.5 Y0.3\nM2\n"
    (tmp_path / "rev.ngc").write_text(prog)
    samples = sample_shape(load_shape(str(tmp_path / "rev.ngc")))
    assert np.isfinite(samples.curvature).all() and np.isfinite(samples.tangent).all()
    assert samples.curvature[2] == KAPPA_MAX_1_MM            # the turn-around: a crawl
    advice = advise_details(samples, None, F_MM_S)
    assert np.isfinite(advice.profile.feed_pct).all()
    assert advice.controller_pct[2] < 20      # the rule table's VB row (before the average filter)
    machine = MachineLimits()       # v²κ|N_j| ≤ A_j: about √(A/κ_max) ≈ 0.32 mm/s through the reversal
    assert feed_limits(samples, machine)[2] <= np.sqrt(2 * np.min(machine.axis_acc_mm_s2) / KAPPA_MAX_1_MM)
    jog = np.array([[0, 0], [1, 0], [1, 1e-4], [2, 1e-4], [3, 1e-4]])   # a 0.1 µm jog
    np.testing.assert_array_equal(polyline_curvature(jog).curvature, 0.0)
    dup = np.array([[0, 0], [1, 0], [1, 0], [1, 0], [1, 1]], dtype=float)
    res = polyline_curvature(dup)
    assert res.curvature[1] == res.curvature[2] == res.curvature[3] == pytest.approx(1 / blend_radius(np.pi / 2))


@pytest.mark.parametrize("step_mm", [0.1, 0.2])
def test_free_form_curve_rounded_to_3_decimals_beats_the_three_point_estimate(step_mm):
    curve = load_shape("infinity").curve
    s = sample_by_arc_length(curve, step_mm=step_mm)
    pts = np.round(s.xyz[:, :2], 3)
    scale = s.curvature.max()
    ours = np.abs(polyline_curvature(pts).curvature - s.curvature)[3:-3] / scale
    paper = np.abs(three_point_curvature(pts) - s.curvature)[3:-3] / scale
    assert np.percentile(ours, 95) < 0.02 and ours.max() < 0.1
    assert np.percentile(paper, 95) > 0.1


def test_exact_points_of_a_fine_circle_keep_the_exact_curvature():
    t = np.linspace(0, 1.5 * np.pi, 300)
    res = polyline_curvature(np.column_stack([7 * np.cos(t), 7 * np.sin(t)]))
    assert res.quantum_mm is None
    np.testing.assert_allclose(res.curvature, 1 / 7, rtol=1e-9)


points_strategy = st.lists(st.tuples(st.integers(-50, 50), st.integers(-50, 50)), min_size=2, max_size=40)


@settings(max_examples=150, deadline=None)
@given(points_strategy, st.sampled_from([1.0, 0.01, 1e-4]))
@example([(1, 0), (0, 0), (1, 0), (0, 0), (1, 0)], 1.0)   # reversals: inf - inf in the run screen
def test_property_curvature_is_finite_bounded_and_tangents_unit(raw, scale):
    pts = np.array(raw, dtype=float) * scale
    if np.all(pts == pts[0]):
        return
    res = polyline_curvature(pts)
    assert np.isfinite(res.curvature).all() and (res.curvature >= 0).all()
    assert (res.curvature <= KAPPA_MAX_1_MM).all()
    np.testing.assert_allclose(np.linalg.norm(res.tangent, axis=1), 1.0, atol=1e-9)


def read_csv_column(path, name):
    import csv
    return np.array([float(r[name]) for r in csv.DictReader(open(path))])


def test_cli_tolerances_reach_the_curvature(tmp_path, capsys):
    from fuzzyfeed.cli import main

    write_ngc(tmp_path / "sq.ngc", np.array([[0, 0], [10, 0], [10, 10], [0, 10]], dtype=float))
    out = tmp_path / "sq.csv"
    assert main(["advise", str(tmp_path / "sq.ngc"), "-o", str(out), "--path-tolerance", "0.05"]) == 0
    kappa, x, y = (read_csv_column(out, c) for c in ("curvature_1_mm", "x_mm", "y_mm"))
    corners = ((x == 10) & (y == 0)) | ((x == 10) & (y == 10))   # the program's rows at its corners
    assert corners.sum() == 2
    np.testing.assert_allclose(kappa[corners], 1 / blend_radius(np.pi / 2, 0.05), rtol=1e-12)
    assert (kappa[~corners] == 0).all()                          # the sides are straight
    # a circle digitised with ±2 µm noise, written with 6 decimals: only the tolerance the user
    # gives lets the curvature see the circle
    rng = np.random.default_rng(7)
    t = np.linspace(0, 2 * np.pi, 401)
    pts = np.column_stack([20 * np.cos(t), 20 * np.sin(t)]) + rng.uniform(-0.002, 0.002, (401, 2))
    pts[-1] = pts[0]
    write_csv(tmp_path / "noisy.csv", pts, decimals=6)
    assert main(["advise", str(tmp_path / "noisy.csv"), "-o", str(out)]) == 0
    assert np.ptp(read_csv_column(out, "curvature_1_mm")) > 0.01
    assert main(["advise", str(tmp_path / "noisy.csv"), "-o", str(out), "--point-tolerance", "0.003"]) == 0
    np.testing.assert_allclose(read_csv_column(out, "curvature_1_mm"), 1 / 20, rtol=1e-3)
    assert np.ptp(read_csv_column(out, "feed_pct")) < 1e-6
    capsys.readouterr()


@pytest.mark.parametrize("radius", [5.0, 20.0, 50.0])
def test_rounded_circle_program_is_advised_like_the_exact_circle_through_the_cli(radius, tmp_path, capsys):
    """The whole-program path (`advise PROGRAM.ngc`: each cut sampled on its moves) sees the same
    circle as the shape path: every row within ±3 % of the exact NURBS circle's feed."""
    from fuzzyfeed.cli import main

    exact = advise_details(sample_uniform_u(circle_nurbs(radius)), None, F_MM_S).profile.feed_pct[0]
    write_ngc(tmp_path / "c.ngc", rounded_circle(radius, 0.001))
    out = tmp_path / "c.csv"
    assert main(["advise", str(tmp_path / "c.ngc"), "-o", str(out)]) == 0
    capsys.readouterr()
    got = read_csv_column(out, "feed_pct")
    assert np.all(np.abs(got[3:-3] / exact - 1) <= 0.03), (got.min(), got.max(), exact)
    np.testing.assert_allclose(read_csv_column(out, "curvature_1_mm")[3:-3], 1 / radius, rtol=1e-3)


def wavy_spiral(n: int, decimals: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """The whole-program benchmark's path (benchmarks/bench_program.py) rounded as its post writes
    it, with its curvature in closed form (κ = |x'y'' − y'x''| / |r'|³ of the parametric curve)."""
    t = np.linspace(0, 60 * np.pi, n)
    c = 30 / t[-1]
    r, dr = 20 + c * t, c
    w, dw, ddw = 1 + 0.1 * np.sin(9 * t), 0.9 * np.cos(9 * t), -8.1 * np.sin(9 * t)
    f, df, ddf = r * w, dr * w + r * dw, 2 * dr * dw + r * ddw        # x = f cos t
    x, y = f * np.cos(t), r * np.sin(t)
    dx, ddx = df * np.cos(t) - f * np.sin(t), ddf * np.cos(t) - 2 * df * np.sin(t) - f * np.cos(t)
    dy, ddy = dr * np.sin(t) + r * np.cos(t), 2 * dr * np.cos(t) - r * np.sin(t)
    kappa = np.abs(dx * ddy - dy * ddx) / (dx * dx + dy * dy) ** 1.5
    return np.round(np.column_stack([x, y]), decimals), kappa


def test_compiled_run_search_constants_match():
    pytest.importorskip("numba")
    from fuzzyfeed.geometry import _polyline_jit, polyline_runs

    assert _polyline_jit.MIN_RUN == polyline_runs.MIN_RUN


@pytest.mark.parametrize("case", ["circle", "open-arc", "squares", "polygon", "walk-3d"])
def test_compiled_run_search_gives_the_numpy_result(case, monkeypatch):
    """Both forms of the run search (numpy below COMPILED_MIN_VERTICES, numba from there on) find
    the same runs and κ on circles, corners, random polygons and 3-D walks."""
    pytest.importorskip("numba")
    import fuzzyfeed.geometry.polyline_runs as runs

    rng = np.random.default_rng(3)
    sq = np.array([[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]], dtype=float)
    pts = {"circle": lambda: rounded_circle(200.0, 1e-4, decimals=4),
           "open-arc": lambda: rounded_circle(30.0, 0.001, sweep=1.5 * np.pi),
           "squares": lambda: np.round(np.concatenate([sq * (1 + k * 0.01) for k in range(300)]), 3),
           "polygon": lambda: np.round(rng.uniform(-50, 50, (1500, 2)), 3),
           "walk-3d": lambda: np.round(np.cumsum(rng.normal(0, 0.05, (2000, 3)), axis=0), 4)}[case]()
    forms = {}
    for compiled in (False, True):
        monkeypatch.setattr(runs, "COMPILED_MIN_VERTICES", 0 if compiled else 10**9)
        forms[compiled] = polyline_curvature(pts)
    np.testing.assert_allclose(forms[True].curvature, forms[False].curvature, rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(forms[True].corner, forms[False].corner)
    np.testing.assert_allclose(forms[True].tangent, forms[False].tangent, atol=1e-12)


def test_both_forms_see_the_curvature_of_a_rounded_free_form_curve(monkeypatch):
    """On a free-form curve (the program benchmark's wavy spiral, 4 decimals, 0.07 mm moves) each
    form is near the closed-form curvature, far nearer than the paper's three-point estimate. The
    two forms may cut the runs differently where a near-straight stretch's fit residual sits at the
    tolerance to the last bits (their sums run in another order), so they are compared with the
    truth, not bit for bit."""
    pytest.importorskip("numba")
    import fuzzyfeed.geometry.polyline_runs as runs

    pts, exact = wavy_spiral(100_000)
    pts, exact = pts[20_000:24_000], exact[20_000:24_000]
    paper = np.abs(three_point_curvature(pts) - exact)[3:-3] / exact.max()
    assert np.percentile(paper, 95) > 0.15
    stats = []
    for compiled in (False, True):
        monkeypatch.setattr(runs, "COMPILED_MIN_VERTICES", 0 if compiled else 10**9)
        err = np.abs(polyline_curvature(pts).curvature - exact)[3:-3] / exact.max()
        stats.append((np.percentile(err, 95), err.max()))
        assert stats[-1][0] < 0.04 and stats[-1][1] < 0.15, stats
    assert abs(stats[0][0] - stats[1][0]) < 0.002, stats


def test_a_small_polyline_does_not_import_numba():
    import subprocess
    import sys

    code = ("import sys, numpy as np\nfrom fuzzyfeed.geometry.polyline import polyline_curvature\n"
            "t = np.linspace(0, 6, 800)\n"
            "polyline_curvature(np.round(np.column_stack([20 * np.cos(t), 20 * np.sin(t)]), 3))\n"
            "print('numba' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
