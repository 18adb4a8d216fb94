"""The jerk-limited feed transitions and the four block types of seed 000 (Table 1).

Two transition shapes (``shape``): ``"cosine"`` is seed 000's, below; ``"seven-phase"`` is the
classic trapezoidal-acceleration (S-curve) ramp — jerk ±J through its two ramps, acceleration
held at A between them — with T = Δv/A + A/J when Δv ≥ A²/J, else 2·√(Δv/J). Both are symmetric
in time, so both cover (v_s + v_e)·T/2; the seven-phase ramp is the shorter (its jerk is J all
through its ramps, the cosine's only at its ends: π/2 = 1.57 against 1 + A²/(JΔv) on the
acceleration-limited side, π/√2 = 2.22 against 2 on the jerk-limited side).

A transition from v_s to v_e over T seconds follows v(τ) = v_s + Δv·(1 − cos(πτ/T))/2
(seed 000, eq. (16)-(17)); its peak acceleration is π|Δv|/(2T) and its peak jerk π²|Δv|/(2T²)
(eq. (18)-(19)), so the shortest T under A and J is max(π|Δv|/(2A), π·√(|Δv|/(2J))) (eq. (20)) and
the distance covered is (v_s + v_e)·T/2 (eq. (21)).

A block of length S between two junctions is one of (approach 1 for types 2-3):
1. long: accelerate v_s → v_m, cruise at v_m, decelerate v_m → v_e;
2. short, v_s < v_e: accelerate v_s → v_e, cruise at v_e (the cruise at the higher-speed end);
3. short, v_s ≥ v_e: cruise at v_s, decelerate v_s → v_e;
4. too short for v_s → v_e at all: not schedulable; the junction speed is corrected by bisection
   (:func:`max_end_speed`, :func:`max_start_speed`; Heng & Erkorkmaz, seed 000 ref. 21).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: Below this fraction of the block's peak feed, a short block uses approach 2 (a peak) instead of
#: approach 1 (a cruise at the higher end feed), which would crawl — or stand still between two stops.
SLOW_CRUISE = 1e-3
#: A feed change below this (mm/s) is none: no transition is planned for it.
NEGLIGIBLE_DV = 1e-200
#: Bisection steps for junction corrections: the bracket shrinks by 2**-60, below rounding.
BISECTION_STEPS = 60
#: The transition shapes: seed 000's cosine, and the seven-phase (trapezoidal-acceleration) ramp.
COSINE = "cosine"
SEVEN_PHASE = "seven-phase"
TRANSITIONS = (SEVEN_PHASE, COSINE)


def check_shape(shape: str) -> str:
    if shape not in TRANSITIONS:
        raise ValueError(f"transition = {shape!r}; use one of {', '.join(TRANSITIONS)}")
    return shape


def transition_time(v_s: float, v_e: float, acc: float, jerk: float, shape: str = COSINE) -> float:
    """Shortest duration of the transition v_s → v_e under |a| ≤ acc, |j| ≤ jerk: the cosine's
    (eq. (20)) or the seven-phase ramp's (module docstring)."""
    dv = abs(v_e - v_s)
    if dv < NEGLIGIBLE_DV:  # a subnormal Δv would lose its digits in √(Δv/2J)
        return 0.0
    if shape == SEVEN_PHASE:
        return dv / acc + acc / jerk if dv * jerk >= acc * acc else 2.0 * math.sqrt(dv / jerk)
    return max(math.pi * dv / (2.0 * acc), math.pi * math.sqrt(dv / (2.0 * jerk)))


def transition_distance(v_s: float, v_e: float, acc: float, jerk: float, shape: str = COSINE) -> float:
    """Distance travelled by that transition: (v_s + v_e)·T/2 (eq. (21); both shapes)."""
    return 0.5 * (v_s + v_e) * transition_time(v_s, v_e, acc, jerk, shape)


def stop_distance(feed: float, acc: float, jerk: float, shape: str = COSINE) -> float:
    """Distance of a full stop from ``feed`` (seed 000, eq. (22)): the least look-ahead length."""
    return transition_distance(feed, 0.0, acc, jerk, shape)


