"""A program run kept without its plans (``run_program(keep_plans=False)``, the written run of
``advise --machine``, and every run of the limit reference) keeps none through its chains' streams
either (~0.1 KB a segment), and its rows are those of the run with its plans; a ChainRun is built
without its plan (:meth:`~fuzzyfeed.program.run.ChainRun.without_plan`), never emptied after."""

from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.program.read import parse_program, read_program
from fuzzyfeed.program.run import ChainRun, program_path, run_program, without_plan

PROGRAM = Path(__file__).resolve().parents[1] / "benchmarks" / "library" / "programs" / "camotics" / "engrave.ngc"
SQUARE = "G21 G90 G94\nG0 X0 Y0 Z1\nG1 Z0 F300\nG1 X10 F3000\nG1 Y10\nG1 X0\nM2\n"


def _kept_and_dropped(program):
    machine = load_machine("reference")
    path = program_path(program, machine.chord_tol_mm)
    kept = run_program(path, machine)
    dropped = run_program(path, machine, keep_plans=False)
    assert all(r.plan is not None and r.stream.plan is not None for r in kept.runs)
    assert all(r.plan is None and r.stream.plan is None for r in dropped.runs)
    assert (dropped.time_s, dropped.max_um, dropped.p99_um) == (kept.time_s, kept.max_um, kept.p99_um)
    for a, b in zip(kept.runs, dropped.runs):
        assert a.time_s == b.time_s and np.array_equal(a.stream.seg_max_mm, b.stream.seg_max_mm)
        assert np.array_equal(a.tick_move, b.tick_move)
    return kept


def test_a_run_without_plans_holds_none_and_the_same_rows():
    if not PROGRAM.exists():
        pytest.skip(f"{PROGRAM} not in the library")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        program = read_program(PROGRAM)
    _kept_and_dropped(program)


def test_a_run_without_its_plan_keeps_no_plan_anywhere():
    kept = _kept_and_dropped(parse_program(SQUARE))
    run = kept.runs[0]
    bare = without_plan(run)
    assert bare.plan is None and bare.stream.plan is None and bare.time_s == run.time_s
    assert run.plan is not None and run.stream.plan is not None    # built anew, the run untouched
    assert without_plan(bare) is bare
    with pytest.raises(ValueError, match="without_plan"):          # no half-dropped run
        replace(run, plan=None)
    with pytest.raises(TypeError):                                 # its time is given, not guessed
        ChainRun(plan=run.plan, stream=run.stream, tick_move=run.tick_move)
