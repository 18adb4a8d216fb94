"""The cosine jerk-limited feed transition and the four block types of seed 000 (Table 1).

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
from collections.abc import Callable
from dataclasses import dataclass

#: Below this fraction of the block's peak feed, a short block uses approach 2 (a peak) instead of
#: approach 1 (a cruise at the higher end feed), which would crawl — or stand still between two stops.
SLOW_CRUISE = 1e-3
#: A feed change below this (mm/s) is none: no transition is planned for it.
NEGLIGIBLE_DV = 1e-200
#: Bisection steps for junction corrections: the bracket shrinks by 2**-60, below rounding.
BISECTION_STEPS = 60


def transition_time(v_s: float, v_e: float, acc: float, jerk: float) -> float:
    """Shortest duration of the cosine transition v_s → v_e under |a| ≤ acc, |j| ≤ jerk (eq. (20))."""
    dv = abs(v_e - v_s)
    if dv < NEGLIGIBLE_DV:  # a subnormal Δv would lose its digits in √(Δv/2J)
        return 0.0
    return max(math.pi * dv / (2.0 * acc), math.pi * math.sqrt(dv / (2.0 * jerk)))


def transition_distance(v_s: float, v_e: float, acc: float, jerk: float) -> float:
    """Distance travelled by that transition: (v_s + v_e)·T/2 (eq. (21))."""
    return 0.5 * (v_s + v_e) * transition_time(v_s, v_e, acc, jerk)


def stop_distance(feed: float, acc: float, jerk: float) -> float:
    """Distance of a full stop from ``feed`` (seed 000, eq. (22)): the least look-ahead length."""
    return transition_distance(feed, 0.0, acc, jerk)


def _bisect(holds: Callable[[float], bool], good: float, bad: float) -> float:
    """The speed nearest ``bad`` at which the monotone test ``holds`` is still true, by bisection
    between ``good`` (where it holds) and ``bad`` (where it fails) — the correction of seed 000."""
    for _ in range(BISECTION_STEPS):
        mid = 0.5 * (good + bad)
        if holds(mid):
            good = mid
        else:
            bad = mid
        if abs(bad - good) <= 1e-11 * max(good, bad, 1.0):
            break
    return good


def max_rise(v: float, length: float, acc: float, jerk: float) -> float:
    """Largest Δv ≥ 0 with transition_distance(v, v + Δv) ≤ length, in closed form.

    D = max(D_A, D_J) with D_A = (2v + Δv)·πΔv/(4A) (a quadratic in Δv) and
    D_J = (2v + Δv)·(π/2)·√(Δv/(2J)), a depressed cubic w³ + 2v·w − c = 0 in w = √Δv with
    c = 2L√(2J)/π (one real root, hyperbolic form); Δv is the smaller of the two roots.
    """
    if length <= 0.0:
        return 0.0
    q = 4.0 * acc * length / math.pi
    d_a = q / (v + math.sqrt(v * v + q))  # −v + √(v² + q) without cancellation
    c = 2.0 * length * math.sqrt(2.0 * jerk) / math.pi
    p = 2.0 * v
    if p * p * p <= 1e-12 * c * c:
        w = c ** (1.0 / 3.0)
    else:
        r = math.sqrt(p / 3.0)
        w = 2.0 * r * math.sinh(math.asinh(1.5 * c / (p * r)) / 3.0)
    for _ in range(2):  # Newton polish of the cubic
        f = w * w * w + p * w - c
        w -= f / (3.0 * w * w + p) if w > 0.0 else 0.0
    return max(min(d_a, w * w), 0.0)


def _bisect_speed(fixed: float, length: float, cap: float, acc: float, jerk: float) -> float:
    """Largest v in [fixed, cap] with transition_distance(fixed, v) ≤ length (monotone in v):
    the closed form of :func:`max_rise`, rounded down until the distance holds."""
    if cap <= fixed:
        return cap
    rise = max_rise(fixed, length, acc, jerk)
    if fixed + rise >= cap:
        return cap
    for shrink in (0.0, 1e-9, 1e-6, 1e-3):  # v = fixed + Δv rounds; keep the distance within length
        v = fixed + rise * (1.0 - shrink)
        if transition_distance(fixed, v, acc, jerk) <= length:
            return v
    return _bisect(lambda x: transition_distance(fixed, x, acc, jerk) <= length, fixed, v)


def max_end_speed(v_s: float, length: float, cap: float, acc: float, jerk: float) -> float:
    """Highest end speed ≤ cap reachable from v_s within ``length`` (type-4 end correction)."""
    return _bisect_speed(v_s, length, cap, acc, jerk)


def min_end_speed(v_s: float, length: float, acc: float, jerk: float) -> float:
    """Lowest end speed reachable from v_s within ``length`` (a deceleration can go no lower)."""
    if transition_distance(v_s, 0.0, acc, jerk) <= length:
        return 0.0
    # D(v_s, v) decreases towards v = v_s, where it is 0
    return _bisect(lambda v: transition_distance(v_s, v, acc, jerk) <= length, v_s, 0.0)


def lowest_end_speed(v_s: float, length: float, floor: float, acc: float, jerk: float) -> float:
    """An end speed near ``floor`` (≤ v_s) reachable from v_s by one transition within ``length``.

    The distance of a deceleration is not monotone in its end speed (a jerk-limited stop can be
    shorter than braking to a moderate feed: T grows with √Δv while the mean feed falls), so the
    feasible end speeds below v_s are [0, a] ∪ [b, v_s]. Returns ``floor`` if it is feasible, else
    the largest feasible speed below it (a, on the rising branch) when a stop fits, else b, the
    lowest feasible speed above it (bisection on the falling branch).
    """
    if floor >= v_s or transition_distance(v_s, floor, acc, jerk) <= length:
        return min(floor, v_s)
    if transition_distance(v_s, 0.0, acc, jerk) <= length:
        return _bisect(lambda v: transition_distance(v_s, v, acc, jerk) <= length, 0.0, floor)
    return _bisect(lambda v: transition_distance(v_s, v, acc, jerk) <= length, v_s, floor)


def peak_speed(v_s: float, v_e: float, length: float, cap: float, acc: float, jerk: float) -> float:
    """Highest v_p ≤ cap with D(v_s, v_p) + D(v_p, v_e) ≤ length (Table 1, approach 2)."""
    lo = max(v_s, v_e)

    def dist(v: float) -> float:
        return transition_distance(v_s, v, acc, jerk) + transition_distance(v, v_e, acc, jerk)

    if cap <= lo or dist(cap) <= length:
        return max(cap, lo)
    return _bisect(lambda v: dist(v) <= length, lo, cap)


def max_start_speed(v_e: float, length: float, cap: float, acc: float, jerk: float) -> float:
    """Highest start speed ≤ cap from which v_e is reachable within ``length`` (type-4 start
    correction; the distance of a transition is symmetric in its two speeds)."""
    return _bisect_speed(v_e, length, cap, acc, jerk)


@dataclass(frozen=True)
class Segment:
    """One piece of a feed profile: a cosine transition v0 → v1 (or a cruise, v0 = v1) of T s."""

    v0: float
    v1: float
    duration_s: float

    @property
    def length_mm(self) -> float:
        return 0.5 * (self.v0 + self.v1) * self.duration_s


def _rise_cruise_fall(v_s: float, v_top: float, v_e: float, cruise: float, acc: float,
                      jerk: float) -> list[Segment]:
    """Cosine rise v_s → v_top, a cruise of ``cruise`` mm at v_top, cosine fall v_top → v_e
    (pieces of zero length left out): the shape of seed 000's type 1 and of approach 2."""
    segs = []
    if v_top > v_s:
        segs.append(Segment(v_s, v_top, transition_time(v_s, v_top, acc, jerk)))
    if cruise > 0.0 and v_top > 0.0:
        segs.append(Segment(v_top, v_top, cruise / v_top))
    if v_top > v_e:
        segs.append(Segment(v_top, v_e, transition_time(v_top, v_e, acc, jerk)))
    return segs