def _depressed_cubic(p: float, c: float) -> float:
    """The real root w ≥ 0 of w³ + p·w − c = 0 (p, c ≥ 0; hyperbolic form, Newton-polished)."""
    if p * p * p <= 1e-12 * c * c:
        w = c ** (1.0 / 3.0)
    else:
        r = math.sqrt(p / 3.0)
        w = 2.0 * r * math.sinh(math.asinh(1.5 * c / (p * r)) / 3.0)
    for _ in range(2):  # Newton polish of the cubic
        f = w * w * w + p * w - c
        w -= f / (3.0 * w * w + p) if w > 0.0 else 0.0
    return w


def max_rise(v: float, length: float, acc: float, jerk: float, shape: str = COSINE) -> float:
    """Largest Δv ≥ 0 with transition_distance(v, v + Δv) ≤ length, in closed form.

    Seven-phase: D = (2v + Δv)·√(Δv/J) while Δv ≤ A²/J (the cubic w³ + 2v·w − L√J = 0 in
    w = √Δv), else D = (2v + Δv)(Δv/A + A/J)/2 (a quadratic in Δv). Cosine: D = max(D_A, D_J) with D_A = (2v + Δv)·πΔv/(4A) (a quadratic in Δv) and
    D_J = (2v + Δv)·(π/2)·√(Δv/(2J)), a depressed cubic w³ + 2v·w − c = 0 in w = √Δv with
    c = 2L√(2J)/π (one real root, hyperbolic form); Δv is the smaller of the two roots.
    """
    if length <= 0.0:
        return 0.0
    if shape == SEVEN_PHASE:
        w = _depressed_cubic(2.0 * v, length * math.sqrt(jerk))
        if w * w * jerk <= acc * acc:
            return max(w * w, 0.0)
        # Δv²/A + Δv·(2v/A + A/J) + 2vA/J − 2L = 0, the positive root without cancellation
        b = 2.0 * v / acc + acc / jerk
        c0 = 2.0 * length - 2.0 * v * acc / jerk  # > 0: the cubic's branch ended below L
        return max(2.0 * c0 / (b + math.sqrt(b * b + 4.0 * c0 / acc)), 0.0)
    q = 4.0 * acc * length / math.pi
    d_a = q / (v + math.sqrt(v * v + q))  # −v + √(v² + q) without cancellation
    w = _depressed_cubic(2.0 * v, 2.0 * length * math.sqrt(2.0 * jerk) / math.pi)
    return max(min(d_a, w * w), 0.0)


def _bisect_speed(fixed: float, length: float, cap: float, acc: float, jerk: float,
                  shape: str = COSINE) -> float:
    """Largest v in [fixed, cap] with transition_distance(fixed, v) ≤ length (monotone in v):
    the closed form of :func:`max_rise`, rounded down until the distance holds."""
    if cap <= fixed:
        return cap
    rise = max_rise(fixed, length, acc, jerk, shape)
    if fixed + rise >= cap:
        return cap
    for shrink in (0.0, 1e-9, 1e-6, 1e-3):  # v = fixed + Δv rounds; keep the distance within length
        v = fixed + rise * (1.0 - shrink)
        if transition_distance(fixed, v, acc, jerk, shape) <= length:
            return v
    return _bisect_end(fixed, length, fixed, v, acc, jerk, shape)


def max_end_speed(v_s: float, length: float, cap: float, acc: float, jerk: float,
                  shape: str = COSINE) -> float:
    """Highest end speed ≤ cap reachable from v_s within ``length`` (type-4 end correction)."""
    return _bisect_speed(v_s, length, cap, acc, jerk, shape)


def _k():
    """The compiled transition kernels (numba is imported on first use, not with this module)."""
    import fuzzyfeed.slw._kernels as kernels

    return kernels


def _bisect_end(v_s: float, length: float, good: float, bad: float, acc: float, jerk: float,
                shape: str) -> float:
    """_bisect of transition_distance(v_s, v) ≤ length, compiled (_kernels.bisect_end)."""
    return float(_k().bisect_end(float(v_s), float(length), float(good), float(bad), float(acc),
                                 float(jerk), shape == SEVEN_PHASE, BISECTION_STEPS))


