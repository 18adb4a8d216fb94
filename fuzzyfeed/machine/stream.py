"""A motion run on a machine tick by tick without keeping the ticks (issue 36, item 1).

:func:`stream_plan` runs the ticks of a :class:`~fuzzyfeed.machine.planner.Plan` through the
servo and the contour measure in one compiled pass (:mod:`fuzzyfeed.machine._ticks_jit`: the
operations of :func:`~fuzzyfeed.machine.trace.trace_motion`, the whole-array reference, tick by
tick), carrying the servo's state (its lag, through rapids) from tick to tick, and keeps only
summaries (:class:`StreamRun`): the largest contour error per commanded segment and where the
largest of all is, a fixed-resolution histogram (the p99), the largest error *in the air* (ticks
commanded on a feed move while the tool is still nearest a rapid it lags behind) apart from the
error *in the part*, and the ticks over a threshold merged into runs (what the limit reference and
the value plot need). Memory: O(segments) + a 64k-event buffer, never O(ticks).

**Search.** Each tick's nearest segment of its lookback window is found by blocks of
:data:`BOX_BLOCK` segments and their bounding boxes (:func:`segment_boxes`): a block farther than
the best distance so far is skipped, since |q − X| ≥ dist(q, box) for every point X of its
segments (:func:`fuzzyfeed.machine._ticks_jit.nearest_pruned`). The answer is the plain scan's bit
for bit (``block=0``; tests/test_tick_search.py).

**Windows.** ``windows`` runs only stretches of ticks [k_a, k_b]: each starts at rest
:data:`WARMUP_TIME_CONSTANTS` servo time constants earlier, so its error at k_a differs from the
whole run's by at most e^-16 ≈ 1e-7 of the largest lag (a first-order loop forgets its state as
e^(−Kv·t); a second-order one as e^(−ζωn·t), its envelope). This is what lets the uniform slowdown
and the limit reference re-run only the stretches around hot spots.

**Fast path** (``fast=True``, the default; issue 36 item 2). Most ticks of a program are far below
the tolerance; the search of their nearest segment is what costs. A measured tick whose window
holds no unmeasured segment gets a proven upper bound on its contour error first: its distance to
the last tick's nearest segment and the next few (the search's minimum runs over a set that holds
them: the same floats, so the bound holds bit for bit). Where it is at most ``skip_mm``
(:func:`skip_threshold`: 0.25 µm, or 2 % of the tolerance if smaller) the search is skipped and the
bound stands for the error: in the histogram (a bin at or above the tick's true bin, all within
``skip_mm``) and in ``seg_max_mm`` (the true maximum ≤ it ≤ the true maximum + ``skip_mm``); never
an event (the bound is ≤ ``keep_mm`` too). The servo is still stepped every tick (exact: the
state the next searched tick starts from is the tick pass's, for every loop — first or second
order, with feed-forward). The largest error and where are exact: they come from searched ticks,
and a run whose largest bound reaches its largest searched error is run again tick by tick
(``StreamRun.rerun``). ``fast=False`` is the tick pass, the reference the tests hold this one to.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cache

import numpy as np

from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.planner import Plan

#: A window's warm-up, in servo time constants (its error from starting at rest: ≤ e^-16 of the lag).
WARMUP_TIME_CONSTANTS = 16.0
#: Events (merged ticks over the threshold) held before they are handed to Python.
EVENT_CHUNK = 65_536
#: Segments per bounding box of the pruned nearest-segment search (:func:`segment_boxes`).
BOX_BLOCK = 8
#: The pruned search's rounding slack, mm per mm of the largest coordinate (distances are exact
#: to ~1e-16 of it; see :func:`fuzzyfeed.machine._ticks_jit.nearest_pruned`).
BOX_SLACK_PER_MM = 1e-9
#: The fast path skips a tick's search when its bound is at most this (µm) ... (low enough that
#: the p99 of engraving programs, often 0.3–1 µm, stays settled: :func:`percentile_settled`)
FAST_SKIP_UM = 0.25
#: ... and at most this fraction of the machine's contour tolerance.
FAST_SKIP_TOL_FRACTION = 0.02


@dataclass(frozen=True, eq=False)
class StreamRun:
    """Summaries of one run (all errors in mm): per commanded segment the largest error in the
    part (``seg_max_mm``, 0 where none was measured); the histogram (sparse bins of
    :func:`hist_edges`); the largest error in the part and in the air with where; the events
    (ticks over the threshold, merged while segment, lookback segment, nearest segment and 0.1 mm
    of path hold: the most demanding tick of each run, smallest speed/√error)."""

    plan: Plan | None            # None once a run keeps only its rows (program/run.py: without_plan)
    seg_max_mm: np.ndarray
    hist_bins: np.ndarray
    hist_counts: np.ndarray
    max_mm: float
    max_time_s: float
    max_segment: int
    max_xyz: np.ndarray
    air_max_mm: float
    air_time_s: float
    air_segment: int
    air_nearest: int
    air_xyz: np.ndarray
    tick_time_s: np.ndarray
    contour_mm: np.ndarray
    speed_mm_s: np.ndarray
    nearest_xyz: np.ndarray
    tick_segment: np.ndarray
    nearest_segment: np.ndarray
    lookback_segment: np.ndarray
    part_ticks: int = 0          # measured ticks in the part (in the histogram)
    skipped_ticks: int = 0       # of those, the fast path's (bounded, not searched)
    leapt_ticks: int = 0         # of those, counted by a leap (servo stepped, nothing measured)
    skip_mm: float = 0.0         # the fast path's threshold (0: the tick pass)
    skip_max_mm: float = 0.0     # the largest bound the fast path placed
    rerun: bool = False          # the fast path's run was made again tick by tick (its max was a bound's)


def skip_threshold(machine: Machine) -> float:
    """The fast path's threshold (mm): FAST_SKIP_UM, or FAST_SKIP_TOL_FRACTION of the tolerance
    if smaller (far below anything compared with the tolerance, within the 1 µm of issue 36)."""
    return min(FAST_SKIP_UM, FAST_SKIP_TOL_FRACTION * machine.contour_tol_um) * 1e-3


def percentile_settled(bins: np.ndarray, counts: np.ndarray, q: float, skip_mm: float) -> bool:
    """Whether the q-th percentile of a fast-path histogram is the tick pass's: the fast path moves
    ticks only among the bins up to ``skip_mm``'s (each at or above its true bin, at most that
    one), so the counts of every bin above it are the tick pass's; the percentile (both ranks
    :func:`percentile_um` reads) is settled when it falls in a bin above it, or when that bin is
    the first (nothing can have moved)."""
    n = int(counts.sum())
    if n == 0 or skip_mm <= 0.0:
        return True
    from fuzzyfeed.machine._ticks_jit import hist_bin

    top = hist_bin(skip_mm * 1e3)
    if top == 0:                                # a bound in the first bin: so is the true value
        return True
    rank = q / 100.0 * (n - 1)
    below = int(counts[bins <= top].sum())      # ticks at ranks 0 … below − 1 may have moved
    return int(np.floor(rank)) >= below


def hist_edges() -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper edge (µm) of every histogram bin of the tick loop."""
    from fuzzyfeed.machine import _ticks_jit as j

    i = np.arange(j.HIST_BINS, dtype=float)
    lin = i * j.HIST_STEP_UM
    log = j.HIST_LINEAR_UM * np.exp((i - 10_000) * np.log1p(j.HIST_LOG_STEP))
    lo = np.where(i < 10_000, lin, log)
    hi = np.append(lo[1:], np.inf)
    return lo, hi


