"""A chain's whole tick pass made part by part from the plan's windows, the servo's state carried
from part to part (issue 36: the whole runs — as written, advised, the uniform check, the limit
reference's last pass — planned a whole chain, ~0.1 KB a segment, with the arrays the tick pass
copies; a one-cut raster of 10⁶ moves, or a program whose rapids keep every cut in one chain).

:func:`stream_chain` is :func:`~fuzzyfeed.machine.stream.stream_plan` on
``plan_motion(motion, machine)`` without windows, bit for bit, holding O(part) of the plan:

- the plan's windows are swept once whole (:func:`~fuzzyfeed.machine.plan_parts.sweep`: the
  carries, the time and arc length at every window's start), then planned again part by part
  (:func:`~fuzzyfeed.machine.plan_parts.plan_groups`), each part the whole plan's slice;
- part p runs the ticks [K_p, K_p+1 − 1] (K_p: the tick of its first window's start time); it
  holds the plan from :data:`~fuzzyfeed.machine.plan_parts.RANGE_MARGIN_MM` of arc length before
  the segment commanded a lookback (+ 2 ticks) before K_p, to that margin after the end vertex of
  the segment commanded at its last tick, and a plan window more on each side: every array the
  kernel reads for those ticks (the tick's segment and the next vertex, the lookback window's
  ends and the search between them, the leap's reach) lies inside it, so every count and search
  answers the whole plan's less the part's first segment;
- between parts the kernel's state is handed on: the servo (errors, velocities, last set-point),
  the lookback rings, the maxima, the fast path's last error and leap, the event buffer (not
  drained at a part's end, so events merge and the buffer fills as in one pass), every segment
  index in them moved by the difference of the parts' first segments; a leap is bounded by the
  run's last tick, not the part's (``k_end`` and ``k_stop`` of
  :func:`~fuzzyfeed.machine._ticks_jit.run_ticks`).

Held to ``stream_plan`` on the whole plan by tests/test_chain_pass.py (every summary, bit for bit).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.plan_parts import RANGE_MARGIN_MM, WINDOW_SEGMENTS, Sweep, plan_groups, sweep
from fuzzyfeed.machine.planner import Motion
from fuzzyfeed.machine.stream import (BOX_BLOCK, BOX_SLACK_PER_MM, StreamRun, TickPass, _kernel, lookback_ticks, segment_boxes,
                                      skip_threshold, tick_count)

#: Plan windows (of ``size`` segments at least) whose ticks one part runs.
PART_WINDOWS = 16


def carried_groups(sw: Sweep, machine: Machine, part_windows: int = PART_WINDOWS) -> list[tuple[int, int, tuple]]:
    """Per part (module docstring): the plan windows [w0, w1) it holds and its ticks (k_lo, k_hi);
    the ticks of the parts are 0 … K (:func:`~fuzzyfeed.machine.stream.tick_count`), in order."""
    if part_windows < 1:
        raise ValueError(f"part_windows = {part_windows!r}; must be >= 1")
    ts, total = machine.ts_s, sw.time_s
    n_win = sw.first.size - 1
    k_end = tick_count(sw, ts)
    back = lookback_ticks(machine) + 2
    cuts = [0] + [int(np.floor(sw.t0[w] / ts)) for w in range(part_windows, n_win, part_windows)] + [k_end + 1]
    out: list[tuple[int, int, tuple]] = []
    starts = sw.t0[:-1]
    for k_lo, k_next in zip(cuts[:-1], cuts[1:]):
        k_lo = max(k_lo, out[-1][2][1] + 1 if out else 0)
        k_hi = min(k_next - 1, k_end)
        if k_hi < k_lo:
            continue
        w_from = max(int(np.searchsorted(starts, max(k_lo - back, 0) * ts, side="right")) - 1, 0)
        w0 = int(np.searchsorted(sw.s0[1:], sw.s0[w_from] - RANGE_MARGIN_MM, side="left"))
        w0 = max(min(w0, w_from - 1), 0)
        w_to = max(int(np.searchsorted(starts, min(k_hi * ts, total), side="right")) - 1, 0)
        w1 = int(np.searchsorted(sw.s0[:-1], sw.s0[min(w_to + 1, n_win)] + RANGE_MARGIN_MM, side="right"))
        w1 = min(max(w1, w_to + 2), n_win)
        out.append((w0, w1, (k_lo, k_hi)))
    if out and out[-1][2][1] != k_end:
        raise AssertionError("the parts' ticks do not reach the run's last")
    return out


def stream_chain(motion: Motion, machine: Machine, measured: np.ndarray | None = None, keep_mm: float | None = None,
                 fast: bool = True, skip_mm: float | None = None, size: int | None = None,
                 part_windows: int | None = None, before_ticks=None, seg_sink=None) -> tuple[StreamRun, float]:
    """``stream_plan(plan_motion(motion, machine), machine, measured, keep_mm, fast=fast,
    skip_mm=skip_mm)`` (no windows) part by part (module docstring), and the plan's time (s); the
    run holds no plan (``plan`` None). ``size``/``part_windows``: segments per plan window and plan
    windows per part (default :data:`~fuzzyfeed.machine.plan_parts.WINDOW_SEGMENTS`,
    :data:`PART_WINDOWS`). ``before_ticks(time_s)`` is called with the plan's time before any tick
    is run (a caller's budget check). ``seg_sink``: where the largest error per segment goes as the
    parts finish with it (its ``open()`` gives ``add(values)`` for the next segments; the run's
    ``seg_max_mm`` is then ``seg_sink``, read by slices: :class:`~fuzzyfeed.base.spill.SpilledValues`),
    nothing per segment of the chain held."""
    size = WINDOW_SEGMENTS if size is None else size
    part_windows = PART_WINDOWS if part_windows is None else part_windows
    n = motion.n_segments
    # measured: an array, or a column read a slice at a time (program/chain_store.py's)
    meas = np.ones(n, bool) if measured is None else (measured if getattr(measured, "stored", False)
                                                      else np.asarray(measured, dtype=bool))
    sw = sweep(motion, machine, np.zeros(0, np.int64), size)
    if before_ticks is not None:
        before_ticks(sw.time_s)
    groups = carried_groups(sw, machine, part_windows)
    if fast:
        skip = skip_threshold(machine) if skip_mm is None else float(skip_mm)
        if not (np.isfinite(skip) and skip >= 0.0):
            raise ValueError(f"skip_mm = {skip_mm!r}; must be a finite number >= 0")
        run = _pass(motion, machine, meas, sw, groups, keep_mm, skip, size, seg_sink)
        if run.skipped_ticks and run.skip_max_mm >= run.max_mm:
            again = _pass(motion, machine, meas, sw, groups, keep_mm, 0.0, size, seg_sink)
            return replace(again, rerun=True), sw.time_s
        return run, sw.time_s
    return _pass(motion, machine, meas, sw, groups, keep_mm, 0.0, size, seg_sink), sw.time_s


class _Handed:
    """The largest error per segment of the segments a part may still reach, the ones before
    handed to ``add`` in order (the parts' first segments never go back: :func:`carried_groups`)."""

    def __init__(self, add, n: int):
        self.add, self.n = add, n
        self.done = 0                     # segments handed on
        self.held = np.zeros(0)           # segments done .. done + held.size

    def _reach(self, end: int) -> None:
        if self.held.size < end - self.done:
            self.held = np.concatenate([self.held, np.zeros(end - self.done - self.held.size)])

    def part(self, first: int, part_max: np.ndarray) -> None:
        if first < self.done:
            raise AssertionError("a part starts before a segment already handed on")
        if first > self.done:
            self._reach(first)
            k = first - self.done
            self.add(self.held[:k])
            self.held, self.done = self.held[k:], first
        self._reach(first + part_max.size)
        view = self.held[:part_max.size]
        np.maximum(view, part_max, out=view)

    def finish(self) -> None:
        self._reach(self.n)
        self.add(self.held)
        self.held, self.done = np.zeros(0), self.n


def _pass(motion, machine, measured, sw, groups, keep_mm, skip_mm, size, seg_sink=None) -> StreamRun:
    """One tick pass over the parts (the fast path's threshold ``skip_mm``; 0: every tick searched)."""
    from fuzzyfeed.machine._ticks_jit import (I_AIR_NEAR, I_AIR_SEG, I_EV_N, I_K0, I_K1, I_K2, I_LEAP, I_LEFT,
                                              I_MAX_SEG, I_NEAR, I_RIGHT, I_SEG, S_AIR, S_MAX)
    from fuzzyfeed.machine.trace import WINDOW_MARGIN_MM

    tp = TickPass(machine, keep_mm, False, BOX_BLOCK, skip_mm, 1.0)
    fstate, istate, ev_f, ev_i = tp.fstate, tp.istate, tp.ev_f, tp.ev_i
    ts = machine.ts_s
    k_end = tick_count(sw, ts)
    lookback = lookback_ticks(machine)
    handed = None if seg_sink is None else _Handed(seg_sink.open(), motion.n_segments)
    seg_max = np.zeros(motion.n_segments if handed is None else 0)
    f64 = lambda a: np.require(a, dtype=np.float64, requirements=["C", "W"])  # noqa: E731
    y_hist, x_hist, prev = np.zeros((3, 2)), np.zeros((3, 2)), np.zeros(3)
    s_ring = np.zeros(lookback + 1)
    seg_ring = np.zeros(lookback + 1, dtype=np.int64)
    run = _kernel()
    last_first = None
    for pr, (k_lo, k_hi) in plan_groups(motion, machine, sw, groups, size):
        first, n = pr.first, pr.length.size
        if last_first is None:                       # the run's start: at rest on its first set-point
            istate[I_K0] = -1
            istate[I_EV_N] = 0
            istate[I_NEAR] = istate[I_RIGHT] = istate[I_LEFT] = istate[I_LEAP] = -1
            istate[I_SEG] = min(max(int(np.searchsorted(pr.t_start, min(k_lo * ts, pr.time_s), side="right")) - 1,
                                    0), n - 1)
        else:                                        # the state of the part before, its indices moved
            d = last_first - first
            istate[I_SEG] += d
            if istate[I_NEAR] >= 0:
                istate[I_NEAR] += d
            for i in (I_RIGHT, I_LEFT):                 # counts of vertices: a walk's start (any is exact)
                if istate[i] >= 0:
                    istate[i] = min(max(istate[i] + d, 0), n + 1)
            seg_ring += d
            m = int(istate[I_EV_N])
            if m:
                ev_i[:m] += d
                istate[I_K1] += d
                istate[I_K2] += d
        meas = measured[first:first + n]
        arrays = (f64(pr.motion.points), f64(pr.unit), f64(pr.length), f64(pr.segment_arc_start()),
                  f64(pr.t_start), f64(pr.v_entry), f64(pr.v_peak), f64(pr.acc), f64(pr.t_acc), f64(pr.t_cruise),
                  np.array(meas, dtype=np.bool_), tp.fb, tp.fa)
        box_lo, box_hi = segment_boxes(pr.motion.points, BOX_BLOCK)
        slack = BOX_SLACK_PER_MM * (1.0 + pr.coordinate_max())
        part_max = np.zeros(n)
        unmeasured_cum = np.concatenate([[0], np.cumsum(~meas)]).astype(np.int64)
        max_before, air_before = fstate[S_MAX], fstate[S_AIR]
        k = k_lo
        while k <= k_hi:
            k = run(*arrays, ts, pr.time_s, k, 0, k_end, k_hi, lookback, WINDOW_MARGIN_MM, tp.keep,
                    y_hist, x_hist, prev, s_ring, seg_ring, part_max, tp.hist, fstate, istate, ev_f, ev_i,
                    f64(box_lo), f64(box_hi), BOX_BLOCK, slack, unmeasured_cum, tp.skip_mm, tp.bound_scale,
                    tp.leap)
            m = int(istate[I_EV_N])
            if m and (k <= k_hi or k_hi == k_end):   # the buffer full (or the run's end): drained
                tp.parts_f.append(ev_f[:m].copy())
                tp.parts_i.append(ev_i[:m] + first)
                istate[I_EV_N] = 0
        if handed is None:
            np.maximum(seg_max[first:first + n], part_max, out=seg_max[first:first + n])
        else:
            handed.part(first, part_max)
        if fstate[S_MAX] > max_before:
            tp.max_segment = first + int(istate[I_MAX_SEG])
        if fstate[S_AIR] > air_before:
            tp.air_segment, tp.air_nearest = first + int(istate[I_AIR_SEG]), first + int(istate[I_AIR_NEAR])
        last_first = first
    if handed is None:
        return tp.result(None, seg_max)
    handed.finish()
    return tp.result(None, seg_sink)
