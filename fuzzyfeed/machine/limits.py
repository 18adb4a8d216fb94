"""Machine limits as one validated value, and the pointwise feasible feed they allow on a path.

``MachineLimits`` holds the command feed, per-axis velocity and acceleration, tangential jerk, chord
tolerance and servo period (mm, s). ``feed_limits`` is the envelope of seed 000, eq. (8)-(12): at
every sample the largest feed that respects the command feed, the axial velocities, the chord
error at the servo period and the centripetal (normal) part of the axial accelerations. It belongs
to the core: the SLW scheduler schedules under it, the time-optimal bound integrates under it, and
any other planner's advice can be clamped to it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fuzzyfeed.base.checks import expect
from fuzzyfeed.errors import MachineLimitsError
from fuzzyfeed.geometry.sampling import PathSamples

#: The issue's reference machine: 6000 mm/min, 100 mm/s and 1000 mm/s² per axis, 10 000 mm/s³,
#: 1 µm chord tolerance, 1 ms servo period.
DEFAULT_FEED_MM_S = 100.0
DEFAULT_AXIS_VEL_MM_S = 100.0
DEFAULT_AXIS_ACC_MM_S2 = 1000.0
DEFAULT_JERK_MM_S3 = 10_000.0
DEFAULT_CHORD_TOL_MM = 0.001
DEFAULT_TS_S = 0.001

AXES = ("x", "y", "z")


#: Largest value any limit may have (in its own unit): beyond it no machine exists and squares of
#: the value overflow (a feed of 1e308 mm/min prints "mean inf").
MAX_LIMIT = 1e9


def _positive(name: str, value: object) -> float:
    if isinstance(value, bool):
        raise MachineLimitsError(f"{name} = {value!r}; must be a finite number > 0")
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise MachineLimitsError(f"{name} = {value!r}; must be a finite number > 0") from None
    if not math.isfinite(v) or v <= 0.0:
        raise MachineLimitsError(f"{name} = {value!r}; must be a finite number > 0")
    if v > MAX_LIMIT:
        raise MachineLimitsError(f"{name} = {value!r}; must be at most {MAX_LIMIT:g}")
    return v


def _per_axis(name: str, value: object) -> tuple[float, float, float]:
    if np.ndim(value) == 0:
        v = _positive(name, value)
        return (v, v, v)
    items = list(value)  # type: ignore[call-overload]
    if len(items) != 3:
        raise MachineLimitsError(f"{name} = {items!r}; give one value for all axes or exactly 3 "
                                 "(x, y, z)")
    return tuple(_positive(f"{name}[{axis}]", v) for axis, v in zip(AXES, items))  # type: ignore[return-value]


@dataclass(frozen=True)
class MachineLimits:
    """Kinematic limits of a 3-axis machine (seed 000, Table 3), validated at construction.

    ``feed_mm_s`` command feed F; ``axis_vel_mm_s`` and ``axis_acc_mm_s2`` per axis (x, y, z; a
    scalar is broadcast to the three axes); ``jerk_mm_s3`` tangential jerk J; ``chord_tol_mm``
    chord error δ; ``ts_s`` servo (interpolation) period Ts. Every value must be finite and > 0;
    otherwise :class:`MachineLimitsError` names the field, the value and the rule.
    """

    feed_mm_s: float = DEFAULT_FEED_MM_S
    axis_vel_mm_s: tuple[float, float, float] = (DEFAULT_AXIS_VEL_MM_S,) * 3
    axis_acc_mm_s2: tuple[float, float, float] = (DEFAULT_AXIS_ACC_MM_S2,) * 3
    jerk_mm_s3: float = DEFAULT_JERK_MM_S3
    chord_tol_mm: float = DEFAULT_CHORD_TOL_MM
    ts_s: float = DEFAULT_TS_S

    def __post_init__(self) -> None:
        for name in ("feed_mm_s", "jerk_mm_s3", "chord_tol_mm", "ts_s"):
            object.__setattr__(self, name, _positive(name, getattr(self, name)))
        for name in ("axis_vel_mm_s", "axis_acc_mm_s2"):
            object.__setattr__(self, name, _per_axis(name, getattr(self, name)))
        if self.ts_s > 1.0:
            raise MachineLimitsError(f"ts_s = {self.ts_s!r}; a servo period longer than 1 s is not "
                                     "a servo period (give seconds, e.g. 0.001)")

    @classmethod
    def default(cls) -> MachineLimits:
        """The issue's efficiency machine: 100 mm/s, 100 mm/s, 1000 mm/s², 10 000 mm/s³, 1 µm, 1 ms."""
        return cls()

    @classmethod
    def from_feed_mm_min(cls, feed_mm_min: float, **kwargs) -> MachineLimits:
        """Same as the constructor with the command feed given in mm/min (the user's unit)."""
        return cls(feed_mm_s=_positive("feed_mm_min", feed_mm_min) / 60.0, **kwargs)

    @property
    def feed_mm_min(self) -> float:
        return self.feed_mm_s * 60.0

    @property
    def tangential_acc_mm_s2(self) -> float:
        """Tangential acceleration limit of the profile: the smallest axis acceleration, so that
        |a_t·T_j| ≤ A_j on every axis whatever the direction (seed 000, eq. (13)-(14))."""
        return min(self.axis_acc_mm_s2)

    def as_dict(self) -> dict[str, object]:
        return {"feed_mm_s": self.feed_mm_s, "axis_vel_mm_s": list(self.axis_vel_mm_s),
                "axis_acc_mm_s2": list(self.axis_acc_mm_s2), "jerk_mm_s3": self.jerk_mm_s3,
                "chord_tol_mm": self.chord_tol_mm, "ts_s": self.ts_s}