def percentile_um(bins: np.ndarray, counts: np.ndarray, q: float) -> float:
    """The q-th percentile (numpy's linear rule) of the values a sparse histogram holds, each
    value taken at its bin's middle (within half a bin: 0.025 µm below 500 µm)."""
    n = int(counts.sum())
    if n == 0:
        return 0.0
    lo, hi = hist_edges()
    mid = np.where(np.isfinite(hi[bins]), 0.5 * (lo[bins] + hi[bins]), lo[bins])
    order = np.argsort(bins)
    cum = np.cumsum(counts[order])
    rank = q / 100.0 * (n - 1)
    i0, i1 = int(np.floor(rank)), int(np.ceil(rank))
    v0 = mid[order][np.searchsorted(cum, i0, side="right")]
    v1 = mid[order][np.searchsorted(cum, i1, side="right")]
    return float(v0 + (rank - i0) * (v1 - v0))


def servo_coefficients(machine: Machine) -> tuple[np.ndarray, np.ndarray]:
    """(b, a) of every axis's error filter (:meth:`ServoModel.error_filter`), padded to 3 taps."""
    fb = np.zeros((3, 3))
    fa = np.zeros((3, 3))
    for j in range(3):
        b, a = machine.servo.error_filter(j, machine.ts_s)
        if abs(b[0]) > 1e-12 * max(np.abs(b).max(), 1e-300):
            raise ValueError("servo filter: b0 != 0 (the error filter must be strictly proper)")
        fb[j, :b.size] = b
        fa[j, :a.size] = a
    return fb, fa


