"""A subroutine called once per point (pcb2gcode's autolevelling: ``o1 call [x] [y] [z]``) is
advised per call: an F line before each call, read back by the reader and by rs274 as the feed of
that call's move; where a call cannot be advised on its own (the call line runs several times
with other lines between, or the sub sets F) the line's single slowest F stays the rule."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from fuzzyfeed.program.read import parse_program
from fuzzyfeed.program.rewrite import rewrite_program

SUB = "G21 G90 G94\nG0 X0 Y0 Z1\nG1 Z0 F600\no1 sub\n  G1 X#1 Y#2\no1 endsub\n"


def _rewrite(text, wanted):
    """The program rewritten with one piece per feed move at ``wanted`` (mm/min by move; the
    others not advised), and the feeds read back per move."""
    program = parse_program(text, "p.ngc")
    moves = np.array(sorted(wanted), int)
    out = rewrite_program(program, moves, np.ones(moves.size), np.array([wanted[m] for m in moves], float))
    return program, out, parse_program(out, "q.ngc").feed_mm_min


def test_each_call_gets_its_own_feed_and_the_feed_after_is_restored():
    text = SUB + "o1 call [10] [0]\no1 call [10] [10]\no1 call [0] [10]\nG1 X0 Y0\nM2\n"
    program, out, feeds = _rewrite(text, {2: 100.0, 3: 200.0, 4: 300.0})
    assert np.isnan(feeds[0])
    np.testing.assert_allclose(feeds[1:], [600, 100, 200, 300, 600])
    lines = out.splitlines()
    assert lines[lines.index("o1 call [10] [0]") - 1] == "F100.0"
    assert "  G1 X#1 Y#2" in lines                      # the sub's line keeps no F of its own


def test_unadvised_calls_keep_their_feed_between_advised_ones():
    text = SUB + "o1 call [10] [0]\no1 call [10] [10]\no1 call [0] [10]\nM2\n"
    _, out, feeds = _rewrite(text, {3: 150.0})
    np.testing.assert_allclose(feeds[1:], [600, 600, 150, 600])


def test_a_call_line_in_a_loop_with_other_lines_falls_back_to_one_feed_per_line():
    text = SUB + "#5=0\no2 while [#5 LT 2]\nG0 Z1\no1 call [#5*10+10] [0]\n#5=[#5+1]\no2 endwhile\nM2\n"
    program = parse_program(text, "p.ngc")
    feed = np.flatnonzero(program.kind == 1)
    sub_moves = [m for m in feed if program.move_line[m] == 4]
    _, out, feeds = _rewrite(text, {sub_moves[0]: 100.0, sub_moves[1]: 300.0})
    assert "F100.0" in out.splitlines()[4]               # the slowest, on the sub's line
    np.testing.assert_allclose(feeds[sub_moves], [100, 100])


def test_a_sub_that_sets_its_own_feed_is_not_advised_per_call():
    text = ("G21 G90 G94\nG0 X0 Y0 Z1\nG1 Z0 F600\no1 sub\n  G1 X#1 Y#2 F500\no1 endsub\n"
            "o1 call [10] [0]\no1 call [10] [10]\nM2\n")
    _, out, feeds = _rewrite(text, {2: 100.0, 3: 200.0})
    assert not any(line.startswith("F") for line in out.splitlines())
    np.testing.assert_allclose(feeds[2:], [100, 100])


@pytest.mark.skipif(shutil.which("rs274") is None, reason="needs LinuxCNC's rs274")
def test_rs274_runs_each_call_at_its_feed(tmp_path):
    from canon import canon, compare

    text = SUB + "o1 call [10] [0]\no1 call [10] [10]\no1 call [0] [10]\nG1 X0 Y0\nM2\n"
    _, out, _ = _rewrite(text, {2: 100.0, 3: 200.0, 4: 300.0})
    (tmp_path / "a.ngc").write_text(text)
    (tmp_path / "b.ngc").write_text(out)
    a, b = canon(tmp_path / "a.ngc", tmp_path), canon(tmp_path / "b.ngc", tmp_path)
    res = compare(a, b)
    assert res.feed_moves == 5
    np.testing.assert_allclose(res.ratios, [1.0, 100 / 600, 200 / 600, 300 / 600, 1.0])
