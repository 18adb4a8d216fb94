"""Jerk-limited feed transitions between states that carry an acceleration: (v0, a0) → (v1, a1).

The transitions of slw/profile.py start and end at zero acceleration, so every junction of the
look-ahead window is a zero acceleration (issue 38). These are their generalisation, the velocity
part of the double-S with nonzero boundary accelerations (Biagiotti & Melchiorri, Trajectory
Planning for Automatic Machines and Robots, §3.4, the acceleration profile of the double S): the
acceleration goes a0 → a_p in a ramp of t1, holds a_p for t2, and goes a_p → a1 in a ramp of t3,
with |a| ≤ A throughout and |j| ≤ J.

- ``seven-phase``: the ramps at constant jerk ±J, t = |Δa|/J (the double S's acceleration phase,
  B&M §3.4); each ramp changes the feed by (a_i + a_e)·t/2. The time-optimal one (bang,
  coast at ±A, bang) is found in closed form: with σ the sign of v1 − v0 against the single ramp
  a0 → a1, a_p = σ·√((2J·σΔv + a0² + a1²)/2), saturated at ±A with the hold
  t2 = (σΔv − Δv_ramps(A))/A.
- ``cosine`` (the analogue of seed 000's eq. (16)-(19)): the first ramp a quarter sine,
  a = a0 + (a_p − a0)·sin(πτ/(2t1)), the last a quarter cosine, a = a1 + (a_p − a1)·cos(πτ/(2t3)),
  each with peak jerk π|Δa|/(2t) = J, so t = π|Δa|/(2J). With a0 = a1 = 0 and no hold the
  acceleration is a_p·sin(πτ/T) over T = t1 + t3: exactly seed 000's cosine transition where it
  is jerk-bound (T = π√(Δv/(2J)), eq. (20)); where the cosine is acceleration-bound, this one
  holds A between its ramps (as the seven-phase does) instead of stretching the sine, so it is
  never slower. A ramp changes the feed by t·(a_i + 2(a_p − a_i)/π) (quarter sine) or
  t·(a_e + 2(a_p − a_e)/π) (quarter cosine). Unlike the seven-phase, the single ramp a0 → a1
  has a feed change that depends on where its peak is: for a change between the two (a_p
  between a0 and a1) the feed change is linear in a_p at the same duration π|a1 − a0|/(2J).

The feed may pass outside [min(v0, v1), max(v0, v1)] on the way (an acceleration against the
change must first be undone): :func:`speed_range` gives the extremes; :func:`stop_distance_from`
is infinite when a stop from (v, a) would pass below zero feed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from fuzzyfeed.slw.profile import SEVEN_PHASE, check_shape

#: Boundary accelerations may exceed A by this share (rounding of the state they come from).
ACC_RTOL = 1e-9
_HALF_PI = 0.5 * math.pi


@dataclass(frozen=True)
class AccSegment:
    """A transition (v0, a0) → (v1, a1): ramp a0 → a_p (t1 s), hold a_p (t2 s), ramp a_p → a1
    (t3 s), of ``shape`` (module docstring)."""

    v0: float
    a0: float
    v1: float
    a1: float
    a_p: float
    t1: float
    t2: float
    t3: float
    shape: str = SEVEN_PHASE

    def __post_init__(self) -> None:
        check_shape(self.shape)
        for name in ("v0", "a0", "v1", "a1", "a_p", "t1", "t2", "t3"):
            x = getattr(self, name)
            if not math.isfinite(x):
                raise ValueError(f"AccSegment.{name} = {x!r}; must be finite")
        if min(self.t1, self.t2, self.t3) < 0.0:
            raise ValueError(f"AccSegment phase durations ({self.t1}, {self.t2}, {self.t3}) must be ≥ 0")

    @property
    def duration_s(self) -> float:
        return self.t1 + self.t2 + self.t3

    @property
    def length_mm(self) -> float:
        """Distance covered: the phases' closed forms (:func:`_phase_end`) summed."""
        s, v = 0.0, self.v0
        for kind, t, a_i, a_e in self.phases():
            ds, v_end = _phase_end(kind, t, a_i, a_e, v)
            s += ds
            v = v_end
        return s

    def state(self, tau):
        """s, v, a, j at times τ (:func:`acc_segment_state`; profile.segment_state calls it)."""
        return acc_segment_state(self, tau)

    def phases(self) -> tuple[tuple[str, float, float, float], ...]:
        """(kind, duration, a at its start, a at its end) of the three phases; kind ``lin`` (constant
        jerk), ``sin`` (quarter sine), ``cos`` (quarter cosine) or ``hold``."""
        first, last = ("lin", "lin") if self.shape == SEVEN_PHASE else ("sin", "cos")
        return ((first, self.t1, self.a0, self.a_p), ("hold", self.t2, self.a_p, self.a_p),
                (last, self.t3, self.a_p, self.a1))


