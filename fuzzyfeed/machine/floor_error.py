"""The error a feed factor cannot take away: a place's contour error with every F × a floor factor
(issue 36, item 3: the places that keep the uniform slowdown a bound).

A uniform factor c scales the feed moves, not the rapids. At a feed move entered from rapids (a
retract, a short rapid across, a plunge that starts above the stock: blendercam's ``_from_curve``,
``Waterline_OCL``, KB-35) the tool still lags behind the rapids' deceleration, A/Kv² for a first-order
loop (1.1 mm on ``reference``), while the command turns into the feed move, and cuts that corner at
the same distance whatever c is: 271 µm at c = 1 and 268 µm at c = 0.01 on ``_from_curve``'s line
89. No factor holds the tolerance there, so the search on ever smaller factors ends at its tick
budget with a bound.

:func:`floor_errors` measures it: the plan with every F × ``floor`` (default 0.01, the limit
reference's floor), run only over the ticks from the start of each given segment to
:data:`~fuzzyfeed.machine.stream.WARMUP_TIME_CONSTANTS` servo time constants after it (each window
warmed up from rest as :func:`~fuzzyfeed.machine.stream.segment_windows`: the state there is the
rapids', the feed's own motion at that speed has barely started). The plan is made window by window and only the parts holding those ticks are run
(:func:`~fuzzyfeed.machine.plan_parts.stream_parts`, bit for bit the whole plan's). A place whose floor error is over
the tolerance is one no uniform factor fixes: the uniform search sets it apart and says so
(:mod:`fuzzyfeed.program.apart`), as the value report does with errors in the air. This is a
measurement at one small factor, not a proof that the error stays above it for every c below: it is
what "found" is defined against.
"""

from __future__ import annotations

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.plan_parts import WINDOW_SEGMENTS, stream_parts, sweep
from fuzzyfeed.machine.planner import Motion
from fuzzyfeed.machine.stream import WARMUP_TIME_CONSTANTS, tick_count, warmup_ticks

#: The floor factor (as the limit reference's REFERENCE_FLOOR: no feed is lowered below 1 % of F).
FLOOR = 0.01


def floor_errors(motion: Motion, measured: np.ndarray, machine: Machine, segments: np.ndarray,
                 floor: float = FLOOR, size: int = WINDOW_SEGMENTS) -> np.ndarray:
    """Largest contour error (mm) in the part of each of ``segments`` (indices into ``motion``)
    with every feed × ``floor`` (of the feed the machine can run there, min(F, the axes' speed
    along the segment): as the limit reference's floor), over its first WARMUP_TIME_CONSTANTS
    servo time constants. ``size``: segments per plan window."""
    if not (np.isfinite(floor) and 0.0 < floor <= 1.0):
        raise InputError(f"floor = {floor!r}; must be finite, > 0 and <= 1")
    seg = np.unique(np.asarray(segments, dtype=np.int64))
    if seg.size == 0:
        return np.zeros(0)
    # the floor of the feed the machine can run (an F far above it, F1e6, runs at the axes' speed)
    reachable = np.minimum(motion.feed_mm_s, machine.speed_along(motion.points))
    scaled = Motion(motion.points, np.where(motion.rapid, motion.feed_mm_s, reachable * floor),
                    motion.rapid, motion.arc_radius_mm)
    # the plan window by window (machine/plan_parts.py: bit for bit the whole plan's), never whole
    sw = sweep(scaled, machine, seg, size)
    ts = machine.ts_s
    k_end = tick_count(sw, ts)
    span = int(np.ceil(WARMUP_TIME_CONSTANTS * machine.servo.time_constant_s / ts))
    ka = np.clip(np.floor(sw.t_a / ts).astype(np.int64), 0, k_end)
    kb = np.minimum(np.clip(np.ceil(sw.t_b / ts).astype(np.int64), 0, k_end), ka + span)
    gap = warmup_ticks(machine)
    windows: list[tuple[int, int]] = []
    for a, b in zip(ka.tolist(), kb.tolist()):
        if windows and a - gap <= windows[-1][1]:
            windows[-1] = (windows[-1][0], max(windows[-1][1], b))
        else:
            windows.append((a, b))
    # every tick searched (fast=False): this measures errors far below the tolerance too
    run = stream_parts(scaled, machine, measured, sw, windows, keep_mm=np.inf, fast=False, size=size)
    # a merged window may run on past a segment's own span: its maximum is over at least that span;
    # parts may overlap (a segment's largest error is the larger of its parts')
    out = np.zeros(seg.size)
    for first, m in run.parts:
        i0, i1 = np.searchsorted(seg, [first, first + m.size])
        np.maximum(out[i0:i1], m[seg[i0:i1] - first], out=out[i0:i1])
    return out[np.searchsorted(seg, np.asarray(segments, dtype=np.int64))]
