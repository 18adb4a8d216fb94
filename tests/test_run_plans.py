"""A program run kept without its plans (``run_program(keep_plans=False)``, the written run of
``advise --machine``) keeps none through its chains' streams either (~0.1 KB a segment), and its
rows are those of the run with its plans."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.program.read import read_program
from fuzzyfeed.program.run import program_path, run_program

PROGRAM = Path(__file__).resolve().parents[1] / "benchmarks" / "library" / "programs" / "camotics" / "engrave.ngc"


def test_a_run_without_plans_holds_none_and_the_same_rows():
    if not PROGRAM.exists():
        pytest.skip(f"{PROGRAM} not in the library")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        program = read_program(PROGRAM)
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
