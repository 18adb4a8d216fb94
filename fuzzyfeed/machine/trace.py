"""A motion run on a machine: planned (:mod:`~fuzzyfeed.machine.planner`), sampled every Ts, the
set-points run through the axis servo (:func:`~fuzzyfeed.machine.servo.following_errors`), and the
contour error of the actual tool measured against the path it was commanded
(:func:`~fuzzyfeed.machine.contour.windowed_distance`).

Every tick is held in memory here: this is the reference implementation (small motions: the
designer, the tests). Program runs go through :func:`fuzzyfeed.machine.stream.stream_plan`, the
same operations tick by tick keeping summaries only, held to this one by tests/test_machine_stream.py."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.machine.contour import windowed_distance
from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.planner import Motion, Plan, plan_motion
from fuzzyfeed.machine.servo import following_errors

#: Lookback of the contour-error window, in servo time constants (the weight of older set-points
#: in a first-order loop's position is below e^-6 = 0.25 %).
LOOKBACK_TIME_CONSTANTS = 6.0
#: The most servo periods one run may simulate (the scheduler's budget too): about 5 GB of
#: temporaries at the most.
MAX_TICKS = 2e7
#: Margin of the window either side (mm): a loop with feed-forward or a second-order loop can run
#: slightly ahead of its command.
WINDOW_MARGIN_MM = 0.2


@dataclass(frozen=True, eq=False)
class Trace:
    """Per measured tick: its time, the contour error (mm), the segment commanded and the segment
    nearest to the actual tool."""

    plan: Plan
    tick_time_s: np.ndarray
    contour_mm: np.ndarray
    tick_segment: np.ndarray
    nearest_segment: np.ndarray
    nearest_xyz: np.ndarray         # (K, 3) the point of the path nearest to the tool
    speed_mm_s: np.ndarray          # commanded speed over the tick before
    lookback_segment: np.ndarray    # the segment commanded LOOKBACK_TIME_CONSTANTS before

    @property
    def max_mm(self) -> float:
        return float(self.contour_mm.max()) if self.contour_mm.size else 0.0


def trace_motion(motion: Motion, machine: Machine, measured: np.ndarray | None = None) -> Trace:
    """Run ``motion`` on ``machine`` and measure the contour error at the ticks commanded on the
    segments ``measured`` (bool per segment; default all) while the tool is nearest one of them
    (a tool still lagging round the corner of two rapids is in the air, not on the cut)."""
    plan = plan_motion(motion, machine)
    if not plan.time_s / machine.ts_s <= MAX_TICKS:
        raise InputError(f"a run of {plan.time_s:.0f} s at Ts = {machine.ts_s:g} s is "
                         f"{plan.time_s / machine.ts_s:.2g} servo periods; at most {MAX_TICKS:.0e} are "
                         "simulated (split the program, or give a longer --ts-s)")
    t, cmd, seg = plan.sample(machine.ts_s)
    err = following_errors(machine.servo, cmd, machine.ts_s)
    actual = cmd - err
    s_vertex = plan.segment_arc_start()
    s_cmd = s_vertex[seg] + np.linalg.norm(cmd - motion.points[seg], axis=1)
    idx = np.arange(t.size) if measured is None else np.flatnonzero(np.asarray(measured)[seg])
    lookback = int(np.ceil(LOOKBACK_TIME_CONSTANTS * machine.servo.time_constant_s / machine.ts_s))
    s_lo = s_cmd[np.maximum(idx - lookback, 0)] - WINDOW_MARGIN_MM
    s_hi = s_cmd[idx] + WINDOW_MARGIN_MM
    if idx.size:
        dist, nearest, foot = windowed_distance(motion.points, s_vertex, actual[idx], s_lo, s_hi)
    else:
        dist, nearest, foot = np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    if measured is not None and idx.size:
        # a tool still nearest a segment that is not measured (a rapid it lags behind, in the air)
        # is not on the measured path yet
        on = np.asarray(measured)[nearest]
        idx, dist, nearest, foot, s_lo = idx[on], dist[on], nearest[on], foot[on], s_lo[on]
    speed = np.concatenate([[0.0], np.diff(s_cmd)]) / machine.ts_s
    return Trace(plan=plan, tick_time_s=t[idx], contour_mm=dist, tick_segment=seg[idx],
                 nearest_segment=nearest, nearest_xyz=foot, speed_mm_s=speed[idx],
                 lookback_segment=seg[np.maximum(idx - lookback, 0)])
