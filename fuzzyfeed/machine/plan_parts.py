"""The stretches of a chain's plan that a windowed tick pass needs, made from the plan's windows
(:mod:`fuzzyfeed.machine.plan_windows`) without the whole plan (issue 36: the uniform trials and
the limit reference's passes run only the stretches around hot spots).

A tick window [k_a, k_b] (:func:`~fuzzyfeed.machine.stream.tick_windows`) is run from rest a
warm-up earlier; its ticks are commanded on the segments between those instants, and each tick's
nearest-segment search looks :data:`~fuzzyfeed.machine.trace.WINDOW_MARGIN_MM` before the
lookback's position and after the tick's. :class:`PlanRange` holds the plan's windows that cover
that with :data:`RANGE_MARGIN_MM` to spare on both sides (and a whole window more), so the tick pass
on it (:class:`~fuzzyfeed.machine.stream.TickPass`) is the whole plan's bit for bit. A tick window
whose range lies within the last part's is run on that part; parts may overlap (a segment's largest
error is then the larger of its parts'). The plan's windows are swept once whole (its two
passes: :func:`sweep`) for the times of the segments asked for; then only the windows the parts
need are planned again (from the carries the sweep kept), part by part (:func:`plan_parts`), each
dropped before the next is made.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Iterator

import numpy as np

from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.plan_windows import Carries, PlanWindow, first_sweep, plan_windows
from fuzzyfeed.machine.planner import Motion
from fuzzyfeed.machine.stream import BOX_BLOCK, StreamRun, TickPass, merge_windows, skip_threshold, tick_count, \
    tick_windows, warmup_ticks

#: Segments per plan window of the sweeps (at least; they end at move boundaries): a part holds
#: its tick windows' stretch and a window or more on each side.
WINDOW_SEGMENTS = 4096
#: Arc length (mm) a part's plan reaches beyond the ticks' own search windows (those reach
#: WINDOW_MARGIN_MM = 0.2 mm; the fast path's leap checks that far past a segment's end).
RANGE_MARGIN_MM = 1.0


@dataclass(frozen=True, eq=False)
class PlanRange(PlanWindow):
    """Segments ``first`` … ``first + n − 1`` of a chain's plan, for the tick pass: its arrays the
    whole plan's slices (``motion`` the chain's polyline there), ``t_start``/``s_start`` from the
    chain's start; :attr:`time_s` and :meth:`coordinate_max` the chain's (what the tick pass reads
    of the whole plan). Not for :meth:`Plan.sample` (its ticks start at the chain's)."""

    chain_time_s: float = 0.0
    chain_coordinate_max: float = 0.0

    @property
    def time_s(self) -> float:
        return self.chain_time_s

    def coordinate_max(self) -> float:
        return self.chain_coordinate_max


@dataclass(frozen=True)
class Sweep:
    """What the first sweep keeps (O(windows + segments asked for)): per plan window its first
    segment, start time and start arc length (one more entry: the chain's end), the start and end
    time of each segment asked for, and the plan's carries (:class:`~fuzzyfeed.machine.plan_windows.Carries`:
    the second sweep plans only the windows it needs)."""

    first: np.ndarray
    t0: np.ndarray
    s0: np.ndarray
    t_a: np.ndarray
    t_b: np.ndarray
    carries: Carries
    spans: tuple[tuple[int, int], ...] | None = None   # the tick windows, merged as the sweep went
    #                                                    (changed_sweep: no time kept per segment)

    @property
    def time_s(self) -> float:
        return float(self.t0[-1])

    def windows(self, machine: Machine) -> list[tuple[int, int]]:
        """The tick windows of the segments asked for (:func:`~fuzzyfeed.machine.stream.segment_windows`)."""
        if self.spans is not None:     # ticks k_a <= k_end always: only the ends can pass it
            k_end = tick_count(self, machine.ts_s)
            return [(a, min(b, k_end)) for a, b in self.spans]
        if self.t_a.size == 0:
            return []
        return tick_windows(self.t_a, self.t_b, tick_count(self, machine.ts_s), machine)


def sweep(motion: Motion, machine: Machine, segments: np.ndarray, size: int = WINDOW_SEGMENTS,
          feed_scale: float = 1.0) -> Sweep:
    """The first sweep (module docstring) for ``segments`` (sorted unique indices)."""
    seg = np.asarray(segments, dtype=np.int64)
    first, t0, s0 = [], [], []
    t_a, t_b = np.empty(seg.size), np.empty(seg.size)
    carries = first_sweep(motion, machine, size, feed_scale)
    for pw in plan_windows(motion, machine, size, feed_scale, carries=carries):
        first.append(pw.first)
        t0.append(float(pw.t_start[0]))
        s0.append(float(pw.s_start[0]))
        i0, i1 = np.searchsorted(seg, [pw.first, pw.stop])
        local = seg[i0:i1] - pw.first
        t_a[i0:i1] = pw.t_start[local]
        t_b[i0:i1] = pw.t_start[local + 1]
        end = pw
    first.append(end.stop)
    t0.append(float(end.t_start[-1]))
    s0.append(float(end.s_start[-1]))
    return Sweep(np.array(first, np.int64), np.array(t0), np.array(s0), t_a, t_b, carries)


def _groups(sw: Sweep, machine: Machine, spans: list[tuple[int, int]]) -> list[tuple[int, int, list]]:
    """Per part: the plan windows [w0, w1) it holds and its tick windows."""
    ts, warm, total = machine.ts_s, warmup_ticks(machine), sw.time_s
    n_win = sw.first.size - 1
    out: list[tuple[int, int, list]] = []
    for ka, kb in spans:
        t_from = min(max(ka - warm, 0) * ts, total)
        t_to = min(kb * ts, total)
        wa = int(np.searchsorted(sw.t0[:-1], t_from, side="right")) - 1
        wb = int(np.searchsorted(sw.t0[:-1], t_to, side="right")) - 1
        wa, wb = max(wa, 0), max(wb, 0)
        # a window more on each side, and as many as the arc length margin needs
        w0 = int(np.searchsorted(sw.s0[1:], sw.s0[wa] - RANGE_MARGIN_MM, side="left"))
        w0 = max(min(w0, wa - 1), 0)
        w1 = int(np.searchsorted(sw.s0[:-1], sw.s0[wb + 1] + RANGE_MARGIN_MM, side="right"))
        w1 = min(max(w1, wb + 2), n_win)
        if out and out[-1][0] <= w0 and w1 <= out[-1][1]:    # within the last part's plan: one part
            out[-1][2].append((ka, kb))
        else:
            out.append((w0, w1, [(ka, kb)]))
    return out


def plan_parts(motion: Motion, machine: Machine, sw: Sweep, spans: list[tuple[int, int]],
               size: int = WINDOW_SEGMENTS, feed_scale: float = 1.0) -> Iterator[tuple[PlanRange, list]]:
    """The second sweep: per part (in the order of the ticks) its :class:`PlanRange` and its tick
    windows ``spans`` (of the chain, from :func:`~fuzzyfeed.machine.stream.tick_windows` on
    ``sw``'s times), with the same ``size`` and ``feed_scale`` as :func:`sweep`."""
    yield from plan_groups(motion, machine, sw, _groups(sw, machine, spans), size, feed_scale)


def plan_groups(motion: Motion, machine: Machine, sw: Sweep, groups, size: int = WINDOW_SEGMENTS,
                feed_scale: float = 1.0) -> Iterator[tuple[PlanRange, object]]:
    """Per group ``(w0, w1, what)`` (plan windows [w0, w1), increasing) its :class:`PlanRange` and
    ``what``, the windows shared with the group before planned once."""
    if not groups:
        return
    # a motion read from a scratch file a slice at a time (program/chain_store.py) knows its own
    coord_max = getattr(motion, "coordinate_max", None)
    coord_max = float(np.abs(motion.points).max()) if coord_max is None else float(coord_max)
    kept: dict[int, PlanWindow] = {}          # the last part's windows the next one shares
    for w0, w1, sp in groups:
        kept = {w: pw for w, pw in kept.items() if w0 <= w < w1}
        todo = [w for w in range(w0, w1) if w not in kept]
        kept.update(zip(todo, plan_windows(motion, machine, size, feed_scale, carries=sw.carries, only=todo,
                                           starts=(sw.t0, sw.s0))))
        yield _range(motion, [kept[w] for w in range(w0, w1)], sw.time_s, coord_max), sp


def _range(motion: Motion, held: list[PlanWindow], time_s: float, coord_max: float) -> PlanRange:
    a, b = held[0].first, held[-1].stop
    cat = lambda name: np.concatenate([getattr(p, name) for p in held])  # noqa: E731
    edge = lambda name: np.concatenate([getattr(p, name)[:-1] for p in held] + [getattr(held[-1], name)[-1:]])  # noqa: E731
    sub = Motion(motion.points[a:b + 1], motion.feed_mm_s[a:b], motion.rapid[a:b], motion.arc_radius_mm[a:b + 1])
    return PlanRange(motion=sub, length=cat("length"), unit=cat("unit"), acc=cat("acc"), v_entry=cat("v_entry"),
                     v_peak=cat("v_peak"), v_exit=cat("v_exit"), t_acc=cat("t_acc"), t_cruise=cat("t_cruise"),
                     t_dec=cat("t_dec"), t_start=edge("t_start"), first=a, s_start=edge("s_start"),
                     chain_time_s=time_s, chain_coordinate_max=coord_max)


@dataclass(frozen=True, eq=False)
class PartsRun:
    """A chain's run over tick windows made part by part: the summaries (``stream``: its
    ``seg_max_mm`` empty, no plan) and per part its first segment and largest error per segment."""

    stream: StreamRun
    parts: tuple[tuple[int, np.ndarray], ...]

    def seg_max_mm(self, n: int) -> np.ndarray:
        """The largest error per segment of the chain (n,), as the whole plan's run gives it."""
        out = np.zeros(n)
        for first, m in self.parts:
            np.maximum(out[first:first + m.size], m, out=out[first:first + m.size])
        return out


def stream_parts(motion: Motion, machine: Machine, measured: np.ndarray, sw: Sweep, spans: list[tuple[int, int]],
                 keep_mm: float | None = None, fast: bool = True, size: int = WINDOW_SEGMENTS,
                 feed_scale: float = 1.0, part_summary=None) -> PartsRun:
    """The run of ``motion`` (every F times ``feed_scale``) over the tick windows ``spans``, part by
    part (:func:`plan_parts`), bit for bit :func:`~fuzzyfeed.machine.stream.stream_plan` on the
    whole plan with those windows (the fast path's re-run tick by tick included).
    ``part_summary(first, seg_max)``: what :attr:`PartsRun.parts` keeps of each part instead of its
    largest error per segment (a caller that needs a few figures of each: the parts of a long chain's
    hot stretches are not held; :meth:`PartsRun.seg_max_mm` is then not available)."""
    measured = measured if getattr(measured, "stored", False) else np.asarray(measured, dtype=bool)

    def once(skip: float) -> PartsRun:
        tp = TickPass(machine, keep_mm, True, BOX_BLOCK, skip, 1.0)
        parts = []
        for pr, sp in plan_parts(motion, machine, sw, spans, size, feed_scale):
            seg_max = tp.part(pr, pr.first, measured[pr.first:pr.stop], sp)
            parts.append((pr.first, seg_max) if part_summary is None else part_summary(pr.first, seg_max))
        return PartsRun(tp.result(None, np.zeros(0)), tuple(parts))

    run = once(skip_threshold(machine) if fast else 0.0)
    s = run.stream
    if fast and s.skipped_ticks and s.skip_max_mm >= s.max_mm:
        again = once(0.0)
        return PartsRun(replace(again.stream, rerun=True), again.parts)
    return run


def changed_sweep(motion: Motion, machine: Machine, profile: tuple[np.ndarray, ...], horizon_s: float,
                  size: int = WINDOW_SEGMENTS) -> tuple[Sweep, tuple[np.ndarray, np.ndarray]]:
    """The first sweep of ``motion``'s plan against ``profile`` — (v_entry, v_peak, v_exit, acc) of
    the chain's last plan, per segment — for the segments whose run may differ: those whose speed
    profile changed and, after each, those starting within ``horizon_s`` of its end (the servo's
    memory), as the limit reference's whole-plan comparison marks them. ``profile`` is overwritten
    window by window with the new plan's (it is the only copy kept). Returns the sweep (with the
    tick windows of those segments, merged window by window: :attr:`Sweep.spans`) and the runs
    [start, stop) of those segments: O(runs), nothing per segment redone (issue 36: a pass that
    redoes most of a long chain held 24–48 B a segment)."""
    v_entry, v_peak, v_exit, acc = profile
    first, t0, s0, starts, stops, spans = [], [], [], [], [], []
    carry = -np.inf
    ts, gap = machine.ts_s, warmup_ticks(machine)
    carries = first_sweep(motion, machine, size)
    for pw in plan_windows(motion, machine, size, carries=carries):
        sl = slice(pw.first, pw.stop)
        diff = ((v_entry[sl] != pw.v_entry) | (v_peak[sl] != pw.v_peak) | (v_exit[sl] != pw.v_exit)
                | (acc[sl] != pw.acc))
        # a changed segment j marks those after it starting at most t_start[j + 1] + horizon
        # (times increase: the last changed segment before a segment decides)
        cand = np.where(diff, pw.t_start[1:] + horizon_s, -np.inf)
        reach = np.maximum.accumulate(np.concatenate([[carry], cand]))
        redo = diff | (pw.t_start[:-1] <= reach[:-1])
        carry = float(reach[-1])
        local = np.flatnonzero(redo)
        if local.size:
            # runs of consecutive segments: each one tick window from its first segment's start to
            # its last one's end (tick_windows would merge them so: their windows touch)
            cut = np.flatnonzero(np.diff(local) > 1)
            a, b = local[np.concatenate([[0], cut + 1])], local[np.concatenate([cut, [local.size - 1]])]
            starts.append(pw.first + a)
            stops.append(pw.first + b + 1)
            merge_windows(np.floor(pw.t_start[a] / ts).astype(np.int64),
                          np.ceil(pw.t_start[b + 1] / ts).astype(np.int64), gap, spans)
        v_entry[sl], v_peak[sl], v_exit[sl], acc[sl] = pw.v_entry, pw.v_peak, pw.v_exit, pw.acc
        first.append(pw.first)
        t0.append(float(pw.t_start[0]))
        s0.append(float(pw.s_start[0]))
        end = pw
    first.append(end.stop)
    t0.append(float(end.t_start[-1]))
    s0.append(float(end.s_start[-1]))
    sw = Sweep(np.array(first, np.int64), np.array(t0), np.array(s0), np.zeros(0), np.zeros(0), carries,
               spans=tuple(spans))
    cat = (lambda parts: np.concatenate(parts) if parts else np.zeros(0, np.int64))
    return sw, (cat(starts), cat(stops))
