"""The last check of a schedule: every servo tick, every axis, against every kinematic limit.

A schedule is returned only if the motion the machine would make — the interpolated positions,
one per servo period Ts, each tick a straight chord travelled at constant speed — keeps:

* the feed |ΔP_k|/Ts ≤ F and each axis's velocity |ΔP_kj|/Ts ≤ V_j;
* each axis's acceleration (ΔP_k+1,j − ΔP_kj)/Ts² ≤ A_j, from rest before the first tick and to
  rest after the last (the same differences as :func:`fuzzyfeed.machine.simulate.simulate`);
* the jerk J along the path: the scheduled profile's, and the third difference of the distance
  travelled along the chords, Σ|ΔP_k| (the tangential jerk the machine makes; the chords of a
  tick that crosses a true corner of the path are left out of this one — the turn there is the
  corner's, within one tick by the corner rule, and has no jerk of its own).

The scheduler lowers the feed around a breach and schedules again (a few times at most); one left
after that is an :class:`~fuzzyfeed.errors.InputError` naming the limit, the axis, the arc length
and the ratio, never a schedule with a limit above 100 %.
"""

from __future__ import annotations

from functools import cache

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.geometry._kernels import use_compiled
from fuzzyfeed.machine.limits import AXES, MachineLimits

#: A tick may pass a limit by this fraction (the finite differences' rounding); the summary prints
#: per cents with two decimals, so no line reads above 100.00 %.
TICK_RTOL = 5e-5
#: The jerk along the chords (a third difference of their lengths) may pass J by this fraction:
#: the chord-exact interpolation leaves ~1e-9 mm per chord, which the third difference divides by
#: Ts³ (5e-5 over on a random curve where the profile holds J exactly).
PATH_JERK_RTOL = 1e-3


