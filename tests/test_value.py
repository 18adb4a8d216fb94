"""Advice worth having (issue 32): machine-aware advice holds the tolerance on the controller and
servo model, never exceeds a programmed F, leaves a program that already holds the tolerance
alone, beats the uniform slowdown, and reads dimensionless inputs."""

from __future__ import annotations

import csv
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from canon import canon, compare
from fuzzyfeed.cli import main
from fuzzyfeed.fuzzy.machine_inputs import machine_features
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.machine.description import Machine, load_machine
from fuzzyfeed.machine.servo import ServoModel
from fuzzyfeed.program.cuts import sample_cut
from fuzzyfeed.program.read import parse_program, read_program
from fuzzyfeed.program.run import program_path, run_program
from fuzzyfeed.report.value import evaluate_program

CORPUS = Path(__file__).parent / "programs" / "corpus"


@pytest.fixture(scope="module")
def grbl02():
    program = read_program(CORPUS / "grbl_02.ngc")
    return program, evaluate_program(program, load_machine("reference"), load_rule_table("machine"))


def test_advice_holds_the_tolerance_and_beats_the_uniform_slowdown(grbl02):
    _, ev = grbl02
    r = ev.report
    assert r.written.max_um > 3 * r.tol_um                    # the program breaks the tolerance
    assert r.advised.max_um <= r.tol_um
    assert r.uniform.max_um <= r.tol_um and r.uniform_factor < 0.5
    assert r.advised.time_s <= 0.7 * r.uniform.time_s
    assert r.reference is not None and r.reference_converged
    assert r.advised.time_s <= 1.5 * r.reference.time_s
    assert "holds the tolerance" in r.verdict()


def test_the_advised_program_never_runs_above_its_f(grbl02):
    program, ev = grbl02
    machine = load_machine("reference")
    written = program_path(program, machine.chord_tol_mm)
    advised = program_path(parse_program(ev.text, program.path), machine.chord_tol_mm)

    def along(path):
        """Per measured segment: the arc length at its end and at its middle, and its F."""
        end, mid, f = [], [], []
        off = 0.0
        for chain in path.chains:
            keep = chain.seg_measured
            lk = np.linalg.norm(np.diff(chain.motion.points, axis=0), axis=1)[keep]
            end.append(off + np.cumsum(lk))
            mid.append(off + np.cumsum(lk) - lk / 2)
            f.append(chain.motion.feed_mm_s[keep])
            off += lk.sum()
        return np.concatenate(end), np.concatenate(mid), np.concatenate(f)

    ew, _, fw = along(written)
    ea, ma, fa = along(advised)
    assert abs(ew[-1] - ea[-1]) < 1e-6              # the same path, only split
    idx = np.clip(np.searchsorted(ew, ma), 0, fw.size - 1)   # the written segment each advised one lies in
    assert np.all(fa <= fw[idx] + 1e-9)
    assert np.all(fa > 0)
    assert fa.min() < 0.2 * fw.max()                # and it does slow down somewhere


