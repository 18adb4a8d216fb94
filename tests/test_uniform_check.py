"""The uniform slowdown's checking run and the limit reference left to the report (issue 36):
``advise --machine`` prints the factor the hot stretches hold, marked unchecked, and says the limit
reference was not run; ``--report`` (and ``.value``) runs both and gives what the evaluation at once
gives."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fuzzyfeed.cli import main
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.program import uniform as reference
from fuzzyfeed.program.read import read_program
from fuzzyfeed.program.run import program_path, run_program
from fuzzyfeed.report.value import UNCHECKED, evaluate_program

GRBL02 = Path(__file__).parent / "programs" / "corpus" / "grbl_02.ngc"
LIBRARY = Path(__file__).parent.parent / "benchmarks" / "library" / "programs"


@pytest.fixture(scope="module")
def grbl02():
    machine = load_machine("reference")
    program = read_program(GRBL02)
    path = program_path(program, machine.chord_tol_mm)
    return machine, program, path, run_program(path, machine)


def test_unchecked_then_checked_is_the_checked_search(grbl02):
    machine, _, path, written = grbl02
    whole = reference.uniform_slowdown(path, machine, written)
    hot = reference.uniform_slowdown(path, machine, written, check=False)
    assert not hot.checked and hot.run is None and not hot.bounded
    assert hot.time_s == pytest.approx(reference._planned_time(path, machine, hot.factor), rel=1e-12)
    assert hot.max_um <= machine.contour_tol_um
    later = reference.check_uniform(path, machine, hot)
    assert later.checked and whole.checked
    assert later.factor == whole.factor and later.runs == whole.runs
    assert later.run is not None and later.run.max_um == whole.run.max_um
    assert later.run.p99_um == whole.run.p99_um and later.time_s == whole.time_s
    assert reference.check_uniform(path, machine, later) is later


def test_a_check_that_breaks_goes_on_below(grbl02, monkeypatch):
    # the hot stretches of the program as written cut down to its mildest segment's: the factor they hold
    # breaks the tolerance elsewhere, the checking run finds it and the search goes on below it,
    # the same way with the check made later as with it made at once
    machine, _, path, written = grbl02
    real_hot = reference._hot
    seen = []

    def partial_hot(run, tol_mm):
        hot = real_hot(run, tol_mm)
        if not seen:                 # the program as written: keep its mildest hot segment only
            i, j = min(((i, j) for i, h in enumerate(hot) for j in h),
                       key=lambda ij: run.runs[ij[0]].stream.seg_max_mm[ij[1]])
            hot = [np.array([j]) if k == i else np.zeros(0, np.int64) for k in range(len(hot))]
        seen.append(1)
        return hot

    monkeypatch.setattr(reference, "_hot", partial_hot)
    at_once = reference.uniform_slowdown(path, machine, written)
    seen.clear()
    hot = reference.uniform_slowdown(path, machine, written, check=False)
    later = reference.check_uniform(path, machine, hot)
    assert hot.factor > later.factor                  # the first factor broke the tolerance elsewhere
    assert later.factor == at_once.factor and later.runs == at_once.runs
    assert later.run is not None and later.run.max_um <= machine.contour_tol_um


def test_evaluation_checked_gives_the_checked_report(grbl02):
    machine, program, _, _ = grbl02
    table = load_rule_table("machine")
    at_once = evaluate_program(program, machine, table).report
    ev = evaluate_program(program, machine, table, check_uniform=False)
    assert ev.report.uniform.label.endswith(UNCHECKED) and ev.report.uniform.p99_um != ev.report.uniform.p99_um
    assert any(line.lstrip().startswith(UNCHECKED + " uniform") for line in ev.report.lines())
    assert ev.report.reference is None and ev.report.reference_deferred
    assert "limit reference: not run (--report runs it)" in "\n".join(ev.report.lines())
    done = ev.checked().report
    assert done.uniform == at_once.uniform and done.uniform_factor == at_once.uniform_factor
    assert done.lines() == at_once.lines() and done.reference == at_once.reference
    assert not done.reference_deferred and ev.checked().checked() is not None
    assert ev.report.written == done.written and ev.report.advised == done.advised


def test_cli_marks_the_uniform_row_unchecked_without_report(tmp_path, capsys):
    assert main(["advise", str(GRBL02), "-o", str(tmp_path / "a.csv"), "--machine", "reference"]) == 0
    plain = capsys.readouterr().out
    assert "uniform x" in plain and f"{UNCHECKED} uniform:" in plain and "--report runs it" in plain
    assert "limit reference: not run" in plain
    assert main(["advise", str(GRBL02), "-o", str(tmp_path / "b.csv"), "--machine", "reference",
                 "--report", str(tmp_path / "r.csv")]) == 0
    full = capsys.readouterr().out
    assert f"{UNCHECKED} uniform:" not in full and "limit reference: not run" not in full
    assert any(line.strip().startswith("limit reference") for line in full.splitlines())
    row = next(line for line in full.splitlines() if line.strip().startswith("uniform x"))
    assert not row.split()[1].endswith(UNCHECKED) and "nan" not in row


def test_a_place_no_factor_holds_is_set_apart_and_the_check_agrees():
    # gSender's KB-35: the lag of a rapid at a plunge, which no F changes (issue 36 item 3): those
    # places are set apart and the factor found without them, the same with the check made later
    machine = load_machine("reference")
    path = program_path(read_program(LIBRARY / "gsender" / "KB-35 test.nc"), machine.chord_tol_mm)
    written = run_program(path, machine)
    hot = reference.uniform_slowdown(path, machine, written, check=False)
    assert not hot.bounded and not hot.checked and hot.apart
    at_once = reference.uniform_slowdown(path, machine, written)
    later = reference.check_uniform(path, machine, hot)
    assert not at_once.bounded and at_once.run is not None and at_once.max_um <= machine.contour_tol_um
    assert at_once.run.max_um > machine.contour_tol_um              # only at the places set apart
    assert later.factor == at_once.factor and later.runs == at_once.runs and later.apart == at_once.apart
    assert all(p.floor_um > machine.contour_tol_um and p.factor_um > machine.contour_tol_um for p in at_once.apart)


def test_an_early_bound_is_true_and_the_check_searches_on(monkeypatch):
    # KB-35 with nothing set apart (the floor measure made to clear every place): without the check
    # the search stops at the first factor (half or less) whose error stayed flat, a true bound
    # (that factor breaks the tolerance); check_uniform searches on to what the search with its
    # check gives
    import fuzzyfeed.program.apart as apart

    monkeypatch.setattr(apart, "floor_errors", lambda motion, measured, machine, segments: np.zeros(len(segments)))
    machine = load_machine("reference")
    path = program_path(read_program(LIBRARY / "gsender" / "KB-35 test.nc"), machine.chord_tol_mm)
    written = run_program(path, machine)
    early = reference.uniform_slowdown(path, machine, written, check=False)
    assert early.bounded and not early.checked and early.factor <= 0.5 and early.apart == ()
    slower = run_program(path, machine, feed_scale=early.factor)          # the bound is true
    assert slower.max_um > machine.contour_tol_um
    at_once = reference.uniform_slowdown(path, machine, written)
    later = reference.check_uniform(path, machine, early)
    assert later.bounded and later.checked and at_once.bounded
    assert later.factor == at_once.factor and later.runs == at_once.runs and later.time_s == at_once.time_s
    assert later.factor < early.factor
