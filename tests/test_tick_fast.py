"""The tick pass's fast path (issue 36 item 2: ticks whose proven error bound is far below the
tolerance are not searched) held to the tick pass (``fast=False``, itself held to the whole-array
reference by tests/test_machine_stream.py): the same time and largest error (value and place), the
events, the p99 of every program; per segment the largest error at or above the tick pass's and
within the threshold of it; the histogram moved only upwards and only below the threshold. On
every library program fuzzyfeed reads, on two machines, and on random polylines and arcs with
first- and second-order loops, feed-forward and unequal axes; a bound made too small and a
threshold that skips corners are caught."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fuzzyfeed.machine._ticks_jit import hist_bin
from fuzzyfeed.machine.description import Machine, load_machine
from fuzzyfeed.machine.planner import Motion, plan_motion
from fuzzyfeed.machine.servo import ServoModel
from fuzzyfeed.machine.stream import (percentile_settled, percentile_um, skip_threshold, stream_plan,
                                      segment_windows)
from fuzzyfeed.program.read import read_program
from fuzzyfeed.program.run import program_path, run_program
from tick_cases import library_path, library_programs


def _check(fast, ticks, skip_mm: float) -> None:
    """``fast`` (a fast-path StreamRun) against ``ticks`` (the tick pass of the same plan)."""
    assert fast.plan.time_s == ticks.plan.time_s
    assert fast.part_ticks == ticks.part_ticks
    assert abs(fast.max_mm - ticks.max_mm) <= 1e-9
    assert fast.max_segment == ticks.max_segment
    assert abs(fast.air_max_mm - ticks.air_max_mm) <= 1e-9
    # per segment: at or above the tick pass's largest error, within the threshold of it
    assert np.all(fast.seg_max_mm >= ticks.seg_max_mm - 1e-12)
    assert np.all(fast.seg_max_mm <= ticks.seg_max_mm + skip_mm + 1e-12)
    # histogram: the same ticks; above the threshold's bin the same counts; below it moved upwards
    top = hist_bin(skip_mm * 1e3)
    nb = max(int(fast.hist_bins.max(initial=0)), int(ticks.hist_bins.max(initial=0))) + 1
    hf = np.bincount(fast.hist_bins, weights=fast.hist_counts, minlength=nb)
    ht = np.bincount(ticks.hist_bins, weights=ticks.hist_counts, minlength=nb)
    assert hf.sum() == ht.sum()
    assert np.array_equal(hf[top + 1:], ht[top + 1:])
    assert np.all(np.cumsum(hf) <= np.cumsum(ht))
    # events (ticks over keep_mm, never a bounded one): the same
    assert np.array_equal(fast.tick_segment, ticks.tick_segment)
    assert np.allclose(fast.contour_mm, ticks.contour_mm, rtol=0, atol=1e-9)


@pytest.mark.parametrize("machine_name", ["reference", "hobby-router"])
@pytest.mark.parametrize("rel", library_programs())
def test_fast_path_holds_to_the_tick_pass_on_the_library(rel, machine_name):
    machine = load_machine(machine_name)
    path = library_path(rel, machine)
    fast = run_program(path, machine)                     # the default: the fast path
    ticks = run_program(path, machine, fast=False)
    skip = skip_threshold(machine)
    for f, t in zip(fast.runs, ticks.runs):
        _check(f.stream, t.stream, skip)
    assert math.isclose(fast.time_s, ticks.time_s, rel_tol=1e-3)
    assert fast.max_um == pytest.approx(ticks.max_um, abs=1.0)
    assert fast.worst() is None and ticks.worst() is None or fast.worst()[0] == ticks.worst()[0]
    assert fast.p99_um == ticks.p99_um                    # settled, or the chains run again
    assert np.all(np.abs(fast.cut_max_um() - ticks.cut_max_um()) <= skip * 1e3 + 1e-9)


def _random_motion(rng, n: int, scale: float, arcs: bool) -> Motion:
    pts = [np.zeros(3)]
    for _ in range(n):
        if arcs and rng.random() < 0.4:      # an arc as chords (a few µm of sag), either way round
            r = rng.uniform(1.0, 30.0)
            sweep = rng.uniform(0.2, 3.0) * rng.choice([-1.0, 1.0])
            k = max(int(abs(sweep) * r / rng.uniform(0.05, 1.0)), 2)
            a0 = rng.uniform(0, 2 * np.pi)
            centre = pts[-1] - r * np.array([np.cos(a0), np.sin(a0), 0.0])
            a = a0 + sweep * np.arange(1, k + 1) / k
            z = pts[-1][2] + np.linspace(0, rng.normal(0, 0.2), k + 1)[1:]
            pts.extend(centre + np.stack([r * np.cos(a), r * np.sin(a), z - centre[2]], axis=1))
        else:                                # a straight stretch, sometimes in many short moves
            d = rng.normal(size=3) * [scale, scale, 0.2 * scale]
            parts = int(rng.choice([1, 1, 5, 40]))
            pts.extend(pts[-1] + d * (np.arange(1, parts + 1) / parts)[:, None])
    p = np.array(pts)
    p = p[np.concatenate([[True], np.linalg.norm(np.diff(p, axis=0), axis=1) > 1e-6])]
    m = p.shape[0] - 1
    rapid = rng.random(m) < (0.1 if rng.random() < 0.5 else 0.0)
    feed = np.where(rapid, np.nan, rng.uniform(2.0, 90.0, m))
    return Motion(p, feed, rapid, np.full(m + 1, np.nan))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), order=st.sampled_from([1, 2]), n=st.integers(1, 30),
       scale=st.floats(0.5, 40.0), ff=st.sampled_from([0.0, 0.6, 1.0]), equal=st.booleans(),
       arcs=st.booleans())
def test_fast_path_holds_to_the_tick_pass_on_random_paths(seed, order, n, scale, ff, equal, arcs):
    rng = np.random.default_rng(seed)
    motion = _random_motion(rng, n, scale, arcs)
    if motion.points.shape[0] < 2:
        return
    if order == 1:
        kv = rng.uniform(15, 80) if equal else tuple(rng.uniform(15, 80, 3))
        servo = ServoModel(kv_1_s=kv, feedforward=ff)
    else:
        fn = rng.uniform(8, 30) if equal else tuple(rng.uniform(8, 30, 3))
        servo = ServoModel(natural_freq_hz=fn, damping=rng.uniform(0.5, 1.0), feedforward=ff)
    machine = Machine(servo=servo, contour_tol_um=float(rng.uniform(5, 80)))
    plan = plan_motion(motion, machine)
    measured = ~motion.rapid
    skip = skip_threshold(machine)
    ticks = stream_plan(plan, machine, measured, fast=False)
    fast = stream_plan(plan, machine, measured)
    _check(fast, ticks, skip)
    # the p99 of the run: equal where the fast histogram says it is settled
    if percentile_settled(fast.hist_bins, fast.hist_counts, 99.0, skip):
        assert percentile_um(fast.hist_bins, fast.hist_counts, 99) == percentile_um(ticks.hist_bins, ticks.hist_counts, 99)
    # windows (what the uniform slowdown and the limit reference run) too
    if ticks.max_mm > 0:
        hot = np.flatnonzero(ticks.seg_max_mm > 0.5 * ticks.max_mm)
        w = segment_windows(plan, machine, hot)
        _check(stream_plan(plan, machine, measured, windows=w), stream_plan(plan, machine, measured, windows=w, fast=False), skip)


def _long_lines():
    """A zig-zag of long lines with a few short ones: most ticks far below 1 µm, corners over it."""
    pts = np.array([[0, 0, 0], [60, 0, 0], [60, 2, 0], [0, 2, 0], [0, 4, 0.5], [60, 4, 0.5], [60.3, 4.2, 0.5],
                    [60.6, 4.3, 0.5], [0, 6, 0.0]], dtype=float)
    m = pts.shape[0] - 1
    machine = load_machine("reference")
    motion = Motion(pts, np.full(m, 40.0), np.zeros(m, bool), np.full(m + 1, np.nan))
    return machine, plan_motion(motion, machine), np.ones(m, bool)


def test_most_ticks_of_long_lines_are_bounded_not_searched():
    machine, plan, measured = _long_lines()
    ticks = stream_plan(plan, machine, measured, fast=False)
    fast = stream_plan(plan, machine, measured)
    _check(fast, ticks, skip_threshold(machine))
    assert fast.skipped_ticks > 0.5 * fast.part_ticks
    assert fast.leapt_ticks > 0.5 * fast.skipped_ticks         # most by a leap along a line
    assert not fast.rerun and ticks.skipped_ticks == 0


@pytest.mark.parametrize("servo", [ServoModel(natural_freq_hz=20.0, damping=0.8),
                                   ServoModel(kv_1_s=(30.0, 25.0, 30.0))])
def test_second_order_and_unequal_loops_are_bounded_tick_by_tick(servo):
    # no leap (its closed form is the equal first-order loops'): every skipped tick is bounded
    _, plan, measured = _long_lines()
    machine = Machine(servo=servo, contour_tol_um=50.0)
    plan = plan_motion(plan.motion, machine)
    fast = stream_plan(plan, machine, measured)
    _check(fast, stream_plan(plan, machine, measured, fast=False), skip_threshold(machine))
    assert fast.skipped_ticks > 0 and fast.leapt_ticks == 0


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 20))
def test_leap_ends_at_the_last_tick_the_sampling_puts_on_the_segment(seed, n):
    from fuzzyfeed.machine._ticks_jit import leap_end
    from fuzzyfeed.machine.stream import tick_count

    rng = np.random.default_rng(seed)
    motion = _random_motion(rng, n, 10.0, arcs=True)
    machine = load_machine("reference")
    plan = plan_motion(motion, machine)
    _, _, seg = plan.sample(machine.ts_s)                   # the whole-array reference's ticks
    k_end = tick_count(plan, machine.ts_s)
    assert seg.size == k_end + 1
    for j in np.unique(seg):
        ks = np.flatnonzero(seg == j)
        for k in (ks[0], ks[ks.size // 2]):
            assert leap_end(plan.t_start, plan.time_s, machine.ts_s, int(j), int(k), k_end) == ks[-1]


@pytest.mark.parametrize("p_um,decay,n", [(0.9, math.exp(-0.03), 5000), (0.3, math.exp(-0.06), 40),
                                          (1e-4, 0.97, 100), (0.0, 0.97, 10), (0.99, 0.999999, 3)])
def test_leap_histogram_puts_each_tick_at_or_above_its_bin(p_um, decay, n):
    from fuzzyfeed.machine._ticks_jit import HIST_BINS, leap_histogram

    sl = 1e-9
    hist = np.zeros(HIST_BINS, np.int64)
    leap_histogram(hist, p_um * 1e-3, decay, sl, n)
    own = np.zeros(HIST_BINS, np.int64)
    for i in range(1, n + 1):
        own[hist_bin((p_um * 1e-3 * decay ** i + sl) * 1e3)] += 1
    assert hist.sum() == n
    assert np.all(np.cumsum(hist) <= np.cumsum(own))          # moved upwards only ...
    assert np.flatnonzero(hist).max() == np.flatnonzero(own).max()   # ... not above the first tick's


def test_a_bound_made_too_small_is_caught():
    machine, plan, measured = _long_lines()
    ticks = stream_plan(plan, machine, measured, fast=False)
    wrong = stream_plan(plan, machine, measured, bound_scale=0.25)   # claims a quarter of the distance
    assert wrong.skipped_ticks > 0
    with pytest.raises(AssertionError):
        _check(wrong, ticks, skip_threshold(machine))


def test_a_threshold_that_skips_corners_is_caught():
    # a bound that is valid but loose (1.5 times the distance) keeps the tolerances under the
    # threshold (it is the threshold that holds them, not the bound's tightness) ...
    machine, plan, measured = _long_lines()
    ticks = stream_plan(plan, machine, measured, fast=False)
    _check(stream_plan(plan, machine, measured, bound_scale=1.5), ticks, skip_threshold(machine))
    # ... and a threshold as large as half the corners' errors does not
    loose = stream_plan(plan, machine, measured, skip_mm=0.5 * ticks.max_mm, bound_scale=1.5)
    assert loose.skip_max_mm > 10 * skip_threshold(machine)
    with pytest.raises(AssertionError):
        _check(loose, ticks, skip_threshold(machine))


def test_a_run_whose_largest_error_is_bounded_is_run_again():
    # one straight line at a low feed: every error after the start is far below 1 µm
    machine = load_machine("reference")
    motion = Motion(np.array([[0, 0, 0], [30, 10, 0.0]]), np.array([5.0]), np.zeros(1, bool), np.full(2, np.nan))
    plan = plan_motion(motion, machine)
    ticks = stream_plan(plan, machine, fast=False)
    fast = stream_plan(plan, machine)
    assert fast.rerun and fast.max_mm == ticks.max_mm and fast.max_time_s == ticks.max_time_s
    assert ticks.max_mm < skip_threshold(machine)


def test_an_unsettled_p99_runs_the_chains_again(tmp_path):
    # long slow lines: the p99 itself is below the threshold, the fast histogram cannot tell it
    prog = tmp_path / "slow.ngc"
    prog.write_text("G21 G90\nG0 X0 Y0 Z1\nG1 Z0 F120\nG1 X80\nG1 Y1\nG1 X0\nM2\n")
    machine = load_machine("reference")
    path = program_path(read_program(prog), machine.chord_tol_mm)
    fast = run_program(path, machine)
    ticks = run_program(path, machine, fast=False)
    assert ticks.p99_um < skip_threshold(machine) * 1e3
    first = [stream_plan(plan_motion(c.motion, machine), machine, c.seg_measured) for c in path.chains]
    assert sum(s.skipped_ticks for s in first) > 0
    bins = np.concatenate([s.hist_bins for s in first])
    counts = np.concatenate([s.hist_counts for s in first])
    assert not percentile_settled(bins, counts, 99.0, skip_threshold(machine))
    # run again: with a lower threshold, or tick by tick
    assert all(r.stream.skipped_ticks == 0 or r.stream.skip_mm < skip_threshold(machine) for r in fast.runs)
    assert fast.p99_um == ticks.p99_um and fast.p99_settled
