"""The program reader against LinuxCNC's interpreter: on every corpus program without drilling
cycles or NURBS (rs274 expands those), the reader's feed moves end where rs274's STRAIGHT_FEED /
ARC_FEED calls end, arcs have rs274's centre and turn count, and the programmed feed in force is
rs274's SET_FEED_RATE; and the per-line modal state is what the program says."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from canon import _nums, canon
from fuzzyfeed.program.read import read_program
from fuzzyfeed.program.model import ARC, CYCLE, KEPT, LINE, NURBS, PLANE_AXES

CORPUS = sorted((Path(__file__).parent / "programs" / "corpus").glob("*.ngc"))
_PLANES = {"CANON_PLANE_XY": 17, "CANON_PLANE_XZ": 18, "CANON_PLANE_YZ": 19}


@pytest.mark.parametrize("path", CORPUS, ids=lambda p: p.stem)
def test_reader_matches_rs274(path, tmp_path):
    program = read_program(path)
    if np.isin(program.kind, [CYCLE, NURBS]).any():
        pytest.skip("rs274 expands drilling cycles and NURBS into other calls")
    calls = canon(path, tmp_path)
    inch = any(n == "USE_LENGTH_UNITS" and "INCHES" in a for n, a in calls)
    unit = 25.4 if inch else 1.0
    rate, plane = 0.0, 17
    feeds = []
    for name, args in calls:
        if name == "SET_FEED_RATE":
            rate = float(args)
        elif name == "SELECT_PLANE":
            plane = _PLANES[args.strip()]
        elif name in ("STRAIGHT_FEED", "ARC_FEED"):
            feeds.append((name, _nums(args), rate, plane))
    moves = np.flatnonzero(np.isin(program.kind, [LINE, ARC, KEPT]))
    assert len(moves) == len(feeds)
    for m, (name, v, rate, plane) in zip(moves, feeds):
        assert rate * unit == pytest.approx(program.feed_mm_min[m], rel=1e-5)  # rs274 prints 4 decimals
        if program.kind[m] == KEPT:
            continue
        if name == "STRAIGHT_FEED":
            assert program.kind[m] == LINE
            np.testing.assert_allclose(program.end[m] / unit, v[:3], atol=1e-4)
        else:
            assert program.kind[m] == ARC and program.arc_plane[m] == plane
            a, b, n = PLANE_AXES[plane]
            np.testing.assert_allclose(program.end[m][[a, b, n]] / unit, v[[0, 1, 5]], atol=1e-4)
            np.testing.assert_allclose(program.centre[m][[a, b]] / unit, v[[2, 3]], atol=1e-4)
            assert program.turns[m] == int(v[4])


def test_modal_state_per_line():
    program = read_program(next(p for p in CORPUS if p.stem == "fusion_03"))
    lines = program.lines
    at = lambda text: next(i for i, ln in enumerate(lines) if text in ln)
    assert program.work_offset[at(" G55")] == 55.0 and program.work_offset[at(" G54")] == 54.0
    assert program.length_offset[at("G43 Z15.")] == 43.0
    assert program.tool[at("T1 M6")] == 1 and program.tool[-1] == 5
    assert program.ij_absolute.sum() == 0 and program.plane.max() == 17 and not program.inch.any()
