"""program_path (issue 36: lines handled with Python floats, points kept as indices) against the
per-move implementation it replaced, kept here as the reference: the same chains, bit for bit, on
the corpus, the public library and random programs (arcs, helices, rapids, stops, frames)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from fuzzyfeed.program import path_builder
from fuzzyfeed.program.model import ARC, HOME, LINE, NURBS, RAPID, Program
from fuzzyfeed.program.read import parse_program, read_program
from fuzzyfeed.program.run import Chain, Motion, ProgramPath, program_path

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE / "programs"))


def reference_program_path(program: Program, chord_tol_mm: float) -> ProgramPath:
    """The chains of ``program`` (see the module docstring), arcs as chords within ``chord_tol_mm``."""
    kinds = program.kind
    feed_mode = program.feed_mode[program.move_line] if program.move_line.size else np.zeros(0)
    runnable = np.isin(kinds, [RAPID, HOME, LINE, ARC, NURBS])
    feed_move = np.isin(kinds, [LINE, ARC, NURBS])
    runnable &= ~feed_move | ((feed_mode == 94) & (program.feed_mm_min > 0))
    if program.known is not None:
        runnable &= program.known           # a move from an unknown start is not run
    # a line with a stop code stops the tool after its motion
    stops = program.stops if program.stops is not None else program.no_split & ~(kinds == ARC)
    chains: list[Chain] = []
    pts: list[np.ndarray] = []
    feed: list[float] = []
    rapid: list[bool] = []
    radius: list[float] = []
    seg_move: list[int] = []
    measured: list[bool] = []
    last_end: np.ndarray | None = None

    def close() -> None:
        nonlocal pts, feed, rapid, radius, seg_move, measured, last_end
        if feed:
            p = np.vstack(pts)
            r = np.array(radius)
            chains.append(Chain(Motion(p, np.array(feed), np.array(rapid), r),
                                np.array(seg_move), np.array(measured)))
        pts, feed, rapid, radius, seg_move, measured, last_end = [], [], [], [], [], [], None

    for m in range(kinds.size):
        if not runnable[m]:
            close()
            continue
        start, end = program.start[m], program.end[m]
        if last_end is not None and not np.array_equal(start, last_end):
            close()
        kind = int(kinds[m])
        if kind == ARC:
            new, r = path_builder._arc_chords(program, m, chord_tol_mm)
            rads = [r] * (new.shape[0] - 1) + [np.nan]
        elif kind == NURBS:
            new = path_builder._nurbs_chords(program, m, chord_tol_mm)
            rads = [np.nan] * new.shape[0]
        else:
            new = end[None, :]
            rads = [np.nan]
        if not pts:
            pts.append(start[None, :])
            radius.append(np.nan)
        prev = pts[-1][-1]
        steps = np.linalg.norm(np.diff(np.vstack([prev[None, :], new]), axis=0), axis=1)
        keep = steps > 1e-9
        if keep.any():
            new = new[keep]
            rads = [r for r, k in zip(rads, keep) if k]
            rads[-1] = np.nan
            is_rapid = kind in (RAPID, HOME)
            pts.append(new)
            radius.extend(rads)
            f = np.nan if is_rapid else float(program.feed_mm_min[m]) / 60.0
            feed.extend([f] * new.shape[0])
            rapid.extend([is_rapid] * new.shape[0])
            seg_move.extend([m] * new.shape[0])
            measured.extend([(not is_rapid) and program.cut[m] >= 0] * new.shape[0])
        last_end = end
        if stops[m]:
            close()
    close()
    return ProgramPath(program=program, chains=tuple(chains), chord_tol_mm=chord_tol_mm)



def _same(a: ProgramPath, b: ProgramPath) -> None:
    assert len(a.chains) == len(b.chains)
    for x, y in zip(a.chains, b.chains):
        for u, v in ((x.motion.points, y.motion.points), (x.motion.feed_mm_s, y.motion.feed_mm_s),
                     (x.motion.rapid, y.motion.rapid), (x.motion.arc_radius_mm, y.motion.arc_radius_mm),
                     (x.seg_move, y.seg_move), (x.seg_measured, y.seg_measured)):
            assert u.dtype == v.dtype and u.shape == v.shape
            np.testing.assert_array_equal(u, v)


CORPUS = sorted((HERE / "programs" / "corpus").glob("*.ngc"))
LIBRARY = sorted((HERE.parent / "benchmarks" / "library" / "programs").glob("*/*"))[::7]


@pytest.mark.parametrize("path", CORPUS + LIBRARY, ids=lambda p: p.name)
def test_program_path_equals_the_per_move_reference(path):
    try:
        program = read_program(path)
    except Exception:          # a file of the library fuzzyfeed does not read (its MANIFEST says so)
        pytest.skip("not read")
    for tol in (0.002, 0.05):
        _same(program_path(program, tol), reference_program_path(program, tol))


@pytest.mark.parametrize("seed", range(12))
def test_program_path_on_random_programs(seed):
    from random_programs import random_program

    program = parse_program(random_program(seed), Path(f"random_{seed}.ngc"))
    path = program_path(program, 0.002)
    _same(path, reference_program_path(program, 0.002))
    assert path.n_segments > 0


@pytest.mark.parametrize("chunk", [1, 7, 100])
def test_chains_the_same_in_any_chunk(chunk, monkeypatch):
    """program_path turns its per-segment lists into arrays at every chunk of moves (a chain
    crossing chunks is joined from parts): the same chains, bit for bit, as in one chunk."""
    from test_program_stream import raster_text

    program = parse_program(raster_text(600, 3), "r.ngc")
    whole = program_path(program, 0.002)
    monkeypatch.setattr(path_builder, "PATH_CHUNK_MOVES", chunk)
    parts = program_path(program, 0.002)
    assert len(whole.chains) == len(parts.chains) >= 2
    for a, b in zip(whole.chains, parts.chains):
        for x, y in ((a.motion.points, b.motion.points), (a.motion.feed_mm_s, b.motion.feed_mm_s),
                     (a.motion.rapid, b.motion.rapid), (a.motion.arc_radius_mm, b.motion.arc_radius_mm),
                     (a.seg_move, b.seg_move), (a.seg_measured, b.seg_measured)):
            assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True)
