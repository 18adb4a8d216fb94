"""The advised program's model built from the written one (fuzzyfeed.program.advised) equals the
advised text read back, in every chain the controller runs: points, feeds, moves, measured segments
and lines; where it is not reproduced (arcs split, inch) it says so (None) and the text is read."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.program.advised import advised_program
from fuzzyfeed.program.read import parse_program, read_program
from fuzzyfeed.program.rewrite import rewrite_program
from fuzzyfeed.program.run import program_path
from fuzzyfeed.report.value import advised_feeds, evaluate_program

LIBRARY = Path(__file__).resolve().parents[1] / "benchmarks" / "library" / "programs"


def _pieces(program):
    a = advised_feeds(program, load_rule_table("machine"), load_machine("reference"), list(range(program.n_cuts)),
                      cap_mm_min=None, step_mm=0.25, feed_step_mm_min=10.0, min_piece_mm=1.0)
    return a.piece_move, a.piece_end, a.piece_feed_mm_min


def _read(name):
    path = LIBRARY / name
    if not path.exists():
        pytest.skip(f"{path} not in the library")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_program(path)


@pytest.mark.parametrize("name", ["linuxcnc/3D_Chips.ngc", "camotics/engrave.ngc", "pycut/jscut.gcode",
                                  "blendercam/HelixEnter.gcode", "pcb2gcode/D1MiniGSR_front.ngc"])
def test_model_is_the_text_read_back(name):
    program = _read(name)
    pieces = _pieces(program)
    assert np.sum(np.diff(pieces[0]) == 0) > 5           # moves split: new lines, shifted lines
    built = advised_program(program, *pieces)
    assert built is not None
    back = parse_program(rewrite_program(program, *pieces), program.path)
    tol = load_machine("reference").chord_tol_mm
    a, b = program_path(built, tol), program_path(back, tol)
    assert len(a.chains) == len(b.chains)
    for x, y in zip(a.chains, b.chains):
        assert np.array_equal(x.motion.points, y.motion.points)
        assert np.array_equal(x.motion.feed_mm_s, y.motion.feed_mm_s, equal_nan=True)
        assert np.array_equal(x.motion.rapid, y.motion.rapid)
        assert np.array_equal(x.seg_move, y.seg_move) and np.array_equal(x.seg_measured, y.seg_measured)
        assert np.array_equal(built.move_line[x.seg_move], back.move_line[y.seg_move])
    assert np.array_equal(built.cut, back.cut)


def test_the_check_can_fail():
    """Pieces' feeds dropped (the written feeds kept): the chains' feeds differ from the text's."""
    program = _read("linuxcnc/3D_Chips.ngc")
    pm, pe, pf = _pieces(program)
    built = advised_program(program, pm, pe, program.feed_mm_min[pm])
    back = parse_program(rewrite_program(program, pm, pe, pf), program.path)
    tol = load_machine("reference").chord_tol_mm
    fa = np.concatenate([c.motion.feed_mm_s for c in program_path(built, tol).chains])
    fb = np.concatenate([c.motion.feed_mm_s for c in program_path(back, tol).chains])
    assert fa.shape == fb.shape and not np.array_equal(fa, fb, equal_nan=True)


def test_split_arcs_and_inch_are_read_back():
    """A split arc (its pieces' centres and chords) and a program in inches: None, the text is read."""
    arcs = _read("ugs/arc_rword_test.gcode")
    pieces = _pieces(arcs)
    assert np.sum(np.diff(pieces[0]) == 0) > 0
    assert advised_program(arcs, *pieces) is None
    inch = parse_program("G20 G90 G94\nG0 X0 Y0 Z0\nG1 X4 F50\nG1 Y4\nM30\n", "i.ngc")
    assert advised_program(inch, np.array([2]), np.array([1.0]), np.array([1000.0])) is None


def test_value_report_same_as_reading_the_text(monkeypatch):
    """evaluate_program with the built model and with the text read back: the same report."""
    import fuzzyfeed.program.advised as adv

    program = _read("linuxcnc/3D_Chips.ngc")
    machine, table = load_machine("reference"), load_rule_table("machine")
    built = evaluate_program(program, machine, table, reference=False, check_uniform=False).report
    monkeypatch.setattr(adv, "advised_program", lambda *a: None)
    read = evaluate_program(program, machine, table, reference=False, check_uniform=False).report
    assert not built.holds_as_written          # the advised program is run
    assert built.lines() == read.lines()
    assert built.advised == read.advised
