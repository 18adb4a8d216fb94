"""Load every compiled kernel a schedule uses before anything is timed.

numba keeps compiled kernels on disk beside their modules; a fresh checkout (or a new worktree)
has none, and the first schedule that needs one compiles it inside its own time (13.9 s on
bench_slw's first polyline against 1.45 s warm; 21.6 s of compilation inside camotics bear.nc#1).
:func:`warm_kernels` compiles or loads them once, outside the timed region: the NURBS kernel, u(s)
(geometry/_arc_jit.py: the interpolator's arc-length inversions), the interpolator's per-tick
passes (geometry/_chord_jit.py), the tick check (slw/_check_jit.py), the polyline run search of the blend fit, and the look-ahead's
kernels (slw/_kernels.py, typed on first call: a short blended polyline and a curve scheduled
with both transitions).
"""

from __future__ import annotations

import time

import numpy as np


def warm_kernels() -> float:
    """Compile (first run) or load every kernel of :func:`fuzzyfeed.slw.schedule`; returns the CPU
    seconds it took."""
    from fuzzyfeed.geometry._kernels import arc_kernel, chord_kernels, nurbs_kernel
    from fuzzyfeed.geometry.nurbs import Nurbs
    from fuzzyfeed.geometry.polyline_runs import run_search_kernel as _runs_kernel
    from fuzzyfeed.machine.limits import MachineLimits
    from fuzzyfeed.slw.check import _worst_kernel
    from fuzzyfeed.slw.trajectory import schedule

    t0 = time.process_time()
    nurbs_kernel()
    arc_kernel()
    chord_kernels()
    _runs_kernel()
    _worst_kernel()
    # a zig-zag of short moves (blended, corners and kinks) and a cubic (no polyline fit)
    t = np.linspace(0.0, 6.0, 241)
    pts = np.column_stack([10.0 * np.cos(t), 10.0 * np.sin(t) + 0.2 * (np.arange(t.size) % 2), 0.1 * t])
    line = Nurbs(1, np.concatenate([[0.0], np.arange(t.size, dtype=float), [t.size - 1.0]]), np.round(pts, 3))
    cubic = Nurbs(3, np.array([0, 0, 0, 0, 1, 2, 2, 2, 2], dtype=float),
                  np.array([[0, 0], [20, 30], [40, -30], [60, 30], [80, 0]], dtype=float))
    slow_y = MachineLimits(axis_vel_mm_s=(100, 50, 100), axis_acc_mm_s2=(1000, 250, 1000))
    for curve in (line, cubic):
        for transition in ("cosine", "seven-phase"):
            schedule(curve, slow_y, transition=transition, planner="window")
    return time.process_time() - t0