def block_segments(length: float, v_s: float, v_e: float, v_max: float, acc: float,
                   jerk: float, approach: int = 1) -> tuple[int, list[Segment]]:
    """Block type (1-3) and its segments covering exactly ``length`` mm (seed 000, Table 1).

    ``approach`` 2 replaces approach 1 for types 2-3 by Table 1's figure (d): a peak feed between
    the two transitions instead of a cruise at the higher end feed (shorter, less smooth). Where
    either profile crosses a falling (rising) feed limit inside the block, the look-ahead splits
    the block there (a junction just under the limit) rather than flattening it.

    Raises ValueError for a type-4 block (v_e not reachable from v_s within ``length``): the
    look-ahead corrects junction speeds so that this does not happen.
    """
    v_max = max(v_max, v_s, v_e)
    if v_max <= 0.0:
        raise ValueError(f"block of {length} mm with a peak feed of 0 cannot be travelled")
    d_se = transition_distance(v_s, v_e, acc, jerk)
    if d_se > length * (1.0 + 1e-9) + 1e-12:
        raise ValueError(f"type-4 block: {v_s} -> {v_e} mm/s needs {d_se} mm, block is {length} mm")
    if d_se > length:  # rounding: shorten the transition to the block
        return (2 if v_e > v_s else 3), [Segment(v_s, v_e, 2.0 * length / (v_s + v_e))]
    d_up = transition_distance(v_s, v_max, acc, jerk)
    d_down = transition_distance(v_max, v_e, acc, jerk)
    segs: list[Segment] = []
    if d_up + d_down <= length:  # type 1
        return 1, _rise_cruise_fall(v_s, v_max, v_e, length - d_up - d_down, acc, jerk)
    cruise = max(length - d_se, 0.0)
    if (approach == 2 or max(v_s, v_e) <= SLOW_CRUISE * v_max) and cruise > 0.0:
        # approach 1 would crawl (or stand still) at the higher end speed: approach 2 instead,
        # a peak v_p between the two transitions (Table 1, figure (d))
        v_p = peak_speed(v_s, v_e, length, v_max, acc, jerk)
        rest = length - transition_distance(v_s, v_p, acc, jerk) - transition_distance(v_p, v_e, acc, jerk)
        return 2 if v_e > v_s else 3, _rise_cruise_fall(v_s, v_p, v_e, rest, acc, jerk)
    if v_s < v_e:  # type 2: accelerate, then cruise at the higher (end) speed
        segs.append(Segment(v_s, v_e, transition_time(v_s, v_e, acc, jerk)))
        if cruise > 0.0:
            segs.append(Segment(v_e, v_e, cruise / v_e))
        return 2, segs
    if cruise > 0.0:  # type 3: cruise at the higher (start) speed, then decelerate
        if v_s <= 0.0:
            raise ValueError(f"block of {length} mm cannot be travelled from rest to rest at 0 mm/s")
        segs.append(Segment(v_s, v_s, cruise / v_s))
    if v_s > v_e:
        segs.append(Segment(v_s, v_e, transition_time(v_s, v_e, acc, jerk)))
    return 3, segs


def segment_state(seg: Segment, tau):
    """s, v, a, j at times τ (array, 0 ≤ τ ≤ T) into a segment (seed 000, eq. (17)-(19))."""
    import numpy as np

    tau = np.asarray(tau, dtype=float)
    T = seg.duration_s
    dv = seg.v1 - seg.v0
    if dv == 0.0 or T == 0.0:
        z = np.zeros_like(tau)
        return seg.v0 * tau, np.full_like(tau, seg.v0), z, z
    w = math.pi / T
    c, s_ = np.cos(w * tau), np.sin(w * tau)
    v = seg.v0 + 0.5 * dv * (1.0 - c)
    pos = seg.v0 * tau + 0.5 * dv * (tau - s_ / w)
    a = 0.5 * dv * w * s_
    j = 0.5 * dv * w * w * c
    return pos, v, a, j
