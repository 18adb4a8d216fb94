"""G-code export: LinuxCNC's own interpreter (rs274) accepts every program and reads back the
exported points and feeds; F rules (never 0, written only on change, quantised); G5.2 for uniform
clamped knots and a clear refusal otherwise; atomic output."""

from __future__ import annotations

import os
import re
import shutil
import subprocess

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzyfeed.errors import ExportError
from fuzzyfeed.io.gcode import (check_g52_curve, gcode_program, linuxcnc_knots, write_gcode,
                                write_gcode_nurbs)
from fuzzyfeed.io.shapes import load_shape, shape_names
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.machine.profile import FeedProfile
from fuzzyfeed.geometry.sampling import sample_uniform_u, samples_from_points

UNIFORM_SHAPES = ("infinity", "trident", "trident2")
NON_UNIFORM_SHAPES = ("wm", "butterfly")
#: rs274 prints coordinates and feeds with 4 decimals.
RS274_DECIMALS = 4


def rs274_binary() -> str:
    """Path of rs274; fails when CI demands it (FUZZYFEED_REQUIRE_RS274=1), else skips."""
    found = shutil.which("rs274")
    if found:
        return found
    reason = ("rs274 not found: install Debian's linuxcnc-uspace (apt-get install linuxcnc-uspace) "
              "to check exported programs with LinuxCNC's interpreter")
    if os.environ.get("FUZZYFEED_REQUIRE_RS274"):
        pytest.fail(reason + " (FUZZYFEED_REQUIRE_RS274 is set)")
    pytest.skip(reason)


def run_rs274(program, tmp_path):
    """Run ``rs274 -g`` on a program file; returns the canonical-call lines (exit 0 asserted)."""
    out = tmp_path / (program.stem + ".canon")
    result = subprocess.run([rs274_binary(), "-g", str(program), str(out)], capture_output=True,
                            text=True, stdin=subprocess.DEVNULL, timeout=120)
    assert result.returncode == 0, f"rs274 rejected {program}: {result.stdout[-500:]} {result.stderr[-500:]}"
    text = out.read_text()
    assert "PROGRAM_END" in text
    return text.splitlines()


def canon_moves(lines):
    """(traverse targets, feed-move targets, feed in force per feed move, SET_FEED_RATE values)."""
    call = re.compile(r"\b([A-Z_]+)\((.*)\)\s*$")
    traverses, feeds_xyz, feed_per_move, set_rates = [], [], [], []
    rate = None
    for line in lines:
        m = call.search(line)
        if not m:
            continue
        name, args = m.groups()
        if name == "SET_FEED_RATE":
            rate = float(args)
            set_rates.append(rate)
        elif name in ("STRAIGHT_FEED", "STRAIGHT_TRAVERSE"):
            xyz = [float(a) for a in args.split(",")[:3]]
            if name == "STRAIGHT_FEED":
                feeds_xyz.append(xyz)
                feed_per_move.append(rate)
            else:
                traverses.append(xyz)
    return np.array(traverses), np.array(feeds_xyz), np.array(feed_per_move), set_rates


def curvature_profile(shape_name: str, n: int = 2000, rest_at_ends: bool = True) -> FeedProfile:
    """A curvature-dependent feed on the seed-002 sampling, 0 at both ends like an SLW profile."""
    samples = sample_uniform_u(load_shape(shape_name).curve, n)
    k = samples.curvature
    feed = 10.0 + 90.0 / (1.0 + 20.0 * k / k.max())
    if rest_at_ends:
        feed[0] = feed[-1] = 0.0
    return FeedProfile(samples, feed, "test", 100.0)


def assert_rs274_reproduces(path, program, profile, tmp_path, decimals):
    lines = run_rs274(path, tmp_path)
    traverses, xyz, feed, _ = canon_moves(lines)
    tol = 0.5 * 10.0 ** -RS274_DECIMALS + 1e-9
    # the G0 target and every G1 end point, as written, read back by LinuxCNC
    np.testing.assert_allclose(traverses[-1], program.start_mm, rtol=0, atol=tol)
    assert xyz.shape == program.points_mm.shape
    np.testing.assert_allclose(xyz, program.points_mm, rtol=0, atol=tol)
    np.testing.assert_allclose(feed, program.feeds_mm_min, rtol=0, atol=tol)
    # ... and those are the profile's samples to the written precision
    if len(program.points_mm) == len(profile.samples) - 1:
        coarse = 0.5 * 10.0 ** -min(decimals, RS274_DECIMALS) + 1e-9
        if decimals > RS274_DECIMALS:  # written rounded to `decimals`, printed rounded to 4
            coarse += 0.5 * 10.0 ** -decimals
        np.testing.assert_allclose(xyz, profile.samples.xyz[1:], rtol=0, atol=coarse)
        np.testing.assert_allclose(traverses[-1], profile.samples.xyz[0], rtol=0, atol=coarse)
    assert np.all(feed > 0)