def _ramp_dv(kind: str, t: float, a_i: float, a_e: float) -> float:
    """Feed change of a phase: (a_i + a_e)·t/2 (constant jerk), t·(a_i + 2Δa/π) (quarter sine from
    a_i), t·(a_e + 2(a_i − a_e)/π) (quarter cosine from a_i = a_p to a_e), a·t (hold)."""
    if kind == "lin" or kind == "hold":
        return 0.5 * (a_i + a_e) * t
    if kind == "sin":
        return t * (a_i + (a_e - a_i) / _HALF_PI)
    return t * (a_e + (a_i - a_e) / _HALF_PI)


def _phase_end(kind: str, t: float, a_i: float, a_e: float, v_i: float) -> tuple[float, float]:
    """(distance, feed) at the end of a phase entered at feed v_i (:func:`_phase_state` at τ = t)."""
    if kind == "lin" or kind == "hold":
        return v_i * t + a_i * t * t / 2.0 + (a_e - a_i) * t * t / 6.0, v_i + _ramp_dv(kind, t, a_i, a_e)
    w = 1.0 / _HALF_PI * t        # 2t/π
    if kind == "sin":  # a = a_i + Δa·sin(πτ/2t): s = v_i·t + a_i·t²/2 + Δa·w·(t − w)
        return v_i * t + a_i * t * t / 2.0 + (a_e - a_i) * w * (t - w), v_i + _ramp_dv(kind, t, a_i, a_e)
    # a = a_e + (a_i − a_e)·cos(πτ/2t): s = v_i·t + a_e·t²/2 + (a_i − a_e)·w²
    return v_i * t + a_e * t * t / 2.0 + (a_i - a_e) * w * w, v_i + _ramp_dv(kind, t, a_i, a_e)


def _phase_state(kind: str, t: float, a_i: float, a_e: float, v_i: float, tau):
    """s, v, a, j at τ (array, 0 ≤ τ ≤ t) into a phase entered at s = 0, feed v_i."""
    import numpy as np

    tau = np.asarray(tau, dtype=float)
    da = a_e - a_i
    if kind == "hold" or t < 1e-200:  # a subnormal ramp is none (π/2t would overflow)
        a = np.full_like(tau, a_i)
        return v_i * tau + 0.5 * a_i * tau * tau, v_i + a_i * tau, a, np.zeros_like(tau)
    if kind == "lin":
        j = da / t
        return (v_i * tau + 0.5 * a_i * tau * tau + j * tau ** 3 / 6.0, v_i + a_i * tau + 0.5 * j * tau * tau,
                a_i + j * tau, np.full_like(tau, j))
    k = _HALF_PI / t
    sn, cs = np.sin(k * tau), np.cos(k * tau)
    if kind == "sin":  # a = a_i + Δa·sin(kτ)
        return (v_i * tau + 0.5 * a_i * tau * tau + da / k * (tau - sn / k), v_i + a_i * tau + da / k * (1.0 - cs),
                a_i + da * sn, da * k * cs)
    # a = a_e + (a_i − a_e)·cos(kτ)
    d = a_i - a_e
    return (v_i * tau + 0.5 * a_e * tau * tau + d / (k * k) * (1.0 - cs), v_i + a_e * tau + d / k * sn,
            a_e + d * cs, -d * k * sn)