def leap_decay(fb: np.ndarray, fa: np.ndarray, ts_s: float) -> float:
    """A of e_k+1 = A·e_k + B·v_k+1 when every axis has the same first-order error filter (the
    fast path's leap, :func:`fuzzyfeed.machine._ticks_jit.run_ticks`), else 0 (no leap: a
    second-order loop, or axes with different loops, are bounded tick by tick)."""
    first = np.all(fa[:, 2] == 0.0) and np.all(fb[:, 2] == 0.0)
    same = np.all(fa == fa[0]) and np.all(fb == fb[0])
    if not (first and same) or fa[0, 0] == 0.0:
        return 0.0
    a = -fa[0, 1] / fa[0, 0]
    b = fb[0, 1] / fa[0, 0]
    return float(a) if 0.0 < a < 1.0 and 0.0 <= b <= ts_s else 0.0


@cache
def _kernel():
    from fuzzyfeed.machine._ticks_jit import run_ticks

    return run_ticks


def tick_count(plan: Plan, ts_s: float) -> int:
    """K: the ticks of a plan are t_k = min(k·Ts, T), k = 0 … K (as :meth:`Plan.sample`); ``plan``:
    anything with the plan's ``time_s``."""
    return int(np.ceil(plan.time_s / ts_s - 1e-9))


def lookback_ticks(machine: Machine) -> int:
    from fuzzyfeed.machine.trace import LOOKBACK_TIME_CONSTANTS

    return int(np.ceil(LOOKBACK_TIME_CONSTANTS * machine.servo.time_constant_s / machine.ts_s))


def warmup_ticks(machine: Machine) -> int:
    return max(int(np.ceil(WARMUP_TIME_CONSTANTS * machine.servo.time_constant_s / machine.ts_s)),
               lookback_ticks(machine) + 1)


def segment_windows(plan: Plan, machine: Machine, segments: np.ndarray) -> list[tuple[int, int]]:
    """Tick windows [k_a, k_b] that hold every tick commanded on ``segments`` (indices), merged
    where their warm-ups would overlap."""
    seg = np.unique(np.asarray(segments, dtype=np.int64))
    if seg.size == 0:
        return []
    return tick_windows(plan.t_start[seg], plan.t_start[seg + 1], tick_count(plan, machine.ts_s), machine)


def tick_windows(t_a: np.ndarray, t_b: np.ndarray, k_end: int, machine: Machine) -> list[tuple[int, int]]:
    """:func:`segment_windows` from the start and end times of the (sorted) segments and the
    plan's last tick ``k_end`` (:func:`tick_count`)."""
    ts = machine.ts_s
    ka = np.clip(np.floor(np.asarray(t_a) / ts).astype(np.int64), 0, k_end)
    kb = np.clip(np.ceil(np.asarray(t_b) / ts).astype(np.int64), 0, k_end)
    return merge_windows(ka, kb, warmup_ticks(machine), [])


