"""The feed at which a machine holds its contour tolerance, at a curve and at a corner.

- **On a curve** of radius r at feed v the servo settles on a circle of radius r·|G(jv/r)|, so the
  steady-state contour error is r·(1 − |G(jv/r)|) (first order without feed-forward:
  r·(1 − 1/√(1 + (v/(r·Kv))²)) ≈ v²/(2r·Kv²)). :func:`curve_safe_feed` is the largest v whose
  error is at most the tolerance (no limit when r ≤ tolerance: the error never exceeds r).
- **At a corner** of turn angle φ between two lines, the error depends on the controller's corner
  speed (junction deviation or path tolerance), its acceleration and the servo; it is measured, not
  assumed: :func:`corner_error_table` runs two long lines meeting at φ, both at feed v, through the
  machine's own planner and servo (:func:`~fuzzyfeed.machine.trace.trace_motion`) for a grid of φ
  and v (a corner is scale-free, so the table serves every corner of that angle), and
  :func:`corner_safe_feed` reads the largest v that holds the tolerance at each φ. A cut's entry
  from a rapid is a corner of its own kind: the rapid brakes at the full acceleration into it, and
  the lag that leaves must decay while the feed move starts (``rapid_lead``).
- :func:`settle_time_s`: how long before a hot spot the feed must already be low, so that the lag
  the planner's braking leaves in the servo (a/Kv² for a first-order loop) has decayed to a
  quarter of the tolerance.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.planner import Motion

#: Turn angles (deg) of the corner table; speeds per angle, geometric from the lowest to the top.
CORNER_ANGLES_DEG = np.array([0.0, 1.0, 2.0, 3.0, 5.0, 7.5, 10.0, 15.0, 20.0, 30.0, 45.0, 60.0, 75.0,
                              90.0, 105.0, 120.0, 135.0, 150.0, 165.0, 180.0])
CORNER_SPEEDS = 28
#: The lowest speed of the table, as a fraction of the machine's top speed (a relative grid keeps
#: the table's speeds in proportion when the machine is scaled).
LOWEST_SPEED_FRACTION = 5e-4


def curve_error_mm(machine: Machine, radius_mm: np.ndarray, feed_mm_s: np.ndarray) -> np.ndarray:
    """Steady-state contour error (mm) on circles of ``radius_mm`` at ``feed_mm_s`` (the worst axis)."""
    r = np.asarray(radius_mm, dtype=float)
    v = np.asarray(feed_mm_s, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        omega = np.where(r > 0, v / r, np.inf)
    out = np.zeros(np.broadcast(r, v).shape)
    for axis in range(3):
        gain = machine.servo.circle_gain(axis, np.where(np.isfinite(omega), omega, 0.0))
        err = np.where(np.isfinite(omega), r * np.abs(1.0 - gain), 0.0)
        out = np.maximum(out, err)
    return out


def curve_safe_feed(machine: Machine, curvature_1_mm: np.ndarray, tol_mm: float | None = None) -> np.ndarray:
    """Largest feed (mm/s) whose steady-state error on a curve of this curvature is within the
    tolerance; inf where the curve is straight or its radius is below the tolerance."""
    tol = machine.contour_tol_mm if tol_mm is None else tol_mm
    k = np.asarray(curvature_1_mm, dtype=float)
    with np.errstate(divide="ignore"):
        r = np.where(k > 0, 1.0 / k, np.inf)
    out = np.full(k.shape, np.inf)
    hot = np.isfinite(r) & (r > tol)
    if not hot.any():
        return out
    rh = r[hot]
    if machine.servo.order == 1 and max(machine.servo.feedforward) == 0.0:
        # r(1 − 1/√(1 + w²)) = tol, w = v/(r·Kv): closed form
        kv = min(machine.servo.kv_1_s)
        w = np.sqrt(1.0 / (1.0 - tol / rh) ** 2 - 1.0)
        out[hot] = w * rh * kv
        return out
    lo = np.zeros_like(rh)
    hi = np.full_like(rh, 1e6)
    for _ in range(60):      # bisection on log v would do too; the error is monotone in v here
        mid = 0.5 * (lo + hi)
        ok = curve_error_mm(machine, rh, mid) <= tol
        lo = np.where(ok, mid, lo)
        hi = np.where(ok, hi, mid)
    out[hot] = lo
    return out


def low_frequency_gain_loss(machine: Machine) -> float:
    """c with 1 − |G(jω)| ≈ c·ω² for slow motion (the worst axis): 1/(2·Kv²) for a first-order
    loop without feed-forward; measured at ω = 10⁻³ of the loop's bandwidth for any other."""
    w0 = 1e-3 / machine.servo.time_constant_s
    return max(float(1.0 - machine.servo.circle_gain(axis, np.array([w0]))[0]) / (w0 * w0) for axis in range(3))


