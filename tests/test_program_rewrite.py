"""Property tests of the program write-back, read back with the program reader: for random
programs (G90/G91, G20/G21, lines, I/J and R arcs in G17/G18/G19, F changes, comments) the
rewritten program moves through every original end point in order, each original move's pieces
stay on it (lines: collinear; arcs: same centre and radius), every feed is > 0 and at most the
programmed feed, and every original line is still there with at most its F and geometry words
changed."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.program.read import parse_program
from fuzzyfeed.program.rewrite import rewrite_program
from fuzzyfeed.program.model import ARC, PLANE_AXES
from fuzzyfeed.program.feeds import advise_program

TABLE = load_rule_table(None)


@st.composite
def programs(draw):
    inch = draw(st.booleans())
    incremental = draw(st.booleans())
    u = 1 / 25.4 if inch else 1.0
    d = 5 if inch else 3
    fmt = lambda v: f"{v * u:.{d}f}"
    lines = [("G20" if inch else "G21") + " G17 G94 G90", "G0 X0 Y0 Z2", f"G1 Z0 F{300 * u:.3f}"]
    if incremental:
        lines.append("G91")
    pos = np.zeros(3)
    n = draw(st.integers(3, 12))
    plane = 17
    for _ in range(n):
        kind = draw(st.sampled_from(["line", "line", "arc", "arc_r"]))
        f = draw(st.sampled_from([None, 400, 900, 1500]))
        fw = f" F{f * u:.3f}" if f else ""
        if kind == "line":
            step = np.array([draw(st.floats(-20, 20)), draw(st.floats(-20, 20)), 0.0])
            if np.linalg.norm(step) < 0.5:
                step[0] += 3
            new = pos + step
            words = new - pos if incremental else new
            lines.append(f"G1 X{fmt(words[0])} Y{fmt(words[1])}{fw} (cut)")
            pos = np.round(new * u, d) / u
            continue
        new_plane = draw(st.sampled_from([17, 17, 18, 19]))
        if new_plane != plane:
            lines.append(f"G{new_plane}")
            plane = new_plane
        a, b, nrm = PLANE_AXES[plane]
        r = draw(st.floats(2, 15))
        sweep = draw(st.floats(0.3, 3.0)) * (1 if draw(st.booleans()) else -1)
        phi0 = draw(st.floats(0, 6.28))
        centre = pos.copy()
        centre[a] -= r * np.cos(phi0)
        centre[b] -= r * np.sin(phi0)
        new = pos.copy()
        new[a] = centre[a] + r * np.cos(phi0 + sweep)
        new[b] = centre[b] + r * np.sin(phi0 + sweep)
        new = np.round(new * u, d) / u
        g = "G3" if sweep > 0 else "G2"
        letters = "XYZ"
        words = new - pos if incremental else new
        axes = f"{letters[a]}{fmt(words[a])} {letters[b]}{fmt(words[b])}"
        if kind == "arc_r" and abs(sweep) < np.pi:
            lines.append(f"{g} {axes} R{fmt(r)}{fw}")
        else:
            ij = centre - pos
            lines.append(f"{g} {axes} {'IJK'[a]}{fmt(ij[a])} {'IJK'[b]}{fmt(ij[b])}{fw}")
        pos = new
    lines += ["G90", "G0 Z2", "M2"]
    return "\n".join(lines) + "\n"


@settings(max_examples=40, deadline=None)
@given(programs(), st.sampled_from([5.0, 20.0, 100.0]))
def test_rewrite_keeps_the_path_and_never_exceeds_the_programmed_feed(text, step):
    program = parse_program(text, "p.ngc")
    pa = advise_program(program, TABLE, feed_step_mm_min=step, step_mm=0.5)
    out = rewrite_program(program, pa.piece_move, pa.piece_end, pa.piece_feed_mm_min)
    again = parse_program(out, "q.ngc")
    # every original line is there, in order
    it = iter(out.splitlines())
    for line in text.splitlines():
        head = line.split("(")[0].split()
        keep = [w for w in head if w[0] not in "XYZIJKRF"]
        for cand in it:
            if [w for w in cand.split("(")[0].split() if w[0] not in "XYZIJKRF"] == keep and \
                    ("(" in cand) == ("(" in line):
                break
        else:
            raise AssertionError(f"line {line!r} lost")
    # walk the moves: the rewritten ones cover each original move exactly
    j = 0
    tol = 2e-4 * (25.4 if "G20" in text else 1.0)
    for m in range(program.kind.size):
        end = program.end[m]
        while True:
            assert j < again.kind.size
            assert again.kind[j] == program.kind[m]
            if program.kind[m] == ARC:
                np.testing.assert_allclose(again.centre[j], program.centre[m], atol=tol, equal_nan=True)
            else:
                s, e = program.start[m], program.end[m]
                d = e - s
                if np.linalg.norm(d) > 0:
                    p = again.end[j] - s
                    off = p - np.dot(p, d) / np.dot(d, d) * d
                    assert np.linalg.norm(off) < tol
            if not np.isnan(program.feed_mm_min[m]):
                assert 0 < again.feed_mm_min[j] <= program.feed_mm_min[m] + 1e-9
            j += 1
            if np.allclose(again.end[j - 1], end, atol=tol):
                break
    assert j == again.kind.size
    # and it ends where the original ends, exactly on the program's grid
    np.testing.assert_allclose(again.end[-1], program.end[-1], atol=1e-9)
