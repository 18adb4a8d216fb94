"""``schedule(planner="optimal")``: the whole-path LP's feed (slw/optimal.py) as servo ticks
(slw/phase_ticks.py), through the same interpolation, tick check and repair as the window.

The profile x(s) = v² and the nodal accelerations of the LP in bounded pieces
(:func:`fuzzyfeed.slw.optimal_pieces.pieced_profile`) become ticks t_k = k·Ts (:func:`fuzzyfeed.slw.phase_ticks.ticks_from_phase`, with the planner's a and
J); the ticks' arc lengths are interpolated on the curve (``interpolate_u`` "best") and every tick
checked against every limit (:func:`fuzzyfeed.slw.check.breach`). On a breach the feed is capped
around it (``trajectory._dip``) and the LP solved again over the span around it
(:func:`fuzzyfeed.slw.optimal_pieces.repair`), at most ``TICK_REPAIRS`` times; a breach
left after that is an InputError. No schedule above a limit is returned.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.slw.check import breach_error, checked_positions
from fuzzyfeed.slw.feed_cap import FeedCap
from fuzzyfeed.slw.optimal import JERK_MARGIN
from fuzzyfeed.slw.optimal_pieces import pieced_profile, repair
from fuzzyfeed.slw.phase_ticks import ticks_from_phase


def schedule_optimal(curve: Nurbs, limits: MachineLimits, cap: FeedCap | None, kinks_u: np.ndarray,
                     dip: Callable, repairs: int, progress: Callable[[float], None] | None = None):
    """The ticks of the LP's profile under ``cap`` (or None), repaired as the window's are (``dip``:
    trajectory._dip, at most ``repairs`` times) → (t, s, u, xyz, v, a, j, critical arc lengths: the
    profile's rests and valleys on its grid), the arrays read-only. ``progress`` (optional) is
    called with the arc length planned so far after each piece of the first LP pass."""
    total = float(curve.length)
    grid = None
    for attempt in range(repairs + 1):
        try:
            if grid is None:
                grid, x_grid, a_grid = pieced_profile(curve, limits, cap, progress=progress)
            else:  # only the span around the breach solved again
                grid, x_grid, a_grid = repair(grid, x_grid, a_grid, cap, limits)
        except RuntimeError as exc:
            raise InputError(f"the whole-path feed LP failed on the path of {total:.6g} mm: {exc}") from None
        s_grid = grid[0]
        t, s, v, a, j = ticks_from_phase(s_grid, x_grid, limits.ts_s, a_grid=a_grid,
                                         jerk_mm_s3=JERK_MARGIN * limits.jerk_mm_s3)
        u, xyz, found = checked_positions(curve, s, j, limits, kinks_u)
        if found is None:
            break
        if attempt == repairs:
            raise breach_error(found, s, limits)
        cap = dip(cap, found, s, v, limits, total)
    inner = x_grid[1:-1]
    critical = s_grid[1:-1][(inner <= 0.0) | _local_minima(x_grid)]
    for arr in (t, s, u, xyz, v, a, j):
        arr.flags.writeable = False
    return t, s, u, xyz, v, a, j, critical


def _local_minima(x: np.ndarray) -> np.ndarray:
    """Interior nodes strictly below both neighbours (the profile's valleys)."""
    return (x[1:-1] < x[:-2]) & (x[1:-1] < x[2:])
