"""A program run the way a controller runs it, then through the axis servo (DESIGN §3, "Advice on
a machine: is it worth having?").

:func:`program_path` turns a :class:`~fuzzyfeed.program.model.Program` into *chains*: runs of
moves the controller plans in one look-ahead, from rest to rest — rapids and feed moves (lines;
arcs and G5.2 blocks as chords within the machine's chord tolerance) whose positions follow on.
A chain ends where the tool stops or the position is not known: a move of unknown position (or
from an unknown start: its lag is not known either; the next chain starts from rest), a
canned cycle, a move in G93/G95 or with rotary axes, a stop code (M0/M1/M2/M6/M30/M60), a frame
change. Those moves are left out of the time. :func:`run_program` plans every chain
(:func:`fuzzyfeed.machine.planner.plan_motion`) and runs it tick by tick through the servo,
measuring the contour error of the ticks commanded on feed moves of cuts against the programmed
path (:func:`fuzzyfeed.machine.stream.stream_plan`, held to the whole-array reference
:func:`fuzzyfeed.machine.trace.trace_motion`); rapids are excluded. Nothing is kept per tick: a
run keeps summaries (largest error per segment, a histogram, the ticks over the tolerance).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.planner import Motion, Plan, plan_motion
from fuzzyfeed.machine.stream import StreamRun, percentile_settled, percentile_um, stream_plan
from fuzzyfeed.program.model import Program

#: The most servo periods one chain's run may simulate (CPU, not memory: the run keeps no ticks;
#: 100–300 ns a tick, so a minute or two).
MAX_STREAM_TICKS = 5e8
#: Segments from which a chain run without keeping its plan is planned and run part by part
#: (:func:`fuzzyfeed.machine.chain_pass.stream_chain`: bit for bit, O(part) of the plan held).
CARRIED_MIN_SEGMENTS = 1 << 17
#: Runs again with a lower fast-path threshold before every tick is searched, for an unsettled p99.
P99_RETRIES = 1


@dataclass(frozen=True, eq=False)
class Chain:
    """One look-ahead chain: the polyline the controller runs, and per segment the program move it
    belongs to and whether it is a feed move of a cut (its ticks count for the contour error)."""

    motion: Motion
    seg_move: np.ndarray
    seg_measured: np.ndarray


@dataclass(frozen=True, eq=False)
class ProgramPath:
    program: Program
    chains: tuple[Chain, ...]
    chord_tol_mm: float

    @property
    def n_segments(self) -> int:
        return sum(c.motion.n_segments for c in self.chains)


def program_path(program: Program, chord_tol_mm: float) -> ProgramPath:
    """The chains of ``program`` (see the module docstring), arcs as chords within ``chord_tol_mm``
    (built move by move by :class:`~fuzzyfeed.program.path_builder.PathBuilder`, which the windowed
    read shares)."""
    from fuzzyfeed.program.path_builder import PathBuilder

    chains: list[Chain] = []
    parts: list[tuple] = []

    def chunk(_program, _move0, pts, radius, feed, rapid, seg_move, measured) -> None:
        parts.append((pts, radius, feed, rapid, seg_move, measured))

    def close(has_segments: bool) -> None:
        if has_segments:
            pts, rad, f, r, sm, ms = (np.concatenate(c) for c in zip(*parts))
            chains.append(Chain(Motion(pts, f, r, rad), sm, ms))
        parts.clear()

    builder = PathBuilder(chord_tol_mm, chunk, close)
    builder.add(program)
    builder.finish()
    return ProgramPath(program=program, chains=tuple(chains), chord_tol_mm=chord_tol_mm)


@dataclass(frozen=True, eq=False)
class ChainRun:
    """One chain planned and run (:func:`~fuzzyfeed.machine.stream.stream_plan`): its plan, the
    run's summaries (``stream``) and, per tick over the tolerance in the part (merged into runs,
    see :class:`~fuzzyfeed.machine.stream.StreamRun`), the time, the contour error (mm), the move
    and segment commanded, the nearest segment and point of the path, the commanded speed and the
    segment commanded a lookback earlier."""

    plan: Plan | None             # None when the run was made without keeping it (``keep_plan``; its
    #                               stream's plan then dropped too: ~0.1 KB a segment)
    stream: StreamRun
    tick_move: np.ndarray
    time_s: float                  # the plan's time (kept when the plan is not)

    def __post_init__(self):
        if self.plan is None and self.stream.plan is not None:
            raise ValueError("a ChainRun without its plan holds none in its stream either "
                             "(build it with ChainRun.without_plan)")

    def without_plan(self) -> ChainRun:
        """This run without its plan (~0.1 KB a segment), neither its own nor its summaries' (the
        :class:`~fuzzyfeed.machine.stream.StreamRun` keeps the plan it ran): its rows and time
        only; ``self`` when it holds none."""
        if self.plan is None and self.stream.plan is None:
            return self
        return ChainRun(plan=None, stream=replace(self.stream, plan=None), tick_move=self.tick_move,
                        time_s=self.time_s)

    @property
    def tick_time_s(self) -> np.ndarray:
        return self.stream.tick_time_s

    @property
    def contour_mm(self) -> np.ndarray:
        return self.stream.contour_mm

    @property
    def tick_segment(self) -> np.ndarray:
        return self.stream.tick_segment

    @property
    def nearest_segment(self) -> np.ndarray:
        return self.stream.nearest_segment

    @property
    def nearest_xyz(self) -> np.ndarray:
        return self.stream.nearest_xyz

    @property
    def speed_mm_s(self) -> np.ndarray:
        return self.stream.speed_mm_s

    @property
    def lookback_segment(self) -> np.ndarray:
        return self.stream.lookback_segment

    @property
    def max_mm(self) -> float:
        return self.stream.max_mm


@dataclass(frozen=True, eq=False)
class ProgramRun:
    path: ProgramPath
    machine: Machine
    runs: tuple[ChainRun, ...]

    @property
    def time_s(self) -> float:
        """Time of every chain (rapids and feed moves), as the planner runs them."""
        return float(sum(r.time_s for r in self.runs))

    @property
    def max_um(self) -> float:
        """Largest contour error in the part (µm)."""
        return max((r.stream.max_mm for r in self.runs), default=0.0) * 1e3

    def _histogram(self) -> tuple[np.ndarray, np.ndarray]:
        if not self.runs:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        bins = np.concatenate([r.stream.hist_bins for r in self.runs])
        counts = np.concatenate([r.stream.hist_counts for r in self.runs])
        ub, inv = np.unique(bins, return_inverse=True)
        return ub, np.bincount(inv, weights=counts, minlength=ub.size).astype(np.int64)

    @property
    def p99_um(self) -> float:
        """99th percentile of the contour error in the part over every measured tick (µm, from the
        runs' histograms: within 0.025 µm below 500 µm)."""
        bins, counts = self._histogram()
        return percentile_um(bins, counts, 99.0) if bins.size else 0.0

    @property
    def p99_settled(self) -> bool:
        """Whether :attr:`p99_um` is the tick pass's although the fast path bounded some ticks
        (:func:`~fuzzyfeed.machine.stream.percentile_settled`; else it is at most their threshold
        above it)."""
        skip = max((r.stream.skip_mm for r in self.runs if r.stream.skipped_ticks), default=0.0)
        bins, counts = self._histogram()
        return percentile_settled(bins, counts, 99.0, skip)

    @property
    def air_max_um(self) -> float:
        """Largest error in the air (µm): ticks commanded on a feed move while the tool is still
        nearest a rapid it lags behind (no feed of the cut changes it)."""
        return max((r.stream.air_max_mm for r in self.runs), default=0.0) * 1e3

    def _where(self, attr: str, seg_attr: str, xyz_attr: str) -> tuple[int, np.ndarray] | None:
        best = None
        for chain, r in zip(self.path.chains, self.runs):
            v = getattr(r.stream, attr)
            seg = getattr(r.stream, seg_attr)
            if seg >= 0 and (best is None or v > best[0]):
                best = (v, int(chain.seg_move[seg]), getattr(r.stream, xyz_attr))
        if best is None:
            return None
        return int(self.path.program.move_line[best[1]]), best[2]

    def worst(self) -> tuple[int, np.ndarray] | None:
        """(program line, 0-based, of the move commanded then) and the point of the path nearest to
        the tool (mm) at the largest contour error in the part, or None."""
        return self._where("max_mm", "max_segment", "max_xyz")

    def worst_air(self) -> tuple[int, np.ndarray] | None:
        """As :meth:`worst`, for the largest error in the air (the point: on the rapid)."""
        return self._where("air_max_mm", "air_segment", "air_xyz")

    def cut_max_um(self) -> np.ndarray:
        """Largest contour error (µm) of every cut of the program (0 for a cut never measured)."""
        out = np.zeros(self.path.program.n_cuts)
        cut = self.path.program.cut
        for chain, r in zip(self.path.chains, self.runs):
            c = cut[chain.seg_move]
            ok = (c >= 0) & (r.stream.seg_max_mm > 0)
            np.maximum.at(out, c[ok], r.stream.seg_max_mm[ok] * 1e3)
        return out


def chain_motion(chain: Chain, feed_mm_s: np.ndarray | None = None) -> Motion:
    """The chain's motion, with ``feed_mm_s`` per segment instead of its own if given."""
    motion = chain.motion
    if feed_mm_s is not None and getattr(motion.points, "stored", False):   # a chain in a scratch store
        return replace(motion, feed_mm_s=feed_mm_s)
    if feed_mm_s is not None:
        motion = Motion(motion.points, feed_mm_s, motion.rapid, motion.arc_radius_mm)
    return motion


def run_chain(chain: Chain, machine: Machine, feed_mm_s: np.ndarray | None = None,
              windows: list[tuple[int, int]] | None = None, plan: Plan | None = None,
              keep_mm: float | None = None, keep_plan: bool = True, fast: bool = True,
              skip_mm: float | None = None, seg_sink=None) -> ChainRun:
    """Plan ``chain`` (with ``feed_mm_s`` per segment instead of its own, if given; or take
    ``plan``) and run it through the servo tick by tick (only the tick ``windows`` if given),
    measuring the contour error of its measured ticks; ticks over ``keep_mm`` (default the
    machine's tolerance) are kept as events. ``fast``, ``skip_mm``: the tick pass's fast path and its
    threshold (:func:`~fuzzyfeed.machine.stream.stream_plan`). A chain of at least
    :data:`CARRIED_MIN_SEGMENTS` run whole without keeping its plan is planned and run part by part
    (:func:`~fuzzyfeed.machine.chain_pass.stream_chain`, the same floats). ``seg_sink``: the run's
    largest error per segment written there (a long chain's as its parts finish with it; its
    ``seg_max_mm`` is then the sink, read by slices: :class:`~fuzzyfeed.base.spill.SpilledValues`)."""
    def budget(time_s: float) -> None:
        ticks = time_s / machine.ts_s
        if windows is None and not ticks <= MAX_STREAM_TICKS:
            raise InputError(f"a run of {time_s:.0f} s at Ts = {machine.ts_s:g} s is {ticks:.2g} servo "
                             f"periods; at most {MAX_STREAM_TICKS:.0e} are simulated (split the program, or "
                             "give a longer --ts-s)")

    if plan is None and windows is None and not keep_plan and chain.motion.n_segments >= CARRIED_MIN_SEGMENTS:
        # a long chain whose plan is not kept: planned and run part by part (bit for bit the same)
        from fuzzyfeed.machine.chain_pass import stream_chain

        sr, time_s = stream_chain(chain_motion(chain, feed_mm_s), machine, chain.seg_measured, keep_mm=keep_mm,
                                  fast=fast, skip_mm=skip_mm, before_ticks=budget, seg_sink=seg_sink)
        return ChainRun(plan=None, stream=sr, tick_move=chain.seg_move[sr.tick_segment], time_s=time_s)
    if plan is None:
        plan = plan_motion(chain_motion(chain, feed_mm_s), machine)
    budget(plan.time_s)
    sr = stream_plan(plan, machine, chain.seg_measured, keep_mm=keep_mm, windows=windows, fast=fast,
                     skip_mm=skip_mm)
    if seg_sink is not None:
        seg_sink.open()(sr.seg_max_mm)
        sr = replace(sr, seg_max_mm=seg_sink)
    run = ChainRun(plan=plan, stream=sr, tick_move=chain.seg_move[sr.tick_segment], time_s=float(plan.time_s))
    return run if keep_plan else run.without_plan()


def without_plan(run: ChainRun) -> ChainRun:
    """``run`` without its plan: :meth:`ChainRun.without_plan`."""
    return run.without_plan()


def run_program(path: ProgramPath, machine: Machine, feeds: list[np.ndarray] | None = None,
                feed_scale: float = 1.0, keep_plans: bool = True, fast: bool = True, seg_sinks=None) -> ProgramRun:
    """Run every chain of ``path`` on ``machine``: its own feeds times ``feed_scale``, or ``feeds``
    (one array per chain, mm/s per segment). ``keep_plans=False``: the chains' plans (~100 bytes a
    segment) are dropped once run, their times kept (a run only reported, not searched on).
    ``fast``: the tick pass's fast path; where its bounds leave the p99 unsettled
    (:attr:`ProgramRun.p99_settled`: a p99 within the fast path's threshold, ~1 µm), the chains
    with bounded ticks are run again with a quarter of that p99 as the threshold, then, if still
    unsettled, tick by tick. ``seg_sinks(i)``: where chain i's largest error per segment goes
    (:func:`run_chain`'s ``seg_sink``; none held in memory)."""
    if not (np.isfinite(feed_scale) and feed_scale > 0):
        raise InputError(f"feed_scale = {feed_scale!r}; must be finite and > 0")

    def feed(i: int) -> np.ndarray | None:
        if feeds is not None:
            return feeds[i]
        if feed_scale == 1.0:
            return None
        feed_mm_s = path.chains[i].motion.feed_mm_s
        return feed_mm_s.scaled(feed_scale) if getattr(feed_mm_s, "stored", False) else feed_mm_s * feed_scale

    sink = (lambda _i: None) if seg_sinks is None else seg_sinks
    runs = [run_chain(chain, machine, feed(i), keep_plan=keep_plans, fast=fast, seg_sink=sink(i))
            for i, chain in enumerate(path.chains)]
    return settle_p99(path, machine, runs, feed, keep_plans=keep_plans, fast=fast, seg_sinks=seg_sinks)


def settle_p99(path: ProgramPath, machine: Machine, runs: list[ChainRun], feed, keep_mm: float | None = None,
               keep_plans: bool = True, fast: bool = True, seg_sinks=None) -> ProgramRun:
    """The program run of the whole-chain ``runs`` of ``path`` (``feed(i)``: chain i's feeds, None
    for its own) with its p99 the tick pass's: where the fast path's bounds leave it unsettled
    (:attr:`ProgramRun.p99_settled`: a p99 within the fast path's threshold, ~1 µm), the chains with
    bounded ticks are run again with a quarter of that p99 as the threshold, then, if still
    unsettled (after :data:`P99_RETRIES`), tick by tick (:func:`run_program` and the limit
    reference's last run share it). ``keep_mm``: the events' threshold of the runs; ``seg_sinks``:
    :func:`run_program`'s."""
    runs = list(runs)
    out = ProgramRun(path=path, machine=machine, runs=tuple(runs))
    for attempt in range(P99_RETRIES + 1):
        if not fast or out.p99_settled:
            break
        skip = 0.25 * out.p99_um * 1e-3 if attempt < P99_RETRIES else 0.0
        for i, chain in enumerate(path.chains):
            if runs[i].stream.skipped_ticks:
                runs[i] = run_chain(chain, machine, feed(i), plan=runs[i].plan, keep_mm=keep_mm,
                                    keep_plan=keep_plans, fast=skip > 0.0, skip_mm=skip,
                                    seg_sink=None if seg_sinks is None else seg_sinks(i))
        out = ProgramRun(path=path, machine=machine, runs=tuple(runs))
    return out
