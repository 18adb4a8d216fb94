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
from dataclasses import dataclass

#: Bisection steps for junction corrections: the bracket shrinks by 2**-60, below rounding.
BISECTION_STEPS = 60


def transition_time(v_s: float, v_e: float, acc: float, jerk: float) -> float:
    """Shortest duration of the cosine transition v_s → v_e under |a| ≤ acc, |j| ≤ jerk (eq. (20))."""
    dv = abs(v_e - v_s)
    if dv == 0.0:
        return 0.0
    return max(math.pi * dv / (2.0 * acc), math.pi * math.sqrt(dv / (2.0 * jerk)))


def transition_distance(v_s: float, v_e: float, acc: float, jerk: float) -> float:
    """Distance travelled by that transition: (v_s + v_e)·T/2 (eq. (21))."""
    return 0.5 * (v_s + v_e) * transition_time(v_s, v_e, acc, jerk)


def stop_distance(feed: float, acc: float, jerk: float) -> float:
    """Distance of a full stop from ``feed`` (seed 000, eq. (22)): the least look-ahead length."""
    return transition_distance(feed, 0.0, acc, jerk)


def _bisect_speed(fixed: float, length: float, cap: float, acc: float, jerk: float) -> float:
    """Largest v in [fixed, cap] with transition_distance(fixed, v) ≤ length (monotone in v)."""
    if cap <= fixed or transition_distance(fixed, cap, acc, jerk) <= length:
        return cap
    lo, hi = fixed, cap
    for _ in range(BISECTION_STEPS):
        mid = 0.5 * (lo + hi)
        if transition_distance(fixed, mid, acc, jerk) <= length:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-13 * max(hi, 1.0):
            break
    return lo


def max_end_speed(v_s: float, length: float, cap: float, acc: float, jerk: float) -> float:
    """Highest end speed ≤ cap reachable from v_s within ``length`` (type-4 end correction)."""
    return _bisect_speed(v_s, length, cap, acc, jerk)


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


def block_segments(length: float, v_s: float, v_e: float, v_max: float, acc: float,
                   jerk: float) -> tuple[int, list[Segment]]:
    """Block type (1-3) and its segments covering exactly ``length`` mm (seed 000, Table 1).

    Raises ValueError for a type-4 block (v_e not reachable from v_s within ``length``): the
    look-ahead corrects junction speeds so that this does not happen.
    """
    v_max = max(v_max, v_s, v_e)
    d_se = transition_distance(v_s, v_e, acc, jerk)
    if d_se > length * (1.0 + 1e-9) + 1e-12:
        raise ValueError(f"type-4 block: {v_s} -> {v_e} mm/s needs {d_se} mm, block is {length} mm")
    d_up = transition_distance(v_s, v_max, acc, jerk)
    d_down = transition_distance(v_max, v_e, acc, jerk)
    segs: list[Segment] = []
    if d_up + d_down <= length:  # type 1
        kind = 1
        if v_max > v_s:
            segs.append(Segment(v_s, v_max, transition_time(v_s, v_max, acc, jerk)))
        cruise = length - d_up - d_down
        if cruise > 0.0 and v_max > 0.0:
            segs.append(Segment(v_max, v_max, cruise / v_max))
        if v_max > v_e:
            segs.append(Segment(v_max, v_e, transition_time(v_max, v_e, acc, jerk)))
        return kind, segs
    cruise = max(length - d_se, 0.0)
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
