"""A run's largest error per segment kept out of memory (issue 36: the windowed ``--machine`` path's
last growth per line): a long chain's handed to a scratch file as its parts finish with it
(machine/chain_pass.py ``_Handed``, base/spill.py ``SpilledValues``), a short chain's after its run;
read back in blocks by what needs it (the cuts' maxima, the uniform search's hot segments) — the
same floats as the array the run keeps otherwise (held to stream_plan on the whole plan)."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzyfeed.base.spill import SpilledValues
from fuzzyfeed.machine.chain_pass import stream_chain
from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.machine.planner import plan_motion
from fuzzyfeed.machine.stream import stream_plan
from fuzzyfeed.program.read import parse_program, read_program
from fuzzyfeed.program.run import program_path, run_program
from test_chain_pass import _banded_raster


@pytest.mark.parametrize("size, part_windows", [(4, 1), (30, 2), (200, 3)])
@pytest.mark.parametrize("fast", [True, False])
def test_a_long_chains_errors_handed_on_part_by_part_are_the_whole_plans(tmp_path, size, part_windows, fast):
    """Parts that overlap (a plan window shared with the part before): a segment's largest error is
    the larger of both parts' before it is handed on; the segments no part reaches are 0."""
    machine = load_machine("reference")
    path = program_path(parse_program(_banded_raster()), machine.chord_tol_mm)
    chain = max(path.chains, key=lambda c: c.motion.n_segments)
    whole = stream_plan(plan_motion(chain.motion, machine), machine, chain.seg_measured, fast=fast)
    sink = SpilledValues(tmp_path, "s")
    got, _ = stream_chain(chain.motion, machine, chain.seg_measured, fast=fast, size=size,
                          part_windows=part_windows, seg_sink=sink)
    assert got.seg_max_mm is sink and len(sink) == chain.motion.n_segments
    assert sink[:].tobytes() == whole.seg_max_mm.tobytes()
    assert sink[5:17].tobytes() == whole.seg_max_mm[5:17].tobytes()
    assert (got.max_mm, got.max_segment) == (whole.max_mm, whole.max_segment)
    assert got.hist_counts.tobytes() == whole.hist_counts.tobytes()


def test_a_run_made_again_starts_its_errors_again(tmp_path):
    sink = SpilledValues(tmp_path, "s")
    add = sink.open()
    add(np.arange(5.0))
    add(np.arange(3.0))
    assert sink[:].tolist() == [0, 1, 2, 3, 4, 0, 1, 2]
    sink.open()(np.ones(2))
    assert sink[:].tolist() == [1, 1] and len(sink) == 2
    assert [a for a, _ in sink.blocks(1)] == [0, 1]


def test_programs_errors_out_of_memory_give_the_cuts_maxima_and_the_uniform_search(tmp_path, monkeypatch):
    """run_program with every chain's errors in scratch files (the long chains' handed on part by
    part): the cuts' maxima read in blocks (machine_windows.cut_max_um on the store) and the
    uniform slowdown's search are the in-memory run's."""
    import fuzzyfeed.machine.chain_pass as chain_pass
    import fuzzyfeed.machine.plan_parts as plan_parts
    import fuzzyfeed.program.run as run
    import fuzzyfeed.program.uniform as uniform
    from fuzzyfeed.program.chain_store import ChainStore, StoredPath
    from fuzzyfeed.program.machine_windows import _spilled, build_store, cut_max_um
    from test_program_windows import _raster

    monkeypatch.setattr(run, "CARRIED_MIN_SEGMENTS", 40)
    monkeypatch.setattr(plan_parts, "WINDOW_SEGMENTS", 16)
    monkeypatch.setattr(chain_pass, "PART_WINDOWS", 2)
    monkeypatch.setattr(uniform, "HOT_BLOCK", 7)
    machine = load_machine("reference")
    prog = _raster(tmp_path / "r.ngc", cuts=4, rows=4)
    program = read_program(prog)
    whole = program_path(program, machine.chord_tol_mm)
    store = ChainStore(tmp_path / "s", machine.chord_tol_mm)
    build_store(prog, store, None, 150)
    sp = StoredPath.of(store)
    try:
        a = run_program(whole, machine, keep_plans=False)
        b = run_program(sp, machine, keep_plans=False, seg_sinks=_spilled(tmp_path / "m", "w"))
        assert all(getattr(r.stream.seg_max_mm, "stored", False) for r in b.runs)
        assert (a.time_s, a.max_um, a.p99_um) == (b.time_s, b.max_um, b.p99_um)
        assert cut_max_um(sp, b, program.n_cuts).tobytes() == a.cut_max_um().tobytes()
        assert (a.cut_max_um() > machine.contour_tol_um).any()
        ua = uniform.uniform_slowdown(whole, machine, a, check=False)
        ub = uniform.uniform_slowdown(sp, machine, b, check=False)
        assert (ua.factor, ua.runs, ua.time_s, ua.max_um) == (ub.factor, ub.runs, ub.time_s, ub.max_um)
        sa, sb = ua.resume[0], ub.resume[0]
        assert sa.rest0_mm == sb.rest0_mm
        for x, y, ex, ey in zip(sa.hot0, sb.hot0, sa.hot0_mm, sb.hot0_mm):
            assert np.array_equal(x, y) and ex.tobytes() == ey.tobytes()
    finally:
        store.close()
