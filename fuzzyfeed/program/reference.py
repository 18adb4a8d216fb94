"""The limit reference (DESIGN §3, "Advice on a machine"), the second of the two baselines advice is
judged against (the first, the uniform slowdown: :mod:`fuzzyfeed.program.uniform`, whose names
this module still exports), on the same controller and servo model (:mod:`fuzzyfeed.program.run`):
feeds lowered only where the simulated error passes the tolerance, on short pieces of the path,
until none does: every feed move is cut into pieces of at most ``piece_mm``; after each run, every
tick over the tolerance lowers the pieces the tool was commanded over during the servo's lookback
window (and the piece it is nearest to) to a fraction of the speed it was commanded at there,
√(tol/error) (the error grows about as v² on curves) times a margin. Slow to compute; the time any
per-piece feed could approach.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine import plan_parts
from fuzzyfeed.machine.plan_parts import changed_sweep, stream_parts
from fuzzyfeed.machine.plan_windows import plan_windows
from fuzzyfeed.machine.planner import Motion, Plan
from fuzzyfeed.machine.stream import WARMUP_TIME_CONSTANTS
from fuzzyfeed.program import run as program_run
from fuzzyfeed.program.run import (ChainRun, ProgramPath, ProgramRun, chain_motion, run_chain, settle_p99,
                                  without_plan)
from fuzzyfeed.program.reference_state import Events, HeldState, Profile, StoredState, refine_chain  # noqa: F401
from fuzzyfeed.program.uniform import (HOT_MAX_TICKS, MAX_TICKS, NO_PROGRESS, UNIFORM_CHECKS,  # noqa: F401
                                       UNIFORM_RTOL, Uniform, _hot, _planned_time, check_uniform, uniform_slowdown)

#: A piece's new feed is this fraction of the √(tol/error) estimate (the estimate's own margin).
REFERENCE_MARGIN = 0.97
#: Passes of the limit reference before it gives up.
REFERENCE_PASSES = 40
#: The limit reference never lowers a piece below this fraction of its programmed feed.
REFERENCE_FLOOR = 0.01


@dataclass(frozen=True, eq=False)
class Reference:
    """The limit reference: the refined path its feeds apply to, per chain its feeds, the final
    run, the passes made. On a path in a scratch store (:class:`~fuzzyfeed.program.chain_store.StoredPath`)
    ``path`` is the refined path's store and ``feeds`` per chain a column read by slices
    (``feeds[i][a:b]``), valid until :meth:`close`; the run keeps no events."""

    path: ProgramPath          # the refined path the feeds apply to
    feeds: tuple[np.ndarray, ...]
    run: ProgramRun
    passes: int
    converged: bool
    held: object = None        # what holds path and feeds on the store (closed by close())

    def close(self) -> None:
        """The refined store's files closed and removed (on a stored path; else nothing)."""
        if self.held is not None:
            self.held.close()


def _changed(old: Plan | Profile, new: Plan, machine: Machine) -> np.ndarray:
    """Segments whose run may differ between two plans of the same path (bool per segment): those
    whose speed profile changed, and after each the ones commanded within a warm-up of the servo
    (its memory; :data:`~fuzzyfeed.machine.stream.WARMUP_TIME_CONSTANTS`). ``old``: a plan or its
    :class:`Profile`. On whole plans: the reference :func:`~fuzzyfeed.machine.plan_parts.changed_sweep`
    (what the passes use, window by window) is held to (tests/test_plan_parts.py)."""
    diff = ((old.v_entry != new.v_entry) | (old.v_peak != new.v_peak) | (old.v_exit != new.v_exit)
            | (old.acc != new.acc))
    out = diff.copy()
    idx = np.flatnonzero(diff)
    if idx.size == 0:
        return out
    horizon = WARMUP_TIME_CONSTANTS * machine.servo.time_constant_s
    # runs of changed segments: from each run's first segment to the one commanded a horizon
    # after the run's end
    starts = idx[np.concatenate([[True], np.diff(idx) > 1])]
    ends = idx[np.concatenate([np.diff(idx) > 1, [True]])]
    until = np.searchsorted(new.t_start, new.t_start[ends + 1] + horizon, side="right")
    n = diff.size
    mark = np.zeros(n + 1, np.int64)
    np.add.at(mark, starts, 1)
    np.add.at(mark, np.minimum(until, n), -1)
    return np.cumsum(mark[:-1]) > 0


