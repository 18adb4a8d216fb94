"""The two baselines advice is judged against (DESIGN §3, "Advice on a machine"), on the same
controller and servo model (:mod:`fuzzyfeed.program.run`):

- :func:`uniform_slowdown`: every F of the program times one factor c ≤ 1, the largest c whose run
  holds the contour tolerance — what a machinist does without any tool. A bisection on log c.
  Places no factor holds (the error at every F × 0.01 still over the tolerance: a feed move entered
  from rapids) are set apart and listed (:mod:`fuzzyfeed.program.apart`); the factor holds the rest.
- :func:`limit_reference`: feeds lowered only where the simulated error passes the tolerance, on
  short pieces of the path, until none does: every feed move is cut into pieces of at most
  ``piece_mm``; after each run, every tick over the tolerance lowers the pieces the tool was
  commanded over during the servo's lookback window (and the piece it is nearest to) to a fraction
  of the speed it was commanded at there, √(tol/error) (the error grows about as v² on curves)
  times a margin. Slow to compute; the time any per-piece feed could approach.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.plan_parts import PartsRun, changed_sweep, stream_parts, sweep
from fuzzyfeed.machine.plan_windows import planned_time
from fuzzyfeed.machine.planner import Motion, Plan
from fuzzyfeed.machine.stream import WARMUP_TIME_CONSTANTS, warmup_ticks
from fuzzyfeed.program.apart import Apart, describe, masked, no_places, run_max_um, set_apart
from fuzzyfeed.program.run import (Chain, ChainRun, ProgramPath, ProgramRun, run_chain, run_program, settle_p99,
                                  without_plan)

#: A uniform factor whose whole run passes this many servo periods is reported from its hot
#: stretches (time: the planner's) without the whole run.
MAX_TICKS = 2e8
#: The most servo periods the hot stretches of one uniform trial may hold (beyond, the factor is a
#: bound: the error does not come down with the feed there).
HOT_MAX_TICKS = 4e7
#: Whole runs checking a uniform factor found on the hot stretches, at most.
UNIFORM_CHECKS = 8
#: Without the check (``uniform_slowdown(check=False)``), a trial at half the factor or less whose
#: largest error is still above this fraction of the last one ends the search with a bound: the
#: error does not come down with the feed there (a rapid's lag), the bound is true (that factor
#: breaks the tolerance) if weaker than the one the search on ever longer stretches would reach.
NO_PROGRESS = 0.9
#: The uniform factor is searched to this relative step.
UNIFORM_RTOL = 0.01
#: A piece's new feed is this fraction of the √(tol/error) estimate (the estimate's own margin).
REFERENCE_MARGIN = 0.97
#: Passes of the limit reference before it gives up.
REFERENCE_PASSES = 40
#: The limit reference never lowers a piece below this fraction of its programmed feed.
REFERENCE_FLOOR = 0.01


@dataclass(frozen=True, eq=False)
class Uniform:
    """The uniform slowdown: its factor and run (``run`` None when the run at that factor would pass
    the tick budget: then ``time_s`` is the planner's time at the factor, exact, and ``max_um``
    the largest error of the stretches around the hot spots, where the tolerance is decided).
    ``apart``: the places no factor holds (:mod:`fuzzyfeed.program.apart`), left out of ``max_um``
    and of the search, listed with where and their error; the factor holds everywhere else."""

    factor: float
    run: ProgramRun | None
    runs: int          # trials the search took (whole runs and runs of the hot stretches)
    time_s: float
    max_um: float = float("nan")
    bounded: bool = False   # no factor found within the tick budget: ``factor`` the lowest tried
                            # (it breaks the tolerance), ``time_s`` the planner's time there
    checked: bool = True    # False: found on the hot stretches only, no whole run at the factor
                            # (``time_s`` the planner's, ``max_um`` the stretches'; check_uniform),
                            # or a bound the search stopped at early (NO_PROGRESS)
    resume: tuple | None = field(default=None, repr=False)   # the search's state, for check_uniform
    apart: tuple[Apart, ...] = ()


def _planned_time(path: ProgramPath, machine: Machine, scale: float) -> float:
    """The run's time at ``scale`` without the servo (the planner alone, closed form), each chain
    planned window by window (:func:`~fuzzyfeed.machine.plan_windows.planned_time`: bit for bit the
    whole plan's time, no chain's plan held)."""
    return float(sum(planned_time(c.motion, machine, feed_scale=scale) for c in path.chains))


def _hot(run: ProgramRun, tol_mm: float) -> list[np.ndarray]:
    return [np.flatnonzero(r.stream.seg_max_mm > tol_mm) for r in run.runs]


class _Search:
    """One uniform search's state: the tolerance and budgets, the places set apart so far (per
    chain, with their floor errors), what the program as written gave (its hot segments and their
    errors, the largest error elsewhere: where the search starts again once places are set apart),
    the trials made and the checking runs left."""

    def __init__(self, path: ProgramPath, machine: Machine, tol: float, max_ticks: float, first: ProgramRun):
        self.path, self.machine, self.tol, self.tol_mm, self.max_ticks = path, machine, tol, tol * 1e-3, max_ticks
        self.apart = no_places(path)
        self.floor = [np.zeros(0) for _ in path.chains]
        self.seen = no_places(path)          # segments whose floor error was measured
        self.hot0 = _hot(first, self.tol_mm)
        self.hot0_mm = [r.stream.seg_max_mm[h] for r, h in zip(first.runs, self.hot0)]
        self.rest0_mm = max((float(masked(r.stream.seg_max_mm, h).max(initial=0.0))
                             for r, h in zip(first.runs, self.hot0)), default=0.0)
        self.first: ProgramRun | None = first     # dropped when the state is kept for later
        self.runs = 1
        self.checks_left = UNIFORM_CHECKS

    def hot_trial(self, scale: float, hot: list[np.ndarray]) -> tuple[float, list[np.ndarray]] | None:
        """Largest error (µm) of the stretches around the ``hot`` segments (per chain) with every F ×
        ``scale``, the places apart left out, and the segments over the tolerance there; None when
        the stretches pass the tick budget. No chain's plan is held: its windows are swept for the
        hot segments' times, then the stretches are planned and run part by part
        (:mod:`fuzzyfeed.machine.plan_parts`, bit for bit the whole plan's windowed run)."""
        path, machine = self.path, self.machine
        sweeps, windows = [], []
        for chain, h in zip(path.chains, hot):
            if h.size == 0:
                sweeps.append(None)
                windows.append([])
                continue
            sw = sweep(chain.motion, machine, np.unique(h), feed_scale=scale)
            sweeps.append(sw)
            windows.append(sw.windows(machine))
        if sum(b - a + warmup_ticks(machine) for w in windows for a, b in w) > min(self.max_ticks, HOT_MAX_TICKS):
            return None
        worst, out = 0.0, []
        for chain, h, sw, w, a in zip(path.chains, hot, sweeps, windows, self.apart):
            if h.size == 0:
                out.append(h)
                continue
            r = stream_parts(chain.motion, machine, chain.seg_measured, sw, w, keep_mm=np.inf, feed_scale=scale)
            over = []
            for first, seg_max in r.parts:
                local = a[(a >= first) & (a < first + seg_max.size)] - first
                seg_max = masked(seg_max, local)
                worst = max(worst, float(seg_max.max(initial=0.0)) * 1e3)
                over.append(first + np.flatnonzero(seg_max > self.tol_mm))
            out.append(np.unique(np.concatenate(over)) if over else np.zeros(0, np.int64))
        return worst, out

    def copy(self) -> _Search:
        """A copy to go on from (a kept state is never changed: check_uniform twice gives the same)."""
        out = copy.copy(self)
        out.apart, out.floor, out.seen = list(self.apart), list(self.floor), list(self.seen)
        return out

    def set_apart(self, hot: list[np.ndarray]) -> bool:
        return set_apart(self.path, self.machine, hot, self.apart, self.floor, self.seen, self.tol_mm)

    def top(self) -> tuple[float, float, list[np.ndarray]]:
        """(1, the largest error as written outside the places apart (µm), the hot segments there)."""
        hot, mx = [], self.rest0_mm
        for h, e, a in zip(self.hot0, self.hot0_mm, self.apart):
            keep = ~np.isin(h, a)
            hot.append(h[keep])
            if keep.any():
                mx = max(mx, float(e[keep].max()))
        return 1.0, mx * 1e3, hot

    def places(self, run: ProgramRun | None = None) -> tuple[Apart, ...]:
        return describe(self.path, self.apart, self.floor, run)

    def planned(self, scale: float) -> float:
        return _planned_time(self.path, self.machine, scale)


def uniform_slowdown(path: ProgramPath, machine: Machine, as_written: ProgramRun | None = None,
                     tol_um: float | None = None, max_ticks: float = MAX_TICKS, check: bool = True) -> Uniform:
    """The largest factor c (to 1 %) with every F × c holding the tolerance (c = 1 when the program
    as written holds it) outside the places no factor holds. Each trial runs only the stretches
    around the segments over the tolerance at the last factor that broke it (the error of a place
    grows with the feed: those that held there hold below it;
    :func:`~fuzzyfeed.machine.stream.segment_windows`); the time is the planner's. When the error
    does not come down with the feed (a trial at half the factor or less still at
    :data:`NO_PROGRESS` of the last, or hot stretches past the tick budget: a rapid's lag at a
    plunge) the segments over the tolerance are measured with every F × 0.01
    (:func:`~fuzzyfeed.program.apart.set_apart`); those still over it are set apart
    (:attr:`Uniform.apart`) and the search starts again from the program as written without them.
    With ``check`` the factor found is checked by one whole run (if within ``max_ticks`` servo
    periods); should a place outside the hot stretches break it, the search goes on below (after
    :data:`UNIFORM_CHECKS` such misses, on whole runs). Without ``check`` the factor of the hot
    stretches is returned unchecked (:attr:`Uniform.checked` False, no run: the checking run is the
    longest of all, 1/c times the program's time; :func:`check_uniform` does it later), and a trial
    whose error does not come down with the feed and sets nothing apart ends the search with a bound.
    Where the search really runs out (hot stretches past the budget, nothing set apart) the result
    is a bound (:attr:`Uniform.bounded`)."""
    tol = machine.contour_tol_um if tol_um is None else tol_um
    first = as_written if as_written is not None else run_program(path, machine)
    if first.max_um <= tol:
        return Uniform(1.0, first, 1, first.time_s, first.max_um)
    st = _Search(path, machine, tol, max_ticks, first)
    if UNIFORM_CHECKS <= 0:
        return _whole_search(st, 1.0, first.max_um)
    return _search(st, 1.0, first.max_um, st.hot0, check)


def check_uniform(path: ProgramPath, machine: Machine, u: Uniform, tol_um: float | None = None,
                  max_ticks: float | None = None) -> Uniform:
    """``u`` (from :func:`uniform_slowdown` with ``check=False``) checked by a whole run, the search
    going on below should a place outside the hot stretches break it: what
    ``uniform_slowdown(..., check=True)`` returns. The search's path, machine, tolerance and tick
    budget are ``u``'s (``tol_um``, ``max_ticks``: others instead, if given)."""
    if u.checked:
        return u
    st = u.resume[0].copy()
    if tol_um is not None:
        st.tol, st.tol_mm = tol_um, tol_um * 1e-3
    if max_ticks is not None:
        st.max_ticks = max_ticks
    if u.bounded:           # a bound the search stopped at early: the search goes on
        _, hi, hi_max, hot, c = u.resume
        return _search(st, hi, hi_max, hot, True, c)
    return _verify(st, u.factor, u.max_um)


def _kept(st: _Search) -> _Search:
    st.first = None          # the run as written is not kept with a result left for later
    return st


def _verify(st: _Search, lo: float, lo_max: float) -> Uniform:
    """One whole run at ``lo`` (a factor the hot stretches hold); the search below it if it breaks."""
    st.checks_left -= 1
    time_s = st.planned(lo)
    if time_s / st.machine.ts_s > st.max_ticks:
        return Uniform(lo, None, st.runs, time_s, lo_max, apart=st.places())
    if lo == 1.0 and st.first is not None:
        run = st.first
    else:
        run = run_program(st.path, st.machine, feed_scale=lo, keep_plans=False)  # rows and times only
        st.runs += 1
    mx = run_max_um(run, st.apart)
    if mx <= st.tol:
        return Uniform(lo, run, st.runs, run.time_s, mx, apart=st.places(run))
    if st.checks_left <= 0:  # the hot stretches kept missing a place (not monotone there): whole runs
        return _whole_search(st, lo, mx)
    # a place the hot stretches missed: the search goes on below
    hot = [np.setdiff1d(h, a) for h, a in zip(_hot(run, st.tol_mm), st.apart)]
    return _search(st, lo, mx, hot, True)


def _search(st: _Search, hi: float, hi_max: float, hot: list[np.ndarray], check: bool, c=None) -> Uniform:
    """The hot-stretch search below ``hi`` (whose max was ``hi_max`` µm, ``hot`` its segments over
    the tolerance per chain) from the factor ``c``, then :func:`_verify` with ``check``."""
    tol = st.tol
    lo, lo_max = None, 0.0
    while lo is None:
        if hi_max <= tol:      # started again: the program as written holds outside the places apart
            lo, lo_max = hi, hi_max
            break
        if c is None:
            c = min(hi, hi * tol / hi_max)          # the error grows at least linearly with the feed
        trial = st.hot_trial(c, hot)
        if trial is None:      # the stretches pass the budget: places no factor holds, or a bound
            if st.set_apart(hot):
                hi, hi_max, hot = st.top()
                c = None
                continue
            return Uniform(hi, None, st.runs, st.planned(hi), bounded=True, apart=st.places())
        m, h = trial
        st.runs += 1
        if m <= tol:
            lo, lo_max = c, m
            break
        c_next = c * max(0.1, min(0.7, tol / m))
        stuck = c <= 0.5 * hi and m >= NO_PROGRESS * hi_max
        if stuck and st.set_apart(h):
            hi, hi_max, hot = st.top()
            c = None
            continue
        if stuck and not check:
            return Uniform(c, None, st.runs, st.planned(c), bounded=True, checked=False,
                           resume=(_kept(st), c, m, h, c_next), apart=st.places())
        hi, hi_max, hot, c = c, m, h, c_next
    while hi / lo > 1.0 + UNIFORM_RTOL:
        c = math.sqrt(lo * hi)
        trial = st.hot_trial(c, hot)
        if trial is None:
            return Uniform(lo, None, st.runs, st.planned(lo), lo_max, apart=st.places())
        m, h = trial
        st.runs += 1
        if m <= tol:
            lo, lo_max = c, m
        else:
            hi, hot = c, h
    if not check:
        return Uniform(lo, None, st.runs, st.planned(lo), lo_max, checked=False, resume=(_kept(st),),
                       apart=st.places())
    return _verify(st, lo, lo_max)


def _whole_search(st: _Search, hi: float, hi_max: float) -> Uniform:
    """The uniform search below ``hi`` (whose run's max was ``hi_max`` µm) on whole runs only (the
    places already set apart left out)."""
    path, machine, tol = st.path, st.machine, st.tol
    lo, lo_run, lo_max = None, None, 0.0
    c = hi * min(1.0, tol / hi_max)
    while lo is None:
        r = run_program(path, machine, feed_scale=c, keep_plans=False)
        st.runs += 1
        m = run_max_um(r, st.apart)
        if m <= tol:
            lo, lo_run, lo_max = c, r, m
        else:
            hi = c
            c *= max(0.1, min(0.7, tol / m))
    while hi / lo > 1.0 + UNIFORM_RTOL:
        c = math.sqrt(lo * hi)
        r = run_program(path, machine, feed_scale=c, keep_plans=False)
        st.runs += 1
        m = run_max_um(r, st.apart)
        if m <= tol:
            lo, lo_run, lo_max = c, r, m
        else:
            hi = c
    return Uniform(lo, lo_run, st.runs, lo_run.time_s, lo_max, apart=st.places(lo_run))


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
    re-run: its plan's speed profile (:class:`_Profile`, not the plan), the largest error per
    segment and the events (ticks over the tolerance)."""

    profile: _Profile
    seg_max_mm: np.ndarray
    contour_mm: np.ndarray
    speed_mm_s: np.ndarray
    tick_segment: np.ndarray
    nearest_segment: np.ndarray
    lookback_segment: np.ndarray

    @classmethod
    def of(cls, r: ChainRun, plan: Plan) -> _Measured:
        s = r.stream
        return cls(_Profile.of(plan), s.seg_max_mm, s.contour_mm, s.speed_mm_s, s.tick_segment,
                   s.nearest_segment, s.lookback_segment)

    def splice_parts(self, r: PartsRun, redone: np.ndarray) -> _Measured:
        """This run with the segments ``redone`` (bool per segment) taken from ``r``, a run of their
        stretches made part by part; the profile is already the new plan's
        (:func:`~fuzzyfeed.machine.plan_parts.changed_sweep` overwrote it)."""
        s = r.stream
        old = ~redone[self.tick_segment]
        new = redone[s.tick_segment]
        cat = lambda a, b: np.concatenate([a[old], b[new]])  # noqa: E731
        return _Measured(self.profile, np.where(redone, r.seg_max_mm(redone.size), self.seg_max_mm),
                         cat(self.contour_mm, s.contour_mm), cat(self.speed_mm_s, s.speed_mm_s),
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
                    tol_um: float | None = None, progress=None) -> Reference:
    """Feeds lowered piece by piece where the run breaks the tolerance (module docstring). Each
    pass re-runs only the stretches whose speed profile the new feeds changed (and the servo's
    memory after them); the result is one whole run on the final feeds, its p99 settled as
    :func:`~fuzzyfeed.program.run.run_program`'s (:func:`~fuzzyfeed.program.run.settle_p99`).

    Memory: per chain its rows (the largest error per segment, the events), its feeds and its
    plan's speed profile (:class:`_Profile`, 32 B a segment); a pass plans the chain window by
    window against that profile (:func:`~fuzzyfeed.machine.plan_parts.changed_sweep`, overwriting
    it) and runs the stretches to redo part by part (:func:`~fuzzyfeed.machine.plan_parts.stream_parts`):
    no plan of a whole chain: 1 B a segment (which to redo) and, while splicing, the new largest
    error per segment (8 B), besides the feeds' own temporaries (:func:`_lowered`). The
    first and last runs are whole runs (no run keeps a plan: :func:`~fuzzyfeed.program.run.without_plan`)."""
    tol = (machine.contour_tol_um if tol_um is None else tol_um) * 1e-3
    chains = tuple(refine_chain(c, piece_mm) for c in path.chains)
    refined = ProgramPath(program=path.program, chains=chains, chord_tol_mm=path.chord_tol_mm)
    feeds = [c.motion.feed_mm_s.copy() for c in chains]
    reachable = [_reachable_feed(c.motion, machine) for c in chains]
    state: list[_Measured] = []
    runs: list[ChainRun] = []        # each chain's last whole run: its rows, without plans
    for c in chains:
        r = run_chain(c, machine, keep_mm=tol)
        state.append(_Measured.of(r, r.plan))
        runs.append(without_plan(r))
        del r
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
                r = stream_parts(motion, machine, chain.seg_measured, sw, sw.windows(machine), keep_mm=tol)
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
                r = run_chain(chains[i], machine, feeds[i], keep_mm=tol)
                state[i] = _Measured.of(r, r.plan)
                runs[i] = without_plan(r)
                touched[i] = False
                del r
            if not any((state[i].contour_mm > tol).any() for i in stale):
                break
    del state
    for i, t in enumerate(touched):
        if t:
            runs[i] = run_chain(chains[i], machine, feeds[i], keep_mm=tol, keep_plan=False)
    final = settle_p99(refined, machine, runs, lambda i: feeds[i], keep_mm=tol, keep_plans=False)
    return Reference(path=refined, feeds=tuple(feeds), run=final, passes=passes,
                     converged=final.max_um <= tol * 1e3 * (1 + 1e-9))


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
