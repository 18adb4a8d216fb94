"""How a controller runs a program: look-ahead over the moves, trapezoidal speed profiles, corner
speeds from junction deviation (GRBL) or a path-tolerance blend (LinuxCNC ``G64 P``).

The path is a polyline (arcs and G5.2 blocks already flattened into chords within the machine's
chord tolerance, see :mod:`fuzzyfeed.program.run`), each segment with its programmed feed as the
cap of its speed. The plan, like GRBL's planner (``planner.c``):

- nominal speed of a segment: min(F, every axis within its velocity limit along the segment);
  a rapid's is the axes' limit alone;
- acceleration along a segment: the largest a with |a·u_j| ≤ A_j on every axis (GRBL's
  ``limit_value_by_axis_maximum``), and at most the path limit if the machine has one;
- the speed at a junction of turn angle θ (θ = π − angle between the segments, GRBL's
  ``junction_cos_theta = −u_in·u_out``): v² = a_j·r with the radius of the virtual circle
  r = δ·sin(θ/2)/(1 − sin(θ/2)) (δ the junction deviation, ``$11``; a_j the acceleration along
  u_out − u_in); never more than either segment's nominal speed; a reversal stops; a straight
  junction has no limit. With ``corner = "path-tolerance"`` the same speed is taken on a blend arc
  of that radius (LinuxCNC leaves the corner by at most δ = ``G64 P``; the blend's geometry is made
  by :func:`blend_corners`), and the inner vertices of a flattened arc take v² = a·ρ on the arc's
  own radius ρ instead;
- LinuxCNC (``corner = "path-tolerance"``) does not blend a rapid into a feed move or a feed move
  into a rapid: its planner sets the junction's end condition to a stop (``tp.c``,
  ``tpCheckCanonType``: "Can't blend between rapid and feed move"), the command stops there, and it
  does not wait for the axes to be in position, so the servo's lag from the rapid still decays
  while the feed move starts (issue 37, defect 3). GRBL's planner blends them like any junction;
- with ``corner = "path-tolerance"`` the accelerations, speed caps and corner speeds are LinuxCNC
  2.9's own (:mod:`fuzzyfeed.machine.linuxcnc_tp`: axes-only acceleration, arcs' reduced
  tangential acceleration, half acceleration at a parabolic end, blend arcs limited by the moves'
  lengths, kinks, a move of at least 1.02 servo periods), and a segment changes speed only on what
  the blend arcs leave of it;
- the squared speed at every vertex is the largest that allows reaching the next and the previous
  cap with the acceleration: w_k = min_j (c_j + |D_k − D_j|), D the running sum of 2·a·L (one
  forward and one backward pass, each a running minimum); the program starts and ends at rest;
- a finite look-ahead of N moves: when segment i − 1 ends, the buffer holds segments i … i + N − 2
  after it (GRBL plans a block once, when it starts, and the buffer's last block ends at rest),
  so the speed at vertex i must allow a stop within them;
- each segment: accelerate at a, cruise at the peak, decelerate at a (a trapezoid or triangle);
  its time and the position at any instant are closed forms.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.linuxcnc_tp import linuxcnc_limits

#: Cosine of the junction angle beyond which two segments count as one straight line (GRBL: 0.999999).
STRAIGHT_COS = 0.999999


@dataclass(frozen=True, eq=False)
class Motion:
    """A polyline the controller executes: ``points`` (n+1, 3) mm; per segment the speed cap
    ``feed_mm_s`` (n,) (the programmed F; ignored for rapids) and ``rapid`` (n,) bool; per vertex
    ``arc_radius_mm`` (n+1,) the radius of the arc a vertex lies inside (NaN at move ends: a
    junction between moves)."""

    points: np.ndarray
    feed_mm_s: np.ndarray
    rapid: np.ndarray
    arc_radius_mm: np.ndarray

    def __post_init__(self) -> None:
        pts = np.asarray(self.points, dtype=float)
        n = pts.shape[0] - 1
        if pts.ndim != 2 or pts.shape[1] != 3 or n < 1:
            raise InputError(f"motion points: shape {pts.shape}; expected (n + 1, 3) with n >= 1")
        if not np.isfinite(pts).all():
            raise InputError("motion points: not finite")
        feed = np.asarray(self.feed_mm_s, dtype=float)
        rapid = np.asarray(self.rapid, dtype=bool)
        radius = np.asarray(self.arc_radius_mm, dtype=float)
        if feed.shape != (n,) or rapid.shape != (n,) or radius.shape != (n + 1,):
            raise InputError(f"motion: {n} segments but feed {feed.shape}, rapid {rapid.shape}, "
                             f"arc radius {radius.shape}")
        bad = ~rapid & ~(feed > 0)
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(f"motion feed_mm_s[{i}] = {feed[i]!r}; a feed segment needs a feed > 0")
        for name, value in (("points", pts), ("feed_mm_s", feed), ("rapid", rapid),
                            ("arc_radius_mm", radius)):
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    @property
    def n_segments(self) -> int:
        return self.feed_mm_s.size


@dataclass(frozen=True, eq=False)
class Plan:
    """The speed profile of a :class:`Motion` on a :class:`Machine`: per segment its length,
    direction, acceleration, entry/peak/exit speed and the durations of its three phases."""

    motion: Motion
    length: np.ndarray
    unit: np.ndarray
    acc: np.ndarray
    v_entry: np.ndarray
    v_peak: np.ndarray
    v_exit: np.ndarray
    t_acc: np.ndarray
    t_cruise: np.ndarray
    t_dec: np.ndarray
    t_start: np.ndarray          # (n + 1,) time at each vertex

    @property
    def time_s(self) -> float:
        return float(self.t_start[-1])

    def distance_at(self, seg: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Distance travelled along segment ``seg`` at time ``tau`` after its start."""
        v0, vp, a = self.v_entry[seg], self.v_peak[seg], self.acc[seg]
        ta, tc = self.t_acc[seg], self.t_cruise[seg]
        t1 = np.minimum(tau, ta)
        d = v0 * t1 + 0.5 * a * t1 * t1
        t2 = np.clip(tau - ta, 0.0, tc)
        d += vp * t2
        t3 = np.maximum(tau - ta - tc, 0.0)
        d += vp * t3 - 0.5 * a * t3 * t3
        return np.minimum(d, self.length[seg])

    def sample(self, ts_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Commanded positions every ``ts_s`` from 0 to the end (the last tick at the end time):
        (t (K+1,), positions (K+1, 3), segment index of each tick)."""
        total = self.time_s
        k = int(np.ceil(total / ts_s - 1e-9))
        t = np.minimum(np.arange(k + 1) * ts_s, total)
        seg = np.clip(np.searchsorted(self.t_start, t, side="right") - 1, 0, self.length.size - 1)
        d = self.distance_at(seg, t - self.t_start[seg])
        pos = self.motion.points[seg] + self.unit[seg] * d[:, None]
        return t, pos, seg

    def segment_arc_start(self) -> np.ndarray:
        """Arc length (mm) at each vertex."""
        return np.concatenate([[0.0], np.cumsum(self.length)])

    def coordinate_max(self) -> float:
        """The largest |coordinate| of the path (mm): the tick search's rounding scale."""
        return float(np.abs(self.motion.points).max())


def junction_radius(unit: np.ndarray, machine: Machine, arc_radius_mm: np.ndarray) -> np.ndarray:
    """Radius (mm) of the circle a junction is taken on, per interior vertex (n − 1,): the
    junction-deviation circle (GRBL), or — path tolerance — the blend arc's radius at a corner and
    the arc's own radius inside a flattened arc. 0 at a reversal, inf on a straight line."""
    u_in, u_out = unit[:-1], unit[1:]
    cos_theta = -np.einsum("ij,ij->i", u_in, u_out)        # GRBL's junction_cos_theta
    sin_half = np.sqrt(np.clip(0.5 * (1.0 - cos_theta), 0.0, 1.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        r = machine.corner_mm * sin_half / (1.0 - sin_half)
    r = np.where(cos_theta < -STRAIGHT_COS, np.inf, r)
    r = np.where(cos_theta > STRAIGHT_COS, 0.0, r)
    if machine.corner == "path-tolerance":
        inner = arc_radius_mm[1:-1]
        r = np.where(np.isfinite(inner) & (cos_theta >= -STRAIGHT_COS), inner, r)
    return r


def plan_motion(motion: Motion, machine: Machine) -> Plan:
    """The plan of ``motion`` on ``machine`` (see the module docstring)."""
    length, unit, acc, nominal, reach, cap = local_limits(motion.points, motion.feed_mm_s, motion.rapid,
                                                          motion.arc_radius_mm, machine)
    n = length.size
    if machine.lookahead_moves:
        csum = np.concatenate([[0.0], np.cumsum(reach)])
        end = np.minimum(np.arange(n + 1) + machine.lookahead_moves - 1, n)
        cap = np.minimum(cap, csum[end] - csum[np.arange(n + 1)])
    w = reachable_squared_speed(cap, reach)
    v0, vp, v1, t_acc, t_cruise, t_dec = segment_profiles(length, acc, nominal, reach, w)
    t_seg = t_acc + t_cruise + t_dec
    t_start = np.concatenate([[0.0], np.cumsum(t_seg)])
    return Plan(motion=motion, length=length, unit=unit, acc=acc, v_entry=v0, v_peak=vp, v_exit=v1,
                t_acc=t_acc, t_cruise=t_cruise, t_dec=t_dec, t_start=t_start)


def local_limits(pts: np.ndarray, feed_mm_s: np.ndarray, rapid: np.ndarray, arc_radius_mm: np.ndarray,
                 machine: Machine, first: int = 0):
    """What the plan takes from the geometry alone, on a polyline (``pts`` (n+1, 3), per segment
    its feed and rapid flag, per vertex the arc radius): per segment its length, unit direction,
    acceleration, nominal speed and reach 2·a·L (Δ(v²) it allows, less LinuxCNC's blend trims), per
    vertex the squared-speed cap before the look-ahead (0 at both ends). Each value depends on its
    segment's or vertex's neighbours and their program moves only, so a stretch of a chain run with
    two whole moves of context on each side gives its inner values bit for bit
    (:mod:`fuzzyfeed.machine.plan_windows`). ``first``: the index of segment 0 in the chain (errors)."""
    delta = np.diff(pts, axis=0)
    length = np.linalg.norm(delta, axis=1)
    if not (length > 0).all():
        i = int(np.argmax(~(length > 0)))
        raise InputError(f"motion segment {first + i} has length 0; drop repeated points first")
    unit = delta / length[:, None]
    vmax = machine.move_velocity(unit)
    lcnc = machine.corner == "path-tolerance"
    if lcnc:
        requested = np.where(rapid, vmax, np.minimum(feed_mm_s, vmax))
        acc, arc_cap, w_lcnc, trim = linuxcnc_limits(unit, length, arc_radius_mm, requested, machine)
        vmax = np.minimum(vmax, arc_cap)
    else:
        acc = machine.move_acceleration(unit)
    nominal = np.where(rapid, vmax, np.minimum(feed_mm_s, vmax))
    n = length.size
    cap = np.empty(n + 1)
    cap[0] = cap[-1] = 0.0
    if n > 1 and lcnc:
        cap[1:-1] = np.minimum(w_lcnc, np.minimum(nominal[:-1], nominal[1:]) ** 2)
        cap[1:-1] = np.where(rapid[:-1] != rapid[1:], 0.0, cap[1:-1])
    elif n > 1:
        r = junction_radius(unit, machine, arc_radius_mm)
        j_dir = unit[1:] - unit[:-1]
        j_norm = np.linalg.norm(j_dir, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            j_unit = np.where(j_norm[:, None] > 0, j_dir / j_norm[:, None], unit[1:])
        j_acc = machine.move_acceleration(j_unit)
        w_corner = j_acc * r
        cap[1:-1] = np.minimum(w_corner, np.minimum(nominal[:-1], nominal[1:]) ** 2)
    reach = 2.0 * acc * length                       # Δ(v²) a segment allows
    if lcnc and n > 1:                               # less what LinuxCNC's blend arcs take
        trim = np.where(rapid[:-1] != rapid[1:], 0.0, trim)   # a stop: no blend
        free = length - np.concatenate([[0.0], trim]) - np.concatenate([trim, [0.0]])
        reach = 2.0 * acc * np.maximum(free, 0.0)
    return length, unit, acc, nominal, reach, cap


def segment_profiles(length, acc, nominal, reach, w):
    """Per segment the trapezoid (or triangle) between the squared speeds ``w`` (n + 1,) at its
    ends: entry, peak and exit speed and the durations of its three phases (closed forms)."""
    w0, w1 = w[:-1], w[1:]
    wp = np.minimum(nominal ** 2, 0.5 * (reach + w0 + w1))
    wp = np.maximum(wp, np.maximum(w0, w1))
    v0, v1, vp = np.sqrt(w0), np.sqrt(w1), np.sqrt(wp)
    t_acc = np.maximum(vp - v0, 0.0) / acc
    t_dec = np.maximum(vp - v1, 0.0) / acc
    d_acc = np.maximum(wp - w0, 0.0) / (2.0 * acc)
    d_dec = np.maximum(wp - w1, 0.0) / (2.0 * acc)
    d_cruise = np.maximum(length - d_acc - d_dec, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_cruise = np.where(vp > 0, d_cruise / vp, 0.0)
    return v0, vp, v1, t_acc, t_cruise, t_dec


def reachable_squared_speed(cap: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """The largest squared speeds w (n + 1,) with w_k ≤ cap_k and |w_k+1 − w_k| ≤ reach_k: the
    min-plus distance w_k = min_j (cap_j + |D_k − D_j|), D = cumulative reach, as a forward and a
    backward running minimum (the planner's two passes without a loop)."""
    d = np.concatenate([[0.0], np.cumsum(reach)])
    forward = d + np.minimum.accumulate(cap - d)
    backward = np.minimum.accumulate((cap + d)[::-1])[::-1] - d
    return np.maximum(np.minimum(forward, backward), 0.0)
