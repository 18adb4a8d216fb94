"""The timed trajectory of the SLW scheduler: one row per servo period, and its measurement.

:func:`schedule` runs preprocessing → sliding look-ahead window → sampling of the jerk-limited profile at
t_k = k·Ts → :func:`fuzzyfeed.geometry.interpolate.interpolate_u` ("best": chord-exact, second-order Taylor
step + Newton on s(u)). The last tick lands exactly on the path's end (terminal-error compensation,
seed 000): the profile reaches rest at t_end and the tick at ⌈t_end/Ts⌉·Ts is put on the end point.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from fuzzyfeed.base.cache import per_curve
from fuzzyfeed.base.checks import expect
from fuzzyfeed.errors import InputError
from fuzzyfeed.machine.limits import AXES, MachineLimits
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.geometry.polyline_fit import PolylineFit, fit_polyline
from fuzzyfeed.machine.profile import FeedProfile
from fuzzyfeed.geometry.sampling import PathSamples
from fuzzyfeed.machine.simulate import Simulation, TimeLaw, simulate
from fuzzyfeed.slw.lookahead import KINK_MIN, LookaheadStats, ScheduledBlock, SlidingWindow
from fuzzyfeed.slw.feed_cap import FeedCap, lower, stairs
from fuzzyfeed.slw.check import breach_error, checked_positions
from fuzzyfeed.slw.preprocess import corner_plan, iter_blocks, joins, machine_cap
from fuzzyfeed.slw.phase_ticks import MAX_TICKS  # the one limit on servo periods (≈ 14 h at 1 ms)
from fuzzyfeed.slw.profile import SEVEN_PHASE, TRANSITIONS, segment_table, segments_state
from fuzzyfeed.slw.resume import Recorder, resume


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Servo-period samples of a scheduled path (K + 1 rows; units mm, s).

    ``t_s`` times k·Ts; ``s_mm`` scheduled arc length; ``u`` curve parameters from the interpolator;
    ``xyz`` (K+1, 3) positions; ``feed_mm_s``, ``acc_mm_s2``, ``jerk_mm_s3`` the scheduled
    tangential feed, acceleration and jerk. ``blocks`` are the released blocks (their junctions
    are the critical points), ``stats`` the look-ahead counters.
    """

    curve: Nurbs
    limits: MachineLimits
    t_s: np.ndarray
    s_mm: np.ndarray
    u: np.ndarray
    xyz: np.ndarray
    feed_mm_s: np.ndarray
    acc_mm_s2: np.ndarray
    jerk_mm_s3: np.ndarray
    blocks: tuple[ScheduledBlock, ...] = field(repr=False)
    stats: LookaheadStats = field(repr=False)
    critical_s_mm: np.ndarray = field(repr=False, default=None)  # type: ignore[assignment]
    polyline_fit: PolylineFit | None = field(repr=False, default=None)
    #: How the planner chose (``planner="optimal"``): why the window's schedule was kept (the LP
    #: refused, failed or was not faster), or the window's time beside the LP's; "" for the window alone.
    planner_note: str = field(repr=False, default="")

    @property
    def cycle_time_s(self) -> float:
        return float(self.t_s[-1])

    @property
    def n_blocks(self) -> int:
        return len(self.blocks)

    @property
    def n_critical(self) -> int:
        return int(self.critical_s_mm.size)

    def columns(self) -> dict[str, np.ndarray]:
        """CSV columns, units in the names."""
        return {"t_s": self.t_s, "u": self.u, "x_mm": self.xyz[:, 0], "y_mm": self.xyz[:, 1],
                "z_mm": self.xyz[:, 2], "s_mm": self.s_mm, "feed_mm_s": self.feed_mm_s,
                "feed_mm_min": self.feed_mm_s * 60.0, "acc_mm_s2": self.acc_mm_s2,
                "jerk_mm_s3": self.jerk_mm_s3}

    def time_law(self) -> TimeLaw:
        """The schedule as the simulator's time law (arc length, feed, acceleration, jerk per tick)."""
        return TimeLaw(ts_s=self.limits.ts_s, s_mm=self.s_mm, feed_mm_s=self.feed_mm_s,
                       acc_mm_s2=self.acc_mm_s2, jerk_mm_s3=self.jerk_mm_s3,
                       duration_s=self.cycle_time_s)

    def simulate(self, method: str = "slw", bound_time_s: float | None = None, servo=None) -> Simulation:
        """The trajectory through the one simulator (:func:`fuzzyfeed.machine.simulate.simulate`) on the
        path it follows, with its own interpolated parameters."""
        return simulate(self.curve, self.time_law(), self.limits, method, bound_time_s=bound_time_s,
                        servo=servo, u=self.u, xyz=self.xyz)

    def feed_at(self, samples: PathSamples) -> FeedProfile:
        """The scheduled feed at the sampling layer's points (method "slw"), interpolated in s
        (the samples' arc lengths scaled to the followed path's length)."""
        s, idx = np.unique(self.s_mm, return_index=True)
        v = np.maximum.reduceat(self.feed_mm_s, idx) if s.size < self.s_mm.size else self.feed_mm_s
        feed = np.interp(self._scaled(samples.s), s, v)
        return FeedProfile(samples, feed, "slw", self.limits.feed_mm_s)

    def time_at(self, s_mm: np.ndarray) -> np.ndarray:
        """Scheduled time (s) at which the input path's arc lengths ``s_mm`` (increasing, from 0
        to its end) are passed; scaled to the followed path's length like :meth:`feed_at`."""
        return np.interp(self._scaled(s_mm), self.s_mm, self.t_s)

    def _scaled(self, s_mm) -> np.ndarray:
        """Arc lengths over the whole input path (last = its end) scaled to the followed path."""
        s_mm = np.asarray(s_mm, dtype=float)
        return s_mm * (self.s_mm[-1] / s_mm[-1]) if s_mm[-1] > 0 else s_mm