@pytest.mark.parametrize("name", shape_names())
def test_rs274_accepts_and_reproduces_curvature_profile(name, tmp_path):
    profile = curvature_profile(name)
    path = tmp_path / f"{name}.ngc"
    program = write_gcode(path, profile)
    assert path.read_text() == program.text
    assert_rs274_reproduces(path, program, profile, tmp_path, 4)
    # F of each move = mean of its two end feeds (mm/min), to the F word's 0.1 mm/min
    seg = 0.5 * (profile.feed_mm_min[:-1] + profile.feed_mm_min[1:])
    np.testing.assert_allclose(program.feeds_mm_min, seg, rtol=0, atol=0.05 + 1e-9)


@pytest.mark.parametrize("options", [
    {"decimals": 3}, {"decimals": 6}, {"line_numbers": True}, {"feed_step_mm_min": 100.0},
    {"feed_step_mm_min": 250.0, "line_numbers": True, "decimals": 5}, {"feed_decimals": 3},
])
def test_rs274_accepts_every_option(options, tmp_path):
    profile = curvature_profile("infinity", n=500)
    path = tmp_path / "opt.ngc"
    program = write_gcode(path, profile, **options)
    assert_rs274_reproduces(path, program, profile, tmp_path, options.get("decimals", 4))
    text = path.read_text()
    assert text.count("\nG17 G21 G90 G94\n") + text.count(" G17 G21 G90 G94\n") == 1
    decimals = options.get("decimals", 4)
    first_move = next(line for line in text.splitlines() if "G1 " in line)
    assert re.search(rf"X-?\d+\.\d{{{decimals}}}\b", first_move)
    if options.get("line_numbers"):
        assert all(line.startswith("N") for line in text.splitlines() if not line.startswith("("))


def test_constant_feed_writes_one_f_word_and_2d_path_has_no_z(tmp_path):
    t = np.linspace(0, 2 * np.pi, 400)
    pts = np.column_stack([20 * np.cos(t), 10 * np.sin(2 * t)])[:-1]
    samples = samples_from_points(pts)
    assert samples.dim == 2
    profile = FeedProfile(samples, np.full(len(samples), 25.0), "constant", 50.0)
    path = tmp_path / "constant.ngc"
    program = write_gcode(path, profile)
    code = "\n".join(line for line in path.read_text().splitlines() if not line.startswith("("))
    assert code.count("F") == 1 and "F1500.0" in code and "Z" not in code
    assert program.n_feed_words == 1
    assert_rs274_reproduces(path, program, profile, tmp_path, 4)


def test_feed_step_rounds_down_and_reduces_f_words(tmp_path):
    profile = curvature_profile("butterfly")
    fine = gcode_program(profile)
    coarse = gcode_program(profile, feed_step_mm_min=200.0)
    seg = 0.5 * (profile.feed_mm_min[:-1] + profile.feed_mm_min[1:])
    assert coarse.n_feed_words < fine.n_feed_words / 5
    assert np.all(coarse.feeds_mm_min <= seg + 1e-9)                      # never faster than advised
    assert np.all((coarse.feeds_mm_min > seg - 200.0) | (coarse.feeds_mm_min == 200.0))
    assert np.allclose(coarse.feeds_mm_min / 200.0, np.round(coarse.feeds_mm_min / 200.0))


def test_zero_feed_ends_are_never_written_as_f0():
    profile = curvature_profile("trident", n=300)
    assert profile.feed_mm_s[0] == 0 and profile.feed_mm_s[-1] == 0
    program = gcode_program(profile)
    assert "F0.0" not in program.text and "F0 " not in program.text
    assert program.feeds_mm_min[0] == pytest.approx(profile.feed_mm_min[1] / 2, abs=0.05)
    assert program.feeds_mm_min[-1] == pytest.approx(profile.feed_mm_min[-2] / 2, abs=0.05)


