"""The tick pass's pruned nearest-segment search (bounding boxes of blocks of segments, issue 36
item 2) against the plain scan of every segment of the window: the same floats, bit for bit, on
random polylines (hypothesis), on dense zig-zag rasters and on library programs; boxes that are
wrong (shrunk: the bound |q − X| ≥ dist(q, box) broken) are caught."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fuzzyfeed.machine.description import Machine, load_machine
from fuzzyfeed.machine.planner import Motion, plan_motion
from fuzzyfeed.machine.servo import ServoModel
from fuzzyfeed.machine.stream import segment_boxes, stream_plan
from tick_cases import library_path, library_programs, random_polyline


def _summaries(run):
    return (run.max_mm, run.max_segment, tuple(run.max_xyz), run.air_max_mm, run.air_nearest,
            run.hist_bins.tobytes(), run.hist_counts.tobytes(), run.seg_max_mm.tobytes(),
            run.contour_mm.tobytes(), run.nearest_segment.tobytes(), run.nearest_xyz.tobytes(),
            run.tick_segment.tobytes())


def _assert_same(plan, machine, measured, block=8, boxes=None):
    scan = stream_plan(plan, machine, measured, block=0)
    fast = stream_plan(plan, machine, measured, block=block, boxes=boxes)
    assert _summaries(fast) == _summaries(scan)


def _raster(rows: int, step: float, pitch: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    out = []
    for r in range(rows):
        x = np.arange(0.0, 20.0 + 1e-9, step)
        x = x if r % 2 == 0 else x[::-1]
        y = np.full_like(x, r * pitch)
        out.append(np.stack([x, y, 0.3 * np.sin(x / 3.0 + r * pitch) + rng.normal(0, 1e-3, x.size)], axis=1))
    return np.concatenate(out)


def test_boxes_hold_their_blocks():
    pts = np.cumsum(np.random.default_rng(3).normal(size=(101, 3)), axis=0)
    lo, hi = segment_boxes(pts, 8)
    for b in range(lo.shape[0]):
        v = pts[b * 8: min(b * 8 + 8, 100) + 1]
        assert np.array_equal(lo[b], v.min(axis=0)) and np.array_equal(hi[b], v.max(axis=0))


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), order=st.sampled_from([1, 2]), n=st.integers(1, 300),
       scale=st.floats(0.02, 20.0), block=st.sampled_from([1, 3, 8, 16]))
def test_pruned_search_equals_the_scan_on_random_polylines(seed, order, n, scale, block):
    rng = np.random.default_rng(seed)
    motion = random_polyline(rng, n, scale, rapids=seed % 2 == 1)
    if motion is None:
        return
    servo = ServoModel(kv_1_s=rng.uniform(15, 80), feedforward=rng.choice([0.0, 0.6])) if order == 1 else \
        ServoModel(natural_freq_hz=rng.uniform(8, 30), damping=rng.uniform(0.5, 1.0))
    machine = Machine(servo=servo, contour_tol_um=float(rng.uniform(5, 80)))
    _assert_same(plan_motion(motion, machine), machine, ~motion.rapid, block=block)


@pytest.mark.parametrize("step,pitch", [(0.1, 0.1), (0.05, 0.02), (0.5, 0.3)])
def test_pruned_search_equals_the_scan_on_rasters(step, pitch):
    pts = _raster(12, step, pitch, 1)
    m = pts.shape[0] - 1
    machine = load_machine("reference")
    plan = plan_motion(Motion(pts, np.full(m, 40.0), np.zeros(m, bool), np.full(m + 1, np.nan)), machine)
    _assert_same(plan, machine, np.ones(m, bool))


def test_a_wrong_bound_is_caught():
    # boxes shrunk by 5 um (the bound no longer holds for the segments at their edges): the pruned
    # search then skips blocks holding the nearest segment, and the comparison above sees it
    pts = _raster(6, 0.1, 0.1, 2)
    m = pts.shape[0] - 1
    machine = load_machine("reference")
    plan = plan_motion(Motion(pts, np.full(m, 40.0), np.zeros(m, bool), np.full(m + 1, np.nan)), machine)
    lo, hi = segment_boxes(pts, 8)
    mid = 0.5 * (lo + hi)
    shrunk = (np.minimum(lo + 0.005, mid), np.maximum(hi - 0.005, mid))
    with pytest.raises(AssertionError):
        _assert_same(plan, machine, np.ones(m, bool), boxes=shrunk)
    _assert_same(plan, machine, np.ones(m, bool), boxes=(lo, hi))


@pytest.mark.parametrize("rel", library_programs(every=3))
@pytest.mark.parametrize("machine_name", ["reference", "hobby-router"])
def test_pruned_search_equals_the_scan_on_the_library(rel, machine_name):
    machine = load_machine(machine_name)
    path = library_path(rel, machine)
    for chain in path.chains:
        plan = plan_motion(chain.motion, machine)
        _assert_same(plan, machine, chain.seg_measured)
