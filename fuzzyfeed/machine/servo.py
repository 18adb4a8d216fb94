"""Axis servo model and contour error: how far the tool really is from the path (DESIGN §3).

Each axis follows its commanded position through a position loop:

first order   ẋ = Kv·(x_cmd − x) + α·ẋ_cmd                       G(s) = (Kv + α·s)/(s + Kv)
second order  ẍ = ωn²·(x_cmd − x) + 2ζωn·(α·ẋ_cmd − ẋ)           G(s) = (ωn² + 2ζωn·α·s)/(s² + 2ζωn·s + ωn²)

Kv is the position-loop gain (1/s; Heidenhain's kV in m/min/mm is Kv·60/1000), α ∈ [0, 1] the
velocity feed-forward fraction. The second-order loop has the same velocity error constant
Kv = ωn/(2ζ): at a constant feed v both lag v·(1 − α)/Kv behind the command.

**Hold.** The interpolator delivers a position set-point every Ts; between two set-points the
command moves linearly (first-order hold on position: the axis drive's fine interpolation), so the
commanded velocity is constant over each tick. The loops are discretised exactly for that input:
the following error e = x_cmd − x obeys E(s) = (1 − G(s))/s · V(s) with V held over the tick, so
``scipy.signal.cont2discrete(..., method="zoh")`` of (1 − G)/s is exact. For the first order this
is e_k+1 = a·e_k + (1 − α)(1 − a)/Kv · v_k, a = e^(−Kv·Ts). (A zero-order hold on the position
instead would add Ts/2 of pure lag.) The axes start at rest on the path's first point; errors are
measured at the ticks of the cycle, t_0 … t_K (the settling after the last set-point is not).

**Contour error** is the distance of the actual position from the exact curve (not from the
commanded polyline): the nearest point is found among brackets around the nearest vertices of a
dense arc-length sampling of the curve and polished by safeguarded Newton steps on
(C(u) − x)·C′(u) = 0. It is the global nearest point, as seed 002 measured its parts (the
shortest distance from the scanned groove to the programmed path, §3.1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fuzzyfeed.base.cache import per_curve
from fuzzyfeed.errors import MachineLimitsError
from fuzzyfeed.machine.limits import AXES
from fuzzyfeed.geometry.nurbs import Nurbs

#: Default position-loop gain (1/s): a typical machining-centre axis without feed-forward.
DEFAULT_KV_1_S = 30.0

#: Heidenhain's kV factor in m/min per mm of following error, times this, is Kv in 1/s.
KV_M_MIN_MM_TO_1_S = 1000.0 / 60.0


def _axis_tuple(name: str, value: object, lo: float, hi: float, lo_open: bool) -> tuple[float, float, float]:
    items = [value] * 3 if np.ndim(value) == 0 else list(value)  # type: ignore[call-overload]
    if len(items) != 3:
        raise MachineLimitsError(f"{name} = {items!r}; give one value for all axes or exactly 3 (x, y, z)")
    out = []
    for axis, item in zip(AXES, items):
        label = name if np.ndim(value) == 0 else f"{name}[{axis}]"
        rule = f"must be a finite number {'>' if lo_open else '>='} {lo:g}" + \
            (f" and <= {hi:g}" if math.isfinite(hi) else "")
        if isinstance(item, bool):
            raise MachineLimitsError(f"{label} = {item!r}; {rule}")
        try:
            v = float(item)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            raise MachineLimitsError(f"{label} = {item!r}; {rule}") from None
        if not math.isfinite(v) or v < lo or (lo_open and v == lo) or v > hi:
            raise MachineLimitsError(f"{label} = {item!r}; {rule}")
        out.append(v)
    return tuple(out)  # type: ignore[return-value]


@dataclass(frozen=True)
class ServoModel:
    """Per-axis position loops (x, y, z), validated at construction (scalars apply to all axes).

    ``kv_1_s`` position-loop gain Kv (1/s, > 0); ``feedforward`` velocity feed-forward fraction α
    (0 … 1); ``natural_freq_hz`` and ``damping``: give the natural frequency fn (Hz) for a
    second-order loop, ωn = 2π·fn, damping ζ (default 0.7). A second-order loop's gain is then
    ωn/(2ζ); a ``kv_1_s`` given with it must agree. Defaults: first order, Kv = 30 1/s, α = 0.
    """

    kv_1_s: tuple[float, float, float] | float | None = None
    feedforward: tuple[float, float, float] | float = 0.0
    natural_freq_hz: tuple[float, float, float] | float | None = None
    damping: tuple[float, float, float] | float = 0.7

    def __post_init__(self) -> None:
        ff = _axis_tuple("servo feedforward", self.feedforward, 0.0, 1.0, lo_open=False)
        zeta = _axis_tuple("servo damping", self.damping, 0.0, math.inf, lo_open=True)
        object.__setattr__(self, "feedforward", ff)
        object.__setattr__(self, "damping", zeta)
        if self.natural_freq_hz is None:
            kv = DEFAULT_KV_1_S if self.kv_1_s is None else self.kv_1_s
            object.__setattr__(self, "kv_1_s", _axis_tuple("servo kv_1_s", kv, 0.0, math.inf, lo_open=True))
            return
        fn = _axis_tuple("servo natural_freq_hz", self.natural_freq_hz, 0.0, math.inf, lo_open=True)
        object.__setattr__(self, "natural_freq_hz", fn)
        derived = tuple(2.0 * math.pi * f / (2.0 * z) for f, z in zip(fn, zeta))
        if self.kv_1_s is not None:
            given = _axis_tuple("servo kv_1_s", self.kv_1_s, 0.0, math.inf, lo_open=True)
            for axis, g, d in zip(AXES, given, derived):
                if abs(g - d) > 1e-9 * d:
                    raise MachineLimitsError(
                        f"servo kv_1_s[{axis}] = {g:g}; a second-order loop's gain is "
                        f"2*pi*natural_freq_hz/(2*damping) = {d:g}: give one or the other")
        object.__setattr__(self, "kv_1_s", derived)

    @classmethod
    def from_kv_m_min_mm(cls, kv_m_min_mm, **kwargs) -> ServoModel:
        """Same as the constructor with the gain in Heidenhain's unit, m/min of feed per mm of
        following error (Kv [1/s] = kV · 1000/60)."""
        kv = _axis_tuple("servo kv_m_min_mm", kv_m_min_mm, 0.0, math.inf, lo_open=True)
        return cls(kv_1_s=tuple(k * KV_M_MIN_MM_TO_1_S for k in kv), **kwargs)

    @property
    def order(self) -> int:
        return 1 if self.natural_freq_hz is None else 2

    @property
    def time_constant_s(self) -> float:
        """The slowest axis's decay time constant (s): 1/Kv for a first-order loop, 1/(ζωn) for a
        second-order one (its envelope); after five of them a step's error is below 1 %."""
        if self.order == 1:
            return 1.0 / min(self.kv_1_s)
        return max(1.0 / (z * 2.0 * math.pi * f) for f, z in zip(self.natural_freq_hz, self.damping))  # type: ignore[arg-type]

    def describe(self) -> str:
        kv = ",".join(f"{k:g}" for k in sorted(set(self.kv_1_s), key=self.kv_1_s.index))
        ff = ",".join(f"{a:g}" for a in sorted(set(self.feedforward), key=self.feedforward.index))
        text = f"Kv = {kv} 1/s, feed-forward {ff}"
        if self.order == 2:
            fn = ",".join(f"{f:g}" for f in sorted(set(self.natural_freq_hz), key=self.natural_freq_hz.index))
            text += f", second order fn = {fn} Hz, damping {','.join(f'{z:g}' for z in sorted(set(self.damping)))}"
        return text

    def error_filter(self, axis: int, ts_s: float) -> tuple[np.ndarray, np.ndarray]:
        """(b, a) of the discrete filter from the commanded velocity per tick v_k (constant over
        tick k) to the following error e_k at tick k (exact, see the module docstring)."""
        kv, ff = self.kv_1_s[axis], self.feedforward[axis]
        if self.order == 1:
            decay = math.exp(-kv * ts_s)
            return np.array([0.0, (1.0 - ff) * (-math.expm1(-kv * ts_s)) / kv]), np.array([1.0, -decay])
        from scipy.signal import cont2discrete

        wn = 2.0 * math.pi * self.natural_freq_hz[axis]  # type: ignore[index]
        zeta = self.damping[axis]
        # (1 − G(s))/s = (s + 2ζωn(1 − α)) / (s² + 2ζωn s + ωn²)
        num, den, _ = cont2discrete(([1.0, 2.0 * zeta * wn * (1.0 - ff)], [1.0, 2.0 * zeta * wn, wn * wn]),
                                    ts_s, method="zoh")
        return np.ravel(num), np.ravel(den)

    def circle_gain(self, axis: int, omega: np.ndarray) -> np.ndarray:
        """|G(jω)|: on a circle of radius r run at feed v (ω = v/r) with equal loops the axes
        settle on a circle of radius r·|G(jω)| (the steady-state radial contour error is
        r·(1 − |G|); first order, α = 0: r·(1 − 1/√(1 + (v/(r·Kv))²)))."""
        s = 1j * np.asarray(omega, dtype=float)
        ff = self.feedforward[axis]
        if self.order == 1:
            kv = self.kv_1_s[axis]
            return np.abs((kv + ff * s) / (s + kv))
        wn = 2.0 * math.pi * self.natural_freq_hz[axis]  # type: ignore[index]
        zeta = self.damping[axis]
        return np.abs((wn * wn + 2.0 * zeta * wn * ff * s) / (s * s + 2.0 * zeta * wn * s + wn * wn))