def _feed_cap(feed_cap, total: float) -> FeedCap | None:
    if feed_cap is None:
        return None
    if isinstance(feed_cap, FeedCap):  # given on the input path: rescaled to the followed one
        return feed_cap if feed_cap.length_mm == total else FeedCap(feed_cap.s_mm, feed_cap.feed_mm_s, total)
    if isinstance(feed_cap, FeedProfile):
        return FeedCap(np.asarray(feed_cap.samples.s), feed_cap.feed_mm_s, total)
    try:
        s, v = feed_cap
    except (TypeError, ValueError):
        raise InputError(f"feed_cap: {type(feed_cap).__name__}; give a FeedProfile or (s_mm, feed_mm_s)") from None
    return FeedCap(s, v, total)


#: Ticks sampled together (a bounded working set: a chunk's segment numbers, 11 floats a tick).
STATE_CHUNK = 1 << 16


def _sample_profile(blocks: list[ScheduledBlock], ts: float, total: float):
    """s, v, a, j at t_k = k·Ts for the concatenated block segments (seed 000, eq. (17)-(19))."""
    segs = [seg for b in blocks for seg in b.segments if seg.duration_s > 0.0]
    durations = np.array([seg.duration_s for seg in segs])
    starts_t = np.concatenate([[0.0], np.cumsum(durations)])
    starts_s = np.concatenate([[0.0], np.cumsum([seg.length_mm for seg in segs])])
    t_end = float(starts_t[-1])
    if not np.isfinite(t_end) or t_end / ts > MAX_TICKS:
        raise InputError(f"the schedule needs {t_end:.4g} s = {t_end / ts:.4g} servo periods (more than "
                         f"{MAX_TICKS:.0e}); the path has a near-stationary point or the limits are "
                         "too small for its length")
    k_last = max(int(np.ceil(t_end / ts - 1e-9)), 1)
    t = np.arange(k_last + 1) * ts
    s = np.empty(t.size)
    v = np.zeros(t.size)
    a = np.zeros(t.size)
    j = np.zeros(t.size)
    which = np.clip(np.searchsorted(starts_t, t, side="right") - 1, 0, max(len(segs) - 1, 0))
    table = segment_table(segs)
    for lo in range(0, t.size if segs else 0, STATE_CHUNK):
        # the ticks a chunk at a time, each the floats of segment_state on its own segment
        m = slice(lo, lo + STATE_CHUNK)
        at = which[m]
        tau = np.minimum(t[m] - starts_t[at], durations[at])
        pos, v[m], a[m], j[m] = segments_state(segs, table, at, tau)
        s[m] = pos + starts_s[at]
    after = t >= t_end
    s[after], v[after], a[after], j[after] = total, 0.0, 0.0, 0.0
    s[0] = 0.0
    s = np.minimum(np.maximum.accumulate(s * (total / starts_s[-1] if starts_s[-1] > 0 else 1.0)), total)
    s[-1] = total
    return t, s, v, a, j


#: Schedules again with the feed lowered around a tick over a limit at most this many times.
TICK_REPAIRS = 4
#: A repair's pass resumes the last one's look-ahead where the lowered cap starts to matter
#: (slw/resume.py: the same blocks as a whole pass); False schedules the whole path again.
RESUME = True


