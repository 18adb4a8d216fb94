"""The streamed machine model (issue 36) against the whole-array tick reference
(:func:`fuzzyfeed.machine.trace.trace_motion`: planner.sample -> following_errors -> windowed_distance):
time equal, max contour error within 1 µm, p99 within its histogram's resolution, on random
polylines (hypothesis) and on every program of the public library fuzzyfeed reads."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fuzzyfeed.machine.description import Machine, load_machine
from fuzzyfeed.machine.planner import Motion, plan_motion
from fuzzyfeed.machine.servo import ServoModel
from fuzzyfeed.machine.stream import percentile_um, segment_windows, stream_plan
from fuzzyfeed.machine.trace import trace_motion
from fuzzyfeed.program.read import read_program
from fuzzyfeed.program.run import program_path, run_program
from tick_cases import LIBRARY, library_path, library_programs, random_polyline

#: Library programs longer than this (planned seconds on the machine) are left to the benchmark:
#: the whole-array reference holds every tick in memory.
REFERENCE_MAX_S = 400.0


def _check_against_reference(motion: Motion, machine: Machine, measured: np.ndarray) -> None:
    ref = trace_motion(motion, machine, measured)
    plan = plan_motion(motion, machine)
    run = stream_plan(plan, machine, measured, fast=False)   # the tick pass (tests/test_tick_fast.py: the fast path)
    near_rapid = np.zeros(measured.size, bool)          # within 4 segments of a rapid
    for off in range(-4, 5):
        near_rapid[np.clip(np.flatnonzero(~measured) + off, 0, measured.size - 1)] = True
    assert plan.time_s == ref.plan.time_s
    assert run.max_mm == pytest.approx(ref.max_mm, abs=1e-3 * 1e-3)          # within 1e-3 um
    if ref.contour_mm.size:
        p99 = float(np.percentile(ref.contour_mm * 1e3, 99))
        # within half a bin without rapids; within 1 um with them (a tie at a rapid's vertex, below,
        # moves ticks between the part and the air by rounding)
        tight = measured.all()
        assert percentile_um(run.hist_bins, run.hist_counts, 99) == pytest.approx(p99, abs=0.03 if tight else 1.0)
        # the ticks over the tolerance are the reference's, merged: same largest, none missed
        tol = machine.contour_tol_um * 1e-3
        over = ref.contour_mm > tol
        assert (run.contour_mm > tol).all()
        clear = over & ~near_rapid[ref.tick_segment]      # not the vertex case below
        assert set(ref.tick_segment[clear].tolist()) <= set(run.tick_segment.tolist())
        # per commanded segment, the largest error; a tool outside the corner of a rapid and a feed
        # move is nearest their common vertex on both, so in the air or in the part by rounding:
        # the feed segments next to a rapid (within a few) are left out of this comparison
        seg_max = np.zeros(plan.length.size)
        np.maximum.at(seg_max, ref.tick_segment, ref.contour_mm)
        assert np.abs(run.seg_max_mm - seg_max)[~near_rapid].max(initial=0.0) < 1e-6
    # windows around the hot segments give the same largest errors there (warm-up from rest)
    hot = np.flatnonzero(run.seg_max_mm > 0.5 * run.max_mm) if run.max_mm > 0 else np.zeros(0, int)
    win = stream_plan(plan, machine, measured, windows=segment_windows(plan, machine, hot), fast=False)
    hot = hot[~near_rapid[hot]]
    assert np.abs(win.seg_max_mm[hot] - run.seg_max_mm[hot]).max(initial=0.0) < 1e-6


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), order=st.sampled_from([1, 2]), n=st.integers(1, 60),
       scale=st.floats(0.5, 20.0), ff=st.sampled_from([0.0, 0.6]))
def test_stream_equals_the_tick_reference_on_random_polylines(seed, order, n, scale, ff):
    rng = np.random.default_rng(seed)
    motion = random_polyline(rng, n, scale, rapids=seed % 2 == 1)
    if motion is None:
        return
    servo = ServoModel(kv_1_s=rng.uniform(15, 80), feedforward=ff) if order == 1 else \
        ServoModel(natural_freq_hz=rng.uniform(8, 30), damping=rng.uniform(0.5, 1.0), feedforward=ff)
    machine = Machine(servo=servo, contour_tol_um=float(rng.uniform(5, 80)))
    _check_against_reference(motion, machine, ~motion.rapid)


@pytest.mark.parametrize("rel", library_programs())
def test_stream_equals_the_tick_reference_on_the_library(rel):
    machine = load_machine("reference")
    path = library_path(rel, machine)
    total = sum(plan_motion(c.motion, machine).time_s for c in path.chains)
    if total > REFERENCE_MAX_S:
        pytest.skip(f"{total:.0f} s on the machine: the whole-array reference is the benchmark's")
    run = run_program(path, machine)
    ref_time, ref_max, errs = 0.0, 0.0, []
    for chain in path.chains:
        tr = trace_motion(chain.motion, machine, chain.seg_measured)
        ref_time += tr.plan.time_s
        ref_max = max(ref_max, tr.max_mm * 1e3)
        errs.append(tr.contour_mm * 1e3)
    assert math.isclose(run.time_s, ref_time, rel_tol=1e-3)
    assert run.max_um == pytest.approx(ref_max, abs=1.0)
    e = np.concatenate(errs)
    if e.size:
        assert run.p99_um == pytest.approx(float(np.percentile(e, 99)), abs=0.1)


def test_uniform_slowdown_on_hot_stretches_equals_the_search_on_whole_runs(monkeypatch):
    # the search re-running only the stretches around the hot spots finds the factor the search on
    # whole runs finds (both to the search's 1 %), and its checking run holds the tolerance
    import fuzzyfeed.program.uniform as reference

    machine = load_machine("reference")
    program = read_program(Path(__file__).parent / "programs" / "corpus" / "grbl_02.ngc")
    path = program_path(program, machine.chord_tol_mm)
    written = run_program(path, machine)
    assert written.max_um > 3 * machine.contour_tol_um
    whole_runs = []
    real_run = reference.run_program
    monkeypatch.setattr(reference, "run_program", lambda *a, **k: whole_runs.append(1) or real_run(*a, **k))
    fast = reference.uniform_slowdown(path, machine, written)
    assert len(whole_runs) == 1                     # the trials ran hot stretches; one checking run
    monkeypatch.setattr(reference, "UNIFORM_CHECKS", 0)
    whole = reference.uniform_slowdown(path, machine, written)
    assert fast.run is not None and fast.run.max_um <= machine.contour_tol_um
    assert whole.run is not None and whole.run.max_um <= machine.contour_tol_um
    assert fast.factor == pytest.approx(whole.factor, rel=reference.UNIFORM_RTOL)
    assert fast.time_s == pytest.approx(reference._planned_time(path, machine, fast.factor), rel=1e-12)


def test_uniform_slowdown_sets_apart_where_no_feed_brings_the_error_down():
    # gSender's KB-35: the servo's lag from a rapid at a plunge's start, which no F changes: those
    # places are set apart (issue 36 item 3; before, the search stopped at its tick budget with a
    # bound) and the factor is found, checked by a whole run, for the rest
    from fuzzyfeed.program.reference import uniform_slowdown

    machine = load_machine("reference")
    path = program_path(read_program(LIBRARY / "programs" / "gsender" / "KB-35 test.nc"), machine.chord_tol_mm)
    written = run_program(path, machine)
    u = uniform_slowdown(path, machine, written)
    assert not u.bounded and u.run is not None and 0.01 < u.factor < 1.0 and u.apart
    assert u.max_um <= machine.contour_tol_um < u.run.max_um
    assert u.time_s > written.time_s and u.runs < 20