def min_end_speed(v_s: float, length: float, acc: float, jerk: float,
                  shape: str = COSINE) -> float:
    """Lowest end speed reachable from v_s within ``length`` (a deceleration can go no lower)."""
    if transition_distance(v_s, 0.0, acc, jerk, shape) <= length:
        return 0.0
    # D(v_s, v) decreases towards v = v_s, where it is 0
    return _bisect_end(v_s, length, v_s, 0.0, acc, jerk, shape)


def lowest_end_speed(v_s: float, length: float, floor: float, acc: float, jerk: float,
                     shape: str = COSINE) -> float:
    """An end speed near ``floor`` (≤ v_s) reachable from v_s by one transition within ``length``.

    The distance of a deceleration is not monotone in its end speed (a jerk-limited stop can be
    shorter than braking to a moderate feed: T grows with √Δv while the mean feed falls), so the
    feasible end speeds below v_s are [0, a] ∪ [b, v_s]. Returns ``floor`` if it is feasible, else
    the largest feasible speed below it (a, on the rising branch) when a stop fits, else b, the
    lowest feasible speed above it (bisection on the falling branch).
    """
    if floor >= v_s or transition_distance(v_s, floor, acc, jerk, shape) <= length:
        return min(floor, v_s)
    if transition_distance(v_s, 0.0, acc, jerk, shape) <= length:
        return _bisect_end(v_s, length, 0.0, floor, acc, jerk, shape)
    return _bisect_end(v_s, length, v_s, floor, acc, jerk, shape)


def peak_speed(v_s: float, v_e: float, length: float, cap: float, acc: float, jerk: float,
               shape: str = COSINE, acc_down: float | None = None) -> float:
    """Highest v_p ≤ cap with D(v_s, v_p) + D(v_p, v_e) ≤ length (Table 1, approach 2); the rise
    under ``acc``, the fall under ``acc_down`` (default ``acc``)."""
    lo = max(v_s, v_e)
    acc_down = acc if acc_down is None else acc_down

    def dist(v: float) -> float:
        return transition_distance(v_s, v, acc, jerk, shape) + transition_distance(v, v_e, acc_down, jerk, shape)

    if cap <= lo or dist(cap) <= length:
        return max(cap, lo)
    return float(_k().bisect_peak(float(v_s), float(v_e), float(length), float(lo), float(cap), float(acc),
                                  float(jerk), shape == SEVEN_PHASE, BISECTION_STEPS, float(acc_down)))


def max_start_speed(v_e: float, length: float, cap: float, acc: float, jerk: float,
                    shape: str = COSINE) -> float:
    """Highest start speed ≤ cap from which v_e is reachable within ``length`` (type-4 start
    correction; the distance of a transition is symmetric in its two speeds)."""
    return _bisect_speed(v_e, length, cap, acc, jerk, shape)


@dataclass(frozen=True)
class Segment:
    """One piece of a feed profile: a transition v0 → v1 (or a cruise, v0 = v1) of T s — seed
    000's cosine, or with ``jerk_mm_s3`` the seven-phase ramp under that jerk."""

    v0: float
    v1: float
    duration_s: float
    jerk_mm_s3: float | None = None

    @property
    def length_mm(self) -> float:
        return 0.5 * (self.v0 + self.v1) * self.duration_s


def peak_acceleration(seg: Segment) -> float:
    """Largest |a| of a segment: π|Δv|/(2T) for the cosine, a_p = |Δv|/(T − t_j) for the
    seven-phase ramp (:func:`_seven_phase_state`), 0 for a cruise."""
    dv = abs(seg.v1 - seg.v0)
    if dv == 0.0 or seg.duration_s == 0.0:
        return 0.0
    if seg.jerk_mm_s3 is None:
        return math.pi * dv / (2.0 * seg.duration_s)
    T = seg.duration_s
    t_j = 0.5 * (T - math.sqrt(max(T * T - 4.0 * dv / seg.jerk_mm_s3, 0.0)))
    return dv / (T - t_j)