def test_a_program_that_holds_the_tolerance_is_left_alone(tmp_path, capsys):
    text = ("G21 G90 G94 G17\nG0 X0 Y0 Z1\nG1 Z0 F100\nG1 X40 Y0 F300\nG2 X60 Y20 I0 J20\n"
            "G1 X60 Y40\nG0 Z5\nM2\n")
    src = tmp_path / "gentle.ngc"
    src.write_text(text)
    out, ngc = tmp_path / "a.csv", tmp_path / "a.ngc"
    code = main(["advise", str(src), "-o", str(out), "--gcode", str(ngc), "--machine", "reference"])
    printed = capsys.readouterr().out
    assert code == 0
    assert ngc.read_text() == text                    # byte for byte
    assert "holds the tolerance" in printed and "left alone" in printed
    with open(out, newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert rows and all(r["advised"] == "0" and float(r["feed_pct"]) == 100.0 for r in rows)


def test_machine_inputs_are_invariant_under_scaling_feed_and_machine_together():
    """F -> cF, Kv -> cKv, A -> c^2 A, V -> cV and Ts -> Ts/c leave every error (and so both ratios)
    unchanged: the same motion, run c times faster."""
    program = read_program(CORPUS / "fusion_03.ngc")
    base = Machine(servo=ServoModel(kv_1_s=30.0), ts_s=0.001)
    cs = sample_cut(program, 0)
    ceiling = program.feed_mm_min[cs.sample_move] / 60.0
    ref = machine_features(cs.samples, ceiling, base, cs.turn_angle, cs.corner, cs.entry_direction)
    for c in (0.5, 3.0):
        scaled = replace(base, servo=ServoModel(kv_1_s=30.0 * c), axis_acc_mm_s2=(1000.0 * c * c,) * 3,
                         path_acc_mm_s2=1000.0 * c * c, axis_vel_mm_s=(100.0 * c,) * 3, ts_s=0.001 / c)
        got = machine_features(cs.samples, ceiling * c, scaled, cs.turn_angle, cs.corner, cs.entry_direction)
        np.testing.assert_allclose(got.safe_feed_ratio, ref.safe_feed_ratio, rtol=2e-3)
        np.testing.assert_allclose(got.safe_feed_ratio_near, ref.safe_feed_ratio_near, rtol=2e-3)
    assert ref.safe_feed_ratio_near.min() < 0.5       # the cut has hot spots: the check is not empty


def test_a_tighter_tolerance_or_a_softer_servo_slows_more():
    program = read_program(CORPUS / "fusion_03.ngc")
    cs = sample_cut(program, 0)
    ceiling = program.feed_mm_min[cs.sample_move] / 60.0
    base = machine_features(cs.samples, ceiling, Machine(), cs.turn_angle, cs.corner, cs.entry_direction)
    tight = machine_features(cs.samples, ceiling, Machine(contour_tol_um=10.0), cs.turn_angle, cs.corner,
                             cs.entry_direction)
    soft = machine_features(cs.samples, ceiling, Machine(servo=ServoModel(kv_1_s=15.0)), cs.turn_angle,
                            cs.corner, cs.entry_direction)
    assert np.all(tight.safe_feed_mm_s <= base.safe_feed_mm_s)
    assert tight.safe_feed_ratio_near.mean() < base.safe_feed_ratio_near.mean()
    assert soft.safe_feed_ratio_near.mean() < base.safe_feed_ratio_near.mean()


def test_cli_value_report_and_rs274_round_trip(tmp_path, capsys):
    src = CORPUS / "fusion_05.ngc"
    out, ngc, html, rep_csv, png = (tmp_path / n for n in ("a.csv", "a.ngc", "r.html", "r.csv", "p.png"))
    args = ["advise", str(src), "-o", str(out), "--gcode", str(ngc), "--axis-acc-mm-s2", "1000",
            "--servo-kv-1-s", "30", "--junction-deviation-mm", "0.01", "--contour-tol-um", "50"]
    assert main(args + ["--report", str(html), "--plot", str(png)]) == 0
    printed = capsys.readouterr().out
    for label in ("as written", "advised", "uniform x", "limit reference"):
        assert label in printed
    page = html.read_text()
    assert "<table>" in page and "data:image/png;base64," in page and "fusion_05.ngc" in page
    assert png.stat().st_size > 10_000
    result = compare(canon(src, tmp_path), canon(ngc, tmp_path))
    assert result.feed_moves > 0 and result.min_ratio < 0.5
    assert main(args + ["--report", str(rep_csv), "--no-reference"]) == 0
    with open(rep_csv, newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 1 and rows[0]["program"] == "fusion_05.ngc"
    assert float(rows[0]["advised_max_um"]) <= 50.0 < float(rows[0]["written_max_um"])
    assert rows[0]["reference_time_s"] == "nan"


def test_value_flags_need_a_program_and_a_machine(tmp_path, capsys):
    code = main(["advise", "trident", "-o", str(tmp_path / "a.csv"), "--report", str(tmp_path / "r.html")])
    assert code == 2 and "not a program" in capsys.readouterr().err
    code = main(["advise", str(CORPUS / "grbl_02.ngc"), "-o", str(tmp_path / "a.csv"),
                 "--report", str(tmp_path / "r.html")])
    err = capsys.readouterr().err
    assert code == 2 and "needs a machine" in err
    assert not (tmp_path / "a.csv").exists() and not (tmp_path / "r.html").exists()
    code = main(["advise", "trident", "-o", str(tmp_path / "a.csv"), "--rules", "machine"])
    assert code == 2 and "give a machine" in capsys.readouterr().err


def test_shapes_take_machine_advice_too(tmp_path, capsys):
    out = tmp_path / "t.csv"
    assert main(["advise", "trident", "-o", str(out), "--machine", "reference"]) == 0
    with open(out, newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert {"safe_feed_mm_min", "safe_feed_ratio", "safe_feed_ratio_near"} <= set(rows[0])
    pct = np.array([float(r["feed_pct"]) for r in rows])
    assert pct.max() == 100.0 and pct.min() < 20.0


def test_a_run_reports_the_worst_place():
    text = "G21 G90 G94\nG0 X0 Y0 Z0\nG1 X50 Y0 F6000\nG1 X50 Y50\nG1 X0 Y50\nM2\n"
    program = parse_program(text, "square.ngc")
    machine = Machine()
    run = run_program(program_path(program, machine.chord_tol_mm), machine)
    line, xyz = run.worst()
    assert run.max_um > machine.contour_tol_um
    assert line in (3, 4)                    # 0-based: a corner's leaving move
    assert np.allclose(xyz[:2], [50, 0], atol=1) or np.allclose(xyz[:2], [50, 50], atol=1)


def test_an_f_far_above_the_machine_is_the_machine_speed():
    """A program written at F 1e6 (LinuxCNC's 3D_Chips does so: 'as fast as the machine goes') is
    advised as the same program at the machine's own speed: the ratios and the fractions refer to
    the feed the axes can reach, so the advice still holds the tolerance (at 0.05 % of F1e6 it
    could not: 500 mm/min on a 0.5 mm corner radius is too fast), and the uniform slowdown is found,
    not bounded by a time estimate that assumed the run slows with F."""
    text = CORPUS.joinpath("grbl_02.ngc").read_text()
    fast = "\n".join(_with_feed(line, 1e6) for line in text.splitlines()) + "\n"
    program = parse_program(fast, "fast.ngc")
    assert program.feed_mm_min[program.cut_moves(0)].min() == 1e6
    machine = load_machine("reference")
    ev = evaluate_program(program, machine, load_rule_table("machine"), reference=False)
    r = ev.report
    assert r.written.max_um > 3 * r.tol_um and r.advised.max_um <= r.tol_um
    assert not r.uniform.label.endswith("(at least)") and r.uniform.max_um <= r.tol_um
    assert r.uniform_factor < 0.01 and f"uniform x{r.uniform_factor:.3g}" in "\n".join(r.lines())
    advised = parse_program(ev.text, "fast.ngc")
    assert np.nanmax(advised.feed_mm_min) <= 1e6


def _with_feed(line: str, feed: float) -> str:
    import re

    return re.sub(r"F[0-9.]+", f"F{feed:.0f}", line)


def test_a_chain_with_nothing_measured_adds_no_segment_to_the_feed_trace():
    """A chain of one rapid between two offset changes (LinuxCNC's systems.ngc: G54, G0 X1 Y0, G92)
    has no measured segment; the plot's arc lengths stayed one longer than their ends (a
    broadcast error ended the value report)."""
    from types import SimpleNamespace

    from fuzzyfeed.machine.planner import Motion
    from fuzzyfeed.program.run import Chain
    from fuzzyfeed.report.value_trace import _along

    def chain(points, measured):
        pts = np.array(points, float)
        n = len(points) - 1
        motion = Motion(pts, np.full(n, 10.0), ~np.array(measured), np.full(n + 1, np.nan))
        return Chain(motion, np.arange(n), np.array(measured))

    path = SimpleNamespace(chains=[chain([[0, 0, 0], [1, 0, 0], [1, 2, 0]], [True, True]),
                                   chain([[1, 2, 0], [5, 5, 0]], [False]),
                                   chain([[5, 5, 0], [6, 5, 0]], [True])])
    s0, s1, feed, a, b, offsets = _along(path)
    assert s0.size == s1.size == feed.size == 3
    assert np.allclose(s0, [0, 1, 3]) and np.allclose(s1, [1, 3, 4]) and offsets == [0.0, 3.0, 3.0]


def test_machine_advice_is_a_fraction_of_each_moves_own_f():
    """Every written feed is at least the move's slowest advised fraction times that move's own F
    (quantised down): the segment that ends a contour move at a plunge is not judged by the
    plunge's F (it was once, through the per-sample feed the machine can reach: F40 for F230)."""
    from fuzzyfeed.program.feeds import advise_program

    program = read_program(CORPUS / "grbl_02.ngc")
    pa = advise_program(program, load_rule_table("machine"), machine=load_machine("reference"))
    step = pa.feed_step_mm_min
    lowest: dict[int, float] = {}
    for cs, adv in zip(pa.cuts, pa.advice):
        phi = adv.feed_pct / 100.0
        seg_phi = np.minimum(phi[:-1], phi[1:])
        for m in np.unique(cs.seg_move):
            f = program.feed_mm_min[m]
            bound = max(step, np.floor(seg_phi[cs.seg_move == m].min() * f / step) * step)
            lowest[int(m)] = min(f, bound)
    assert lowest
    for m, feed in zip(pa.piece_move, pa.piece_feed_mm_min):
        assert feed >= lowest[int(m)] - 1e-9, (int(m), feed, lowest[int(m)])


def test_the_report_says_the_error_in_the_air_apart(grbl02):
    # issue 37 defect 3: the rows are the error in the part; the error of a tool still nearest a
    # rapid as a feed move starts is said apart, with its line, in the text and the HTML page
    from fuzzyfeed.report.value_files import report_table_html

    program, ev = grbl02
    r = ev.report
    assert r.written.air_um > 0 and r.worst_air is not None
    line = r.air_line()
    assert line.startswith("in the air") and f"line {r.worst_air[0] + 1} " in line
    assert line in r.lines()[-1]
    assert "in the air" in report_table_html([r])


def test_a_move_from_an_unknown_start_is_not_run():
    # the first move starts where the machine happens to be: its length, direction and the lag it
    # leaves are unknown, so the run starts at its end, from rest (the reader's placeholder start
    # 0,0,0 is not a path: run from it, a 300 mm rapid left ~lag of 3000 mm/s / Kv at the plunge)
    text = "G21 G90 G94\nG0 X300 Y0 Z0\nG1 Z-1 F100\nG1 X310 F1200\nG0 Z5\nM2\n"
    program = parse_program(text, "u.ngc")
    assert not program.known[0] and program.known[1:].all()
    machine = load_machine("reference")
    path = program_path(program, machine.chord_tol_mm)
    assert path.chains[0].seg_move[0] == 1
    np.testing.assert_allclose(path.chains[0].motion.points[0], [300, 0, 0])
    run = run_program(path, machine)
    # from rest at (300, 0, 0): the plunge and the 10 mm line alone, a 90° corner at 20 mm/s:
    # lag v/Kv = 0.67 mm cut across at most; nothing in the air
    assert run.air_max_um == 0.0
    ev = evaluate_program(program, machine, load_rule_table("machine"))
    assert ev.report.advised.max_um <= 1.2 * machine.contour_tol_um
