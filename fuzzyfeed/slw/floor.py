"""A jerk-limited floor: no schedule whose tangential jerk stays within J can be faster.

The acceleration-limited bound (:func:`fuzzyfeed.slw.bound.path_bound`) knows no jerk; at a full
stop it is too optimistic, since under a jerk limit every stop-to-stop leg is a rest-to-rest
move whose least time is the seven-phase (trapezoidal-acceleration) profile's. The floor is the
larger of the bound and the sum of those rest-to-rest times over the legs between the path's
full stops (the true corners passed at ≤ 1 % of F) — the measure issue 27 asks every schedule to
be compared with.
"""

from __future__ import annotations

import numpy as np

from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.machine.limits import MachineLimits

#: A true corner passed at no more than this share of the command feed is a full stop.
STOP_SHARE = 0.01


def seven_phase_s(dv: float, acc: float, jerk: float) -> float:
    """Duration of the fastest change of feed by |dv| under |a| ≤ acc, |j| ≤ jerk (the classic
    seven-phase ramp; symmetric, so it covers (v0 + v1)·T/2)."""
    dv = abs(dv)
    return dv / acc + acc / jerk if dv >= acc * acc / jerk else 2.0 * float(np.sqrt(dv / jerk))


def rest_to_rest_s(length: float, vel: float, acc: float, jerk: float) -> float:
    """Least time of a rest-to-rest move of ``length`` mm under |v| ≤ vel, |a| ≤ acc, |j| ≤ jerk
    (the seven-phase profile; its peak feed found by bisection)."""
    def covered(v: float) -> float:  # distance of 0 → v → 0 without a cruise
        return v * seven_phase_s(v, acc, jerk)

    lo, hi = 0.0, vel
    if covered(hi) > length:
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if covered(mid) <= length else (lo, mid)
        hi = lo
    if hi <= 0.0:
        return 0.0
    return 2.0 * seven_phase_s(hi, acc, jerk) + (length - covered(hi)) / hi


def legs_s(curve: Nurbs, limits: MachineLimits) -> float:
    """Σ rest-to-rest time of the legs between full stops, each under the feed and tangential
    acceleration its axes allow: along a straight leg of direction T, min_j A_j/|T_j| and
    min(F, V_j/|T_j|); on a curved one |A|₂ and F (optimistic: a floor)."""
    from fuzzyfeed.slw.preprocess import corners

    s_c, cap = corners(curve, limits)
    cuts = np.concatenate([[0.0], s_c[cap <= STOP_SHARE * limits.feed_mm_s], [curve.length]])
    acc = np.asarray(limits.axis_acc_mm_s2[:curve.dim])
    vel = np.asarray(limits.axis_vel_mm_s[:curve.dim])
    total = 0.0
    for a, b in zip(cuts[:-1], cuts[1:]):
        if b <= a:
            continue
        s = np.linspace(a, b, 9)[1:-1]
        t = np.abs(curve.evaluate(np.atleast_1d(curve.param_at_length(s)), order=1)[1])
        t /= np.linalg.norm(t, axis=1, keepdims=True)
        if np.ptp(t, axis=0).max() < 1e-9:  # straight
            with np.errstate(divide="ignore"):
                a_leg = float(np.min(np.where(t[0] > 0, acc / t[0], np.inf)))
                v_leg = float(min(limits.feed_mm_s, np.min(np.where(t[0] > 0, vel / t[0], np.inf))))
        else:
            a_leg, v_leg = float(np.linalg.norm(acc)), limits.feed_mm_s
        total += rest_to_rest_s(b - a, v_leg, a_leg, limits.jerk_mm_s3)
    return total


def jerk_floor(curve: Nurbs, limits: MachineLimits, bound_s: float | None = None) -> float:
    """max(acceleration-limited bound, Σ legs rest-to-rest) in s; ``bound_s`` if already known."""
    if bound_s is None:
        from fuzzyfeed.slw.bound import path_bound

        bound_s = path_bound(curve, limits, halve=False).time_s
    return max(bound_s, legs_s(curve, limits))
