"""The path read exactly at given parameters for the look-ahead's check: preprocess._evaluate's
values (feed limit of eq. (8)-(12), unit tangent, κN), computed in one compiled pass
(slw/_exact_jit.py) instead of ~30 numpy calls; value for value the same (tests/test_slw_exact.py)."""

from __future__ import annotations

import sys

import numpy as np

from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.slw.feed_cap import FeedCap
from fuzzyfeed.slw.preprocess import Reference, _evaluate

_EMPTY = np.empty(0)


def evaluate_exact(curve: Nurbs, limits: MachineLimits, s: np.ndarray, cap: FeedCap | None,
                   u: np.ndarray) -> Reference:
    """preprocess._evaluate(curve, limits, s, cap, u): the reference data at arc lengths ``s``
    read at parameters ``u`` (the caller's estimate of u(s)). Falls back to it where a derivative
    is not finite (curvature_vectors' other branch)."""
    from fuzzyfeed.slw import _exact_jit as kernel

    s = np.asarray(s, dtype=float)
    u = np.asarray(u, dtype=float)
    lo, hi = curve.domain
    if not (u.size and u.min() >= lo and u.max() <= hi):   # (NaN too) Nurbs.evaluate's error
        return _evaluate(curve, limits, s, cap, u)
    out, speed = np.empty((3, u.size, curve.dim)), np.empty(u.size)
    kernel.derivatives(curve.span_breaks, curve._coeffs, u, out, speed)
    d1, d2 = out[1], out[2]
    with np.errstate(over="ignore", invalid="ignore"):
        speed3 = speed ** 3                  # numpy's power (not the compiled one's) as in curvature_from_derivatives
    n = s.size
    vlim, tangent, kn = np.empty(n), np.empty((n, 3)), np.empty((n, 3))
    cap_s, cap_v = (cap.s_mm, cap.feed_mm_s) if cap is not None else (_EMPTY, _EMPTY)
    ok = kernel.exact_limits(d1, d2, speed, speed3, s, cap_s, cap_v,
                             np.asarray(limits.axis_vel_mm_s, dtype=float),
                             np.asarray(limits.axis_acc_mm_s2, dtype=float), float(limits.feed_mm_s),
                             float(limits.chord_tol_mm), 2.0 / limits.ts_s, sys.float_info.max,
                             vlim, tangent, kn)
    if not ok:
        return _evaluate(curve, limits, s, cap, u)
    return Reference(s, u, vlim, tangent, kn)
