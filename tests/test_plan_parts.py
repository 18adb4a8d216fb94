"""A chain's windowed tick pass made part by part from the plan's windows (machine/plan_parts.py)
against the same pass on the whole plan (stream_plan with segment_windows): every summary bit for
bit — the largest error per segment, the histogram, the maxima and where, the events, the fast
path's counts — on a 3D raster, library programs (linuxcnc-mill's blends and arcs too), with plan
windows from a few segments up, fast path and tick pass."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.machine.plan_parts import stream_parts, sweep
from fuzzyfeed.machine.planner import Motion, plan_motion
from fuzzyfeed.machine.stream import segment_windows, stream_plan
from fuzzyfeed.program.read import parse_program
from fuzzyfeed.program.run import program_path
from tick_cases import library_path

SCALAR = ("max_mm", "max_time_s", "max_segment", "air_max_mm", "air_time_s", "air_segment", "air_nearest",
          "part_ticks", "skipped_ticks", "leapt_ticks", "skip_mm", "skip_max_mm", "rerun")
ARRAYS = ("hist_bins", "hist_counts", "max_xyz", "air_xyz", "tick_time_s", "contour_mm", "speed_mm_s",
          "nearest_xyz", "tick_segment", "nearest_segment", "lookback_segment")


def _raster_program(rows: int = 12, step: float = 0.1) -> str:
    rng = np.random.default_rng(3)
    lines = ["G21 G90 G94", "G0 X0 Y0 Z5", "G1 Z0 F300", "G1 X0.1 F2000"]
    x = 0.1
    for r in range(rows):
        xs = np.arange(0.0, 20.0 + 1e-9, step)[1:]
        if r % 2:
            xs = 20.0 - xs
        for xv in xs:
            z = 0.3 * np.sin(xv) * np.cos(0.5 * r) + 0.02 * rng.standard_normal()
            lines.append(f"G1 X{xv:.4f} Y{0.1 * r:.4f} Z{z:.4f}")
        lines.append(f"G1 Y{0.1 * (r + 1):.4f}")
    lines += ["G0 Z5", "M2"]
    return "\n".join(lines) + "\n"


def assert_same_run(motion: Motion, measured: np.ndarray, machine, hot: np.ndarray, size: int, scale: float,
                    fast: bool, keep_mm: float | None, small_parts: bool = False) -> None:
    plan = plan_motion(Motion(motion.points, motion.feed_mm_s * scale, motion.rapid, motion.arc_radius_mm)
                       if scale != 1.0 else motion, machine)
    windows = segment_windows(plan, machine, hot)
    whole = stream_plan(plan, machine, measured, keep_mm=keep_mm, windows=windows, fast=fast)
    sw = sweep(motion, machine, np.unique(hot), size, feed_scale=scale)
    assert sw.time_s == plan.time_s
    assert sw.windows(machine) == windows
    parts = stream_parts(motion, machine, measured, sw, windows, keep_mm=keep_mm, fast=fast, size=size,
                         feed_scale=scale)
    got = parts.stream
    assert parts.seg_max_mm(motion.n_segments).tobytes() == whole.seg_max_mm.tobytes()
    for name in SCALAR:
        a, b = getattr(got, name), getattr(whole, name)
        assert a == b or (a != a and b != b), name
    for name in ARRAYS:
        assert np.asarray(getattr(got, name)).tobytes() == np.asarray(getattr(whole, name)).tobytes(), name
    # no part holds the whole chain when the windows are small and the hot spots few
    if small_parts:
        assert max(m.size for _, m in parts.parts) < motion.n_segments


@pytest.mark.parametrize("size", [4, 50, 3000])
@pytest.mark.parametrize("fast", [True, False])
def test_parts_are_the_whole_plans_windowed_run_on_a_raster(size, fast):
    machine = load_machine("reference")
    path = program_path(parse_program(_raster_program()), machine.chord_tol_mm)
    chain = max(path.chains, key=lambda c: c.motion.n_segments)
    n = chain.motion.n_segments
    rng = np.random.default_rng(size)
    for scale, hot in ((1.0, np.array([5, 6, n // 2, n - 3])), (0.4, rng.choice(n, 9, replace=False)),
                       (2.5, np.arange(0, n, 97))):
        assert_same_run(chain.motion, chain.seg_measured, machine, np.sort(hot), size, scale, fast, None,
                        small_parts=size <= 50 and hot.size <= 4)
    # events kept (a tight threshold): their segments are the chain's
    assert_same_run(chain.motion, chain.seg_measured, machine, np.array([40, n - 40]), size, 1.0, fast, 1e-4)


@pytest.mark.parametrize("rel, machine_name", [("programs/linuxcnc/arcspiral.ngc", "linuxcnc-mill"),
                                                ("programs/camotics/engrave.ngc", "reference")])
def test_parts_are_the_whole_plans_windowed_run_on_library_programs(rel, machine_name):
    machine = load_machine(machine_name)
    path = library_path(rel, machine)
    rng = np.random.default_rng(7)
    for chain in path.chains[:4]:
        n = chain.motion.n_segments
        hot = np.unique(rng.choice(n, min(n, 6), replace=False))
        for size in (3, 200):
            assert_same_run(chain.motion, chain.seg_measured, machine, hot, size, 0.7, True, 1e-3)


@pytest.mark.parametrize("size", [3, 40, 5000])
def test_changed_sweep_marks_what_the_whole_plans_comparison_marks(size):
    # the limit reference's pass: feeds lowered on a few pieces; the segments to redo (changed
    # profile, then the servo's memory after each) as program/reference.py's _changed on whole plans
    from fuzzyfeed.machine.plan_parts import changed_sweep
    from fuzzyfeed.machine.stream import WARMUP_TIME_CONSTANTS
    from fuzzyfeed.program.reference import Profile, _changed

    machine = load_machine("reference")
    path = program_path(parse_program(_raster_program(rows=6)), machine.chord_tol_mm)
    chain = max(path.chains, key=lambda c: c.motion.n_segments)
    m = chain.motion
    old = plan_motion(m, machine)
    rng = np.random.default_rng(size)
    feed = m.feed_mm_s.copy()
    for i in rng.choice(m.n_segments, 5, replace=False):
        feed[i:i + 3] *= 0.3
    new_motion = Motion(m.points, feed, m.rapid, m.arc_radius_mm)
    new = plan_motion(new_motion, machine)
    horizon = WARMUP_TIME_CONSTANTS * machine.servo.time_constant_s
    want = np.flatnonzero(_changed(Profile.of(old), new, machine))
    profile = tuple(a.copy() for a in (old.v_entry, old.v_peak, old.v_exit, old.acc))
    sw, (starts, stops) = changed_sweep(new_motion, machine, profile, horizon, size)
    assert 0 < want.size < m.n_segments
    seg = np.concatenate([np.arange(a, b) for a, b in zip(starts, stops)])
    assert np.array_equal(seg, want)
    assert starts.size <= want.size and np.all(stops > starts) and np.all(starts[1:] >= stops[:-1])
    assert sw.windows(machine) == segment_windows(new, machine, want)
    # the profile kept is now the new plan's
    for kept, arr in zip(profile, (new.v_entry, new.v_peak, new.v_exit, new.acc)):
        assert kept.tobytes() == arr.tobytes()


def _nbytes(x) -> int:
    """Bytes of the arrays in ``x`` (an array, or tuples / lists of them, or of numbers)."""
    if isinstance(x, np.ndarray):
        return x.nbytes
    if isinstance(x, (tuple, list)):
        return sum(_nbytes(y) for y in x) + 8 * len(x)
    return 0


def test_a_pass_redoing_most_of_a_chain_keeps_its_runs_not_its_segments():
    """Feeds lowered over most of a chain: the sweep redoes thousands of segments in a few runs; what
    it hands on (their times, indices and tick windows) is O(runs), not 24–48 B a segment redone
    (issue 36: the limit reference's pass on a 4 M-line raster); the same tick windows as the whole plan's."""
    from fuzzyfeed.machine.plan_parts import changed_sweep
    from fuzzyfeed.machine.stream import WARMUP_TIME_CONSTANTS
    from fuzzyfeed.program.reference import Profile, _changed

    machine = load_machine("reference")
    path = program_path(parse_program(_raster_program(rows=12)), machine.chord_tol_mm)
    m = max(path.chains, key=lambda c: c.motion.n_segments).motion
    old = plan_motion(m, machine)
    feed = m.feed_mm_s.copy()
    feed[100:m.n_segments - 100] *= 0.5
    new_motion = Motion(m.points, feed, m.rapid, m.arc_radius_mm)
    new = plan_motion(new_motion, machine)
    want = np.flatnonzero(_changed(Profile.of(old), new, machine))
    assert want.size > 2000
    profile = tuple(a.copy() for a in (old.v_entry, old.v_peak, old.v_exit, old.acc))
    sw, redone = changed_sweep(new_motion, machine, profile, WARMUP_TIME_CONSTANTS * machine.servo.time_constant_s,
                               size=500)
    kept = _nbytes(sw.t_a) + _nbytes(sw.t_b) + _nbytes(redone) + _nbytes(getattr(sw, "spans", None))
    assert kept <= 400, (kept, want.size)
    assert sw.windows(machine) == segment_windows(new, machine, want)


def _hot_trial_with_plans(st, scale, hot):
    """The uniform search's hot trial as main 2a1349a made it: a whole plan per chain, its windows run."""
    from fuzzyfeed.machine.stream import warmup_ticks
    from fuzzyfeed.program.apart import masked
    from fuzzyfeed.program.uniform import HOT_MAX_TICKS
    from fuzzyfeed.program.run import run_chain

    plans, windows = [], []
    for chain, h in zip(st.path.chains, hot):
        plan = plan_motion(Motion(chain.motion.points, chain.motion.feed_mm_s * scale, chain.motion.rapid,
                                  chain.motion.arc_radius_mm), st.machine) if h.size else None
        plans.append(plan)
        windows.append(segment_windows(plan, st.machine, h) if h.size else [])
    if sum(b - a + warmup_ticks(st.machine) for w in windows for a, b in w) > min(st.max_ticks, HOT_MAX_TICKS):
        return None
    worst, out = 0.0, []
    for chain, h, plan, w, a in zip(st.path.chains, hot, plans, windows, st.apart):
        if h.size == 0:
            out.append(h)
            continue
        r = run_chain(chain, st.machine, plan=plan, windows=w, keep_mm=np.inf)
        seg_max = masked(r.stream.seg_max_mm, a)
        worst = max(worst, float(seg_max.max()) * 1e3)
        out.append(np.flatnonzero(seg_max > st.tol_mm))
    return worst, out


@pytest.mark.parametrize("program", ["raster", "programs/camotics/engrave.ngc"])
def test_hot_trials_are_the_whole_plans(program):
    from fuzzyfeed.program.uniform import _Search
    from fuzzyfeed.program.run import run_program

    machine = load_machine("reference")
    path = program_path(parse_program(_raster_program(rows=8, step=0.05)), machine.chord_tol_mm) \
        if program == "raster" else library_path(program, machine)
    first = run_program(path, machine, feed_scale=3.0)      # fast enough to break the tolerance
    st = _Search(path, machine, machine.contour_tol_um, 2e8, first)
    hot = [np.flatnonzero(r.stream.seg_max_mm > 0.3 * st.tol_mm) for r in first.runs]
    assert sum(h.size for h in hot) > 0
    st.apart = [h[::5].copy() for h in hot]                 # some places set apart: masked in both
    over = 0
    for scale in (3.0, 1.7, 0.9):
        got, want = st.hot_trial(scale, hot), _hot_trial_with_plans(st, scale, hot)
        assert got[0] == want[0]
        assert len(got[1]) == len(want[1]) and all(np.array_equal(a, b) for a, b in zip(got[1], want[1]))
        over += sum(h.size for h in got[1])
    assert over > 0
