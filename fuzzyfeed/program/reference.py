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
from fuzzyfeed.machine.plan_parts import PartsRun, changed_sweep, stream_parts
from fuzzyfeed.machine.plan_windows import plan_windows
from fuzzyfeed.machine.planner import Motion, Plan
from fuzzyfeed.machine.stream import WARMUP_TIME_CONSTANTS
from fuzzyfeed.program import run as program_run
from fuzzyfeed.program.run import (Chain, ChainRun, ProgramPath, ProgramRun, chain_motion, run_chain, settle_p99,
                                  without_plan)
from fuzzyfeed.program.uniform import (HOT_MAX_TICKS, MAX_TICKS, NO_PROGRESS, UNIFORM_CHECKS,  # noqa: F401
                                       UNIFORM_RTOL, Uniform, _hot, _planned_time, check_uniform, uniform_slowdown)

#: A piece's new feed is this fraction of the √(tol/error) estimate (the estimate's own margin).
REFERENCE_MARGIN = 0.97
#: Passes of the limit reference before it gives up.
REFERENCE_PASSES = 40
#: The limit reference never lowers a piece below this fraction of its programmed feed.
REFERENCE_FLOOR = 0.01


def refine_chain(chain: Chain, piece_mm: float) -> Chain:
    """``chain`` with every feed segment longer than ``piece_mm`` cut into equal pieces (straight
    junctions: the controller runs it the same way)."""
    m = chain.motion
    length = np.linalg.norm(np.diff(m.points, axis=0), axis=1)
    pieces = np.where(m.rapid, 1, np.maximum(1, np.ceil(length / piece_mm).astype(np.int64)))
    if (pieces == 1).all():
        return chain
    seg = np.repeat(np.arange(length.size), pieces)
    first = np.repeat(np.cumsum(pieces) - pieces, pieces)
    frac = (np.arange(seg.size) - first + 1) / pieces[seg]
    pts = m.points[seg] + (m.points[seg + 1] - m.points[seg]) * frac[:, None]
    is_end = frac == 1.0
    pts[is_end] = m.points[seg[is_end] + 1]
    points = np.vstack([m.points[:1], pts])
    radius = np.concatenate([m.arc_radius_mm[:1], np.where(is_end, m.arc_radius_mm[seg + 1], np.nan)])
    motion = Motion(points, m.feed_mm_s[seg], m.rapid[seg], radius)
    return Chain(motion, chain.seg_move[seg], chain.seg_measured[seg])


@dataclass(frozen=True, eq=False)
class Reference:
    path: ProgramPath          # the refined path the feeds apply to
    feeds: tuple[np.ndarray, ...]
    run: ProgramRun
    passes: int
    converged: bool


@dataclass(frozen=True, eq=False)
class _Profile:
    """What a pass compares of a chain's plan (~32 bytes a segment of its ~104): per segment the
    entry, peak and exit speed and the acceleration (the first plan's own arrays, no copy; each
    pass overwrites them with its plan's, window by window:
    :func:`~fuzzyfeed.machine.plan_parts.changed_sweep`)."""

    v_entry: np.ndarray
    v_peak: np.ndarray
    v_exit: np.ndarray
    acc: np.ndarray

    @classmethod
    def of(cls, plan: Plan) -> _Profile:
        return cls(plan.v_entry, plan.v_peak, plan.v_exit, plan.acc)


@dataclass
class _Measured:
    """What a pass of the limit reference needs of a chain's run, spliced from the stretches
    re-run: its plan's speed profile (:class:`_Profile`, not the plan) and the events (ticks over
    the tolerance; the passes lower the feeds from them, never from the largest error per segment)."""

    profile: _Profile
    contour_mm: np.ndarray
    speed_mm_s: np.ndarray
    tick_segment: np.ndarray
    nearest_segment: np.ndarray
    lookback_segment: np.ndarray

    @classmethod
    def of(cls, r: ChainRun, plan: Plan | _Profile) -> _Measured:
        s = r.stream
        return cls(plan if isinstance(plan, _Profile) else _Profile.of(plan), s.contour_mm, s.speed_mm_s,
                   s.tick_segment, s.nearest_segment, s.lookback_segment)

    def splice_parts(self, r: PartsRun, redone: np.ndarray) -> _Measured:
        """This run with the segments ``redone`` (bool per segment) taken from ``r``, a run of their
        stretches made part by part; the profile is already the new plan's
        (:func:`~fuzzyfeed.machine.plan_parts.changed_sweep` overwrote it)."""
        s = r.stream
        old = ~redone[self.tick_segment]
        new = redone[s.tick_segment]
        cat = lambda a, b: np.concatenate([a[old], b[new]])  # noqa: E731
        return _Measured(self.profile, cat(self.contour_mm, s.contour_mm), cat(self.speed_mm_s, s.speed_mm_s),
                         cat(self.tick_segment, s.tick_segment), cat(self.nearest_segment, s.nearest_segment),
                         cat(self.lookback_segment, s.lookback_segment))


