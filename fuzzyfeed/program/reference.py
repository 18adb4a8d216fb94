"""The two baselines advice is judged against (DESIGN §3, "Advice on a machine"), on the same
controller and servo model (:mod:`fuzzyfeed.program.run`):

- :func:`uniform_slowdown`: every F of the program times one factor c ≤ 1, the largest c whose run
  holds the contour tolerance — what a machinist does without any tool. A bisection on log c.
- :func:`limit_reference`: feeds lowered only where the simulated error passes the tolerance, on
  short pieces of the path, until none does: every feed move is cut into pieces of at most
  ``piece_mm``; after each run, every tick over the tolerance lowers the pieces the tool was
  commanded over during the servo's lookback window (and the piece it is nearest to) to a fraction
  of the speed it was commanded at there, √(tol/error) (the error grows about as v² on curves)
  times a margin. Slow to compute; the time any per-piece feed could approach.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.trace import MAX_TICKS
from fuzzyfeed.machine.planner import Motion
from fuzzyfeed.program.run import Chain, ChainRun, ProgramPath, ProgramRun, run_chain, run_program

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
    """The uniform slowdown: its factor and run; or, when the factor lies below what the tick
    budget lets us simulate, ``run`` None, ``factor`` the lowest factor tried (which breaks the
    tolerance) and ``time_s`` a lower bound: the plan's time at that factor."""

    factor: float
    run: ProgramRun | None
    runs: int          # simulations the search took
    time_s: float

    @property
    def bounded(self) -> bool:
        return self.run is None


def _planned_time(path: ProgramPath, machine: Machine, scale: float) -> float:
    """The run's time at ``scale`` without the servo (the planner alone, closed form)."""
    from fuzzyfeed.machine.planner import plan_motion

    return float(sum(plan_motion(Motion(c.motion.points, c.motion.feed_mm_s * scale, c.motion.rapid,
                                        c.motion.arc_radius_mm), machine).time_s for c in path.chains))


def uniform_slowdown(path: ProgramPath, machine: Machine, as_written: ProgramRun | None = None,
                     tol_um: float | None = None, max_ticks: float = MAX_TICKS) -> Uniform:
    """The largest factor c (to 1 %) with every F × c holding the tolerance (c = 1 when the program
    as written holds it). A factor whose run would pass ``max_ticks`` servo periods is not
    simulated: the result is then a bound (:class:`Uniform`)."""
    tol = machine.contour_tol_um if tol_um is None else tol_um
    first = as_written if as_written is not None else run_program(path, machine)
    if first.max_um <= tol:
        return Uniform(1.0, first, 1, first.time_s)
    hi, lo, lo_run = 1.0, None, None
    c = min(1.0, tol / first.max_um)          # the error grows at least linearly with the feed
    runs = 1
    while lo is None:
        # time grows as 1/c only where F is within the machine's reach: ask the planner first
        if first.time_s / c / machine.ts_s > max_ticks and _planned_time(path, machine, c) / machine.ts_s > max_ticks:
            return Uniform(hi, None, runs, _planned_time(path, machine, hi))
        r = run_program(path, machine, feed_scale=c)
        runs += 1
        if r.max_um <= tol:
            lo, lo_run = c, r
        else:
            hi = c
            c *= max(0.1, min(0.7, tol / r.max_um))
    while hi / lo > 1.0 + UNIFORM_RTOL:
        c = math.sqrt(lo * hi)
        r = run_program(path, machine, feed_scale=c)
        runs += 1
        if r.max_um <= tol:
            lo, lo_run = c, r
        else:
            hi = c
    return Uniform(lo, lo_run, runs, lo_run.time_s)


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


def limit_reference(path: ProgramPath, machine: Machine, piece_mm: float = 1.0,
                    tol_um: float | None = None, progress=None) -> Reference:
    """Feeds lowered piece by piece where the run breaks the tolerance (module docstring)."""
    tol = (machine.contour_tol_um if tol_um is None else tol_um) * 1e-3
    chains = tuple(refine_chain(c, piece_mm) for c in path.chains)
    refined = ProgramPath(program=path.program, chains=chains, chord_tol_mm=path.chord_tol_mm)
    feeds = [c.motion.feed_mm_s.copy() for c in chains]
    reachable = [_reachable_feed(c.motion, machine) for c in chains]
    runs: list[ChainRun] = [run_chain(c, machine) for c in chains]
    passes = 1
    while passes < REFERENCE_PASSES:
        changed = False
        for i, (chain, r) in enumerate(zip(chains, runs)):
            over = np.flatnonzero(r.contour_mm > tol)
            if over.size == 0:
                continue
            new = _lowered(feeds[i], chain.motion.rapid, r, over, tol, reachable[i])
            if not np.array_equal(new, feeds[i]):
                feeds[i] = new
                runs[i] = run_chain(chain, machine, new)
                changed = True
        passes += 1
        if progress is not None:
            progress(passes)
        if not changed:
            break
    final = ProgramRun(path=refined, machine=machine, runs=tuple(runs))
    return Reference(path=refined, feeds=tuple(feeds), run=final, passes=passes,
                     converged=final.max_um <= tol * 1e3 * (1 + 1e-9))


def _reachable_feed(motion: Motion, machine: Machine) -> np.ndarray:
    """Per segment the feed (mm/s) the machine can run: F, or less where the axes cannot reach F
    along the segment (the floor of :func:`_lowered` is a fraction of it)."""
    return np.minimum(motion.feed_mm_s, machine.speed_along(motion.points))


def _lowered(feed: np.ndarray, rapid: np.ndarray, r: ChainRun, over: np.ndarray, tol_mm: float,
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
