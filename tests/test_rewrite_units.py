"""F words written back where a line changes units (G20/G21 on a move line): LinuxCNC reads a
line's F in the units in force *before* the line (issue 37 defect 1), so an advised or kept feed
written there must be in those units, and the feed in force is followed in mm/min across unit
changes. Checked by reading the rewritten program back (the reader follows rs274: issue 40's
parity test) and once with rs274 itself."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzyfeed.errors import ExportError
from fuzzyfeed.program.read import parse_program
from fuzzyfeed.program.rewrite import rewrite_program


@st.composite
def unit_programs(draw):
    """Lines along X with G20/G21 switching on move lines, some with F words; per feed move a
    wanted feed (mm/min) or none (not advised) and a number of pieces."""
    inch = draw(st.booleans())
    lines = [("G20" if inch else "G21") + " G17 G90 G94", "G0 X0 Y0 Z0", "G1 Y1 F" + ("20" if inch else "500")]
    x = 0.0
    for _ in range(draw(st.integers(2, 8))):
        words = []
        if draw(st.booleans()):
            inch = not inch
            words.append("G20" if inch else "G21")
        x += draw(st.sampled_from([5.0, 12.7, 25.4]))
        words.append(f"G1 X{x / 25.4:.5f}" if inch else f"G1 X{x:.4f}")
        if draw(st.booleans()):
            words.append(f"F{draw(st.sampled_from([8, 15, 40])) if inch else draw(st.sampled_from([200, 600, 1000]))}")
        lines.append(" ".join(words))
    lines.append("M2")
    text = "\n".join(lines) + "\n"
    program = parse_program(text, "u.ngc")
    feed = np.flatnonzero(~np.isnan(program.feed_mm_min))
    moves, ends, feeds = [], [], []
    wanted = {}
    for m in feed.tolist():
        if not draw(st.booleans()):
            continue
        n = draw(st.integers(1, 3))
        f = [program.feed_mm_min[m] * draw(st.sampled_from([0.3, 0.5, 0.8])) for _ in range(n)]
        moves += [m] * n
        ends += list(np.arange(1, n + 1) / n)
        feeds += f
        wanted[m] = f
    return program, np.array(moves, int), np.array(ends), np.array(feeds), wanted


@settings(max_examples=60, deadline=None)
@given(unit_programs())
def test_feeds_written_back_across_unit_changes_run_at_the_feed_wanted(case):
    program, moves, ends, feeds, wanted = case
    out = rewrite_program(program, moves, ends, feeds)
    again = parse_program(out, "v.ngc")
    j = 0
    for m in range(program.kind.size):
        if np.isnan(program.feed_mm_min[m]):
            j += 1
            continue
        for f in wanted.get(m, [program.feed_mm_min[m]]):
            got = again.feed_mm_min[j]
            # rounded down to 0.1 mm/min or 0.01 inch/min, never above
            assert f - 0.26 <= got <= f + 1e-9, (m, f, got, out)
            j += 1
    assert j == again.kind.size


def test_a_feed_on_a_g21_line_of_an_inch_program_is_written_in_inches():
    text = "G20 G90 G94\nG0 X0 Y0 Z0\nG1 X1 F20\nG21 G1 X50\nG1 X60\nM2\n"
    program = parse_program(text, "u.ngc")
    out = rewrite_program(program, np.array([2, 3]), np.array([1.0, 1.0]), np.array([254.0, 254.0]))
    line = out.splitlines()[3]
    assert line.startswith("G21 G1 X50") and line.endswith("F10.00"), out   # 10 inch/min, not F254
    assert out.splitlines()[4] == "G1 X60", out                            # 254 mm/min still in force


@pytest.mark.skipif(shutil.which("rs274") is None, reason="needs LinuxCNC's rs274")
def test_rs274_reads_the_rewritten_feed_in_the_units_before_the_line(tmp_path):
    from canon import canon

    text = "G20 G90 G94\nG0 X0 Y0 Z0\nG1 X1 F20\nG21 G1 X50\nM2\n"
    program = parse_program(text, "u.ngc")
    out = rewrite_program(program, np.array([2]), np.array([1.0]), np.array([127.0]))
    (tmp_path / "p.ngc").write_text(out)
    calls = canon(tmp_path / "p.ngc", tmp_path)
    names = [c[0] for c in calls]
    # SET_FEED_RATE prints the value in the units then in force (inches), before USE_LENGTH_UNITS(MM)
    last_feed = max(i for i, n in enumerate(names) if n == "STRAIGHT_FEED")
    rate = max(i for i, n in enumerate(names[:last_feed]) if n == "SET_FEED_RATE")
    assert float(calls[rate][1]) == 5.0, calls                              # 5 inch/min = 127 mm/min
    assert ("USE_LENGTH_UNITS", "CANON_UNITS_MM") in calls[rate + 1:last_feed], calls[rate:last_feed]


def test_a_loop_program_that_changes_units_after_a_feed_is_refused():
    text = ("G21 G90 G94\nG0 X0 Y0 Z0\nG1 X1 F300\n#1=0\no100 while [#1 LT 2]\nG20 G1 X[#1+2]\n"
            "G21 G1 X1\n#1=[#1+1]\no100 endwhile\nM2\n")
    program = parse_program(text, "loop.ngc")
    assert program.rows is not None
    moves = np.flatnonzero(~np.isnan(program.feed_mm_min))
    with pytest.raises(ExportError, match="loop.ngc: line 6 changes units"):
        rewrite_program(program, moves, np.ones(moves.size), program.feed_mm_min[moves] * 0.5)
