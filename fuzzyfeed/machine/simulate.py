"""One simulator for every feed profile, one set of metrics (DESIGN §3 "One simulator").

Any planner's output becomes a :class:`TimeLaw` — the arc length reached at every servo tick
t_k = k·Ts together with the commanded feed, tangential acceleration and jerk. The SLW scheduler
produces one directly; a feed given per sample (fuzzy advice, a constant feed, the time-optimal
bound) is turned into one by :func:`time_law_from_profile`. :func:`simulate` then executes the law
through the one interpolator (:func:`fuzzyfeed.geometry.interpolate.interpolate_u`) and measures the
positions the machine would visit, the same way for everybody — and, through the axis servo model
(:mod:`fuzzyfeed.machine.servo`), the positions the tool really reaches and their contour error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.geometry.interpolate import feed_fluctuation, interpolate_u
from fuzzyfeed.machine.limits import AXES, MachineLimits
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.machine.profile import FeedProfile
from fuzzyfeed.machine.servo import ServoModel, Tracking, track

#: A tick counts as a violation when it exceeds a limit by more than this fraction (rounding and
#: the O(ΔL³) chord-to-arc difference must not count).
VIOLATION_TOLERANCE = 1e-6
#: Ticks per chunk of the per-tick measurements (bounded temporaries on long trajectories).
CHUNK_TICKS = 16384


@dataclass(frozen=True, eq=False)
class TimeLaw:
    """Arc length and its time derivatives at every servo tick t_k = k·Ts, k = 0 … K.

    ``s_mm`` runs from 0 to the path length L (s_K = L: the last tick may be shorter, which is the
    terminal-error compensation); ``duration_s`` is the exact time the law reaches L
    ((K − 1)·Ts < duration ≤ K·Ts).
    """

    ts_s: float
    s_mm: np.ndarray
    feed_mm_s: np.ndarray
    acc_mm_s2: np.ndarray
    jerk_mm_s3: np.ndarray
    duration_s: float

    def __post_init__(self) -> None:
        n = np.shape(self.s_mm)[0]
        for name in ("s_mm", "feed_mm_s", "acc_mm_s2", "jerk_mm_s3"):
            arr = getattr(self, name)
            if not (isinstance(arr, np.ndarray) and arr.dtype == np.float64 and not arr.flags.writeable):
                arr = np.array(arr, dtype=float)  # a read-only float array (a trajectory's) is shared
            if arr.shape != (n,):
                raise InputError(f"time law: {name} has shape {arr.shape}, expected ({n},)")
            if not np.isfinite(arr).all():
                i = int(np.argmax(~np.isfinite(arr)))
                raise InputError(f"time law: {name}[{i}] = {arr[i]}; values must be finite")
            arr.flags.writeable = False
            object.__setattr__(self, name, arr)
        if n < 2:
            raise InputError("time law: fewer than 2 ticks")

    @property
    def t_s(self) -> np.ndarray:
        return np.arange(self.s_mm.size) * self.ts_s


def time_law_from_profile(profile: FeedProfile, ts_s: float) -> TimeLaw:
    """Execute a feed given per sample with constant acceleration between samples.

    Between samples a and b (arc length Δs apart) the feed goes linearly in time from v_a to v_b:
    T = 2Δs/(v_a + v_b), a = (v_b − v_a)/T = (v_b² − v_a²)/(2Δs). This is exact for the
    time-optimal bound (v² linear in s) and handles a stop at either end of a segment.

    The jerk is measured at the table's own resolution: the segments' accelerations, placed at
    their mid-times and joined linearly, have slope (a_i+1 − a_i) / ((T_i + T_i+1)/2). (Dividing
    the acceleration steps by Ts instead would charge the table for its sampling: the SLW
    schedule's own jerk-limited feed, sampled at 2000 points, would show 48 × the jerk limit on
    infinity; measured this way it shows 1.08 ×.)
    """
    if not math.isfinite(ts_s) or ts_s <= 0:
        raise InputError(f"ts_s = {ts_s!r}; the servo period must be finite and > 0")
    s = profile.samples.s
    v = profile.feed_mm_s
    ds = np.diff(s)
    vsum = v[:-1] + v[1:]
    stalled = (ds > 0) & (vsum <= 0)
    if stalled.any():
        i = int(np.argmax(stalled))
        raise InputError(f"{profile.method}: feed is 0 at both samples {i} and {i + 1} "
                         f"(s = {s[i]:.6g} mm); the path is never completed")
    seg_time = np.divide(2.0 * ds, vsum, out=np.zeros_like(ds), where=ds > 0)
    seg_acc = np.divide(v[1:] - v[:-1], seg_time, out=np.zeros_like(ds), where=seg_time > 0)
    nodes = np.concatenate([[0.0], np.cumsum(seg_time)])
    duration = float(nodes[-1])
    ticks = max(1, math.ceil(duration / ts_s - 1e-9))
    t = np.arange(ticks + 1) * ts_s
    seg = np.clip(np.searchsorted(nodes, t, side="right") - 1, 0, ds.size - 1)
    tau = np.minimum(t - nodes[seg], seg_time[seg])
    s_k = np.minimum(s[seg] + v[seg] * tau + 0.5 * seg_acc[seg] * tau * tau, s[-1])
    s_k[0], s_k[-1] = 0.0, s[-1]
    s_k = np.maximum.accumulate(s_k)
    feed = np.maximum(v[seg] + seg_acc[seg] * tau, 0.0)
    acc = seg_acc[seg]
    feed[-1], acc[-1] = v[-1], 0.0 if v[-1] == 0 else acc[-1]
    moving = seg_time > 0
    mid_t = (nodes[:-1] + 0.5 * seg_time)[moving]
    if mid_t.size > 1:
        slopes = np.diff(seg_acc[moving]) / np.diff(mid_t)
        jerk = slopes[np.clip(np.searchsorted(mid_t, t, side="right") - 1, 0, slopes.size - 1)]
    else:
        jerk = np.zeros_like(t)
    return TimeLaw(ts_s=ts_s, s_mm=s_k, feed_mm_s=feed, acc_mm_s2=acc, jerk_mm_s3=jerk,
                   duration_s=duration)


@dataclass(frozen=True, eq=False)
class Metrics:
    """The metric set of DESIGN §3, measured from the interpolated positions at Ts.

    Velocities and accelerations per axis are finite differences of the positions; the chord
    error is the largest distance of the curve from each tick's chord; the feed fluctuation
    compares each chord with the commanded step; the tangential acceleration and jerk are the time
    law's. ``violations`` maps each machine limit — feed, chord error, jerk, axial velocity and
    axial acceleration per axis — to (ticks over it, worst value/limit ratio). The tangential
    acceleration is reported but is no machine limit of its own: the axes' accelerations are.

    The contour error is the distance of the servo-driven actual position from the curve at every
    tick t_0 … t_K (max, mean, RMS); the following error the distance of the actual position from
    its set-point (:mod:`fuzzyfeed.machine.servo`; ``servo`` describes the model used).
    """

    method: str
    cycle_time_s: float
    chord_err_max_um: float
    chord_err_mean_um: float
    feed_fluct_max_pct: float
    feed_fluct_mean_pct: float
    feed_max_mm_s: float
    tan_acc_max_mm_s2: float
    tan_jerk_max_mm_s3: float
    axis_vel_max_mm_s: tuple[float, float, float]
    axis_acc_max_mm_s2: tuple[float, float, float]
    violations: dict[str, tuple[int, float]]
    ratio_to_bound: float = float("nan")
    contour_err_max_um: float = float("nan")
    contour_err_mean_um: float = float("nan")
    contour_err_rms_um: float = float("nan")
    following_err_max_um: float = float("nan")
    servo: str = ""

    def row(self) -> dict[str, object]:
        """Flat mapping with units in the names: one CSV row of a comparison."""
        out: dict[str, object] = {
            "method": self.method, "cycle_time_s": self.cycle_time_s,
            "ratio_to_bound": self.ratio_to_bound,
            "chord_err_max_um": self.chord_err_max_um, "chord_err_mean_um": self.chord_err_mean_um,
            "contour_err_max_um": self.contour_err_max_um, "contour_err_mean_um": self.contour_err_mean_um,
            "contour_err_rms_um": self.contour_err_rms_um, "following_err_max_um": self.following_err_max_um,
            "feed_fluct_max_pct": self.feed_fluct_max_pct, "feed_fluct_mean_pct": self.feed_fluct_mean_pct,
            "feed_max_mm_s": self.feed_max_mm_s,
            "tan_acc_max_mm_s2": self.tan_acc_max_mm_s2, "tan_jerk_max_mm_s3": self.tan_jerk_max_mm_s3,
        }
        for axis, vel, acc in zip(AXES, self.axis_vel_max_mm_s, self.axis_acc_max_mm_s2):
            out[f"axis_vel_max_{axis}_mm_s"] = vel
            out[f"axis_acc_max_{axis}_mm_s2"] = acc
        for name, (count, worst) in self.violations.items():
            out[f"violations_{name}"] = count
            out[f"worst_ratio_{name}"] = worst
        return out


@dataclass(frozen=True, eq=False)
class Simulation:
    """The executed trajectory (one row per tick) and its metrics."""

    law: TimeLaw
    u: np.ndarray
    xyz: np.ndarray
    chord_err_mm: np.ndarray   # per tick interval (K values)
    metrics: Metrics
    tracking: Tracking         # servo response per tick (K + 1 values)


def chord_errors(curve: Nurbs, u: np.ndarray, probes: int = 5, points: np.ndarray | None = None) -> np.ndarray:
    """Largest distance of the curve from each tick's chord C(u_k)C(u_k+1) (mm, one per tick),
    probed at ``probes`` evenly spaced parameters inside every interval (in chunks of
    :data:`CHUNK_TICKS` ticks: the memory stays bounded on long trajectories). ``points``, if
    given, are the ticks' positions C(u_k) already evaluated (their first ``curve.dim`` columns)."""
    u = np.asarray(u, dtype=float)
    out = np.empty(max(u.size - 1, 0))
    for c0 in range(0, out.size, CHUNK_TICKS):
        part = slice(c0, c0 + CHUNK_TICKS + 1)
        ends = curve(u[part]) if points is None else points[part, :curve.dim]
        out[c0:c0 + CHUNK_TICKS] = _chord_errors(curve, u[part], ends, probes)
    return out