def _transition(v0: float, v1: float, duration_s: float, jerk: float, shape: str) -> Segment:
    return Segment(v0, v1, duration_s, jerk if shape == SEVEN_PHASE else None)


def _rise_cruise_fall(v_s: float, v_top: float, v_e: float, cruise: float, acc: float,
                      jerk: float, shape: str, acc_down: float) -> list[Segment]:
    """Rise v_s → v_top (under ``acc``), a cruise of ``cruise`` mm at v_top, fall v_top → v_e
    (under ``acc_down``; pieces of zero length left out): the shape of seed 000's type 1 and of
    approach 2."""
    segs = []
    if v_top > v_s:
        segs.append(_transition(v_s, v_top, transition_time(v_s, v_top, acc, jerk, shape), jerk, shape))
    if cruise > 0.0 and v_top > 0.0:
        segs.append(Segment(v_top, v_top, cruise / v_top))
    if v_top > v_e:
        segs.append(_transition(v_top, v_e, transition_time(v_top, v_e, acc_down, jerk, shape), jerk, shape))
    return segs


def block_segments(length: float, v_s: float, v_e: float, v_max: float, acc: float,
                   jerk: float, approach: int = 1, shape: str = COSINE,
                   acc_down: float | None = None) -> tuple[int, list[Segment]]:
    """Block type (1-3) and its segments covering exactly ``length`` mm (seed 000, Table 1), with
    transitions of ``shape``.

    ``approach`` 2 replaces approach 1 for types 2-3 by Table 1's figure (d): a peak feed between
    the two transitions instead of a cruise at the higher end feed (shorter, less smooth). Where
    either profile crosses a falling (rising) feed limit inside the block, the look-ahead splits
    the block there (a junction just under the limit) rather than flattening it.

    Rises are planned under ``acc``, falls under ``acc_down`` (default ``acc``: seed 000's one
    tangential acceleration per block).

    Raises ValueError for a type-4 block (v_e not reachable from v_s within ``length``): the
    look-ahead corrects junction speeds so that this does not happen.
    """
    v_max = max(v_max, v_s, v_e)
    if v_max <= 0.0:
        raise ValueError(f"block of {length} mm with a peak feed of 0 cannot be travelled")
    acc_down = acc if acc_down is None else acc_down
    acc_se = acc if v_e > v_s else acc_down
    d_se = transition_distance(v_s, v_e, acc_se, jerk, shape)
    if d_se > length * (1.0 + 1e-9) + 1e-12:
        raise ValueError(f"type-4 block: {v_s} -> {v_e} mm/s needs {d_se} mm, block is {length} mm")
    if d_se > length:  # rounding: shorten the transition to the block
        return (2 if v_e > v_s else 3), [_transition(v_s, v_e, 2.0 * length / (v_s + v_e), jerk, shape)]
    d_up = transition_distance(v_s, v_max, acc, jerk, shape)
    d_down = transition_distance(v_max, v_e, acc_down, jerk, shape)
    segs: list[Segment] = []
    if d_up + d_down <= length:  # type 1
        return 1, _rise_cruise_fall(v_s, v_max, v_e, length - d_up - d_down, acc, jerk, shape, acc_down)
    cruise = max(length - d_se, 0.0)
    if (approach == 2 or max(v_s, v_e) <= SLOW_CRUISE * v_max) and cruise > 0.0:
        # approach 1 would crawl (or stand still) at the higher end speed: approach 2 instead,
        # a peak v_p between the two transitions (Table 1, figure (d))
        v_p = peak_speed(v_s, v_e, length, v_max, acc, jerk, shape, acc_down)
        rest = (length - transition_distance(v_s, v_p, acc, jerk, shape)
                - transition_distance(v_p, v_e, acc_down, jerk, shape))
        return 2 if v_e > v_s else 3, _rise_cruise_fall(v_s, v_p, v_e, rest, acc, jerk, shape, acc_down)
    if v_s < v_e:  # type 2: accelerate, then cruise at the higher (end) speed
        segs.append(_transition(v_s, v_e, transition_time(v_s, v_e, acc, jerk, shape), jerk, shape))
        if cruise > 0.0:
            segs.append(Segment(v_e, v_e, cruise / v_e))
        return 2, segs
    if cruise > 0.0:  # type 3: cruise at the higher (start) speed, then decelerate
        if v_s <= 0.0:
            raise ValueError(f"block of {length} mm cannot be travelled from rest to rest at 0 mm/s")
        segs.append(Segment(v_s, v_s, cruise / v_s))
    if v_s > v_e:
        segs.append(_transition(v_s, v_e, transition_time(v_s, v_e, acc_down, jerk, shape), jerk, shape))
    return 3, segs