#: The scale junction runs are judged at, in contour tolerances: features smaller than a few
#: tolerances (a CAM post's micro-segments) do not count, a zig-zag of them does.
RUN_SCALE_TOLERANCES = 10.0
#: The scale a corner's turn is measured at, in contour tolerances: turns that follow within it
#: are one corner to the lagging tool, and a micro-segment's wiggle below it is none.
CORNER_SCALE_TOLERANCES = 4.0


def turn_at_scale(xyz: np.ndarray, s_mm: np.ndarray, at: np.ndarray, scale_mm: float) -> np.ndarray:
    """The angle (rad) the path turns at the samples ``at`` measured at a scale: between the chord
    from ``scale_mm`` before to the sample and the chord from it to ``scale_mm`` after (0 where
    either chord is cut short by an end of the path)."""
    s = np.asarray(s_mm, dtype=float)
    pts = np.asarray(xyz, dtype=float)
    here = pts[at]
    back = np.column_stack([np.interp(s[at] - scale_mm, s, pts[:, k]) for k in range(3)])
    ahead = np.column_stack([np.interp(s[at] + scale_mm, s, pts[:, k]) for k in range(3)])
    d_in, d_out = here - back, ahead - here
    n_in, n_out = np.linalg.norm(d_in, axis=1), np.linalg.norm(d_out, axis=1)
    ok = (n_in > 0.25 * scale_mm) & (n_out > 0.25 * scale_mm)
    cos = np.einsum("ij,ij->i", d_in, d_out) / np.where(ok, n_in * n_out, 1.0)
    return np.where(ok, np.arccos(np.clip(cos, -1.0, 1.0)), 0.0)


def junction_safe_feed(machine: Machine, turn_angle_rad: np.ndarray, xyz: np.ndarray, s_mm: np.ndarray,
                       tol_mm: float | None = None) -> np.ndarray:
    """Largest feed (mm/s) at the junctions of a path (samples with a turn > 0; inf elsewhere):

    - as a corner (:func:`corner_safe_feed`) of the turn measured at
      :data:`CORNER_SCALE_TOLERANCES` tolerances (:func:`turn_at_scale`): several turns within that
      stretch are one corner to the tool, a micro-segment's wiggle below it none;
    - as part of a run of close junctions (a V-carve's zig-zag, a 3-D pass of short moves): the
      turn at :data:`RUN_SCALE_TOLERANCES` tolerances λ taken as a curvature κ = turn / λ, which the
      servo smooths like a curve's, e ≈ c·v²·κ (:func:`low_frequency_gain_loss`), v = √(tol/(c·κ));

    the smaller of the two."""
    tol = machine.contour_tol_mm if tol_mm is None else tol_mm
    phi = np.asarray(turn_angle_rad, dtype=float)
    s = np.asarray(s_mm, dtype=float)
    out = np.full(phi.shape, np.inf)
    at = np.flatnonzero(phi > 1e-6)
    if at.size == 0 or s[-1] <= s[0]:
        return out
    corner_turn = turn_at_scale(xyz, s, at, CORNER_SCALE_TOLERANCES * tol)
    v_corner = corner_safe_feed(machine, corner_turn, tol)
    lam = RUN_SCALE_TOLERANCES * tol
    run_turn = turn_at_scale(xyz, s, at, lam)
    c = low_frequency_gain_loss(machine)
    with np.errstate(divide="ignore"):
        v_run = np.where(run_turn > 0, np.sqrt(tol * lam / (c * np.maximum(run_turn, 1e-300))), np.inf) \
            if c > 0 else np.full(at.size, np.inf)
    out[at] = np.minimum(v_corner, v_run)
    return out