def _chord_errors(curve: Nurbs, u: np.ndarray, ends: np.ndarray, probes: int) -> np.ndarray:
    frac = np.linspace(0.0, 1.0, probes + 2)[1:-1]
    u0, u1 = u[:-1], u[1:]
    inner = u0[:, None] + (u1 - u0)[:, None] * frac[None, :]
    pts = curve(inner.ravel()).reshape(inner.shape + (curve.dim,))
    a, b = ends[:-1], ends[1:]
    ab = b - a
    length2 = np.einsum("ij,ij->i", ab, ab)
    rel = pts - a[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.clip(np.einsum("ikj,ij->ik", rel, ab) / length2[:, None], 0.0, 1.0)
    t = np.where(length2[:, None] > 0, t, 0.0)
    return np.linalg.norm(rel - t[..., None] * ab[:, None, :], axis=-1).max(axis=1)


def _violation(values: np.ndarray, limit: float) -> tuple[int, float]:
    values = np.abs(np.asarray(values, dtype=float))
    if values.size == 0:
        return 0, 0.0
    ratio = values / limit
    return int(np.sum(ratio > 1.0 + VIOLATION_TOLERANCE)), float(ratio.max())


def simulate(curve: Nurbs, law: TimeLaw, limits: MachineLimits, method: str,
             bound_time_s: float | None = None, interpolation: str = "best",
             servo: ServoModel | None = None, u: np.ndarray | None = None,
             xyz: np.ndarray | None = None) -> Simulation:
    """Execute ``law`` on ``curve`` through the one interpolator and measure it (DESIGN §3).

    ``servo`` is the axis model the contour error is measured with (default: ``ServoModel()``,
    first order, Kv = 30 1/s, no feed-forward). ``u``, if given, are the ticks' curve parameters
    already found by ``interpolation`` (a scheduled trajectory's), so they are not found twice;
    ``xyz`` (K+1, 3), with ``u`` only, their positions C(u) already evaluated.
    """
    servo = ServoModel() if servo is None else servo
    if abs(law.ts_s - limits.ts_s) > 1e-12 * limits.ts_s:
        raise InputError(f"time law at Ts = {law.ts_s} s, limits at Ts = {limits.ts_s} s; "
                         "simulate with the limits' servo period")
    given_u = u
    if u is None:
        u = interpolate_u(curve, law.s_mm, method=interpolation)
    elif np.shape(u) != law.s_mm.shape:
        raise InputError(f"u has shape {np.shape(u)}, the time law {law.s_mm.shape}; one parameter per tick")
    if xyz is not None:
        if given_u is None or np.shape(xyz) != (law.s_mm.size, 3):
            raise InputError(f"xyz has shape {np.shape(xyz)}; give the ticks' positions with their u, "
                             f"shape ({law.s_mm.size}, 3)")
        pts = np.asarray(xyz, dtype=float)
        if not np.isfinite(pts).all():
            raise InputError(f"xyz[{int(np.argmax(~np.isfinite(pts).all(axis=1)))}] is not finite; "
                             "positions must be finite")
    else:
        pts = curve(u)
        if pts.shape[1] < 3:
            pts = np.hstack([pts, np.zeros((pts.shape[0], 3 - pts.shape[1]))])
    # tick durations: Ts, except the last (terminal) tick, which ends when the law reaches L
    dt = np.full(law.s_mm.size - 1, law.ts_s)
    dt[-1] = max(law.duration_s - (dt.size - 1) * law.ts_s, 1e-12 * law.ts_s)
    step = np.diff(pts, axis=0)
    vel = step / dt[:, None]                                  # per tick, per axis
    # per tick boundary, including the start from rest and the stop at rest (a jump from rest to
    # full feed in the first tick is an acceleration like any other)
    rest = np.zeros((1, vel.shape[1]))
    dt_b = np.concatenate([[law.ts_s], 0.5 * (dt[:-1] + dt[1:]), [law.ts_s]])
    acc = np.diff(np.vstack([rest, vel, rest]), axis=0) / dt_b[:, None]
    feed = np.linalg.norm(vel, axis=1)
    chord = chord_errors(curve, u, points=pts)
    fluct = feed_fluctuation(curve, u, law.s_mm, points=pts)
    fluct = fluct[np.isfinite(fluct)]
    vel_max = tuple(float(x) for x in np.abs(vel).max(axis=0))
    acc_max = tuple(float(x) for x in (np.abs(acc).max(axis=0) if acc.size else np.zeros(3)))
    violations = {
        "feed": _violation(feed, limits.feed_mm_s),
        "chord_error": _violation(chord, limits.chord_tol_mm),
        "jerk": _violation(law.jerk_mm_s3, limits.jerk_mm_s3),
    }
    for j, axis in enumerate(AXES):
        violations[f"axis_vel_{axis}"] = _violation(vel[:, j], limits.axis_vel_mm_s[j])
        violations[f"axis_acc_{axis}"] = _violation(acc[:, j] if acc.size else np.zeros(0),
                                                    limits.axis_acc_mm_s2[j])
    tracking = track(curve, pts, law.ts_s, servo)
    contour = tracking.contour_mm
    metrics = Metrics(
        method=method, cycle_time_s=law.duration_s,
        chord_err_max_um=float(chord.max()) * 1e3, chord_err_mean_um=float(chord.mean()) * 1e3,
        feed_fluct_max_pct=float(fluct.max()) * 100 if fluct.size else 0.0,
        feed_fluct_mean_pct=float(fluct.mean()) * 100 if fluct.size else 0.0,
        feed_max_mm_s=float(feed.max()),
        tan_acc_max_mm_s2=float(np.abs(law.acc_mm_s2).max()),
        tan_jerk_max_mm_s3=float(np.abs(law.jerk_mm_s3).max()),
        axis_vel_max_mm_s=vel_max, axis_acc_max_mm_s2=acc_max, violations=violations,
        ratio_to_bound=(law.duration_s / bound_time_s) if bound_time_s else float("nan"),
        contour_err_max_um=float(contour.max()) * 1e3, contour_err_mean_um=float(contour.mean()) * 1e3,
        contour_err_rms_um=float(np.sqrt(np.mean(contour * contour))) * 1e3,
        following_err_max_um=float(tracking.following_mm.max()) * 1e3, servo=servo.describe(),
    )
    return Simulation(law=law, u=u, xyz=pts, chord_err_mm=chord, metrics=metrics, tracking=tracking)


def simulate_profile(profile: FeedProfile, limits: MachineLimits,
                     bound_time_s: float | None = None, servo: ServoModel | None = None) -> Simulation:
    """:func:`simulate` for a feed given per sample (see :func:`time_law_from_profile`)."""
    curve = profile.samples.curve
    if curve is None:
        raise InputError(f"{profile.method}: the samples carry no curve to interpolate on")
    law = time_law_from_profile(profile, limits.ts_s)
    return simulate(curve, law, limits, profile.method, bound_time_s=bound_time_s, servo=servo)