def test_segment_with_zero_at_both_ends_takes_next_positive_feed():
    samples = sample_uniform_u(load_shape("infinity").curve, 6)
    profile = FeedProfile(samples, [0, 0, 0, 30, 30, 0], "slw", 50.0)
    program = gcode_program(profile)
    # segments: (0,0) -> next positive (0,30)/2; (0,0) -> same; (0,30); (30,30); (30,0)
    np.testing.assert_allclose(program.feeds_mm_min, [900, 900, 900, 1800, 900])


@settings(max_examples=60, deadline=None)
@given(st.lists(st.one_of(st.just(0.0), st.floats(0.0, 500.0)), min_size=5, max_size=60),
       st.sampled_from([None, 1.0, 50.0, 1000.0]))
def test_property_f_words_positive_and_written_only_on_change(feeds, step):
    feeds = np.array(feeds)
    if not np.any(0.5 * (feeds[:-1] + feeds[1:]) > 0):
        feeds[len(feeds) // 2] = 1.0
    samples = sample_uniform_u(load_shape("trident").curve, len(feeds))
    program = gcode_program(FeedProfile(samples, feeds, "h", 500.0), feed_step_mm_min=step)
    code = "\n".join(line for line in program.lines if not line.startswith("("))
    f_words = re.findall(r"F(\S+)", code)
    values = [float(f) for f in f_words]
    assert all(v > 0 and np.isfinite(v) for v in values)
    assert all(a != b for a, b in zip(f_words, f_words[1:]))       # written only when it changes
    assert len(f_words) == program.n_feed_words == 1 + int(np.sum(np.diff(program.feeds_mm_min) != 0))


def test_points_that_round_together_are_dropped(tmp_path):
    pts = np.array([[0, 0], [1e-5, 0], [1, 0], [1, 1], [1, 1 + 2e-5], [2, 1]], dtype=float)
    samples = samples_from_points(np.array([[0, 0], [1, 0.1], [1.5, 0.3], [2, 0.8], [2.5, 1.5],
                                            [3, 2.5]], dtype=float))
    profile = FeedProfile(samples, np.full(6, 10.0), "c", 10.0)
    # replace positions via a polyline profile where neighbours coincide at 4 decimals
    samples2 = type(samples)(u=samples.u, xyz=np.column_stack([pts, np.zeros(6)]), s=samples.s,
                             tangent=samples.tangent, curvature=samples.curvature, d1=samples.d1,
                             d2=samples.d2, dim=2)
    program = write_gcode(tmp_path / "drop.ngc", FeedProfile(samples2, profile.feed_mm_s, "c", 10.0))
    np.testing.assert_allclose(program.points_mm[:, :2], [[1, 0], [1, 1], [2, 1]])
    assert_rs274_reproduces(tmp_path / "drop.ngc", program, profile, tmp_path, 4)


def test_bad_options_and_profiles_leave_no_file(tmp_path):
    profile = curvature_profile("infinity", n=50)
    target = tmp_path / "keep.ngc"
    target.write_text("old\n")
    for kwargs, match in (({"decimals": 2}, "decimals = 2"), ({"feed_step_mm_min": 0.0}, "feed_step"),
                          ({"feed_step_mm_min": float("nan")}, "feed_step")):
        with pytest.raises(ExportError, match=match):
            write_gcode(target, profile, **kwargs)
    zero = FeedProfile(profile.samples, np.zeros(50), "slw", 100.0)
    with pytest.raises(ExportError, match="0 everywhere"):
        write_gcode(target, zero)
    with pytest.raises(ExportError, match="0 everywhere"):
        write_gcode(tmp_path / "new.ngc", zero)
    assert target.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.ngc"]


# ------------------------------------------------------------------------------------- G5.2
def test_linuxcnc_knot_vector():
    np.testing.assert_allclose(linuxcnc_knots(7, 4), [0, 0, 0, 0, .25, .5, .75, 1, 1, 1, 1])
    np.testing.assert_allclose(linuxcnc_knots(7, 3), [0, 0, 0, .2, .4, .6, .8, 1, 1, 1])
    np.testing.assert_allclose(linuxcnc_knots(4, 4), [0, 0, 0, 0, 1, 1, 1, 1])   # Bezier


@pytest.mark.parametrize("name", UNIFORM_SHAPES)
def test_g52_program_accepted_by_rs274(name, tmp_path):
    curve = load_shape(name).curve
    profile = curvature_profile(name, n=300)
    path = tmp_path / f"{name}_g52.ngc"
    lines = write_gcode_nurbs(path, curve, profile, line_numbers=(name == "trident"))
    canon = run_rs274(path, tmp_path)
    nurbs = [line for line in canon if "NURBS_FEED(" in line]
    assert len(nurbs) == 1
    assert re.search(rf"NURBS_FEED\({curve.n_control_points},", nurbs[0])
    _, _, _, rates = canon_moves(canon)
    f_word = float(re.search(r"\bF(\d\S*)", "\n".join(lines)).group(1))
    assert f_word in rates and f_word > 0
    seg = 0.5 * (profile.feed_mm_min[:-1] + profile.feed_mm_min[1:])
    assert f_word == pytest.approx(seg.min(), abs=0.05)   # one F: the slowest segment's feed
    # the block read back as a NURBS is the curve itself (same knots, weights, points)
    back = load_shape(str(path)).curve
    u = np.linspace(0, 1, 2001)
    np.testing.assert_allclose(back(u)[:, :curve.dim], curve(u), atol=1e-9)


@pytest.mark.parametrize("name", NON_UNIFORM_SHAPES)
def test_g52_refused_for_non_uniform_knots(name, tmp_path):
    with pytest.raises(ExportError, match=r"knots\[\d+\] = [\d.]+, uniform clamped needs [\d.]+: .*split='spans'"):
        write_gcode_nurbs(tmp_path / "x.ngc", load_shape(name).curve, 1000.0)
    assert not list(tmp_path.iterdir())


def test_g52_refused_for_degree_one_and_non_planar():
    with pytest.raises(ExportError, match="order L = degree \\+ 1 >= 3"):
        check_g52_curve(Nurbs(1, [0, 0, 1, 1], [[0, 0], [1, 1]]))
    bent = Nurbs(2, [0, 0, 0, 1, 1, 1], [[0, 0, 0], [1, 1, 0], [2, 0, 1]])
    with pytest.raises(ExportError, match="planar"):
        check_g52_curve(bent)
    with pytest.raises(ExportError, match="feed_mm_min"):
        write_gcode_nurbs("unused.ngc", load_shape("infinity").curve, 0.0)


# ------------------------------------------------------------------- G5.2, one block per span
@pytest.mark.parametrize("name", shape_names())
def test_bezier_segments_equal_the_curve_on_each_span(name):
    from fuzzyfeed.io.gcode import bezier_segments

    curve = load_shape(name).curve
    pieces = bezier_segments(curve)
    breaks = np.unique(curve.knots)
    assert len(pieces) == breaks.size - 1
    for piece, a, b in zip(pieces, breaks[:-1], breaks[1:]):
        assert piece.n_control_points == curve.degree + 1 and piece.domain == (a, b)
        u = np.linspace(a, b, 201)
        np.testing.assert_allclose(piece(u), curve(u), rtol=0, atol=1e-9)
        check_g52_curve(piece)  # uniform clamped: writable as G5.2


def test_bezier_segments_of_repeated_knots_and_a_rational_circle():
    from conftest import circle_nurbs
    from fuzzyfeed.io.gcode import bezier_segments

    circle = circle_nurbs(7.0, (1.0, -2.0))
    pieces = bezier_segments(circle)
    assert len(pieces) == 4
    for piece in pieces:
        u = np.linspace(*piece.domain, 101)
        np.testing.assert_allclose(np.linalg.norm(piece(u) - [1, -2], axis=1), 7.0, atol=1e-12)


@pytest.mark.parametrize("name", shape_names())
def test_g52_spans_program_accepted_by_rs274_for_every_shape(name, tmp_path):
    curve = load_shape(name).curve
    profile = curvature_profile(name, n=2000)
    path = tmp_path / f"{name}_spans.ngc"
    lines = write_gcode_nurbs(path, curve, profile, split="spans", line_numbers=True)
    canon = run_rs274(path, tmp_path)
    nurbs = [line for line in canon if "NURBS_FEED(" in line]
    spans = np.unique(curve.knots).size - 1
    assert len(nurbs) == spans
    assert all(f"NURBS_FEED({curve.degree + 1}," in line for line in nurbs)
    _, _, _, rates = canon_moves(canon)
    f_words = [float(x) for x in re.findall(r"\bF(\d\S*)", "\n".join(lines))]
    assert f_words and all(f > 0 for f in f_words)
    assert set(f_words) <= set(rates)
    # per-span F = the slowest advised segment feed over the span, so the program never runs faster
    seg = 0.5 * (profile.feed_mm_min[:-1] + profile.feed_mm_min[1:])
    assert min(f_words) == pytest.approx(seg.min(), abs=0.05)
    # the imported program (one chain of G5.2 blocks, sampled) lies on the curve
    back = load_shape(str(path))
    from fuzzyfeed.io.gcode import NURBS_IMPORT_POINTS_PER_SPAN
    assert len(back.polyline) == 1 + spans * NURBS_IMPORT_POINTS_PER_SPAN   # every block sampled
    pts = back.polyline[:, :2]
    u = np.linspace(*curve.domain, 400001)
    dense = curve(u)[:, :2]
    from scipy.spatial import cKDTree
    dist, _ = cKDTree(dense).query(pts)
    step = np.max(np.linalg.norm(np.diff(dense, axis=0), axis=1))
    assert dist.max() < 1e-4 + step


def test_g52_spans_refuses_profile_without_curve_parameters(tmp_path):
    samples = samples_from_points(np.array([[0, 0], [1, 1], [2, 0], [3, 1]], dtype=float))
    profile = FeedProfile(samples, np.full(4, 10.0), "c", 10.0)
    with pytest.raises(ExportError, match="samples must be parameters of this curve"):
        write_gcode_nurbs(tmp_path / "x.ngc", load_shape("wm").curve, profile, split="spans")
    with pytest.raises(ExportError, match="split = 'bezier'"):
        write_gcode_nurbs(tmp_path / "x.ngc", load_shape("wm").curve, 100.0, split="bezier")
    assert not list(tmp_path.iterdir())


# ------------------------------------------------------------------------- CLI flag helper
def _flag_parser():
    import argparse

    from fuzzyfeed.cli._gcode import add_gcode_arguments

    parser = argparse.ArgumentParser(prog="t")
    parser.add_argument("-o", "--output")
    add_gcode_arguments(parser)
    return parser


def test_gcode_flags_prepare_checked_programs_before_writing(tmp_path):
    from fuzzyfeed.cli._gcode import prepare_gcode

    profile = curvature_profile("wm", n=800)
    g1, g52 = tmp_path / "a.ngc", tmp_path / "b.ngc"
    args = _flag_parser().parse_args(["-o", str(tmp_path / "a.csv"), "--gcode", str(g1),
                                      "--gcode-g52", str(g52), "--feed-step-mm-min", "100",
                                      "--line-numbers", "--gcode-decimals", "5"])
    prepared = prepare_gcode(args, profile, load_shape("wm"))
    assert not list(tmp_path.iterdir())          # nothing written yet
    assert prepared.write() == [str(g1), str(g52)]
    run_rs274(g1, tmp_path)
    run_rs274(g52, tmp_path)
    assert "N10 G17 G21 G90 G94" in g1.read_text() and "G5.2" in g52.read_text()


@pytest.mark.parametrize("argv, message", [
    (["--feed-step-mm-min", "10"], "--feed-step-mm-min is a G-code option"),
    (["--gcode", "x.ngc", "--g52-whole"], "--g52-whole needs --gcode-g52"),
    (["-o", "same.ngc", "--gcode", "same.ngc"], "output files must differ"),
    (["--gcode-g52", "x.ngc", "--g52-whole"], r"knots\[3\] = 0.15"),
])
def test_gcode_flag_errors(argv, message, tmp_path):
    from fuzzyfeed.cli._gcode import prepare_gcode

    args = _flag_parser().parse_args(argv)
    with pytest.raises(ExportError, match=message):
        prepare_gcode(args, curvature_profile("wm", n=100), load_shape("wm"))


def test_gcode_decimals_flag_is_checked_by_argparse(capsys):
    with pytest.raises(SystemExit):
        _flag_parser().parse_args(["--gcode", "x.ngc", "--gcode-decimals", "2"])
    assert "use 3 to 9 decimals" in capsys.readouterr().err


def test_path_with_nan_is_refused_and_no_file_written(tmp_path):
    samples = sample_uniform_u(load_shape("trident").curve, 50)
    xyz = samples.xyz.copy()
    xyz[17, 1] = np.nan
    broken = type(samples)(u=samples.u, xyz=xyz, s=samples.s, tangent=samples.tangent,
                           curvature=samples.curvature, d1=samples.d1, d2=samples.d2, dim=3)
    profile = FeedProfile(broken, np.full(50, 10.0), "c", 10.0)
    with pytest.raises(ExportError, match=r"samples\.xyz\[17\] = \[.*nan.*\]; refusing to write a non-finite point"):
        write_gcode(tmp_path / "nan.ngc", profile)
    assert not list(tmp_path.iterdir())


# ------------------------------------------------------------------ advise / schedule --gcode
def test_cli_advise_and_schedule_write_gcode_rs274_accepts(tmp_path, capsys):
    from fuzzyfeed.cli import main

    csv, ngc, g52 = tmp_path / "a.csv", tmp_path / "a.ngc", tmp_path / "a52.ngc"
    assert main(["advise", "infinity", "-o", str(csv), "--gcode", str(ngc), "--gcode-g52", str(g52),
                 "--feed-step-mm-min", "100", "--line-numbers"]) == 0
    out = capsys.readouterr().out
    assert f"wrote {ngc}" in out and f"wrote {g52}" in out
    for program in (ngc, g52):
        run_rs274(program, tmp_path)
    code = "\n".join(ln for ln in ngc.read_text().splitlines() if not ln.startswith("("))
    f_values = [float(f) for f in re.findall(r" F(\S+)", code)]
    assert all(f > 0 and f % 100 == 0 for f in f_values)
    # the G-code feeds follow the CSV's advised feeds (mean of the segment ends, rounded down)
    import pandas as pd

    feed = pd.read_csv(csv)["feed_mm_min"].to_numpy()
    traverses, _, per_move, _ = canon_moves(run_rs274(ngc, tmp_path))
    # from the safe height (5 mm) over the first point, plunge, the path, retract
    assert traverses[0][2] == 5.0 and traverses[-1][2] == 5.0
    per_move = per_move[1:]   # the plunge
    seg = 0.5 * (feed[:-1] + feed[1:])
    assert np.all(per_move <= seg + 1e-9) and np.all(per_move > seg - 100 - 1e-9)

    sched = tmp_path / "s.ngc"
    assert main(["schedule", "trident2", "-o", str(tmp_path / "s.csv"), "--gcode", str(sched)]) == 0
    lines = run_rs274(sched, tmp_path)
    _, xyz, per_move, _ = canon_moves(lines)
    assert len(xyz) == 1 + 1999 and np.all(per_move > 0)   # plunge + the path


def test_cli_bad_gcode_options_write_nothing(tmp_path, capsys):
    from fuzzyfeed.cli import main

    csv = tmp_path / "w.csv"
    assert main(["advise", "wm", "-o", str(csv), "--gcode-g52", str(tmp_path / "w.ngc"),
                 "--g52-whole"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot be one G5.2 block" in err[0] and "--g52-whole" in err[0]
    assert main(["advise", "wm", "-o", str(csv), "--line-numbers"]) == 2
    assert "is a G-code option" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_schedule_gcode_takes_the_schedules_time(tmp_path, capsys):
    """A rectangle program scheduled with the SLW: the written program, run at its own F words
    (length / F per move, as rs274 reads them), takes the schedule's cycle time."""
    import pandas as pd

    from fuzzyfeed.cli import main

    rect = tmp_path / "rect.ngc"
    rect.write_text("G21 G90\nG0 X0 Y0\nG1 X60 F3000\nG1 Y40\nG1 X0\nG1 Y0\nM2\n")
    out = tmp_path / "rect_sched.ngc"
    assert main(["schedule", str(rect), "-o", str(tmp_path / "s.csv"), "--gcode", str(out)]) == 0
    cycle = float(pd.read_csv(tmp_path / "s.csv")["t_s"].iloc[-1])
    lines = run_rs274(out, tmp_path)
    _, xyz, per_move, _ = canon_moves(lines)
    pts = xyz[1:]                       # after the plunge
    start = xyz[0]
    lengths = np.linalg.norm(np.diff(np.vstack([start, pts]), axis=0), axis=1)
    t_program = float(np.sum(lengths / per_move[1:])) * 60.0
    assert t_program == pytest.approx(cycle, rel=0.01)