def _changed(old: Plan | _Profile, new: Plan, machine: Machine) -> np.ndarray:
    """Segments whose run may differ between two plans of the same path (bool per segment): those
    whose speed profile changed, and after each the ones commanded within a warm-up of the servo
    (its memory; :data:`~fuzzyfeed.machine.stream.WARMUP_TIME_CONSTANTS`). ``old``: a plan or its
    :class:`_Profile`. On whole plans: the reference :func:`~fuzzyfeed.machine.plan_parts.changed_sweep`
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

    Memory: per chain its rows (the largest error per segment, the events; the passes read the
    events only), its feeds and its plan's speed profile (:class:`_Profile`, 32 B a segment); a
    pass plans the chain window by window against that profile
    (:func:`~fuzzyfeed.machine.plan_parts.changed_sweep`, overwriting it) and runs the stretches to
    redo part by part (:func:`~fuzzyfeed.machine.plan_parts.stream_parts`, keeping their events):
    no plan of a whole chain: 1 B a segment (which to redo), besides the feeds' own temporaries
    (:func:`_lowered`). The first and last runs are whole runs (no run keeps a plan:
    :func:`~fuzzyfeed.program.run.without_plan`; a long chain's made part by part: :func:`_whole_run`).
    ``path``'s chains may be in a scratch store (:class:`~fuzzyfeed.program.chain_store.StoredPath`):
    each is read whole (:func:`_in_memory`). ``seg_sinks``: where the whole runs' largest errors
    per segment go (:func:`~fuzzyfeed.program.run.run_program`'s; none held in memory)."""
    sink = (lambda _i: None) if seg_sinks is None else seg_sinks
    tol = (machine.contour_tol_um if tol_um is None else tol_um) * 1e-3
    chains = tuple(refine_chain(c, piece_mm) for c in _in_memory(path))
    refined = ProgramPath(program=path.program, chains=chains, chord_tol_mm=path.chord_tol_mm)
    feeds = [c.motion.feed_mm_s.copy() for c in chains]
    reachable = [_reachable_feed(c.motion, machine) for c in chains]
    state: list[_Measured] = []
    runs: list[ChainRun] = []        # each chain's last whole run: its rows, without plans
    for i, c in enumerate(chains):
        m, r = _whole_run(c, machine, None, tol, sink(i))
        state.append(m)
        runs.append(r)
        del m, r
    touched = [False] * len(chains)
    horizon = WARMUP_TIME_CONSTANTS * machine.servo.time_constant_s
    passes = 1
    while passes < REFERENCE_PASSES:
        changed = False
        for i, (chain, m) in enumerate(zip(chains, state)):
            over = np.flatnonzero(m.contour_mm > tol)
            if over.size == 0:
                continue
            new = _lowered(feeds[i], chain.motion.rapid, m, over, tol, reachable[i])
            if not np.array_equal(new, feeds[i]):
                feeds[i] = new
                motion = Motion(chain.motion.points, new, chain.motion.rapid, chain.motion.arc_radius_mm)
                # the new plan window by window against the kept profile (overwritten with it):
                # the segments to run again (_changed's), then their stretches part by part
                p = m.profile
                sw, seg = changed_sweep(motion, machine, (p.v_entry, p.v_peak, p.v_exit, p.acc), horizon)
                r = stream_parts(motion, machine, chain.seg_measured, sw, sw.windows(machine), keep_mm=tol,
                                 part_summary=_nothing)
                redo = np.zeros(motion.n_segments, bool)
                redo[seg] = True
                state[i] = m.splice_parts(r, redo)
                del r, m, sw, seg, redo
                touched[i] = changed = True
        passes += 1
        if progress is not None:
            progress(passes)
        if not changed:
            # a stretch's ticks fall at other instants once earlier feeds change (its max moves by
            # a fraction of a µm): the passes end on whole runs, as they began
            stale = [i for i, t in enumerate(touched) if t]
            for i in stale:
                state[i], runs[i] = _whole_run(chains[i], machine, feeds[i], tol, sink(i))
                touched[i] = False
            if not any((state[i].contour_mm > tol).any() for i in stale):
                break
    del state
    for i, t in enumerate(touched):
        if t:
            runs[i] = run_chain(chains[i], machine, feeds[i], keep_mm=tol, keep_plan=False, seg_sink=sink(i))
    final = settle_p99(refined, machine, runs, lambda i: feeds[i], keep_mm=tol, keep_plans=False, seg_sinks=seg_sinks)
    return Reference(path=refined, feeds=tuple(feeds), run=final, passes=passes,
                     converged=final.max_um <= tol * 1e3 * (1 + 1e-9))


