"""The path read exactly at given parameters: preprocess._evaluate's values (feed limit of
eq. (8)-(12), unit tangent, κN), computed in one compiled pass (slw/_exact_jit.py) instead of ~30
numpy calls; value for value the same (tests/test_slw_exact.py). Every read of the path by the
scheduler goes through it: the preprocessor's reference points, the machine's cap, and the
look-ahead's ~10⁷ near-limit samples of a long program (a third of its scheduling in numpy)."""

from __future__ import annotations

import sys

import numpy as np

from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.machine.limits import MachineLimits

_EMPTY = np.empty(0)


def exact_arrays(curve: Nurbs, limits: MachineLimits, s: np.ndarray, cap, u: np.ndarray):
    """(feed limit, unit tangent (n, 3), κN (n, 3)) at arc lengths ``s`` and parameters ``u``, as
    preprocess._evaluate computes them with numpy (``cap``: a FeedCap or None); None where that
    code must run instead (a parameter outside the domain: its error; a derivative that is not
    finite: curvature_vectors' other branch)."""
    import fuzzyfeed.slw._exact_jit as kernel

    lo, hi = curve.domain
    if not (u.size and u.min() >= lo and u.max() <= hi):   # (NaN too)
        return None
    out, speed = np.empty((3, u.size, curve.dim)), np.empty(u.size)
    kernel.derivatives(curve.span_breaks, curve._coeffs, u, out, speed)
    d1, d2 = out[1], out[2]
    with np.errstate(over="ignore", invalid="ignore"):
        speed3 = speed ** 3                  # numpy's power, as curvature_from_derivatives
    n = s.size
    vlim, tangent, kn = np.empty(n), np.empty((n, 3)), np.empty((n, 3))
    cap_s, cap_v = (cap.s_mm, cap.feed_mm_s) if cap is not None else (_EMPTY, _EMPTY)
    ok = kernel.exact_limits(d1, d2, speed, speed3, s, cap_s, cap_v,
                             np.asarray(limits.axis_vel_mm_s, dtype=float),
                             np.asarray(limits.axis_acc_mm_s2, dtype=float), float(limits.feed_mm_s),
                             float(limits.chord_tol_mm), 2.0 / limits.ts_s, sys.float_info.max,
                             vlim, tangent, kn)
    return (vlim, tangent, kn) if ok else None
