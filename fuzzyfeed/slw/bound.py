"""The time-optimal reference: an acceleration-limited forward/backward phase-plane pass.

On the samples of a path, with x = v² and a = dx/(2ds) the tangential acceleration, the feed is
kept under the pointwise limit of :func:`fuzzyfeed.limits.feed_limits` (command, axial velocity,
chord error, centripetal) and every axial acceleration a·T_j + v²·κN_j within ±A_j. The forward
pass accelerates as hard as allowed, the backward pass brakes as hard as allowed; their minimum is
the fastest feed profile without a jerk limit (the classic phase-plane construction; toppra 0.6
gives the same 4.9008 s on the infinity path). Every profile's cycle time is compared with it.
"""

from __future__ import annotations

import numpy as np

from fuzzyfeed.limits import MachineLimits, curvature_vectors, feed_limits
from fuzzyfeed.profile import FeedProfile
from fuzzyfeed.sampling import PathSamples


def time_optimal_bound(samples: PathSamples, limits: MachineLimits,
                       feed_cap: np.ndarray | None = None) -> tuple[FeedProfile, float]:
    """The bound's feed at every sample (method "bound", 0 at both ends) and its cycle time (s).

    ``feed_cap`` (mm/s, one value per sample), if given, is one more pointwise limit: the result
    is then the fastest acceleration-feasible profile that never exceeds it (how the comparison
    makes a planner's advice safe).

    The cycle time integrates ds / v̄ with v̄ the mean of a segment's two feeds, exact for a
    constant acceleration between samples (x linear in s). Use a fine arc-length sampling
    (0.05 mm reproduces the infinity figure to 4 decimals).
    """
    from fuzzyfeed.slw._kernels import phase_plane_kernel

    s = np.asarray(samples.s, dtype=float)
    vlim = feed_limits(samples, limits)
    if feed_cap is not None:
        vlim = np.minimum(vlim, np.asarray(feed_cap, dtype=float))
    tangent = np.ascontiguousarray(np.nan_to_num(np.asarray(samples.tangent, dtype=float), nan=0.0))
    kn = np.ascontiguousarray(np.nan_to_num(curvature_vectors(samples), nan=0.0, posinf=0.0))
    x = phase_plane_kernel()(np.diff(s), vlim * vlim, tangent, kn,
                             np.asarray(limits.axis_acc_mm_s2, dtype=float))
    v = np.sqrt(np.maximum(x, 0.0))
    profile = FeedProfile(samples, v, "bound", limits.feed_mm_s)
    return profile, profile.travel_time_s()