def _nothing(_first: int, _seg_max: np.ndarray) -> None:
    """What a pass keeps of a re-run part's largest errors per segment: nothing (it reads the events)."""
    return None


def _in_memory(path: ProgramPath):
    """The chains of ``path``, each read whole into memory when it is in a scratch store
    (:class:`~fuzzyfeed.program.chain_store.StoredPath`: the passes hold every chain's feeds and
    speed profile anyway), one at a time as they are refined."""
    store = getattr(path, "store", None)
    if store is None:
        return iter(path.chains)
    return (store.chain(i, whole_below=store.n_segments + 1) for i in range(len(store.entries)))


def _whole_run(chain: Chain, machine: Machine, feed: np.ndarray | None, tol: float,
               seg_sink=None) -> tuple[_Measured, ChainRun]:
    """A whole run of ``chain`` (its feeds, or ``feed``) for the passes: what they measure and its
    rows without the plan. A chain of at least :data:`~fuzzyfeed.program.run.CARRIED_MIN_SEGMENTS`
    is run part by part (:func:`~fuzzyfeed.machine.chain_pass.stream_chain`) and its speed profile
    taken window by window (:func:`_window_profile`): the same floats, no whole plan held."""
    if chain.motion.n_segments < program_run.CARRIED_MIN_SEGMENTS:
        r = run_chain(chain, machine, feed, keep_mm=tol, seg_sink=seg_sink)
        return _Measured.of(r, r.plan), without_plan(r)
    r = run_chain(chain, machine, feed, keep_mm=tol, keep_plan=False, seg_sink=seg_sink)
    return _Measured.of(r, _window_profile(chain_motion(chain, feed), machine)), r


def _window_profile(motion: Motion, machine: Machine) -> _Profile:
    """The plan's speed profile (:class:`_Profile`) made window by window
    (:func:`~fuzzyfeed.machine.plan_windows.plan_windows`, bit for bit ``plan_motion``'s arrays)."""
    n = motion.n_segments
    out = _Profile(np.empty(n), np.empty(n), np.empty(n), np.empty(n))
    for pw in plan_windows(motion, machine):
        sl = slice(pw.first, pw.stop)
        out.v_entry[sl], out.v_peak[sl], out.v_exit[sl], out.acc[sl] = pw.v_entry, pw.v_peak, pw.v_exit, pw.acc
    return out


def _reachable_feed(motion: Motion, machine: Machine) -> np.ndarray:
    """Per segment the feed (mm/s) the machine can run: F, or less where the axes cannot reach F
    along the segment (the floor of :func:`_lowered` is a fraction of it)."""
    return np.minimum(motion.feed_mm_s, machine.speed_along(motion.points))


def _lowered(feed: np.ndarray, rapid: np.ndarray, r: _Measured | ChainRun, over: np.ndarray, tol_mm: float,
             original: np.ndarray) -> np.ndarray:
    """Per piece the new feed: the pieces commanded during each offending tick's lookback window
    and the piece the tool is nearest to go down to the fraction √(tol/error)·margin of the
    speed commanded at that tick (never up, never below :data:`REFERENCE_FLOOR` of the feed the
    machine can run there, ``original``)."""
    new = feed.copy()
    err = r.contour_mm[over]
    target = r.speed_mm_s[over] * np.sqrt(tol_mm / err) * REFERENCE_MARGIN
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
    lowered = np.where(touched, np.minimum(lowered, 0.95 * np.minimum(new, cap / REFERENCE_MARGIN)), lowered)
    # never below 1 % of the program's feed: where even that does not hold, no feed does
    return np.where(rapid, feed, np.maximum(lowered, REFERENCE_FLOOR * original))