def _no_hold_dv(a_p: float, a0: float, a1: float, jerk: float, seven: bool) -> float:
    """Feed change of ramp a0 → a_p, ramp a_p → a1 (no hold), for a_p ≥ max(a0, a1): a quadratic in
    a_p ((2a_p² − a0² − a1²)/2J for the seven-phase; the cosine's, module docstring)."""
    if seven:
        return (2.0 * a_p * a_p - a0 * a0 - a1 * a1) / (2.0 * jerk)
    return (2.0 * a_p * a_p + (_HALF_PI - 2.0) * (a0 + a1) * a_p
            + (1.0 - _HALF_PI) * (a0 * a0 + a1 * a1)) / jerk


def _up(a0: float, a1: float, dv: float, acc: float, jerk: float, seven: bool) -> tuple[float, float]:
    """(a_p, hold) of the shortest transition with a_p ≥ max(a0, a1) changing the feed by dv ≥
    _no_hold_dv(max(a0, a1)): the larger root of the quadratic, or a_p = A and a hold."""
    if dv <= _no_hold_dv(max(a0, a1), a0, a1, jerk, seven):
        # the single ramp a0 → a1 (when the quadratic falls first, a0, a1 < 0, its larger root
        # would be another, longer, transition with the same feed change)
        return max(a0, a1), 0.0
    # J·Δv = qa·a_p² + qb·a_p + qc (_no_hold_dv)
    qa, qb, qc = (1.0, 0.0, -0.5 * (a0 * a0 + a1 * a1)) if seven else \
        (2.0, (_HALF_PI - 2.0) * (a0 + a1), (1.0 - _HALF_PI) * (a0 * a0 + a1 * a1))
    c = qc - dv * jerk  # ≤ 0 on the rising branch
    a_p = (-qb + math.sqrt(max(qb * qb - 4.0 * qa * c, 0.0))) / (2.0 * qa)
    a_p = max(a_p, a0, a1)
    if a_p <= acc:
        return a_p, 0.0
    return acc, max(dv - _no_hold_dv(acc, a0, a1, jerk, seven), 0.0) / acc


def acc_transition(v0: float, a0: float, v1: float, a1: float, acc: float, jerk: float,
                   shape: str = SEVEN_PHASE) -> AccSegment:
    """The shortest transition (v0, a0) → (v1, a1) of ``shape`` under |a| ≤ acc, |j| ≤ jerk
    (module docstring). ValueError if |a0| or |a1| is over ``acc``."""
    check_shape(shape)
    for name, x in (("v0", v0), ("a0", a0), ("v1", v1), ("a1", a1), ("acc", acc), ("jerk", jerk)):
        if not math.isfinite(x):
            raise ValueError(f"acc_transition: {name} = {x!r}; must be finite")
    if acc <= 0.0 or jerk <= 0.0:
        raise ValueError(f"acc_transition: acc = {acc}, jerk = {jerk}; both must be > 0")
    if max(abs(a0), abs(a1)) > acc * (1.0 + ACC_RTOL):
        raise ValueError(f"acc_transition: boundary accelerations ({a0}, {a1}) over acc = {acc}")
    a0, a1 = max(min(a0, acc), -acc), max(min(a1, acc), -acc)
    seven = shape == SEVEN_PHASE
    c = 1.0 if seven else _HALF_PI
    dv = v1 - v0
    hi, lo = max(a0, a1), min(a0, a1)
    up_direct = _no_hold_dv(hi, a0, a1, jerk, seven)
    down_direct = -_no_hold_dv(-lo, -a0, -a1, jerk, seven)
    if dv >= up_direct:
        a_p, t2 = _up(a0, a1, dv, acc, jerk, seven)
    elif dv <= down_direct:
        a_p, t2 = _up(-a0, -a1, -dv, acc, jerk, seven)
        a_p = -a_p
    else:  # cosine only (the seven-phase's two are equal): a_p between a0 and a1, no hold, where
        # Δv = |a1 − a0|/J·[(π/2 − 1)(a0 + a1) + (2 − π/2)·a_p], increasing in a_p
        # (a0 = a1: the two directs differ by rounding only, the transition is none)
        a_p = lo if hi == lo else (dv * jerk / (hi - lo) - (_HALF_PI - 1.0) * (a0 + a1)) / (2.0 - _HALF_PI)
        a_p, t2 = min(max(a_p, lo), hi), 0.0
    return AccSegment(v0, a0, v1, a1, a_p, c * abs(a_p - a0) / jerk, t2, c * abs(a_p - a1) / jerk, shape)


