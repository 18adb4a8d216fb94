"""The SLW scheduler (seed 000): deterministic, jerk-limited, sliding look-ahead feed scheduling.

``schedule(curve, limits) -> Trajectory`` is the entry point; ``time_optimal_bound(samples,
limits)`` the acceleration-limited reference every comparison uses. Imports :mod:`fuzzyfeed.machine`
and below (layer 4), never the fuzzy advisor.
"""

from fuzzyfeed.slw.bound import Bound, path_bound, time_optimal_bound
from fuzzyfeed.slw.trajectory import Trajectory, measure, schedule

__all__ = ["Bound", "Trajectory", "measure", "path_bound", "schedule", "time_optimal_bound"]