def curvature_vectors(samples: PathSamples) -> np.ndarray:
    """κ·N = dT/ds (N, 3) in 1/mm at every sample.

    For a NURBS, κN = (C″ − (C″·T)T)/|C′|² exactly; for a point sequence (no derivatives) the
    direction is the arc-length derivative of the tangent, scaled to the sample's curvature.
    Stationary points (|C′| = 0) give an infinite vector along the axes the curve moves in.
    """
    d1 = samples.d1
    if np.isfinite(d1).all():
        speed2 = np.einsum("ij,ij->i", d1, d1)
        t = samples.tangent
        d2 = samples.d2
        with np.errstate(divide="ignore", invalid="ignore"):
            kn = (d2 - np.einsum("ij,ij->i", d2, t)[:, None] * t) / speed2[:, None]
        bad = ~np.isfinite(kn).all(axis=1)
        if bad.any():
            kn[bad] = np.inf
        return kn
    tangent = np.asarray(samples.tangent)
    dt = np.gradient(tangent, samples.s, axis=0) if len(samples) > 2 else np.zeros_like(tangent)
    norm = np.linalg.norm(dt, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        direction = np.where(norm[:, None] > 0, dt / norm[:, None], 0.0)
    return direction * np.asarray(samples.curvature)[:, None]


def feed_limits(samples: PathSamples, limits: MachineLimits) -> np.ndarray:
    """Pointwise feasible feed (mm/s) at every sample: seed 000, eq. (8)-(12).

    v ≤ F (command); v·|T_j| ≤ V_j (axial velocity); v ≤ (2/Ts)·√(2ρδ − δ²) with ρ = 1/κ (chord
    error; no limit where 2ρ ≤ δ: an arc deviates at most 2ρ from any chord of it); v²·κ·|N_j| ≤ A_j
    (centripetal part of the axial acceleration). The
    result is finite and ≥ 0 (0 at a stationary point or a corner sharper than the tolerance).
    """
    return feed_limit_components(samples, limits).min(axis=0)


def feed_limit_components(samples: PathSamples, limits: MachineLimits) -> np.ndarray:
    """The four limits of :func:`feed_limits` as rows (command, axial velocity, chord, centripetal)."""
    expect(samples, PathSamples, "samples", "PathSamples")
    expect(limits, MachineLimits, "limits", "MachineLimits")
    n = len(samples)
    command = np.full(n, limits.feed_mm_s)
    tangent = np.abs(np.asarray(samples.tangent, dtype=float))
    vel = np.asarray(limits.axis_vel_mm_s)
    with np.errstate(divide="ignore", invalid="ignore"):
        axial = np.min(np.where(tangent > 0, vel[None, :] / tangent, np.inf), axis=1)
    axial = np.where(np.isfinite(tangent).all(axis=1), axial, 0.0)
    kappa = np.asarray(samples.curvature, dtype=float)
    delta = limits.chord_tol_mm
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = np.where(kappa > 0, 1.0 / kappa, np.inf)
        # an arc of radius ρ deviates at most 2ρ from any chord of it (the arc beyond a half
        # turn): no chord limit where 2ρ <= δ, where the formula's root is not real either
        chord = np.where(np.isinf(rho) | (2.0 * rho <= delta), np.inf,
                         2.0 / limits.ts_s * np.sqrt(np.maximum(2.0 * rho * delta - delta * delta, 0.0)))
    chord = np.where(np.isnan(kappa), 0.0, chord)
    kn = np.abs(curvature_vectors(samples))
    acc = np.asarray(limits.axis_acc_mm_s2)
    with np.errstate(divide="ignore", invalid="ignore"):
        centripetal = np.min(np.where(kn > 0, np.sqrt(acc[None, :] / kn), np.inf), axis=1)
    centripetal = np.where(np.isnan(kn).any(axis=1), 0.0, centripetal)
    out = np.vstack([command, np.minimum(axial, command), np.minimum(chord, command),
                     np.minimum(centripetal, command)])
    return np.nan_to_num(out, nan=0.0, posinf=limits.feed_mm_s)
