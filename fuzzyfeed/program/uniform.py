"""The uniform slowdown (DESIGN §3, "Advice on a machine"), the first of the two baselines advice is
judged against (the other, the limit reference: :mod:`fuzzyfeed.program.reference`), on the same
controller and servo model (:mod:`fuzzyfeed.program.run`): every F of the program times one factor
c ≤ 1, the largest c whose run holds the contour tolerance — what a machinist does without any
tool. A bisection on log c, trials on the stretches around the hot spots (time from the planner
alone), checked by whole runs (:func:`check_uniform`). Places no factor holds (the error at every
F × 0.01 still over the tolerance: a feed move entered from rapids) are set apart and listed
(:mod:`fuzzyfeed.program.apart`); the factor holds the rest.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.plan_parts import stream_parts, sweep
from fuzzyfeed.machine.plan_windows import planned_time
from fuzzyfeed.machine.stream import warmup_ticks
from fuzzyfeed.program.apart import Apart, describe, masked, no_places, run_max_um, set_apart
from fuzzyfeed.program.run import ProgramPath, ProgramRun, run_program

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
    return [np.flatnonzero(r.stream.seg_max_mm > tol_mm) if not getattr(r.stream.seg_max_mm, "stored", False)
            else np.concatenate([a + np.flatnonzero(b > tol_mm) for a, b in _blocks(r.stream.seg_max_mm)]
                                or [np.zeros(0, np.int64)])
            for r in run.runs]


#: Segments of a run's largest errors read at a time when they are kept out of memory.
HOT_BLOCK = 1 << 20


def _blocks(seg_max_mm):
    """(first, values) of a run's largest errors per segment kept out of memory
    (:class:`~fuzzyfeed.base.spill.SpilledValues`), :data:`HOT_BLOCK` at a time."""
    return seg_max_mm.blocks(HOT_BLOCK)


def _at_and_rest(seg_max_mm, hot: np.ndarray) -> tuple[np.ndarray, float]:
    """The errors of the ``hot`` segments (sorted) and the largest of the others (0 if none): of
    an array, or block by block of one kept out of memory."""
    if not getattr(seg_max_mm, "stored", False):
        return seg_max_mm[hot], float(masked(seg_max_mm, hot).max(initial=0.0))
    at, rest = [], 0.0
    for a, block in _blocks(seg_max_mm):
        here = hot[(hot >= a) & (hot < a + block.size)] - a
        at.append(block[here])
        rest = max(rest, float(masked(block, here).max(initial=0.0)))
    return (np.concatenate(at) if at else np.zeros(0)), rest


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
        at = [_at_and_rest(r.stream.seg_max_mm, h) for r, h in zip(first.runs, self.hot0)]
        self.hot0_mm = [e for e, _ in at]
        self.rest0_mm = max((rest for _, rest in at), default=0.0)
        self.first: ProgramRun | None = first     # dropped when the state is kept for later
        self.runs = 1
        self.checks_left = UNIFORM_CHECKS
        self.seg_sinks = None                # where a checking run's largest errors per segment go

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
            def summary(first: int, seg_max: np.ndarray, a=a) -> tuple[float, np.ndarray]:
                """A part's largest error (the places apart left out) and its segments over the tolerance
                (kept instead of its errors per segment: a long chain's hot stretches are not held)."""
                local = a[(a >= first) & (a < first + seg_max.size)] - first
                seg_max = masked(seg_max, local)
                return float(seg_max.max(initial=0.0)) * 1e3, first + np.flatnonzero(seg_max > self.tol_mm)
            r = stream_parts(chain.motion, machine, chain.seg_measured, sw, w, keep_mm=np.inf, feed_scale=scale,
                             part_summary=summary)
            over = []
            for part_max, part_over in r.parts:
                worst = max(worst, part_max)
                over.append(part_over)
            out.append(np.unique(np.concatenate(over)) if over else np.zeros(0, np.int64))
        return worst, out

    def copy(self) -> _Search:
        """A copy to go on from (a kept state is never changed: check_uniform twice gives the same)."""
        out = copy.copy(self)
        out.apart, out.floor, out.seen = list(self.apart), list(self.floor), list(self.seen)
        return out

    def set_apart(self, hot: list[np.ndarray]) -> bool:
        if self.path.program is None:      # a path in a scratch store (program/chain_store.py)
            from fuzzyfeed.program.windows import Fallback

            raise Fallback("places the uniform slowdown may set apart are measured on the whole read")
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
                  max_ticks: float | None = None, seg_sinks=None) -> Uniform:
    """``u`` (from :func:`uniform_slowdown` with ``check=False``) checked by a whole run, the search
    going on below should a place outside the hot stretches break it: what
    ``uniform_slowdown(..., check=True)`` returns. The search's path, machine, tolerance and tick
    budget are ``u``'s (``tol_um``, ``max_ticks``: others instead, if given). ``seg_sinks``: where
    the checking runs' largest errors per segment go (:func:`~fuzzyfeed.program.run.run_program`'s;
    on a stored path, so that nothing per segment of the program is held: issue 36)."""
    if u.checked:
        return u
    st = u.resume[0].copy()
    st.seg_sinks = seg_sinks
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
        run = run_program(st.path, st.machine, feed_scale=lo, keep_plans=False,   # rows and times only
                          seg_sinks=st.seg_sinks)
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

    def trial(c: float) -> float:
        """Run the whole program at F × c; c becomes lo if it holds the tolerance, else hi."""
        nonlocal lo, lo_run, lo_max, hi
        r = run_program(path, machine, feed_scale=c, keep_plans=False)
        st.runs += 1
        m = run_max_um(r, st.apart)
        if m <= tol:
            lo, lo_run, lo_max = c, r, m
        else:
            hi = c
        return m

    c = hi * min(1.0, tol / hi_max)
    while lo is None:
        m = trial(c)
        if lo is None:
            c *= max(0.1, min(0.7, tol / m))
    while hi / lo > 1.0 + UNIFORM_RTOL:
        trial(math.sqrt(lo * hi))
    return Uniform(lo, lo_run, st.runs, lo_run.time_s, lo_max, apart=st.places(lo_run))
