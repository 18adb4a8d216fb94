"""The jerk-limited feed scheduler: the whole-path time-optimal LP beside seed 000's sliding
look-ahead window (SLW), deterministic, every servo tick checked against every limit.

``schedule(curve, limits) -> Trajectory`` is the entry point (the faster of the two;
``planner="window", transition="cosine"`` is seed 000's scheduler); ``time_optimal_bound(samples,
limits)`` the acceleration-limited reference every comparison uses. Imports :mod:`fuzzyfeed.machine`
and below (layer 4), never the fuzzy advisor.
"""

from fuzzyfeed.slw.bound import Bound, path_bound, time_optimal_bound
from fuzzyfeed.slw.trajectory import Trajectory, measure, schedule

__all__ = ["Bound", "Trajectory", "measure", "path_bound", "schedule", "time_optimal_bound"]