def limit_reference(path: ProgramPath, machine: Machine, piece_mm: float = 1.0,
                    tol_um: float | None = None, progress=None, seg_sinks=None) -> Reference:
    """Feeds lowered piece by piece where the run breaks the tolerance (module docstring). Each
    pass re-runs only the stretches whose speed profile the new feeds changed (and the servo's
    memory after them); the result is one whole run on the final feeds, its p99 settled as
    :func:`~fuzzyfeed.program.run.run_program`'s (:func:`~fuzzyfeed.program.run.settle_p99`).

    Memory: a pass takes the chains one at a time: its events (the passes read the events only),
    its feeds and its plan's speed profile (:class:`Profile`, 32 B a segment); it lowers the feeds
    of the pieces the events point at (:func:`_lowered_at`, O(events)), plans the chain window by
    window against that profile (:func:`~fuzzyfeed.machine.plan_parts.changed_sweep`, overwriting
    it) and runs the stretches to redo part by part (:func:`~fuzzyfeed.machine.plan_parts.stream_parts`,
    keeping their events). The whole runs keep no plan (:func:`~fuzzyfeed.program.run.without_plan`;
    a long chain's made part by part: :func:`_whole_run`). ``path`` in memory: the refined chains,
    feeds, profiles and events held (:class:`~fuzzyfeed.program.reference_state.HeldState`, ~100 B
    a segment). ``path`` in a scratch store
    (:class:`~fuzzyfeed.program.chain_store.StoredPath`): the refined chains go to a store of their
    own beside it, the feeds and profiles to its columns and the events to scratch files
    (:class:`~fuzzyfeed.program.reference_state.StoredState`): a long chain is read and written a
    window at a time, a short one whole; the caller closes the result (:meth:`Reference.close`).
    ``seg_sinks``: where the whole runs' largest errors per segment go
    (:func:`~fuzzyfeed.program.run.run_program`'s; none held in memory)."""
    sink = (lambda _i: None) if seg_sinks is None else seg_sinks
    tol = (machine.contour_tol_um if tol_um is None else tol_um) * 1e-3
    if getattr(path, "store", None) is None:
        st = HeldState(path, piece_mm)
    else:
        st = StoredState(path, piece_mm)
    try:
        return _passes(st, machine, tol, progress, sink, seg_sinks)
    except BaseException:
        st.close()
        raise


def _passes(st, machine: Machine, tol: float, progress, sink, seg_sinks) -> Reference:
    """:func:`limit_reference`'s passes on the state ``st`` (in memory or stored:
    :mod:`fuzzyfeed.program.reference_state`)."""
    runs: list[ChainRun] = [_whole_run(st, i, machine, None, tol, sink(i)) for i in range(st.n)]
    touched = [False] * st.n
    horizon = WARMUP_TIME_CONSTANTS * machine.servo.time_constant_s
    passes = 1
    while passes < REFERENCE_PASSES:
        changed = False
        for i in range(st.n):
            ev = st.events(i)
            over = np.flatnonzero(ev.contour_mm > tol)
            if over.size == 0:
                continue
            chain = st.chain(i)
            at, old, new = _lowered_at(st.feeds_at(i), chain, ev, over, tol, machine)
            if np.array_equal(new, old):
                continue
            st.lower(i, at, new)
            motion = chain_motion(chain, st.feed(i))
            # the new plan window by window against the kept profile (overwritten with it): the
            # segments to run again (_changed's), then their stretches part by part
            size = plan_parts.WINDOW_SEGMENTS
            sw, redone = changed_sweep(motion, machine, st.profile(i).arrays(), horizon, size)
            r = stream_parts(motion, machine, chain.seg_measured, sw, sw.windows(machine), keep_mm=tol, size=size,
                             part_summary=_nothing)
            st.set_events(i, ev.splice(r.stream, redone))
            del r, sw, redone, motion, chain, ev
            touched[i] = changed = True
        passes += 1
        if progress is not None:
            progress(passes)
        if not changed:
            # a stretch's ticks fall at other instants once earlier feeds change (its max moves by
            # a fraction of a µm): the passes end on whole runs, as they began
            stale = [i for i, t in enumerate(touched) if t]
            for i in stale:
                runs[i] = _whole_run(st, i, machine, st.feed(i), tol, sink(i))
                touched[i] = False
            if not any((st.events(i).contour_mm > tol).any() for i in stale):
                break
    st.drop_events()
    for i, t in enumerate(touched):
        if t:
            runs[i] = st.kept(run_chain(st.chain(i), machine, st.feed(i), keep_mm=tol, keep_plan=False,
                                        seg_sink=sink(i)))
    final = settle_p99(st.path, machine, runs, st.feed, keep_mm=tol, keep_plans=False, seg_sinks=seg_sinks)
    final = ProgramRun(final.path, machine, tuple(st.kept(r) for r in final.runs))
    return Reference(path=st.path, feeds=st.feeds(), run=final, passes=passes,
                     converged=final.max_um <= tol * 1e3 * (1 + 1e-9), held=st.held())


def _nothing(_first: int, _seg_max: np.ndarray) -> None:
    """What a pass keeps of a re-run part's largest errors per segment: nothing (it reads the events)."""
    return None