def _dip(cap: FeedCap | None, found: tuple[str, int, float], s: np.ndarray, v: np.ndarray,
         limits: MachineLimits, total: float) -> FeedCap:
    """``cap`` lowered over the ticks k-2 … k+2 around a breach at tick k (ratio r) to the lowest
    feed there times 0.999/r: the axis accelerations the look-ahead checks are the profile's at
    every point, the machine's the positions' second differences over Ts, which a sharp
    curvature peak passes by 0.1 % (a random curve at 100.08 % of A_y)."""
    _, k, r = found
    lo, hi = max(k - 2, 0), min(k + 3, s.size - 1)
    s0, s1 = float(s[lo]), float(s[hi])
    if s1 <= s0:
        s1 = min(s0 + 1e-6 * total, total)
    level = max(float(v[lo:hi + 1].min()) * 0.999 / r, 1e-6 * limits.feed_mm_s)
    pts = np.array([0.0, s0, s0, s1, s1, total])
    vals = np.array([limits.feed_mm_s, limits.feed_mm_s, level, level, limits.feed_mm_s, limits.feed_mm_s])
    if s0 <= 0.0:
        pts, vals = pts[2:], vals[2:]
    if s1 >= total:
        pts, vals = pts[:-2], vals[:-2]
    dip = FeedCap(pts, vals, total)
    return dip if cap is None else lower(cap, dip)


def _faster_optimal(window: Trajectory, cap: FeedCap | None, bar: bool = False) -> Trajectory:
    """The whole-path LP's schedule on the window's followed path (slw/optimal_schedule.py) if it
    passes the tick check and is faster than ``window``; else ``window`` (also when the LP fails,
    exceeds its node budget or breaks a limit after its repairs). ``bar``: a tqdm.auto bar over the
    path's length as the LP's pieces are planned."""
    from fuzzyfeed.slw.optimal_pieces import refused_on_length
    from fuzzyfeed.slw.optimal_schedule import schedule_optimal

    curve, limits = window.curve, window.limits
    why = refused_on_length(float(curve.length))
    if why:  # before the path's joins are read
        return replace(window, planner_note=f"the LP refused {why}")
    s_j, _, _, jump = joins(curve)
    kinks = s_j[jump.max(axis=1, initial=0.0) > KINK_MIN] if s_j.size else s_j
    kinks_u = np.atleast_1d(curve.param_at_length(kinks)) if kinks.size else kinks
    progress, shown = None, None
    if bar:
        from tqdm.auto import tqdm

        shown = tqdm(total=round(curve.length, 3), unit="mm", desc="whole-path LP", leave=False,
                     bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} mm")

        def progress(s_mm: float) -> None:
            shown.update(round(s_mm, 3) - shown.n)
    try:
        *ticks, critical = schedule_optimal(curve, limits, cap, kinks_u, _dip, TICK_REPAIRS, progress)
    except InputError as exc:
        return replace(window, planner_note=f"the LP kept no schedule: {exc}")
    finally:
        if shown is not None:
            shown.close()
    if ticks[0][-1] >= window.cycle_time_s:
        return replace(window, planner_note=f"the LP's {ticks[0][-1]:.4f} s was not faster")
    return Trajectory(curve, limits, *ticks, (), LookaheadStats(), critical, window.polyline_fit,
                      f"the look-ahead window's {window.cycle_time_s:.4f} s was slower")


def check_work(total_mm: float, limits: MachineLimits) -> None:
    """Refuse, before any work, a schedule of more than MAX_TICKS servo periods even at the command
    feed (the fastest the path can be run: L / (F·Ts) is a lower bound on the ticks)."""
    ticks = total_mm / (limits.feed_mm_s * limits.ts_s)
    if not ticks <= MAX_TICKS:
        raise InputError(f"the path of {total_mm:.6g} mm at feed {limits.feed_mm_min:g} mm/min and servo "
                         f"period {limits.ts_s:g} s needs at least {ticks:.4g} servo periods (more than "
                         f"{MAX_TICKS:.0e}); raise --feed-mm-min or --ts-s")