def tick_ratios(xyz: np.ndarray, jerk_mm_s3: np.ndarray, limits: MachineLimits,
                corner_ticks: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Per-tick ratios to each limit: ``feed``, ``velocity x|y|z``, ``acceleration x|y|z``,
    ``jerk`` (the profile's) and ``path jerk`` (of the chord lengths; NaN at ``corner_ticks``,
    indices of the chords that cross a true corner, and the jerks that difference them)."""
    ts = limits.ts_s
    step = np.diff(np.asarray(xyz, dtype=float), axis=0)
    vel = step / ts
    rest = np.zeros((1, vel.shape[1]))
    acc = np.diff(np.vstack([rest, vel, rest]), axis=0) / ts
    chord = np.linalg.norm(step, axis=1)
    feed = chord / ts
    out = {"feed": feed / limits.feed_mm_s}
    for j, axis in enumerate(AXES):
        out[f"velocity {axis}"] = np.abs(vel[:, j]) / limits.axis_vel_mm_s[j]
        out[f"acceleration {axis}"] = np.abs(acc[:, j]) / limits.axis_acc_mm_s2[j]
    out["jerk"] = np.abs(np.asarray(jerk_mm_s3, dtype=float)) / limits.jerk_mm_s3
    tan_acc = np.diff(np.concatenate([[0.0], feed, [0.0]])) / ts   # at tick k (K + 1 values)
    path_jerk = np.abs(np.diff(tan_acc)) / ts / limits.jerk_mm_s3  # between ticks k and k + 1
    if corner_ticks is not None and corner_ticks.size:
        # chord c enters the accelerations at ticks c and c + 1, and those the jerks c - 1 … c + 1
        bad = (np.asarray(corner_ticks)[:, None] + np.arange(-1, 2)[None, :]).ravel()
        path_jerk[np.clip(bad, 0, path_jerk.size - 1)] = np.nan
    out["path jerk"] = path_jerk
    return out


def corner_ticks(u: np.ndarray, corner_u: np.ndarray) -> np.ndarray:
    """Indices k of the chords C(u_k) → C(u_k+1) that contain a corner at a parameter of
    ``corner_u`` (or end on one). Found by parameter: the chord-exact ticks sit off their arc
    lengths by the accumulated arc-chord deficit (a tick at a helix's corner was read as the next
    one's, and the corner's own turn as 4.6 × J along the chords)."""
    if corner_u.size == 0:
        return np.empty(0, dtype=int)
    k = np.searchsorted(u, corner_u, side="left")
    return np.unique(np.concatenate([k - 1, k]).clip(0, max(u.size - 2, 0)))


def worst(ratios: dict[str, np.ndarray]) -> tuple[str, int, float]:
    """The limit, tick and ratio of the largest ratio of :func:`tick_ratios`."""
    name, k, r = "feed", 0, 0.0
    for key, arr in ratios.items():
        if arr.size == 0 or np.isnan(arr).all():
            continue
        i = int(np.nanargmax(arr))
        if arr[i] > r:
            name, k, r = key, i, float(arr[i])
    return name, k, r


@cache
def _worst_kernel():
    """slw/_check_jit.worst_ticks compiled (or loaded from numba's disk cache) once."""
    import numba

    from fuzzyfeed.geometry._kernels import compile_once
    from fuzzyfeed.slw._check_jit import worst_ticks

    ro = lambda ndim: numba.types.Array(numba.float64, ndim, "C", readonly=True)  # noqa: E731
    f8 = numba.float64
    sig = numba.void(ro(2), ro(1), f8, f8, ro(1), ro(1), f8, f8, numba.types.Array(numba.boolean, 1, "C", readonly=True),
                     numba.float64[::1], numba.int64[::1])
    return compile_once(worst_ticks, sig, "the tick check", 2)


def _worst_compiled(xyz: np.ndarray, jerk_mm_s3: np.ndarray, limits: MachineLimits,
                    corners: np.ndarray, scale: float) -> tuple[str, int, float, float]:
    """:func:`worst` of :func:`tick_ratios` with the path jerk divided by ``scale``, in one compiled
    pass (slw/_check_jit.py): the limit, tick, judged ratio and the ratio itself."""
    from fuzzyfeed.slw._check_jit import N_RATIOS

    xyz = np.ascontiguousarray(xyz, dtype=float)
    skip = np.zeros(max(xyz.shape[0] - 1, 0), dtype=bool)
    if corners.size and skip.size:
        skip[np.clip((corners[:, None] + np.arange(-1, 2)[None, :]).ravel(), 0, skip.size - 1)] = True
    best, where = np.empty(N_RATIOS + 1), np.empty(N_RATIOS, dtype=np.int64)
    _worst_kernel()(xyz, np.ascontiguousarray(jerk_mm_s3, dtype=float), float(limits.ts_s),
                    float(limits.feed_mm_s), np.asarray(limits.axis_vel_mm_s, dtype=float),
                    np.asarray(limits.axis_acc_mm_s2, dtype=float), float(limits.jerk_mm_s3), scale, skip,
                    best, where)
    # worst(): the first of the largest, over the ratios in tick_ratios' order
    order = (("feed", 0), ("velocity x", 1), ("acceleration x", 4), ("velocity y", 2), ("acceleration y", 5),
             ("velocity z", 3), ("acceleration z", 6), ("jerk", 7), ("path jerk", 8))
    name, k, r, raw = "feed", 0, 0.0, 0.0
    for key, i in order:
        if where[i] >= 0 and best[i] > r:
            name, k, r = key, int(where[i]), float(best[i])
            raw = float(best[9]) if i == 8 else r
    return name, k, r, raw


def breach(xyz: np.ndarray, u: np.ndarray, jerk_mm_s3: np.ndarray, limits: MachineLimits,
           corner_u: np.ndarray) -> tuple[str, int, float] | None:
    """The limit, tick and ratio of the worst tick over a limit by more than TICK_RTOL (the path
    jerk by PATH_JERK_RTOL too), or None. Compiled over a long schedule (no array per ratio), the
    same ratios and tick as the numpy lines."""
    corners = corner_ticks(u, corner_u)
    if use_compiled(xyz.shape[0]) and xyz.ndim == 2 and xyz.shape[1] == 3:
        name, k, r, raw = _worst_compiled(xyz, jerk_mm_s3, limits, corners, 1.0 + PATH_JERK_RTOL)
        return (name, k, raw) if r > 1.0 + TICK_RTOL else None
    ratios = tick_ratios(xyz, jerk_mm_s3, limits, corners)
    judged = dict(ratios, **{"path jerk": ratios["path jerk"] / (1.0 + PATH_JERK_RTOL)})
    name, k, r = worst(judged)
    return (name, k, float(ratios[name][k])) if r > 1.0 + TICK_RTOL else None


def checked_positions(curve, s_mm: np.ndarray, jerk_mm_s3: np.ndarray, limits: MachineLimits,
                      corner_u: np.ndarray):
    """The ticks' arc lengths on ``curve`` (the chord-exact interpolator, "best"), their positions
    (always 3 columns) and :func:`breach` of them: (u, xyz, breach or None); the window's and the
    whole-path LP's schedules are judged alike. Fewer than two ticks is an InputError."""
    from fuzzyfeed.geometry.interpolate import interpolate_u

    if s_mm.size < 2:
        raise InputError(f"path of {float(s_mm[-1]) if s_mm.size else 0.0!r} mm is scheduled in {s_mm.size} "
                         "servo periods; need at least 1")

    u = interpolate_u(curve, s_mm, "best")
    xyz = curve.evaluate(u, order=0)[0]
    if xyz.shape[1] == 2:
        xyz = np.hstack([xyz, np.zeros((xyz.shape[0], 1))])
    # the motion the machine makes, tick by tick and axis by axis, within every limit
    return u, xyz, breach(xyz, u, jerk_mm_s3, limits, corner_u)


def breach_error(found: tuple[str, int, float], s_mm: np.ndarray, limits: MachineLimits) -> InputError:
    """The one-line error of a breach: the limit, the axis, the arc length and the ratio."""
    name, k, r = found
    at = float(s_mm[min(k, s_mm.size - 1)])
    unit = {"feed": "mm/s", "velocity": "mm/s", "acceleration": "mm/s^2"}.get(name.split()[0], "mm/s^3")
    limit = {"feed": limits.feed_mm_s, "jerk": limits.jerk_mm_s3, "path jerk": limits.jerk_mm_s3}.get(name)
    if limit is None:
        axis = AXES.index(name.split()[1])
        limit = (limits.axis_vel_mm_s if name.startswith("velocity") else limits.axis_acc_mm_s2)[axis]
    return InputError(f"{name} at s = {at:.6g} mm: {r:.4f} x its limit of {limit:g} {unit}; the "
                      "schedule breaks a machine limit there and is not written (please report "
                      "the path and the limits)")
