"""The limit reference with bounded memory (issue 36, program/reference.py): its passes keep each
chain's rows and its plan's speed profile, not its plans, and no run it returns keeps a plan.

Checked against the limit reference as it was before (:func:`_reference_with_plans`, below: each
pass compares whole plans, the runs keep theirs) on library programs and on a raster that needs
several passes: the same feeds, passes, time and largest error; and its final run against the tick
pass (``fast=False``, every measured tick searched) on its feeds: the same time, largest error and
p99 (the p99 re-run :func:`~fuzzyfeed.program.run.settle_p99` shares with ``run_program``)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.machine.planner import Motion, plan_motion
from fuzzyfeed.machine.stream import segment_windows
from fuzzyfeed.program import reference as R
from fuzzyfeed.program.read import parse_program, read_program
from fuzzyfeed.program.run import ProgramPath, ProgramRun, program_path, run_chain, run_program

ROOT = Path(__file__).resolve().parents[1]
LIBRARY = ROOT / "benchmarks" / "library" / "programs"


def _reference_with_plans(path: ProgramPath, machine, piece_mm: float = 1.0):
    """The limit reference of main 55c2bd9, plans kept (an independent copy of its loop): the feeds,
    the passes and the final whole runs (not p99-settled)."""
    tol = machine.contour_tol_um * 1e-3
    chains = tuple(R.refine_chain(c, piece_mm) for c in path.chains)
    feeds = [c.motion.feed_mm_s.copy() for c in chains]
    reach = [np.minimum(c.motion.feed_mm_s, machine.speed_along(c.motion.points)) for c in chains]
    state = [run_chain(c, machine, keep_mm=tol) for c in chains]     # whole ChainRuns, plans kept
    plans = [r.plan for r in state]
    ev = [dict(seg_max_mm=r.stream.seg_max_mm, contour_mm=r.contour_mm, speed_mm_s=r.speed_mm_s,
               tick_segment=r.tick_segment, nearest_segment=r.nearest_segment,
               lookback_segment=r.lookback_segment) for r in state]
    runs = list(state)
    touched = [False] * len(chains)
    passes = 1

    class _Ev:
        def __init__(self, d):
            self.__dict__.update(d)

    while passes < R.REFERENCE_PASSES:
        changed = False
        for i, chain in enumerate(chains):
            m = _Ev(ev[i])
            over = np.flatnonzero(m.contour_mm > tol)
            if over.size == 0:
                continue
            new = _main_lowered(feeds[i], chain.motion.rapid, m, over, tol, reach[i])
            if np.array_equal(new, feeds[i]):
                continue
            feeds[i] = new
            plan = plan_motion(Motion(chain.motion.points, new, chain.motion.rapid, chain.motion.arc_radius_mm),
                               machine)
            redo = R._changed(plans[i], plan, machine)
            r = run_chain(chain, machine, plan=plan, keep_mm=tol,
                          windows=segment_windows(plan, machine, np.flatnonzero(redo)))
            s = r.stream
            old, nw = ~redo[m.tick_segment], redo[s.tick_segment]
            cat = lambda a, b: np.concatenate([a[old], b[nw]])  # noqa: E731
            ev[i] = dict(seg_max_mm=np.where(redo, s.seg_max_mm, m.seg_max_mm),
                         contour_mm=cat(m.contour_mm, s.contour_mm), speed_mm_s=cat(m.speed_mm_s, s.speed_mm_s),
                         tick_segment=cat(m.tick_segment, s.tick_segment),
                         nearest_segment=cat(m.nearest_segment, s.nearest_segment),
                         lookback_segment=cat(m.lookback_segment, s.lookback_segment))
            plans[i] = plan
            touched[i] = changed = True
        passes += 1
        if not changed:
            stale = [i for i, t in enumerate(touched) if t]
            for i in stale:
                r = run_chain(chains[i], machine, feeds[i], keep_mm=tol)
                plans[i], runs[i], touched[i] = r.plan, r, False
                ev[i] = dict(seg_max_mm=r.stream.seg_max_mm, contour_mm=r.contour_mm, speed_mm_s=r.speed_mm_s,
                             tick_segment=r.tick_segment, nearest_segment=r.nearest_segment,
                             lookback_segment=r.lookback_segment)
            if not any((ev[i]["contour_mm"] > tol).any() for i in stale):
                break
    for i, t in enumerate(touched):
        if t:
            runs[i] = run_chain(chains[i], machine, feeds[i], keep_mm=tol)
    refined = ProgramPath(program=path.program, chains=chains, chord_tol_mm=path.chord_tol_mm)
    return feeds, passes, ProgramRun(path=refined, machine=machine, runs=tuple(runs))


def _main_lowered(feed, rapid, r, over, tol_mm, original):
    """main f293ab1's ``_lowered`` of program/reference.py, on whole arrays (the limit reference's
    own, ``_lowered_at``, works on the pieces the events point at): per piece the new feed."""
    new = feed.copy()
    err = r.contour_mm[over]
    target = r.speed_mm_s[over] * np.sqrt(tol_mm / err) * R.REFERENCE_MARGIN
    # a tick at rest (speed 0) still over the tolerance: halve the feed around it
    target = np.where(target > 0, target, np.inf)
    lo_seg = np.minimum(r.lookback_segment[over], r.nearest_segment[over])
    hi_seg = np.maximum(r.tick_segment[over], r.nearest_segment[over])
    counts = hi_seg - lo_seg + 1
    seg = np.repeat(lo_seg, counts) + (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts))
    cap = np.full(feed.size, np.inf)
    np.minimum.at(cap, seg, np.repeat(target, counts))
    halve = np.zeros(feed.size, bool)
    halve[seg[np.isinf(np.repeat(target, counts))]] = True
    cap = np.where(halve, np.minimum(cap, 0.5 * feed), cap)
    lowered = np.minimum(new, cap)
    # a piece whose feed is above the speed the planner gave it must come down by at least 5 %
    touched = np.isfinite(cap) & ~rapid
    lowered = np.where(touched, np.minimum(lowered, 0.95 * np.minimum(new, cap / R.REFERENCE_MARGIN)), lowered)
    # never below 1 % of the program's feed: where even that does not hold, no feed does
    return np.where(rapid, feed, np.maximum(lowered, R.REFERENCE_FLOOR * original))


def _raster(tmp_path, lines: int):
    spec = importlib.util.spec_from_file_location("make_raster", ROOT / "benchmarks" / "make_raster.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("make_raster", mod)
    spec.loader.exec_module(mod)
    out = tmp_path / "raster.ngc"
    mod.main([str(out), "--lines", str(lines)])
    return read_program(out)


def _check(program, machine_name: str, min_passes: int = 2):
    machine = load_machine(machine_name)
    path = program_path(program, machine.chord_tol_mm)
    ref = R.limit_reference(path, machine)
    feeds, passes, whole = _reference_with_plans(path, machine)
    assert ref.passes >= min_passes
    assert ref.passes == passes
    assert all(np.array_equal(a, b, equal_nan=True) for a, b in zip(ref.feeds, feeds))
    assert ref.run.time_s == whole.time_s
    assert ref.run.max_um == whole.max_um
    # the final run keeps no plan: neither its chains' nor their summaries'
    assert all(r.plan is None and r.stream.plan is None for r in ref.run.runs)
    # its p99 is the tick pass's on those feeds (the p99 re-run of run_program), its max and time too
    ticks = run_program(ref.path, machine, feeds=list(ref.feeds), fast=False)
    assert ref.run.p99_um == ticks.p99_um
    assert ref.run.max_um == ticks.max_um
    assert ref.run.time_s == ticks.time_s
    return ref


@pytest.mark.parametrize("rel, machine_name", [("camotics/engrave.ngc", "reference"),
                                                ("linuxcnc/arcspiral.ngc", "linuxcnc-mill")])
def test_the_limit_reference_is_the_one_with_plans_on_library_programs(rel, machine_name):
    _check(read_program(LIBRARY / rel), machine_name)


def test_the_limit_reference_is_the_one_with_plans_on_a_raster_of_several_passes(tmp_path):
    ref = _check(_raster(tmp_path, 6000), "reference", min_passes=3)
    assert ref.run.max_um > 0


def test_the_profile_changes_where_the_plan_does():
    machine = load_machine("reference")
    pts = np.array([[0, 0, 0], [5, 0, 0], [10, 0, 0], [10, 5, 0], [10, 10, 0], [5, 10, 0]], float)
    feed = np.full(5, 50.0)
    m0 = Motion(pts, feed, np.zeros(5, bool), np.full(6, np.nan))
    lower = feed.copy()
    lower[3] = 5.0
    p0 = plan_motion(m0, machine)
    p1 = plan_motion(Motion(pts, lower, m0.rapid, m0.arc_radius_mm), machine)
    by_plan = R._changed(p0, p1, machine)
    by_profile = R._changed(R.Profile.of(p0), p1, machine)
    assert np.array_equal(by_plan, by_profile)
    assert by_profile[3] and not by_profile[0]
    assert not R._changed(R.Profile.of(p1), p1, machine).any()


def test_the_last_run_takes_run_programs_p99_rerun_where_the_fast_path_leaves_it_unsettled():
    # two 3 m passes at F6000 joined by 2 mm steps: the corners break the tolerance, and the p99
    # over every tick (~0.3 µm, the straight lines') falls within the fast path's bounds
    text = ("G21 G90 G94\nG0 X0 Y0 Z1\nG1 Z0 F300\nG1 X3000 F6000\nG1 Y2\nG1 X0\nG1 Y4\nG1 X3000\nM2\n")
    machine = load_machine("reference")
    path = program_path(parse_program(text), machine.chord_tol_mm)
    feeds, passes, whole = _reference_with_plans(path, machine)
    assert not whole.p99_settled          # the limit reference's last run as main made it
    ref = R.limit_reference(path, machine)
    assert ref.passes == passes
    assert all(np.array_equal(a, b, equal_nan=True) for a, b in zip(ref.feeds, feeds))
    assert ref.run.p99_settled
    ticks = run_program(ref.path, machine, feeds=list(ref.feeds), fast=False)
    assert ref.run.p99_um == ticks.p99_um and ref.run.max_um == ticks.max_um


def test_the_limit_reference_with_its_whole_runs_made_part_by_part_is_the_same(tmp_path, monkeypatch):
    # every chain's first, stale and last whole runs planned and run part by part (chain_pass) and
    # its profile taken window by window: the same passes, feeds, time, max and p99
    from fuzzyfeed.machine import chain_pass, plan_parts
    from fuzzyfeed.program import run as program_run

    made = []
    real = chain_pass.stream_chain
    monkeypatch.setattr(chain_pass, "stream_chain", lambda *a, **k: made.append(1) or real(*a, **k))
    monkeypatch.setattr(program_run, "CARRIED_MIN_SEGMENTS", 2)
    monkeypatch.setattr(plan_parts, "WINDOW_SEGMENTS", 9)
    monkeypatch.setattr(chain_pass, "WINDOW_SEGMENTS", 9)
    monkeypatch.setattr(chain_pass, "PART_WINDOWS", 3)
    ref = _check(_raster(tmp_path, 3000), "reference", min_passes=3)
    assert ref.run.max_um > 0 and len(made) >= 2      # the first run and the last


def test_the_limit_reference_on_a_scratch_store_is_the_whole_reads(tmp_path):
    """A program's chains in a scratch store (program/chain_store.py: read back by slices, each
    chain read whole by the passes) and the whole runs' largest errors per segment in scratch
    files (``seg_sinks``): the whole read's passes, feeds, time, max, p99 and air (a raster of
    bands: rapids inside one chain; several passes)."""
    from fuzzyfeed.program.chain_store import ChainStore, StoredPath
    from fuzzyfeed.program.machine_windows import _spilled, build_store

    machine = load_machine("reference")
    program = _raster(tmp_path, 3000)
    whole = R.limit_reference(program_path(program, machine.chord_tol_mm), machine)
    store = ChainStore(tmp_path / "s", machine.chord_tol_mm)
    build_store(tmp_path / "raster.ngc", store, None, 10 ** 6)
    try:
        got = R.limit_reference(StoredPath.of(store, whole_below=1), machine,
                                seg_sinks=_spilled(tmp_path / "m", "reference"))
    finally:
        store.close()
    assert whole.passes >= 3 and got.passes == whole.passes and got.converged == whole.converged
    assert len(got.feeds) == len(whole.feeds)
    assert all(a[:].tobytes() == b.tobytes() for a, b in zip(got.feeds, whole.feeds))
    assert (got.run.time_s, got.run.max_um, got.run.p99_um, got.run.air_max_um) == \
        (whole.run.time_s, whole.run.max_um, whole.run.p99_um, whole.run.air_max_um)
    assert all(getattr(r.stream.seg_max_mm, "stored", False) for r in got.run.runs)
    got.close()
    assert not (tmp_path / "s.reference").exists()