def following_errors(servo: ServoModel, commanded: np.ndarray, ts_s: float) -> np.ndarray:
    """Following error e_k = x_cmd,k − x_k (mm, shape (K+1, 3)) of the axes at every tick.

    ``commanded`` (K+1, 3) are the set-points at t_k = k·Ts; the axes start at rest on the first.
    One discrete filter per axis on the per-tick commanded velocities (:func:`_iir`).
    """
    cmd = np.asarray(commanded, dtype=float)
    vel = np.diff(cmd, axis=0) / ts_s
    err = np.zeros_like(cmd)
    for j in range(cmd.shape[1]):
        if not vel[:, j].any():
            continue
        b, a = servo.error_filter(j, ts_s)
        # e_k depends on v_0 … v_k−1: the filter's first output (k = 0) sees no input
        err[:, j] = _iir(b, a, np.concatenate([vel[:, j], [0.0]]))
    return err


def _iir(b: np.ndarray, a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """y with Σ a_i·y_(n−i) = Σ b_i·x_(n−i), from rest (what ``scipy.signal.lfilter(b, a, x)``
    returns), as one triangular banded solve (LAPACK dtbtrs): the same recursion, without the
    second of CPU that importing scipy.signal costs."""
    from scipy.linalg.lapack import dtbtrs

    n = x.size
    rhs = np.convolve(x, np.asarray(b, dtype=float))[:n]
    band = np.repeat(np.asarray(a, dtype=float)[:, None], n, axis=1)  # LAPACK lower band storage
    y, info = dtbtrs(band, rhs, uplo="L")
    if info != 0:
        raise ValueError(f"servo filter: LAPACK dtbtrs info = {info}")
    return np.ravel(y)


#: Points per chunk of :func:`nearest_on_curve` (its temporaries: ~1 kB per point).
NEAREST_CHUNK = 16384


def _dense_grid(curve: Nurbs, step_mm: float, max_points: int):
    """Parameters of a dense arc-length sampling (plus knots and ends) and a KD-tree of its
    points, cached per curve (a curve is immutable)."""
    return per_curve(curve, ("dense grid", step_mm, max_points),
                     lambda: _make_dense_grid(curve, step_mm, max_points))


def _make_dense_grid(curve: Nurbs, step_mm: float, max_points: int):
    from scipy.spatial import cKDTree

    # uniform in u inside each interval of the curve's arc-length table (where the speed is
    # smooth), twice as many points as the interval's length needs: no Newton on s(u)
    table = curve.arc_table
    lengths = np.diff(table.cumulative)
    want = 2.0 * lengths / step_mm
    want *= min(1.0, max_points / max(float(want.sum()), 1.0))
    per = np.maximum(np.ceil(want).astype(np.int64), 1)
    which = np.repeat(np.arange(per.size), per)
    frac = (np.arange(which.size) - np.repeat(np.cumsum(per) - per, per)) / per[which]
    u = table.breaks[which] + (table.breaks[which + 1] - table.breaks[which]) * frac
    if u.size < 64:  # a short curve: at least 64 points, evenly in u
        u = np.linspace(*curve.domain, 64)
    grid = np.unique(np.concatenate([u, curve.span_breaks, list(curve.domain)]))
    return grid, cKDTree(curve(grid))


def nearest_on_curve(curve: Nurbs, points: np.ndarray, step_mm: float = 0.01, candidates: int = 4,
                     iterations: int = 12, max_points: int = 400_000) -> tuple[np.ndarray, np.ndarray]:
    """Nearest curve parameter and distance (mm) for each of ``points`` (N, 3 or dim).

    The curve is sampled about every ``step_mm`` of arc length or closer (twice as densely as each
    interval of its arc-length table needs, plus its knots and ends); for each point the
    ``candidates`` nearest vertices (scipy cKDTree; those within two vertices of the nearest are
    the same stretch and skipped) give brackets [u_i−1, u_i+1], in which Newton's method on
    f(u) = (C(u) − x)·C′(u), f′ = |C′|² + (C − x)·C″, kept inside the bracket by bisection, finds the
    foot point. The smallest distance over the brackets (and their ends) is returned.
    """
    pts = np.asarray(points, dtype=float)
    grid, tree = _dense_grid(curve, step_mm, max_points)
    u_out = np.empty(pts.shape[0])
    d_out = np.empty(pts.shape[0])
    for c0 in range(0, pts.shape[0], NEAREST_CHUNK):  # bounded temporaries on long trajectories
        part = slice(c0, c0 + NEAREST_CHUNK)
        u_out[part], d_out[part] = _nearest_chunk(curve, pts[part], grid, tree, candidates, iterations)
    return u_out, d_out


def _nearest_chunk(curve: Nurbs, pts: np.ndarray, grid: np.ndarray, tree, candidates: int,
                   iterations: int) -> tuple[np.ndarray, np.ndarray]:
    dim = curve.dim
    if pts.shape[1] > dim:
        extra = np.abs(pts[:, dim:]).sum(axis=1)
        pts2 = pts[:, :dim]
    else:
        extra, pts2 = None, pts
    k = min(candidates, grid.size)
    _, idx = tree.query(pts2, k=k)
    idx = np.asarray(idx).reshape(pts2.shape[0], k)
    lo = grid[np.maximum(idx - 1, 0)].ravel()
    hi = grid[np.minimum(idx + 1, grid.size - 1)].ravel()
    x = np.repeat(pts2, k, axis=0)
    u = grid[idx].ravel()
    span = float(grid[-1] - grid[0])
    # a candidate within two grid points of the nearest one is the same stretch of curve: the
    # foot point lies within half a grid step of the nearest vertex, inside its bracket
    same = (np.abs(idx - idx[:, :1]) <= 2) & (np.arange(k) > 0)[None, :]
    active = np.flatnonzero(~same.ravel())  # a point leaves once its Newton step is below rounding
    for _ in range(iterations):
        if active.size == 0:
            break
        ua, xa = u[active], x[active]
        c, d1, d2 = curve.evaluate(ua, order=2)
        r = c - xa
        f = np.einsum("ij,ij->i", r, d1)
        fp = np.einsum("ij,ij->i", d1, d1) + np.einsum("ij,ij->i", r, d2)
        lo_a = np.where(f < 0, ua, lo[active])
        hi_a = np.where(f > 0, ua, hi[active])
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = ua - f / fp
        # the bracket is closed: a step that lands on its end (the point itself, to rounding)
        # is a converged Newton step, not a reason to bisect
        ok = (fp > 0) & (newton >= lo_a) & (newton <= hi_a)
        new = np.where(ok, newton, 0.5 * (lo_a + hi_a))
        lo[active], hi[active], u[active] = lo_a, hi_a, new
        done = (ok & (np.abs(new - ua) <= 1e-14 * span)) | (f == 0.0)
        active = active[~done]
    # candidates: the polished point and both bracket ends
    cand_u = np.stack([u, lo, hi], axis=1)
    keep = np.flatnonzero(~same.ravel())
    dist = np.full(cand_u.shape, np.inf)
    cand_pts = curve(cand_u[keep].ravel()).reshape((keep.size, 3, dim))
    dist[keep] = np.linalg.norm(cand_pts - x[keep][:, None, :], axis=-1)
    # a bracket end wins only if closer beyond rounding: near the foot point the distance is flat
    # (second order), so an end a few 1e-8 mm away can tie with it
    score = dist.copy()
    score[:, 1:] += 1e-12 * max(1.0, float(np.abs(x).max(initial=0.0)))
    best = np.argmin(score, axis=1)
    rows = np.arange(dist.shape[0])
    d = dist[rows, best].reshape(-1, k)
    uu = cand_u[rows, best].reshape(-1, k)
    pick = np.argmin(d, axis=1)
    n = pts2.shape[0]
    dist_out = d[np.arange(n), pick]
    if extra is not None and extra.any():
        dist_out = np.hypot(dist_out, np.linalg.norm(pts[:, dim:], axis=1))
    return uu[np.arange(n), pick], dist_out


@dataclass(frozen=True, eq=False)
class Tracking:
    """The servo's response at every tick: actual positions, following and contour errors (mm)."""

    actual_xyz: np.ndarray     # (K+1, 3)
    following_mm: np.ndarray   # (K+1,) |x_cmd − x|
    contour_mm: np.ndarray     # (K+1,) distance of the actual position from the curve


def track(curve: Nurbs, commanded: np.ndarray, ts_s: float, servo: ServoModel) -> Tracking:
    """Run the commanded set-points (K+1, 3) through ``servo`` and measure the contour error."""
    err = following_errors(servo, commanded, ts_s)
    actual = np.asarray(commanded, dtype=float) - err
    _, contour = nearest_on_curve(curve, actual)
    return Tracking(actual_xyz=actual, following_mm=np.linalg.norm(err, axis=1), contour_mm=contour)


def steady_circle_error_mm(servo: ServoModel, radius_mm: float, feed_mm_s: float, axis: int = 0) -> float:
    """Steady-state radial contour error on a circle (equal loops): r·|1 − |G(j·v/r)||."""
    return float(radius_mm * abs(1.0 - servo.circle_gain(axis, np.array([feed_mm_s / radius_mm]))[0]))