def schedule(curve: Nurbs, limits: MachineLimits | None = None,
             progress: Callable[[float], None] | None = None, approach: int = 2,
             feed_cap=None, blend: bool = True, path_tolerance_mm: float | None = None,
             transition: str = SEVEN_PHASE, planner: str = "optimal") -> Trajectory:
    """Schedule ``curve`` under ``limits``, jerk-limited, within every machine limit at every servo
    tick → :class:`Trajectory`.

    ``planner``: ``"optimal"`` (default) runs the sliding look-ahead window of seed 000 with these
    options and the whole-path jerk-limited LP (:mod:`fuzzyfeed.slw.optimal`, in bounded pieces:
    :mod:`fuzzyfeed.slw.optimal_pieces`; ticks by :mod:`fuzzyfeed.slw.phase_ticks`, checked and
    repaired tick by tick as the window is: :mod:`fuzzyfeed.slw.optimal_schedule`) and keeps the
    faster — the window's when the LP fails, passes its work budget (over 40 000 grid nodes, its
    pieces' overlaps counted: any path over ~10 m, and shorter dense ones) or keeps a limit broken
    after its repairs; ``Trajectory.planner_note`` says which.
    ``"window"``: the window alone (with ``transition="cosine"`` and ``approach=1``, seed 000's
    scheduler as published).

    ``approach`` selects seed 000's Table 1 profile for short blocks (types 2-3): 2 (default)
    rises to a peak between the two transitions (Table 1, figure (d)); 1, the paper's choice,
    cruises at the higher end feed (smoother, slower on paths of short blocks).

    ``transition`` is the shape of the window's feed changes: ``"seven-phase"`` (default; the
    trapezoidal-acceleration ramp, jerk J all through its ramps: 2.7 % faster than the cosine at
    the median of bench_slw's window cases, slower on 11 of its 282, up to 6.4 %) or ``"cosine"``
    (seed 000's, eq. (16)-(21)).

    ``feed_cap`` (optional) is one more pointwise feed limit in mm/s: a :class:`FeedProfile`
    (its samples' arc lengths and feeds), a pair ``(s_mm, feed_mm_s)`` or a :class:`FeedCap`;
    linear in s between its points. The result is the jerk-limited schedule under
    min(cap, machine): every machine limit still holds. Approach 2 follows the machine's own
    limit in a staircase too (:func:`fuzzyfeed.slw.feed_cap.stairs`); approach 1 follows it as
    seed 000 does.

    A polyline (degree 1) is followed as a blending controller follows it (``blend``, default):
    smooth within the path tolerance P (``path_tolerance_mm``, default G64 P0.01) between its true
    corners, which are passed within one servo period (:func:`fuzzyfeed.geometry.polyline_fit.fit_polyline`);
    ``blend=False`` takes every vertex as a corner. The fit is ``Trajectory.polyline_fit``.

    ``progress``, if given, is called with the arc length scheduled so far (mm) after each block of
    the window; ``progress=True`` shows a tqdm.auto bar over the path's length instead (a terminal
    or a notebook widget), and a second one as the LP's pieces are planned.
    """
    expect(curve, Nurbs, "curve", "a Nurbs")
    limits = MachineLimits.default() if limits is None else limits
    if not isinstance(limits, MachineLimits):
        raise InputError(f"limits: {type(limits).__name__}; expected MachineLimits")
    total = curve.length
    if total <= 0.0 or not np.isfinite(total):
        raise InputError(f"path length {total!r} mm; a path to schedule must have a positive length")
    if approach not in (1, 2):
        raise InputError(f"approach = {approach!r}; use 1 or 2 (seed 000, Table 1)")
    if transition not in TRANSITIONS:
        raise InputError(f"transition = {transition!r}; use one of {', '.join(TRANSITIONS)}")
    if planner not in ("window", "optimal"):
        raise InputError(f"planner = {planner!r}; use 'window' or 'optimal'")
    check_work(total, limits)
    fit = None
    if blend and curve.degree == 1:
        # cached without its source: a value holding its own key would keep the curve alive
        kept = per_curve(curve, ("polyline fit", path_tolerance_mm),
                         lambda: replace(fit_polyline(curve, path_tolerance_mm), source=None))
        fit = replace(kept, source=curve)
        curve, total = fit.curve, fit.curve.length
    cap = _feed_cap(feed_cap, total)
    if planner == "optimal":  # the window's schedule first: the fallback and the one to beat
        window = schedule(curve if fit is None else fit.source, limits, progress, approach, feed_cap, blend,
                          path_tolerance_mm, transition, planner="window")
        return _faster_optimal(window, cap, bar=progress is True)
    acc, jerk = limits.tangential_acc_mm_s2, limits.jerk_mm_s3
    # corners closer together than a stair step needs are a cap, not critical points
    dense = corner_plan(curve, limits)[2]
    if dense is not None:
        cap = dense if cap is None else lower(cap, dense)
    if cap is not None:  # followed in stairs planned once, not repaired crossing by crossing
        cap = stairs(cap, limits.feed_mm_s, acc, jerk)
    if approach == 2:  # and so is the machine's own limit, but near the bottom of its dips
        machine = per_curve(curve, ("machine stairs", limits), lambda: stairs(
            machine_cap(curve, limits), limits.feed_mm_s, acc, jerk, machine=True))
        cap = machine if cap is None else lower(cap, machine)
    bar = None
    if progress is True:
        from tqdm.auto import tqdm

        bar = tqdm(total=round(total, 3), unit="mm", desc="scheduling", leave=False,
                   bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} mm")
        done = [0.0]

        def progress(s_mm: float) -> None:
            bar.update(round(s_mm - done[0], 3))
            done[0] = round(s_mm, 3)
    s_j, _, _, jump = joins(curve)
    kinks = s_j[jump.max(axis=1, initial=0.0) > KINK_MIN] if s_j.size else s_j
    kinks_u = np.atleast_1d(curve.param_at_length(kinks)) if kinks.size else kinks
    previous = None   # the last pass's blocks and window states (slw/resume.py)
    for attempt in range(TICK_REPAIRS + 1):
        window = SlidingWindow(limits, curve, approach, cap, transition)
        if previous is None or not RESUME:
            source, blocks = Recorder(iter_blocks(curve, limits, cap=cap)), []
        else:   # a tick repair: the pass resumed where its window first meets the lowered cap
            source, blocks = resume(previous[0], previous[1], previous[2], previous[3], cap, window,
                                    iter_blocks(curve, limits, cap=cap), total)
        window.keep = source.keep
        try:
            for block in window.run(source):
                blocks.append(block)
                if progress is not None and attempt == 0:
                    progress(block.s1)
        except (ValueError, RuntimeError) as exc:
            if isinstance(exc, InputError):
                raise
            where = blocks[-1].s1 if blocks else 0.0
            raise InputError(f"SLW scheduling failed after s = {where:.6g} mm of {total:.6g} mm: {exc}; the "
                             "path has a (near-)stationary point or a corner the look-ahead cannot "
                             "resolve under these limits") from None
        finally:
            if bar is not None:
                bar.close()
                bar = None
        t, s, v, a, j = _sample_profile(blocks, limits.ts_s, total)
        u, xyz, found = checked_positions(curve, s, j, limits, kinks_u)
        if found is None:
            break
        if attempt == TICK_REPAIRS:
            raise breach_error(found, s, limits)
        previous = (source, blocks, window.stats.critical_s, cap)
        cap = _dip(cap, found, s, v, limits, total)
    critical = np.array([b.s1 for b in blocks[:-1]])
    for arr in (t, s, u, xyz, v, a, j):  # read-only: shared with the time law and simulations
        arr.flags.writeable = False
    return Trajectory(curve, limits, t, s, u, xyz, v, a, j, tuple(blocks), window.stats, critical, fit)