def _whole_run(st, i: int, machine: Machine, feed, tol: float, seg_sink=None) -> ChainRun:
    """A whole run of chain i of the state ``st`` (its feeds, or ``feed``) for the passes: its
    events and its plan's speed profile go to ``st``; its rows without the plan returned. A chain
    of at least :data:`~fuzzyfeed.program.run.CARRIED_MIN_SEGMENTS` is run part by part
    (:func:`~fuzzyfeed.machine.chain_pass.stream_chain`) and its speed profile taken window by
    window (:func:`_window_profile`): the same floats, no whole plan held."""
    chain = st.chain(i)
    if chain.motion.n_segments < program_run.CARRIED_MIN_SEGMENTS:
        r = run_chain(chain, machine, feed, keep_mm=tol, seg_sink=seg_sink)
        st.set_profile(i, Profile.of(r.plan))
    else:
        r = run_chain(chain, machine, feed, keep_mm=tol, keep_plan=False, seg_sink=seg_sink)
        _window_profile(chain_motion(chain, feed), machine, st.profile(i, chain.motion.n_segments))
    st.set_events(i, Events.of(r.stream))
    return st.kept(without_plan(r))


def _window_profile(motion: Motion, machine: Machine, out: Profile) -> Profile:
    """The plan's speed profile (:class:`Profile`) made window by window into ``out``
    (:func:`~fuzzyfeed.machine.plan_windows.plan_windows`, bit for bit ``plan_motion``'s arrays; the
    passes' windows, :data:`~fuzzyfeed.machine.plan_parts.WINDOW_SEGMENTS`)."""
    for pw in plan_windows(motion, machine, plan_parts.WINDOW_SEGMENTS):
        sl = slice(pw.first, pw.stop)
        out.v_entry[sl], out.v_peak[sl], out.v_exit[sl], out.acc[sl] = pw.v_entry, pw.v_peak, pw.v_exit, pw.acc
    return out


def _at(column, at: np.ndarray) -> np.ndarray:
    """Items ``at`` of an array or of a stored column (read in slices)."""
    return column.gather(at) if getattr(column, "stored", False) else column[at]


def reachable_at(motion, at: np.ndarray, machine: Machine) -> np.ndarray:
    """Per segment ``at`` (sorted indices) of ``motion`` (in memory or stored) the feed (mm/s) the
    machine can run: F, or less where the axes cannot reach F along the segment (the floor of
    :func:`_lowered_at` is a fraction of it): :meth:`~fuzzyfeed.machine.description.Machine.speed_along`
    of each segment alone (its ends side by side), the same floats as along the whole polyline."""
    ends = np.empty((2 * at.size, 3))
    ends[0::2], ends[1::2] = _at(motion.points, at), _at(motion.points, at + 1)
    return np.minimum(_at(motion.feed_mm_s, at), machine.speed_along(ends)[0::2])


def _lowered_at(feeds_at, chain, r: Events, over: np.ndarray, tol_mm: float,
                machine: Machine) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pieces whose feed the events ``over`` (indices into ``r``) may lower, sorted, their
    feeds now (``feeds_at(at)``) and their new feeds: the pieces commanded during each offending tick's
    lookback window and the piece the tool is nearest to go down to the fraction
    √(tol/error)·margin of the speed commanded at that tick (never up, never below
    :data:`REFERENCE_FLOOR` of the feed the machine can run there: :func:`reachable_at` of the
    chain's own feeds). Every other piece keeps its feed (it is at least that floor)."""
    err = r.contour_mm[over]
    target = r.speed_mm_s[over] * np.sqrt(tol_mm / err) * REFERENCE_MARGIN
    # a tick at rest (speed 0) still over the tolerance: halve the feed around it
    target = np.where(target > 0, target, np.inf)
    lo_seg = np.minimum(r.lookback_segment[over], r.nearest_segment[over])
    hi_seg = np.maximum(r.tick_segment[over], r.nearest_segment[over])
    counts = hi_seg - lo_seg + 1
    seg = np.repeat(lo_seg, counts) + (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts))
    at, where_ = np.unique(seg, return_inverse=True)
    feed = feeds_at(at)
    rapid = _at(chain.motion.rapid, at)
    target_seg = np.repeat(target, counts)
    cap = np.full(at.size, np.inf)
    np.minimum.at(cap, where_, target_seg)
    halve = np.zeros(at.size, bool)
    halve[where_[np.isinf(target_seg)]] = True
    cap = np.where(halve, np.minimum(cap, 0.5 * feed), cap)
    lowered = np.minimum(feed, cap)
    # a piece whose feed is above the speed the planner gave it must come down by at least 5 %
    touched = np.isfinite(cap) & ~rapid
    lowered = np.where(touched, np.minimum(lowered, 0.95 * np.minimum(feed, cap / REFERENCE_MARGIN)), lowered)
    # never below 1 % of the program's feed: where even that does not hold, no feed does
    original = reachable_at(chain.motion, at, machine)
    return at, feed, np.where(rapid, feed, np.maximum(lowered, REFERENCE_FLOOR * original))