def segment_state(seg: Segment, tau):
    """s, v, a, j at times τ (array, 0 ≤ τ ≤ T) into a segment: the cosine of seed 000
    (eq. (17)-(19)), or the seven-phase ramp (:func:`_seven_phase_state`); a transition between
    states with acceleration (slw/acc_profile.AccSegment) phase by phase."""
    import numpy as np

    if not isinstance(seg, Segment):  # an AccSegment (its own phases; no import back here)
        return seg.state(tau)

    tau = np.asarray(tau, dtype=float)
    T = seg.duration_s
    dv = seg.v1 - seg.v0
    if dv == 0.0 or T == 0.0:
        z = np.zeros_like(tau)
        return seg.v0 * tau, np.full_like(tau, seg.v0), z, z
    if seg.jerk_mm_s3 is not None:
        return _seven_phase_state(seg, tau)
    w = math.pi / T
    c, s_ = np.cos(w * tau), np.sin(w * tau)
    v = seg.v0 + 0.5 * dv * (1.0 - c)
    pos = seg.v0 * tau + 0.5 * dv * (tau - s_ / w)
    a = 0.5 * dv * w * s_
    j = 0.5 * dv * w * w * c
    return pos, v, a, j


def segment_table(segs: list):
    """Per segment its kind (0 cruise, 1 cosine, 2 seven-phase, 3 other: an AccSegment) and the
    numbers :func:`segment_state` computes from it, in Python floats as there (for
    :func:`segments_state`)."""
    import numpy as np

    n = len(segs)
    # per segment: 0 cruise, 1 cosine, 2 seven-phase, 3 other (AccSegment); and their numbers
    kind = np.zeros(n, dtype=np.int8)
    p = np.zeros((n, 11))   # v0, v1, T, w (t_j), h·w (a_p), h·w·w (jr), h (total), sign·jr, sign·½·jr, v_j, s_j
    for i, seg in enumerate(segs):
        if not isinstance(seg, Segment):
            kind[i] = 3
            continue
        T, dv = seg.duration_s, seg.v1 - seg.v0
        if dv == 0.0 or T == 0.0:
            p[i, 0] = seg.v0
        elif seg.jerk_mm_s3 is None:
            w = math.pi / T
            kind[i] = 1
            p[i, :7] = seg.v0, seg.v1, T, w, 0.5 * dv * w, 0.5 * dv * w * w, 0.5 * dv
        else:
            sign = 1.0 if dv > 0 else -1.0
            mag = abs(dv)
            t_j = 0.5 * (T - math.sqrt(max(T * T - 4.0 * mag / seg.jerk_mm_s3, 0.0)))
            a_p = mag / (T - t_j)
            jr = a_p / t_j
            kind[i] = 2
            p[i] = (seg.v0, seg.v1, T, t_j, a_p, jr, 0.5 * (seg.v0 + seg.v1) * T, sign * jr,
                    sign * 0.5 * jr, seg.v0 + sign * 0.5 * a_p * t_j, seg.v0 * t_j + sign * jr * t_j ** 3 / 6.0)
    return kind, p