# ---------------------------------------------------------------------- measurement
def measure(traj: Trajectory) -> dict[str, float]:
    """Worst ratio to each limit, measured by the one simulator (:func:`fuzzyfeed.machine.simulate.simulate`).

    From the positions (differences at Ts): feed, axial velocity, axial acceleration, chord
    error. From the scheduled profile: tangential acceleration (over the smallest axis limit, a
    reference, not a limit: along a fast axis a block accelerates as that axis allows) and jerk. Plus the start/end feeds
    and the start and terminal errors (distance of the first/last point from the path's ends, mm).
    """
    lim = traj.limits
    m = traj.simulate().metrics
    ratio = {name: worst for name, (_, worst) in m.violations.items()}
    start, end = traj.curve(traj.curve.domain[0]), traj.curve(traj.curve.domain[1])
    d = traj.curve.dim
    return {
        "feed": ratio["feed"],
        "axis_vel": max(ratio[f"axis_vel_{a}"] for a in AXES),
        "axis_acc": max(ratio[f"axis_acc_{a}"] for a in AXES),
        "chord": ratio["chord_error"],
        "tangential_acc": m.tan_acc_max_mm_s2 / lim.tangential_acc_mm_s2,
        "jerk": ratio["jerk"],
        "start_feed_mm_s": float(traj.feed_mm_s[0]),
        "end_feed_mm_s": float(traj.feed_mm_s[-1]),
        "start_error_mm": float(np.linalg.norm(traj.xyz[0, :d] - start)),
        "terminal_error_mm": float(np.linalg.norm(traj.xyz[-1, :d] - end)),
    }
