"""The uniform slowdown's places set apart (issue 36 item 3, program/apart.py): a G1 plunge entered
from rapids 10 mm above the stock keeps the tool's lag from the rapids whatever F is, so no factor
holds the tolerance there; the factor is found for the rest of the program and the place is listed
apart. Checked against trace_motion (every tick of the whole run in memory), not against the
search's own runs."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.machine.planner import Motion
from fuzzyfeed.machine.trace import trace_motion
from fuzzyfeed.program import uniform as reference
from fuzzyfeed.program.read import read_program
from fuzzyfeed.program.run import program_path, run_program

# a pocket's first pass, a retract, a short rapid across and a G1 plunge from Z10 at F500 (as
# blendercam's _from_curve writes it), then a pass from there; PLUNGE_FROM_REST the same with a
# rapid down to Z1 first (the plunge starts with the tool settled: nothing to set apart)
PLUNGE_FROM_RAPIDS = """G21 G90 G94 G17
G0 X0 Y0 Z1
G1 Z-0.2 F300
G1 X20 F3000
G1 Y20
G1 X0
G0 Z10
G0 X-0.12 Y19.46
G1 Z-0.2 F500
G1 X-0.12 Y0 F3000
G1 X20
G0 Z10
M2
"""
PLUNGE_FROM_REST = PLUNGE_FROM_RAPIDS.replace("G0 X-0.12 Y19.46\n", "G0 X-0.12 Y19.46\nG0 Z1\n")


def _path(tmp_path, text):
    f = tmp_path / "p.ngc"
    f.write_text(text)
    machine = load_machine("reference")
    return machine, program_path(read_program(f), machine.chord_tol_mm)


def _traced_um(path, machine, scale, line=None):
    """Largest contour error in the part (µm) of every tick of the whole run with every F × ``scale``
    (trace_motion): outside the moves of program line ``line`` (0-based), and on them."""
    out, on = 0.0, 0.0
    for chain in path.chains:
        m = chain.motion
        motion = Motion(m.points, np.where(m.rapid, m.feed_mm_s, m.feed_mm_s * scale), m.rapid, m.arc_radius_mm)
        tr = trace_motion(motion, machine, chain.seg_measured)
        at = path.program.move_line[chain.seg_move[tr.tick_segment]] == line
        out = max(out, float(tr.contour_mm[~at].max(initial=0.0)) * 1e3)
        on = max(on, float(tr.contour_mm[at].max(initial=0.0)) * 1e3)
    return out, on


def test_a_plunge_from_rapids_is_set_apart_and_the_factor_found(tmp_path):
    machine, path = _path(tmp_path, PLUNGE_FROM_RAPIDS)
    tol = machine.contour_tol_um
    u = reference.uniform_slowdown(path, machine)
    assert not u.bounded and u.checked and u.run is not None and u.factor < 0.5
    assert len(u.apart) == 1
    place = u.apart[0]
    assert place.line == 8 and place.xyz == (-0.12, 19.46, 10.0)      # the plunge's top, line 9
    assert place.floor_um > tol and place.factor_um > tol
    # the tick reference: at the factor the rest holds, the plunge does not; a step above, the rest breaks
    out, on = _traced_um(path, machine, u.factor, line=8)
    assert out <= tol + 1e-3 and out == pytest.approx(u.max_um, abs=1e-3)
    assert on == pytest.approx(place.factor_um, abs=1e-3)
    above, _ = _traced_um(path, machine, u.factor * (1 + 3 * reference.UNIFORM_RTOL), line=8)
    assert above > tol
    # and the plunge is over the tolerance even at F × 0.01: no factor would have been found
    _, floor = _traced_um(path, machine, 0.01, line=8)
    assert floor > tol and floor == pytest.approx(place.floor_um, rel=0.05)
    text = place.text()
    assert text.startswith("line 9 (-0.12, 19.46, 10)") and "F x 0.01" in text


def test_without_a_plunge_from_rapids_nothing_is_set_apart(tmp_path, monkeypatch):
    machine, path = _path(tmp_path, PLUNGE_FROM_REST)
    tol = machine.contour_tol_um
    u = reference.uniform_slowdown(path, machine)
    assert u.apart == () and not u.bounded and u.run is not None
    assert u.max_um == u.run.max_um
    out, _ = _traced_um(path, machine, u.factor)
    assert out <= tol + 1e-3 and out == pytest.approx(u.run.max_um, abs=1e-3)
    above, _ = _traced_um(path, machine, u.factor * (1 + 3 * reference.UNIFORM_RTOL))
    assert above > tol
    # the same factor as the search on whole runs alone (no hot stretches, nothing measured at the floor)
    monkeypatch.setattr(reference, "UNIFORM_CHECKS", 0)
    whole = reference.uniform_slowdown(path, machine, run_program(path, machine))
    assert whole.apart == () and whole.factor == pytest.approx(u.factor, rel=reference.UNIFORM_RTOL)


def test_a_place_the_floor_does_not_clear_is_not_set_apart(tmp_path, monkeypatch):
    # with the floor measure finding nothing (the plunge's floor error made 0), the plunge keeps the
    # search from finding a factor: the result is a bound, and says none was set apart
    import fuzzyfeed.program.apart as apart

    machine, path = _path(tmp_path, PLUNGE_FROM_RAPIDS)
    monkeypatch.setattr(apart, "floor_errors", lambda motion, measured, machine, segments: np.zeros(len(segments)))
    u = reference.uniform_slowdown(path, machine, max_ticks=2e6)
    assert u.bounded and u.apart == ()


def test_the_value_report_lists_the_places_set_apart(tmp_path):
    from fuzzyfeed.fuzzy.rule_reader import load_rule_table
    from fuzzyfeed.report.value import evaluate_program
    from fuzzyfeed.report.value_files import report_table_html

    f = tmp_path / "p.ngc"
    f.write_text(PLUNGE_FROM_RAPIDS)
    machine = load_machine("reference")
    program = read_program(f)
    table = load_rule_table("machine")
    r = evaluate_program(program, machine, table, reference=False).report
    assert len(r.uniform_apart) == 1 and r.uniform.max_um <= r.tol_um
    text = "\n".join(r.lines())
    assert "uniform: 1 place(s) set apart" in text and "line 9 (-0.12, 19.46, 10), s = " in text
    row = r.csv_row()
    assert row["uniform_set_apart"] == 1 and row["uniform_set_apart_max_um"] == r.uniform_apart[0].floor_um
    assert not row["uniform_is_bound"]
    assert "<li>line 9 (-0.12, 19.46, 10)" in report_table_html([r])
    # left for later (advise --machine without --report), then checked: the same places
    ev = evaluate_program(program, machine, table, reference=False, check_uniform=False)
    assert [p.line for p in ev.report.uniform_apart] == [8]
    done = ev.checked().report
    assert done.uniform_apart == r.uniform_apart and done.uniform == r.uniform and done.lines() == r.lines()


def test_the_limit_reference_stopped_at_a_place_set_apart_says_so(tmp_path):
    from fuzzyfeed.fuzzy.rule_reader import load_rule_table
    from fuzzyfeed.report.value import evaluate_program

    f = tmp_path / "p.ngc"
    f.write_text(PLUNGE_FROM_RAPIDS)
    r = evaluate_program(read_program(f), load_machine("reference"), load_rule_table("machine")).report
    assert not r.reference_converged and r.reference_apart      # its passes cannot fix the plunge either
    assert "the limit reference ends at" in r.verdict() and "a place the uniform slowdown sets apart" in r.verdict()


def test_a_result_left_for_later_is_checked_the_same_twice(tmp_path):
    machine, path = _path(tmp_path, PLUNGE_FROM_RAPIDS)
    hot = reference.uniform_slowdown(path, machine, check=False)
    assert not hot.checked and len(hot.apart) == 1 and np.isnan(hot.apart[0].factor_um)
    one = reference.check_uniform(path, machine, hot)
    two = reference.check_uniform(path, machine, hot)
    assert one.factor == two.factor and one.runs == two.runs and one.apart == two.apart
    assert one.apart[0].factor_um > machine.contour_tol_um


def test_the_place_over_the_tolerance_is_named_by_the_advised_programs_line(tmp_path, monkeypatch, capsys):
    """The advised run's worst place is a line of the advised program (the rewrite inserts lines:
    line 14 does not exist in the 13-line input); the summary says so, and that line of the written
    G-code is the move whose span holds the point."""
    import re

    from fuzzyfeed.cli import main

    (tmp_path / "p.ngc").write_text(PLUNGE_FROM_RAPIDS)
    monkeypatch.chdir(tmp_path)
    assert main(["advise", "p.ngc", "--machine", "reference", "-o", "x.csv", "--gcode", "y.ngc"]) == 0
    out = capsys.readouterr().out
    found = re.search(r"um at line (\d+) of the advised program \(([^)]*)\) is over the tolerance", out)
    assert found, out
    line = int(found.group(1))
    xyz = np.array([float(c) for c in found.group(2).split(",")])
    assert line > len(PLUNGE_FROM_RAPIDS.splitlines())
    advised = read_program(tmp_path / "y.ngc")
    at = np.flatnonzero(advised.move_line == line - 1)
    assert at.size
    a, b = advised.start[at[0]], advised.end[at[-1]]
    t = float(np.dot(xyz - a, b - a) / np.dot(b - a, b - a))
    assert -1e-6 <= t <= 1 + 1e-6 and np.linalg.norm(a + t * (b - a) - xyz) < 1e-3