def settle_time_s(machine: Machine, tol_mm: float | None = None) -> float:
    """Time (s) the servo needs after braking at the machine's acceleration until the lag it left
    (a·τ² for a first-order loop of time constant τ) is below a quarter of the tolerance."""
    tol = machine.contour_tol_mm if tol_mm is None else tol_mm
    tau = machine.servo.time_constant_s
    lag = machine.tangential_acc_mm_s2 * tau * tau
    return tau * max(1.0, math.log(max(lag / (0.25 * tol), 1.0)))


def _corner_points(angle_rad: float, feed_mm_s: float, machine: Machine, lead_speed: float) -> np.ndarray:
    """A corner of turn ``angle_rad`` at the origin between a lead long enough to reach
    ``lead_speed`` and settle, and a tail long enough for the error after the corner to decay."""
    tau = machine.servo.time_constant_s
    a = machine.tangential_acc_mm_s2
    lead = lead_speed ** 2 / (2.0 * a) + 10.0 * tau * lead_speed + 0.01
    tail = 10.0 * tau * feed_mm_s + 0.01
    out_dir = np.array([math.cos(angle_rad), math.sin(angle_rad), 0.0])
    return np.array([[-lead, 0.0, 0.0], [0.0, 0.0, 0.0], out_dir * tail])


def _corner_errors(angle_rad: float, speeds: np.ndarray, machine: Machine, rapid_lead: bool = False) -> np.ndarray:
    """Max contour error (mm) of the corner at each speed: every case planned from rest to rest,
    the cases run one after another (each starting where the last ended, with a dwell of ten time
    constants between) through the servo in one pass. ``rapid_lead``: the lead is a rapid (at
    the machine's velocity) and only the ticks on the feed move after the corner count."""
    from fuzzyfeed.machine.contour import windowed_distance
    from fuzzyfeed.machine.planner import plan_motion
    from fuzzyfeed.machine.servo import following_errors
    from fuzzyfeed.machine.trace import LOOKBACK_TIME_CONSTANTS, WINDOW_MARGIN_MM

    ts = machine.ts_s
    hold = int(math.ceil(10.0 * machine.servo.time_constant_s / ts))
    origin = np.zeros(3)
    cmds, s_cmds, polys, case_of, near = [], [], [], [], []
    s_offset = 0.0
    for i, v in enumerate(speeds):
        lead_speed = float(machine.move_velocity(np.array([[1.0, 0.0, 0.0]]))[0]) if rapid_lead else float(v)
        pts = _corner_points(angle_rad, float(v), machine, lead_speed)
        pts = pts - pts[0] + origin
        rapid = np.array([rapid_lead, False])
        plan = plan_motion(Motion(pts, np.full(2, float(v)), rapid, np.full(3, np.nan)), machine)
        t, cmd, seg = plan.sample(ts)
        s_vertex = plan.segment_arc_start()
        # the error arises at the corner: measure from one time constant before it (after it
        # behind a rapid, whose ticks are not measured)
        start = plan.t_start[1] - (0.0 if rapid_lead else machine.servo.time_constant_s)
        near.append(np.concatenate([t >= start, np.ones(hold, bool)]))
        s_cmd = s_vertex[seg] + np.linalg.norm(cmd - pts[seg], axis=1) + s_offset
        cmd = np.vstack([cmd, np.repeat(cmd[-1:], hold, axis=0)])
        s_cmd = np.concatenate([s_cmd, np.full(hold, s_cmd[-1])])
        cmds.append(cmd)
        s_cmds.append(s_cmd)
        polys.append(pts if i == 0 else pts[1:])
        case_of.append(np.full(cmd.shape[0], i))
        origin = pts[-1]
        s_offset += float(s_vertex[-1])
    cmd = np.vstack(cmds)
    s_cmd = np.concatenate(s_cmds)
    case = np.concatenate(case_of)
    poly = np.vstack(polys)
    s_vertex = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(poly, axis=0), axis=1))])
    actual = cmd - following_errors(machine.servo, cmd, ts)
    lookback = int(math.ceil(LOOKBACK_TIME_CONSTANTS * machine.servo.time_constant_s / ts))
    k = np.flatnonzero(np.concatenate(near))
    dist, _, _ = windowed_distance(poly, s_vertex, actual[k], s_cmd[np.maximum(k - lookback, 0)] - WINDOW_MARGIN_MM,
                                s_cmd[k] + WINDOW_MARGIN_MM)
    out = np.zeros(speeds.size)
    np.maximum.at(out, case[k], dist)
    return out


