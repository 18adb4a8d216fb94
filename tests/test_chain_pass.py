"""A chain's whole tick pass made part by part with the servo's state carried from part to part
(machine/chain_pass.py) against stream_plan on the whole plan (no windows): every summary bit for
bit — the largest error per segment, the histogram, the maxima and where, the events (merged across
the parts' joins, the buffer filling as in one pass), the fast path's counts and leaps — on a 3D
raster with rapids between its bands, library programs (linuxcnc-mill's blends and arcs too), parts
from one plan window of a few segments up, fast path and tick pass."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzyfeed.machine import stream as machine_stream
from fuzzyfeed.machine.chain_pass import carried_groups, stream_chain
from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.machine.plan_parts import sweep
from fuzzyfeed.machine.planner import Motion, plan_motion
from fuzzyfeed.machine.stream import stream_plan
from fuzzyfeed.program.read import parse_program
from fuzzyfeed.program.run import program_path
from test_plan_parts import ARRAYS, SCALAR, _raster_program
from tick_cases import library_path


def _banded_raster(bands: int = 3, rows: int = 4) -> str:
    """Bands of the raster joined by a retract, a rapid and a plunge: one chain (no stop)."""
    body = []
    for b in range(bands):
        text = _raster_program(rows=rows).splitlines()
        moves = [ln for ln in text if ln.startswith("G1 X") or ln.startswith("G1 Y")]
        body += ["G0 Z5", f"G0 X0 Y{b * 0.1 * (rows + 1):.4f}", "G1 Z0 F300"]
        body += [ln.replace("Y", "Y", 1) for ln in moves[:1]] + [f"{m} F{1500 + 300 * b}" if i == 0 else m
                                                                  for i, m in enumerate(moves[1:])]
    return "\n".join(["G21 G90 G94", "G0 X0 Y0 Z5", *body, "G0 Z5", "M2"]) + "\n"


def assert_same(motion: Motion, measured, machine, size: int, part_windows: int, fast: bool, keep_mm=None):
    plan = plan_motion(motion, machine)
    whole = stream_plan(plan, machine, measured, keep_mm=keep_mm, fast=fast)
    got, time_s = stream_chain(motion, machine, measured, keep_mm=keep_mm, fast=fast, size=size,
                               part_windows=part_windows)
    assert time_s == plan.time_s
    assert got.seg_max_mm.tobytes() == whole.seg_max_mm.tobytes()
    for name in SCALAR:
        a, b = getattr(got, name), getattr(whole, name)
        assert a == b or (a != a and b != b), name
    for name in ARRAYS:
        assert np.asarray(getattr(got, name)).tobytes() == np.asarray(getattr(whole, name)).tobytes(), name
    return got


@pytest.mark.parametrize("size, part_windows", [(4, 1), (30, 2), (200, 3), (100000, 16)])
@pytest.mark.parametrize("fast", [True, False])
def test_carried_parts_are_the_whole_plans_run_on_a_banded_raster(size, part_windows, fast):
    machine = load_machine("reference")
    path = program_path(parse_program(_banded_raster()), machine.chord_tol_mm)
    chain = max(path.chains, key=lambda c: c.motion.n_segments)
    assert chain.seg_measured.sum() < chain.motion.n_segments      # rapids inside the chain
    sw = sweep(chain.motion, machine, np.zeros(0, np.int64), size)
    groups = carried_groups(sw, machine, part_windows)
    if size < 1000:
        assert len(groups) > 3 and max(w1 - w0 for w0, w1, _ in groups) < sw.first.size - 1
    got = assert_same(chain.motion, chain.seg_measured, machine, size, part_windows, fast)
    assert got.part_ticks > 0 and (not fast or got.skipped_ticks > 0)
    # events kept (a tight threshold): merged across the joins as in one pass
    got = assert_same(chain.motion, chain.seg_measured, machine, size, part_windows, fast, keep_mm=2e-4)
    assert got.tick_time_s.size > 10


def test_the_event_buffer_fills_as_in_one_pass(monkeypatch):
    # a buffer of a few events: it fills inside parts and at their joins; drained as one pass drains it
    machine = load_machine("reference")
    path = program_path(parse_program(_banded_raster(bands=2)), machine.chord_tol_mm)
    chain = max(path.chains, key=lambda c: c.motion.n_segments)
    monkeypatch.setattr(machine_stream, "EVENT_CHUNK", 3)
    got = assert_same(chain.motion, chain.seg_measured, machine, 6, 1, True, keep_mm=1e-4)
    assert got.tick_time_s.size > 20


@pytest.mark.parametrize("rel, machine_name", [("programs/linuxcnc/arcspiral.ngc", "linuxcnc-mill"),
                                                ("programs/camotics/engrave.ngc", "reference")])
def test_carried_parts_are_the_whole_plans_run_on_library_programs(rel, machine_name):
    machine = load_machine(machine_name)
    path = library_path(rel, machine)
    for chain in sorted(path.chains, key=lambda c: -c.motion.n_segments)[:3]:
        for size, part_windows in ((3, 1), (40, 2)):
            assert_same(chain.motion, chain.seg_measured, machine, size, part_windows, True, 1e-3)


@pytest.mark.parametrize("rel, machine_name", [("programs/linuxcnc/arcspiral.ngc", "linuxcnc-mill"),
                                                ("programs/camotics/engrave.ngc", "reference")])
def test_runs_without_plans_are_made_part_by_part_the_same(rel, machine_name, monkeypatch):
    # run_program(keep_plans=False) (the value report's whole runs, the uniform check) with every
    # chain run part by part: the same rows, times, maxima and where as with whole plans
    from fuzzyfeed.machine import chain_pass, plan_parts
    from fuzzyfeed.program import run as program_run

    machine = load_machine(machine_name)
    path = library_path(rel, machine)
    whole = program_run.run_program(path, machine, feed_scale=0.8, keep_plans=False)
    called = []
    real = chain_pass.stream_chain
    monkeypatch.setattr(chain_pass, "stream_chain", lambda *a, **k: called.append(1) or real(*a, **k))
    monkeypatch.setattr(program_run, "CARRIED_MIN_SEGMENTS", 2)
    monkeypatch.setattr(plan_parts, "WINDOW_SEGMENTS", 7)
    monkeypatch.setattr(chain_pass, "WINDOW_SEGMENTS", 7)
    monkeypatch.setattr(chain_pass, "PART_WINDOWS", 2)
    parts = program_run.run_program(path, machine, feed_scale=0.8, keep_plans=False)
    assert len(called) >= sum(c.motion.n_segments >= 2 for c in path.chains) > 0
    assert parts.time_s == whole.time_s and parts.max_um == whole.max_um and parts.p99_um == whole.p99_um
    assert parts.air_max_um == whole.air_max_um and parts.cut_max_um().tobytes() == whole.cut_max_um().tobytes()
    assert repr(parts.worst()) == repr(whole.worst()) and repr(parts.worst_air()) == repr(whole.worst_air())
    for a, b in zip(parts.runs, whole.runs):
        assert a.plan is None and a.time_s == b.time_s and a.tick_move.tobytes() == b.tick_move.tobytes()
        for name in ARRAYS + ("seg_max_mm",):
            assert np.asarray(getattr(a.stream, name)).tobytes() == np.asarray(getattr(b.stream, name)).tobytes()


@pytest.mark.parametrize("shift", [-2, 17, -300, -700])
def test_parts_joined_inside_a_segment_carry_the_leap(shift, monkeypatch):
    # the joins moved (-300, -700 ticks: inside the 1 s plunge at F300, where a leap of the fast
    # path is under way; every part given 40 plan windows more of context each side): the same
    # run, a leap bounded by the run's last tick, not the part's (fails with k_end = the part's)
    from fuzzyfeed.machine import chain_pass

    real = chain_pass.carried_groups

    def shifted(sw, machine, part_windows):
        groups = real(sw, machine, part_windows)
        n_win = sw.first.size - 1
        out = []
        for i, (w0, w1, (lo, hi)) in enumerate(groups):
            lo = lo + shift if i else lo
            hi = hi + shift if i + 1 < len(groups) else hi
            out.append((max(w0 - 40, 0), min(w1 + 40, n_win), (lo, hi)))
        return [g for g in out if g[2][0] <= g[2][1]]

    monkeypatch.setattr(chain_pass, "carried_groups", shifted)
    machine = load_machine("reference")
    for text, size in ((_banded_raster(), 4), (_raster_program(rows=4, step=1.5), 1)):   # moves of 1.5 mm
        path = program_path(parse_program(text), machine.chord_tol_mm)
        chain = max(path.chains, key=lambda c: c.motion.n_segments)
        got = assert_same(chain.motion, chain.seg_measured, machine, size, 1, True)
        assert got.leapt_ticks > 0