def acc_transition_time(v0: float, a0: float, v1: float, a1: float, acc: float, jerk: float,
                        shape: str = SEVEN_PHASE) -> float:
    """Duration of :func:`acc_transition`."""
    return acc_transition(v0, a0, v1, a1, acc, jerk, shape).duration_s


def acc_transition_distance(v0: float, a0: float, v1: float, a1: float, acc: float, jerk: float,
                            shape: str = SEVEN_PHASE) -> float:
    """Distance of :func:`acc_transition` (closed form, AccSegment.length_mm)."""
    return acc_transition(v0, a0, v1, a1, acc, jerk, shape).length_mm


def speed_range(seg: AccSegment) -> tuple[float, float]:
    """(lowest, highest) feed of the transition: its ends and the feed where a crosses 0."""
    lo = hi = seg.v0
    v = seg.v0
    for kind, t, a_i, a_e in seg.phases():
        if t > 0.0 and a_i * a_e < 0.0 and kind != "hold":
            if kind == "lin":
                tau = t * a_i / (a_i - a_e)
            elif kind == "sin":
                tau = t / _HALF_PI * math.asin(-a_i / (a_e - a_i))
            else:
                tau = t / _HALF_PI * math.acos(-a_e / (a_i - a_e))
            _, v_z, _, _ = _phase_state(kind, t, a_i, a_e, v, [tau])
            lo, hi = min(lo, float(v_z[0])), max(hi, float(v_z[0]))
        v = _phase_end(kind, t, a_i, a_e, v)[1]
        lo, hi = min(lo, v), max(hi, v)
    return lo, hi


def stop_distance_from(v: float, a: float, acc: float, jerk: float, shape: str = SEVEN_PHASE) -> float:
    """Distance of the hardest stop from feed v at acceleration a, (v, a) → (0, 0): the least
    look-ahead a window ending in (v, a) leaves the next one; infinite when no stop from there
    keeps the feed ≥ 0 (a deceleration too strong to undo before the feed reaches zero)."""
    seg = acc_transition(v, a, 0.0, 0.0, acc, jerk, shape)
    if speed_range(seg)[0] < -1e-9 * max(abs(v), 1.0):
        return math.inf
    return seg.length_mm


def acc_segment_state(seg: AccSegment, tau):
    """s, v, a, j at times τ (array, 0 ≤ τ ≤ T) into the transition, phase by phase."""
    import numpy as np

    tau = np.clip(np.asarray(tau, dtype=float), 0.0, seg.duration_s)
    s_out, v_out = np.zeros_like(tau), np.zeros_like(tau)
    a_out, j_out = np.zeros_like(tau), np.zeros_like(tau)
    t0, s0, v0 = 0.0, 0.0, seg.v0
    phases = seg.phases()
    for n, (kind, t, a_i, a_e) in enumerate(phases):
        last = n == len(phases) - 1
        sel = (tau >= t0) & ((tau <= t0 + t) if last else (tau < t0 + t))
        if sel.any():
            s, v, a, j = _phase_state(kind, t, a_i, a_e, v0, tau[sel] - t0)
            s_out[sel], v_out[sel], a_out[sel], j_out[sel] = s0 + s, v, a, j
        ds, v0 = _phase_end(kind, t, a_i, a_e, v0)
        s0 += ds
        t0 += t
    return s_out, v_out, a_out, j_out