def corner_error_table(machine: Machine, rapid_lead: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(turn angles in rad (A,), speeds in mm/s (S,), max contour error in mm (A, S)) of a corner
    run at constant feed through the machine's planner and servo (``rapid_lead``: a cut's entry,
    the corner reached by a rapid at the machine's velocity, the feed move after it at the speed).
    Computed once per machine and process."""
    return _corner_error_table(machine, bool(rapid_lead))


@lru_cache(maxsize=64)
def _corner_error_table(machine: Machine, rapid_lead: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    angles, speeds = _corner_grid(machine)
    err = np.vstack([_corner_error_row(machine, rapid_lead, i) for i in range(angles.size)])
    return angles, speeds, err


def _corner_grid(machine: Machine) -> tuple[np.ndarray, np.ndarray]:
    top = max(machine.axis_vel_mm_s)
    return np.radians(CORNER_ANGLES_DEG), np.geomspace(LOWEST_SPEED_FRACTION * top, top, CORNER_SPEEDS)


@lru_cache(maxsize=64 * CORNER_ANGLES_DEG.size)
def _corner_error_row(machine: Machine, rapid_lead: bool, i: int) -> np.ndarray:
    """Row ``i`` (angle ``CORNER_ANGLES_DEG[i]``) of the corner table, computed once per machine and
    process: the rows are independent, so a program's advice computes only those its turns need."""
    angles, speeds = _corner_grid(machine)
    err = _corner_errors(float(angles[i]), speeds, machine, rapid_lead)
    # the error grows with the speed: a non-monotone wiggle of the grid is taken at its worst
    err = np.maximum.accumulate(err)
    err.setflags(write=False)
    return err


def corner_safe_feed(machine: Machine, turn_angle_rad: np.ndarray, tol_mm: float | None = None,
                     rapid_lead: bool = False) -> np.ndarray:
    """Largest feed (mm/s) that holds the tolerance at corners of these turn angles (inf for 0):
    from :func:`corner_error_table`, the largest speed on the grid whose error (and every slower
    one's) is within the tolerance, interpolated in log speed, the angle interpolated linearly
    between the table's angles (the slower of the two neighbours' feeds)."""
    tol = machine.contour_tol_mm if tol_mm is None else tol_mm
    angles, speeds = _corner_grid(machine)
    phi = np.clip(np.abs(np.asarray(turn_angle_rad, dtype=float)), 0.0, math.pi)
    k = np.clip(np.searchsorted(angles, phi, side="right"), 1, angles.size - 1)
    per_angle = np.full(angles.size, np.nan)      # only the rows the turns read are computed
    logv = np.log(speeds)
    for i in np.unique(np.concatenate([k - 1, k])):
        e = _corner_error_row(machine, bool(rapid_lead), int(i))
        if e[-1] <= tol:
            per_angle[i] = np.inf
        elif e[0] > tol:
            per_angle[i] = speeds[0]
        else:
            j = int(np.argmax(e > tol))        # first speed beyond the tolerance
            f = (tol - e[j - 1]) / (e[j] - e[j - 1]) if e[j] > e[j - 1] else 0.0
            per_angle[i] = math.exp(logv[j - 1] + f * (logv[j] - logv[j - 1]))
    out = np.minimum(per_angle[k - 1], per_angle[k])
    return out if rapid_lead else np.where(phi <= 0.0, np.inf, out)
