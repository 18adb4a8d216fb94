"""Cross-check and comparison: the simulator reproduces the SLW trajectory; fuzzy vs SLW; CLI."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from fuzzyfeed.cli import main
from fuzzyfeed.report.compare import METHODS, compare
from fuzzyfeed.fuzzy.advisor import advise
from fuzzyfeed.io.shapes import load_shape, sample_shape, shape_names
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.machine.simulate import simulate
from fuzzyfeed.slw import schedule
from fuzzyfeed.slw.trajectory import measure


@pytest.fixture(scope="module")
def infinity_comparison():
    samples = sample_shape(load_shape("infinity"), 2000)
    return compare(samples, MachineLimits(), name="infinity")


@pytest.mark.parametrize("name", ["infinity", "wm"])
def test_simulator_reproduces_slw_trajectory(name):
    """Same profile → same positions, cycle time and extrema as the scheduler's own trajectory,
    the extrema recomputed here from the trajectory's positions (plain differences at Ts)."""
    curve = load_shape(name).curve
    limits = MachineLimits()
    traj = schedule(curve, limits, planner="window", transition="cosine")
    sim = simulate(curve, traj.time_law(), limits, "slw")
    m = sim.metrics
    assert m.cycle_time_s == pytest.approx(traj.cycle_time_s, rel=1e-12)
    np.testing.assert_allclose(sim.xyz, traj.xyz, rtol=0, atol=1e-9)
    ts = limits.ts_s
    vel = np.diff(traj.xyz, axis=0) / ts
    acc = np.diff(traj.xyz, n=2, axis=0) / ts**2
    assert m.feed_max_mm_s == pytest.approx(np.linalg.norm(vel, axis=1).max(), rel=1e-6)
    np.testing.assert_allclose(m.axis_vel_max_mm_s, np.abs(vel).max(axis=0), rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(m.axis_acc_max_mm_s2, np.abs(acc).max(axis=0), rtol=1e-6, atol=1e-6)
    assert m.tan_jerk_max_mm_s3 == pytest.approx(np.abs(traj.jerk_mm_s3).max(), rel=1e-6)
    assert m.tan_acc_max_mm_s2 == pytest.approx(np.abs(traj.acc_mm_s2).max(), rel=1e-6)
    own = measure(traj)
    assert own["terminal_error_mm"] <= 1e-6 and own["start_feed_mm_s"] == 0.0


def test_comparison_methods_and_invariants(infinity_comparison):
    c = infinity_comparison
    assert tuple(c.simulations) == METHODS
    fuzzy = advise(c.samples, None, max_feed_mm_s=c.limits.feed_mm_s)
    np.testing.assert_array_equal(c.profiles["fuzzy"].feed_mm_s, fuzzy.feed_mm_s)
    safe, slw = c.profiles["fuzzy-safe"].feed_mm_s, c.profiles["slw"].feed_mm_s
    # the safe schedule is the jerk-limited one under min(advice, machine): never above the advice
    # (1 % for reading the servo-period schedule at the samples)
    assert np.all(safe <= fuzzy.feed_mm_s * 1.01 + 1e-9)
    assert c.simulations["fuzzy-safe"].metrics.cycle_time_s >= c.simulations["slw"].metrics.cycle_time_s
    times = {m: s.metrics.cycle_time_s for m, s in c.simulations.items()}
    # the SLW schedule obeys every limit and is within 10 % of the bound on infinity
    slw_metrics = c.simulations["slw"].metrics
    assert all(count == 0 for count, _ in slw_metrics.violations.values())
    assert 1.0 <= slw_metrics.ratio_to_bound <= 1.10
    # the bound's feed read at the samples and simulated: the bound's time within 0.5 %
    assert c.simulations["bound"].metrics.ratio_to_bound == pytest.approx(1.0, rel=5e-3)
    assert times["fuzzy-safe"] >= times["fuzzy"] - 1e-9  # clamping never speeds the advice up
    # the safe advice respects every limit, jerk included: no violating tick
    safe_violations = c.simulations["fuzzy-safe"].metrics.violations
    assert all(count == 0 for count, _ in safe_violations.values()), safe_violations
    assert safe[0] == 0.0 and safe[-1] == 0.0  # it starts and ends at rest
    # the constant feed breaks the axis acceleration limit in the tight loops of infinity
    const = c.simulations["constant"].metrics
    assert max(const.violations[f"axis_acc_{a}"][1] for a in "xy") > 1.0


def test_cross_check_accounts_for_the_difference(infinity_comparison):
    check = infinity_comparison.cross_check
    assert 0.0 <= check.over_fraction <= 1.0 and 0.0 <= check.under_fraction <= 1.0
    assert check.over_fraction + check.under_fraction <= 1.0 + 1e-12
    assert check.under_min_ratio < 1.0 < check.over_max_ratio
    assert check.time_lost_s > 0 and check.time_gained_s >= 0
    # the paper's rules are cautious on infinity: the advice is slower than the schedule
    assert check.cycle_time_delta_s > 0
    assert len(check.lines()) == 3


def test_cli_compare_writes_report_and_figure(tmp_path, capsys):
    out, fig = tmp_path / "report.csv", tmp_path / "fig.png"
    assert main(["compare", "trident", "--points", "800", "-o", str(out), "--plot", str(fig)]) == 0
    printed = capsys.readouterr().out
    for method in METHODS:
        assert method in printed
    df = pd.read_csv(out)
    assert df["method"].tolist() == list(METHODS)
    assert {"cycle_time_s", "chord_err_max_um", "feed_fluct_max_pct", "tan_acc_max_mm_s2",
            "tan_jerk_max_mm_s3", "axis_vel_max_x_mm_s", "axis_acc_max_y_mm_s2",
            "violations_jerk", "worst_ratio_chord_error", "ratio_to_bound"} <= set(df.columns)
    assert fig.read_bytes()[:4] == b"\x89PNG"


CONTOUR_COLUMNS = ("contour_err_max_um", "contour_err_mean_um", "contour_err_rms_um")


def test_cli_compare_servo_contour_columns(tmp_path, capsys):
    """`compare SHAPE --servo-kv-1-s 30` prints and writes the contour error of every method; a
    stiffer loop (or Heidenhain's kV) and feed-forward change it the way the model says."""
    reports = {}
    for tag, flags in {"kv30": ["--servo-kv-1-s", "30"], "kv60": ["--servo-kv-1-s", "60,60,60"],
                       "heidenhain": ["--servo-kv-m-min-mm", "1.8"], "ff": ["--servo-ff", "0.9"]}.items():
        out = tmp_path / f"{tag}.csv"
        assert main(["compare", "infinity", "--points", "600", "-o", str(out), *flags]) == 0
        printed = capsys.readouterr().out
        assert "contour max (um)" in printed and "contour rms (um)" in printed
        reports[tag] = pd.read_csv(out).set_index("method")
    df = reports["kv30"]
    assert df.index.tolist() == list(METHODS)
    assert set(CONTOUR_COLUMNS) <= set(df.columns)
    assert (df[list(CONTOUR_COLUMNS)] > 0).all(axis=None) and df[list(CONTOUR_COLUMNS)].notna().all(axis=None)
    assert (df["contour_err_mean_um"] <= df["contour_err_rms_um"]).all()
    assert (df["contour_err_rms_um"] <= df["contour_err_max_um"]).all()
    # 1.8 m/min/mm is 30 1/s; doubling Kv roughly quarters the (v²κ/2Kv²) contour error
    pd.testing.assert_frame_equal(reports["heidenhain"][list(CONTOUR_COLUMNS)], df[list(CONTOUR_COLUMNS)])
    ratio = reports["kv60"]["contour_err_max_um"] / df["contour_err_max_um"]
    assert ((ratio > 0.15) & (ratio < 0.35)).all()
    assert (reports["ff"]["contour_err_max_um"] < 0.5 * df["contour_err_max_um"]).all()


@pytest.mark.parametrize("args, message", [
    (["--servo-kv-1-s", "0"], "--servo-kv-1-s: '0' must be a finite number > 0"),
    (["--servo-kv-1-s", "30,30"], "give one number for all axes or three"),
    (["--servo-ff", "1.5"], "--servo-ff: '1.5' must be a fraction between 0 and 1"),
    (["--servo-kv-1-s", "30", "--servo-natural-freq-hz", "10"], "not allowed with argument"),
    (["--feed-mm-min", "0"], "--feed-mm-min: '0' must be a finite number > 0"),
    (["--feed-mm-min", "-5"], "must be a finite number > 0"),
    (["--rules", "{bad_rules}"], "bad.toml"),
    (["--jerk-mm-s3", "nan"], "must be a finite number > 0"),
])
def test_cli_compare_bad_input(tmp_path, capsys, args, message):
    bad = tmp_path / "bad.toml"
    bad.write_text("this is = not [ a rule table\n")
    out = tmp_path / "report.csv"
    args = [a.format(bad_rules=bad) for a in args]
    with pytest.raises(SystemExit) as info:
        code = main(["compare", "infinity", "-o", str(out), *args])
        raise SystemExit(code)
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not out.exists()


def test_table_jerk_is_measured_at_the_table_resolution():
    """The SLW schedule's feed, sampled and executed as a table, keeps (nearly) its jerk limit:
    the per-sample execution does not invent jerk from its own sampling."""
    samples = sample_shape(load_shape("infinity"), 2000)
    limits = MachineLimits()
    table = schedule(samples.curve, limits, planner="window", transition="cosine").feed_at(samples)
    from fuzzyfeed.machine.simulate import simulate_profile

    m = simulate_profile(table, limits).metrics
    assert m.tan_jerk_max_mm_s3 <= 1.2 * limits.jerk_mm_s3
    assert m.cycle_time_s == pytest.approx(table.travel_time_s(), rel=1e-12)


def test_cli_compare_on_an_imported_polyline(tmp_path, capsys):
    """A G-code program (a point sequence) compares like a NURBS: the planners move along its
    degree-1 curve, the advisor uses the three-point curvature of its vertices."""
    program = tmp_path / "inf.ngc"
    assert main(["advise", "infinity", "--points", "300", "-o", str(tmp_path / "a.csv"),
                 "--gcode", str(program)]) == 0
    report = tmp_path / "report.csv"
    assert main(["compare", str(program), "-o", str(report)]) == 0
    df = pd.read_csv(report)
    assert df["method"].tolist() == list(METHODS)
    assert (df.loc[df["method"] == "slw", [c for c in df.columns if c.startswith("violations_")]] == 0).all(axis=None)
    assert "Traceback" not in capsys.readouterr().err


@pytest.mark.parametrize("name", shape_names())
def test_fuzzy_safe_breaks_no_limit_on_every_shipped_shape(name):
    # the jerk-limited schedule under min(advice, machine): 0 violating ticks, jerk included
    shape = load_shape(name)
    c = compare(sample_shape(shape), MachineLimits(), name=name)
    for method in ("fuzzy-safe", "slw"):
        violations = c.simulations[method].metrics.violations
        assert all(count == 0 for count, _ in violations.values()), (method, violations)


def test_cli_compare_samples_inside_long_lines(tmp_path, capsys):
    """A CAM program of long G1 lines between corners: the bound row, the bound's feed executed
    between the samples, is the bound (it crawled at the corners' feed along every line when only
    the move ends were samples: 1.53 x the bound on a Fusion-style contour)."""
    program = tmp_path / "rect.ngc"
    program.write_text("%\n(rectangle with chamfers)\nG90 G94 G17\nG21\nG54\nG0 X0. Y0.\nG43 Z5. H1\n"
                       "G1 Z-1. F300.\nX60. F1200.\nX65. Y5.\nY35.\nX60. Y40.\nX0.\nY0.\nG0 Z5.\nM30\n%\n")
    report = tmp_path / "report.csv"
    assert main(["compare", str(program), "-o", str(report)]) == 0
    out = capsys.readouterr().out
    df = pd.read_csv(report).set_index("method")
    assert df.loc["bound", "ratio_to_bound"] == pytest.approx(1.0, abs=0.02)
    assert df.loc["slw", "ratio_to_bound"] > 1.0
    samples = int(out.split(" samples,")[0].rsplit(" ", 1)[-1])
    assert samples >= 4 * 201  # 201 mm of path, a sample every 0.25 mm at most