def merge_windows(ka: np.ndarray, kb: np.ndarray, gap: int, out: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The tick windows [ka, kb] (in order) appended to ``out``, each merged into the last where
    its warm-up (``gap`` ticks) would overlap it; ``out``."""
    for a, b in zip(ka.tolist(), kb.tolist()):
        if out and a - gap <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out


def segment_boxes(points: np.ndarray, block: int) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned bounding box (lo, hi), each (⌈n/block⌉, 3), of every block of ``block``
    consecutive segments of the polyline ``points`` (n+1, 3): block b holds segments
    b·block … (b+1)·block − 1, i.e. vertices b·block … (b+1)·block."""
    pts = np.asarray(points, dtype=float)
    n = pts.shape[0] - 1
    nb = -(-n // block)
    starts = np.arange(nb) * block
    lo = np.minimum.reduceat(pts[:-1], starts, axis=0)
    hi = np.maximum.reduceat(pts[:-1], starts, axis=0)
    ends = np.minimum(starts + block, n)            # each block's last vertex
    return np.minimum(lo, pts[ends]), np.maximum(hi, pts[ends])


def stream_plan(plan: Plan, machine: Machine, measured: np.ndarray | None = None,
                keep_mm: float | None = None, windows: list[tuple[int, int]] | None = None,
                block: int = BOX_BLOCK, boxes: tuple[np.ndarray, np.ndarray] | None = None,
                fast: bool = True, skip_mm: float | None = None, bound_scale: float = 1.0) -> StreamRun:
    """Run ``plan`` on ``machine``'s servo tick by tick (module docstring): all ticks, or only
    ``windows``; the contour error measured at the ticks commanded on ``measured`` segments
    (default all); ticks over ``keep_mm`` (default the machine's tolerance) kept as events.

    The nearest segment is searched by blocks of ``block`` segments and their bounding boxes
    (:func:`segment_boxes`, or ``boxes`` given: the tests give wrong ones to see them caught);
    ``block=0`` scans every segment of each tick's window. Both give the same floats.

    ``fast`` (module docstring): ticks proven within ``skip_mm`` (default :func:`skip_threshold`)
    are not searched; ``fast=False`` searches every measured tick (the reference). ``bound_scale``
    multiplies the bound (1; the tests give less to see a wrong bound caught)."""
    if fast:
        skip = skip_threshold(machine) if skip_mm is None else float(skip_mm)
        if not (math.isfinite(skip) and skip >= 0.0):
            raise ValueError(f"skip_mm = {skip_mm!r}; must be a finite number >= 0")
        run = _stream(plan, machine, measured, keep_mm, windows, block, boxes, skip, bound_scale)
        if run.skipped_ticks and run.skip_max_mm >= run.max_mm:
            # the largest error might be a bounded tick's: its value and place need the search
            again = _stream(plan, machine, measured, keep_mm, windows, block, boxes, 0.0, 1.0)
            return replace(again, rerun=True)
        return run
    return _stream(plan, machine, measured, keep_mm, windows, block, boxes, 0.0, 1.0)


def _stream(plan, machine, measured, keep_mm, windows, block, boxes, skip_mm, bound_scale) -> StreamRun:
    ticks = TickPass(machine, keep_mm, windows is not None, block, skip_mm, bound_scale)
    spans = [(0, tick_count(plan, machine.ts_s))] if windows is None else windows
    seg_max = ticks.part(plan, 0, measured, spans, boxes)
    return ticks.result(plan, seg_max)


class TickPass:
    """One run's tick pass over *parts*: plans of stretches of one chain (the whole chain's plan, or
    :class:`~fuzzyfeed.machine.plan_windows.PlanRange` s: the same floats at the same segments), each
    with its tick windows, in the order of the ticks. The histogram, the maxima and counts, the
    fast path's last error and the events (segment indices of the chain) are shared as when one
    plan's windows are run one after the other: the parts of a chain give its run over those windows
    bit for bit."""

    def __init__(self, machine: Machine, keep_mm, windowed: bool, block: int, skip_mm: float, bound_scale: float):
        from fuzzyfeed.machine._ticks_jit import FSTATE_SIZE, HIST_BINS, ISTATE_SIZE

        self.machine, self.windowed, self.block = machine, windowed, int(block)
        self.skip_mm, self.bound_scale = float(skip_mm), float(bound_scale)
        self.keep = machine.contour_tol_um * 1e-3 if keep_mm is None else float(keep_mm)
        self.fb, self.fa = servo_coefficients(machine)
        self.hist = np.zeros(HIST_BINS, dtype=np.int64)
        self.leap = leap_decay(self.fb, self.fa, machine.ts_s) if skip_mm > 0.0 else 0.0
        self.fstate = np.zeros(FSTATE_SIZE)
        self.fstate[[0, 5]] = -1.0
        self.istate = np.full(ISTATE_SIZE, -1, dtype=np.int64)
        self.ev_f = np.zeros((EVENT_CHUNK, 6))
        self.ev_i = np.zeros((EVENT_CHUNK, 3), dtype=np.int64)
        self.parts_f, self.parts_i = [], []
        self.max_segment = self.air_segment = self.air_nearest = -1

    def part(self, plan, first: int, measured, spans, boxes=None) -> np.ndarray:
        """Run ``spans`` (tick windows of the chain) of ``plan`` (its segment 0 the chain's ``first``;
        ``measured`` per segment of it, default all); returns its largest error per segment."""
        from fuzzyfeed.machine._ticks_jit import I_EV_N, I_K0, I_LEAP, I_LEFT, I_NEAR, I_RIGHT, I_SEG
        from fuzzyfeed.machine.trace import WINDOW_MARGIN_MM

        machine, block, fstate, istate = self.machine, self.block, self.fstate, self.istate
        motion = plan.motion
        n = plan.length.size
        meas = np.ones(n, bool) if measured is None else np.ascontiguousarray(measured, dtype=bool)
        ts = machine.ts_s
        lookback = lookback_ticks(machine)
        # writable C float64 arrays (one compilation): the plan's own where they are (the kernel only reads
        # them; a copy of a 10⁶-segment plan is ~80 MB), copies of the others (the motion's read-only points)
        f64 = lambda a: np.require(a, dtype=np.float64, requirements=["C", "W"])  # noqa: E731
        arrays = (f64(motion.points), f64(plan.unit), f64(plan.length), f64(plan.segment_arc_start()),
                  f64(plan.t_start), f64(plan.v_entry), f64(plan.v_peak), f64(plan.acc), f64(plan.t_acc),
                  f64(plan.t_cruise), np.array(meas, dtype=np.bool_), self.fb, self.fa)
        if block > 0:
            box_lo, box_hi = segment_boxes(motion.points, block) if boxes is None else boxes
        else:
            box_lo = box_hi = np.zeros((1, 3))
        slack = BOX_SLACK_PER_MM * (1.0 + plan.coordinate_max())
        box_args = (f64(box_lo), f64(box_hi), block, slack)
        seg_max = np.zeros(n)
        unmeasured_cum = np.concatenate([[0], np.cumsum(~meas)]).astype(np.int64)
        run = _kernel()
        warm = warmup_ticks(machine)
        max_before, air_before = fstate[0], fstate[5]
        for ka, kb in spans:
            k_from = max(ka - warm, 0) if self.windowed else 0
            y_hist, x_hist, prev = np.zeros((3, 2)), np.zeros((3, 2)), np.zeros(3)
            s_ring = np.zeros(lookback + 1)
            seg_ring = np.zeros(lookback + 1, dtype=np.int64)
            istate[I_K0] = -1
            istate[I_EV_N] = 0
            istate[I_NEAR] = istate[I_RIGHT] = istate[I_LEFT] = istate[I_LEAP] = -1
            istate[I_SEG] = min(max(int(np.searchsorted(plan.t_start, min(k_from * ts, plan.time_s),
                                                         side="right")) - 1, 0), n - 1)
            k = k_from
            while k <= kb:
                k = run(*arrays, ts, plan.time_s, k, ka, kb, kb, lookback, WINDOW_MARGIN_MM, self.keep,
                        y_hist, x_hist, prev, s_ring, seg_ring, seg_max, self.hist, fstate, istate,
                        self.ev_f, self.ev_i, *box_args, unmeasured_cum, self.skip_mm, self.bound_scale,
                        self.leap)
                m = int(istate[I_EV_N])
                if m:
                    self.parts_f.append(self.ev_f[:m].copy())
                    self.parts_i.append(self.ev_i[:m] + first)
                    istate[I_EV_N] = 0
        if fstate[0] > max_before:                  # a new largest error in this part: where
            self.max_segment = first + int(istate[0])
        if fstate[5] > air_before:
            self.air_segment, self.air_nearest = first + int(istate[1]), first + int(istate[2])
        return seg_max

    def result(self, plan, seg_max) -> StreamRun:
        """The run's summaries (``seg_max``: the chain's, or its parts' as the caller keeps them)."""
        from fuzzyfeed.machine._ticks_jit import S_N_LEAP, S_N_PART, S_N_SKIP, S_SKIP_MAX

        fstate, hist = self.fstate, self.hist
        ef = np.concatenate(self.parts_f) if self.parts_f else np.zeros((0, 6))
        ei = np.concatenate(self.parts_i) if self.parts_i else np.zeros((0, 3), dtype=np.int64)
        bins = np.flatnonzero(hist)
        has_max, has_air = fstate[0] >= 0, fstate[5] >= 0
        return StreamRun(plan=plan, seg_max_mm=seg_max, hist_bins=bins, hist_counts=hist[bins],
                         max_mm=float(max(fstate[0], 0.0)), max_time_s=float(fstate[1]) if has_max else np.nan,
                         max_segment=self.max_segment if has_max else -1, max_xyz=fstate[2:5].copy(),
                         air_max_mm=float(max(fstate[5], 0.0)), air_time_s=float(fstate[6]) if has_air else np.nan,
                         air_segment=self.air_segment if has_air else -1,
                         air_nearest=self.air_nearest if has_air else -1,
                         air_xyz=fstate[7:10].copy(),
                         tick_time_s=ef[:, 0], contour_mm=ef[:, 1], speed_mm_s=ef[:, 2], nearest_xyz=ef[:, 3:6],
                         tick_segment=ei[:, 0], nearest_segment=ei[:, 1], lookback_segment=ei[:, 2],
                         part_ticks=int(fstate[S_N_PART]), skipped_ticks=int(fstate[S_N_SKIP]),
                         leapt_ticks=int(fstate[S_N_LEAP]), skip_mm=self.skip_mm,
                         skip_max_mm=float(fstate[S_SKIP_MAX]))