def segments_state(segs: list, table, which, tau):
    """s (from each segment's start), v, a, j at times τ_k into segments ``segs[which_k]``
    (``table`` their :func:`segment_table`): the arithmetic of :func:`segment_state` in the same
    order on all the times at once, so the floats are its own; an AccSegment is read segment by
    segment (its own phases)."""
    import numpy as np

    kind, p = table
    tau = np.asarray(tau, dtype=float)
    pos, v, a, j = (np.zeros(tau.size) for _ in range(4))
    k = kind[which]
    at = which[k == 0]
    x, v0 = tau[k == 0], p[at, 0]
    pos[k == 0], v[k == 0] = v0 * x, v0
    sel = k == 1
    if sel.any():
        at = which[sel]
        x, v0, w, h = tau[sel], p[at, 0], p[at, 3], p[at, 6]
        c, s_ = np.cos(w * x), np.sin(w * x)
        v[sel] = v0 + h * (1.0 - c)
        pos[sel] = v0 * x + h * (x - s_ / w)
        a[sel] = p[at, 4] * s_
        j[sel] = p[at, 5] * c
    sel = k == 2
    if sel.any():
        v0, v1, T, t_j, a_p, jr, total, sjr, shj, v_j, s_j = p[which[sel]].T
        sign = np.where(v1 - v0 > 0, 1.0, -1.0)
        x = np.clip(tau[sel], 0.0, T)
        r = T - x
        first, last = x < t_j, r < t_j
        m = x - t_j
        pos[sel] = np.where(first, v0 * x + sjr * x ** 3 / 6.0,
                            np.where(last, total - (v1 * r - sjr * r ** 3 / 6.0),
                                     s_j + v_j * m + sign * 0.5 * a_p * m * m))
        v[sel] = np.where(first, v0 + shj * x * x, np.where(last, v1 - shj * r * r, v_j + sign * a_p * m))
        a[sel] = sign * np.where(first, jr * x, np.where(last, jr * r, a_p))
        j[sel] = sign * np.where(first, jr, np.where(last, -jr, 0.0))
    for i in np.unique(which[k == 3]).tolist():
        sel = which == i
        pos[sel], v[sel], a[sel], j[sel] = segment_state(segs[i], tau[sel])
    return pos, v, a, j


def _seven_phase_state(seg: Segment, tau):
    """s, v, a, j of the seven-phase ramp v0 → v1 over T: jerk ±J' for t_j at either end,
    acceleration a_p between, with Δv = a_p·(T − t_j) and a_p = J'·t_j, so
    t_j = (T − √(T² − 4|Δv|/J))/2 (J' = J; a ramp shortened by rounding to T < 2√(|Δv|/J) has
    t_j = T/2 and J' = 4|Δv|/T², a rounding above J). Symmetric in time: the last ramp mirrors the
    first about (T/2, (v0 + v1)/2)."""
    import numpy as np

    T = seg.duration_s
    dv = seg.v1 - seg.v0
    sign = 1.0 if dv > 0 else -1.0
    mag = abs(dv)
    t_j = 0.5 * (T - math.sqrt(max(T * T - 4.0 * mag / seg.jerk_mm_s3, 0.0)))
    a_p = mag / (T - t_j)
    jr = a_p / t_j
    tau = np.clip(tau, 0.0, T)
    r = T - tau
    total = 0.5 * (seg.v0 + seg.v1) * T
    v_j = seg.v0 + sign * 0.5 * a_p * t_j          # feed at the end of the first ramp
    s_j = seg.v0 * t_j + sign * jr * t_j ** 3 / 6.0
    first, last = tau < t_j, r < t_j
    m = tau - t_j
    pos = np.where(first, seg.v0 * tau + sign * jr * tau ** 3 / 6.0,
                   np.where(last, total - (seg.v1 * r - sign * jr * r ** 3 / 6.0),
                            s_j + v_j * m + sign * 0.5 * a_p * m * m))
    v = np.where(first, seg.v0 + sign * 0.5 * jr * tau * tau,
                 np.where(last, seg.v1 - sign * 0.5 * jr * r * r, v_j + sign * a_p * m))
    a = sign * np.where(first, jr * tau, np.where(last, jr * r, a_p))
    j = sign * np.where(first, jr, np.where(last, -jr, 0.0))
    return pos, v, a, j
