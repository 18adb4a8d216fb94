"""Paths and machines the SLW scheduler must handle (shared by the tests and benchmarks/bench_slw.py).

Random smooth NURBS (degree 2-5, 2-D and 3-D, random weights, random and unequal per-axis limits)
and polylines as CAM programs make them: rectangles, zig-zags, square passes, and long chains of
short segments approximating a curve (10³-10⁵ segments).
"""

from __future__ import annotations

import numpy as np

from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.geometry.nurbs import Nurbs


def random_limits(rng: np.random.Generator) -> MachineLimits:
    """Random limits spanning an order of magnitude, every axis different."""
    return MachineLimits(feed_mm_s=rng.uniform(10, 200), axis_vel_mm_s=tuple(rng.uniform(20, 200, 3)),
                         axis_acc_mm_s2=tuple(rng.uniform(200, 3000, 3)),
                         jerk_mm_s3=rng.uniform(2000, 50000), chord_tol_mm=10 ** rng.uniform(-4, -2),
                         ts_s=float(rng.choice([0.0005, 0.001, 0.002])))


def random_nurbs(seed: int) -> tuple[Nurbs, MachineLimits]:
    """A random smooth NURBS and random unequal limits (the same for the same seed)."""
    rng = np.random.default_rng(seed)
    p = int(rng.integers(2, 6))
    n = int(rng.integers(p + 2, p + 10))
    dim = int(rng.integers(2, 4))
    pts = [np.zeros(dim)]
    d = rng.normal(size=dim)
    d /= np.linalg.norm(d)
    for _ in range(n - 1):
        r = rng.normal(size=dim)
        r -= (r @ d) * d
        r /= np.linalg.norm(r) + 1e-12
        ang = rng.uniform(-1.5, 1.5)
        d = np.cos(ang) * d + np.sin(ang) * r
        d /= np.linalg.norm(d)
        pts.append(pts[-1] + d * rng.uniform(2, 25))
    inner = np.sort(rng.uniform(0.02, 0.98, n - p - 1))
    knots = np.concatenate([[0] * (p + 1), inner, [1] * (p + 1)])
    return Nurbs(p, knots, np.array(pts), rng.uniform(0.5, 2.0, n)), random_limits(rng)


def polyline(points) -> Nurbs:
    """The degree-1 NURBS through ``points`` with chord-length knots (as the G-code/CSV readers)."""
    pts = np.asarray(points, dtype=float)
    chords = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    t = np.concatenate([[0.0], np.cumsum(chords)]) / chords.sum()
    t[-1] = 1.0
    return Nurbs(1, np.concatenate([[0.0], t, [1.0]]), pts)


def rectangle(w: float = 40.0, h: float = 25.0) -> Nurbs:
    return polyline([[0, 0], [w, 0], [w, h], [0, h], [0, 0]])


def zigzag(teeth: int = 20, pitch: float = 2.0, height: float = 10.0) -> Nurbs:
    xs = np.arange(teeth + 1) * pitch
    ys = np.where(np.arange(teeth + 1) % 2 == 0, 0.0, height)
    return polyline(np.column_stack([xs, ys]))


def square_passes(passes: int = 10, size: float = 20.0, stepover: float = 1.0) -> Nurbs:
    """Concentric square passes of a pocket, stepping in between passes (a CAM roughing path)."""
    pts = []
    for k in range(passes):
        a = k * stepover
        b = size - k * stepover
        if b - a <= stepover:
            break
        pts += [[a, a], [b, a], [b, b], [a, b], [a, a + stepover]]
    return polyline(pts)


def cam_polyline(segments: int, seed: int = 0, dim: int = 3, seg_mm: float | None = None) -> Nurbs:
    """A CAM-style chain of ``segments`` short G1 moves approximating a smooth free-form curve: a
    wavy spiral sampled at random chord lengths around ``seg_mm`` (default: 0.5 mm for 10³
    segments, 0.05 mm for 10⁴, 0.01 mm for 10⁵ — a finishing pass), coordinates rounded to 1 µm
    as a post-processor writes them."""
    rng = np.random.default_rng(seed)
    seg = float(np.clip(500.0 / segments, 0.01, 0.5)) if seg_mm is None else seg_mm
    steps = rng.uniform(0.5, 1.5, segments)
    t = np.concatenate([[0.0], np.cumsum(steps)]) * seg / 20.0  # radius about 20 mm: arc ≈ 20·dt
    r = 20.0 + 5.0 * np.sin(0.7 * t)
    pts = np.column_stack([r * np.cos(t), r * np.sin(t), 2.0 * np.sin(0.3 * t)])[:, :dim]
    pts = np.round(pts, 3)
    keep = np.concatenate([[True], np.any(np.diff(pts, axis=0) != 0, axis=1)])
    return polyline(pts[keep])


def polyline_cases() -> list[tuple[str, Nurbs, MachineLimits]]:
    """Named polylines with the default machine and with unequal axes."""
    unequal = MachineLimits(feed_mm_s=80, axis_vel_mm_s=(100, 50, 30), axis_acc_mm_s2=(1500, 600, 400),
                            jerk_mm_s3=20000)
    out = []
    for lim_name, lim in (("default", MachineLimits()), ("unequal", unequal)):
        out += [(f"rectangle/{lim_name}", rectangle(), lim),
                (f"zigzag/{lim_name}", zigzag(), lim),
                (f"square_passes/{lim_name}", square_passes(), lim),
                (f"cam1000/{lim_name}", cam_polyline(1000), lim)]
    return out


# ---------------------------------------------------------------------- property-test families
def ratio_machine(rng: np.random.Generator) -> MachineLimits:
    """A machine whose axes differ by up to 10:1 in velocity and in acceleration (one axis the
    fastest, the others slower by random factors), at a random feed, jerk, tolerance and period."""
    acc0, vel0 = rng.uniform(500, 3000), rng.uniform(50, 200)
    return MachineLimits(feed_mm_s=rng.uniform(20, 200),
                         axis_vel_mm_s=tuple(vel0 / rng.uniform(1, 10, 3)),
                         axis_acc_mm_s2=tuple(acc0 / rng.uniform(1, 10, 3)),
                         jerk_mm_s3=rng.uniform(2000, 50000), chord_tol_mm=10 ** rng.uniform(-3.5, -2),
                         ts_s=float(rng.choice([0.0005, 0.001, 0.002])))


def general_nurbs(rng: np.random.Generator) -> Nurbs:
    """Degree 2-5, 2-D or 3-D, a random walk of control points, non-uniform interior knots some
    of them repeated (up to the degree: a C0 join, maybe a corner), weights in [0.3, 3]."""
    p = int(rng.integers(2, 6))
    n = int(rng.integers(p + 2, p + 12))
    dim = int(rng.integers(2, 4))
    steps = rng.normal(size=(n - 1, dim))
    steps *= (rng.uniform(1, 30, n - 1) / np.linalg.norm(steps, axis=1))[:, None]
    pts = np.vstack([np.zeros(dim), np.cumsum(steps, axis=0)])
    inner: list[float] = []
    while len(inner) < n - p - 1:
        k = float(rng.uniform(0.01, 0.99))
        inner += [k] * min(int(rng.choice([1, 1, 1, 2, p])), n - p - 1 - len(inner))
    knots = np.concatenate([[0.0] * (p + 1), np.sort(inner), [1.0] * (p + 1)])
    return Nurbs(p, knots, pts, rng.uniform(0.3, 3.0, n))


def corner_polyline(rng: np.random.Generator) -> Nurbs:
    """A polyline of 3-60 segments of 0.05-30 mm (log-uniform) turning 0-175 degrees at each
    vertex, coordinates rounded to 1 µm as a post-processor writes them."""
    n = int(rng.integers(3, 61))
    lengths = 10 ** rng.uniform(np.log10(0.05), np.log10(30), n)
    turns = np.radians(rng.uniform(-175, 175, n)) * (rng.uniform(size=n) < 0.7)
    heading = np.cumsum(turns)
    pts = np.vstack([[0.0, 0.0], np.cumsum(np.column_stack([np.cos(heading), np.sin(heading)])
                                           * lengths[:, None], axis=0)])
    pts = np.round(pts, 3)
    keep = np.concatenate([[True], np.any(np.diff(pts, axis=0) != 0, axis=1)])
    return polyline(pts[keep])


def cusp_cubic() -> Nurbs:
    """A random cubic (seeded control points in a 100 mm square, non-uniform knots) with a
    near-cusp of 0.3 µm radius at u ≈ 0.79: before issue 27 the chords there were 10 % short and
    their jerk 9.3 x J at 0.46 mm/s (the issue's report: 13.8 x at a knot, 0.42 mm/s)."""
    rng = np.random.default_rng(3)
    n = int(rng.integers(5, 13))
    pts = rng.uniform(0, 100, (n, 2))
    inner = np.sort(rng.uniform(0, 1, n - 4))
    return Nurbs(3, np.concatenate([[0] * 4, inner, [1] * 4]), pts)


#: The machines of the recorded schedules (tests/test_arc_jit.py, tests/test_slw_kernels.py): the
#: default limits on every axis, and a Y axis at half the speed and a quarter of the acceleration.
EQUAL = MachineLimits()
SLOW_Y = MachineLimits(axis_vel_mm_s=(100, 50, 100), axis_acc_mm_s2=(1000, 250, 1000))
RECORDED_MACHINES = {"equal": EQUAL, "slow-y": SLOW_Y}


def named_curve(name: str) -> Nurbs:
    """The path a recorded row names: "cusp" (cusp_cubic), "nurbsN" (random_nurbs(N)), "cam1000"
    (cam_polyline(1000)), else a shipped shape."""
    if name == "cusp":
        return cusp_cubic()
    if name.startswith("nurbs"):
        return random_nurbs(int(name[5:]))[0]
    if name == "cam1000":
        return cam_polyline(1000)
    from fuzzyfeed.io.shapes import load_shape

    return load_shape(name).curve


def recorded_schedule(name: str, machine: str, **options):
    """The schedule of a recorded row: ``named_curve(name)`` on RECORDED_MACHINES[machine]
    ("equal" or "slow-y"), ``options`` passed to slw.schedule (transition=...)."""
    from fuzzyfeed.slw import schedule

    return schedule(named_curve(name), RECORDED_MACHINES[machine], **{"planner": "window", "transition": "cosine", **options})


def profile_at(segs: list, s_query: np.ndarray, scale: float = 1.0):
    """v, a and the total time of a profile of slw/profile segments at arc lengths ``s_query`` (the
    segments' own s(t) times ``scale``, inverted by bisection on t; a scaled by ``scale`` too)."""
    from fuzzyfeed.slw.profile import segment_table, segments_state

    durations = np.array([g.duration_s for g in segs])
    starts = np.concatenate([[0.0], np.cumsum(durations)])
    starts_s = np.concatenate([[0.0], np.cumsum([g.length_mm for g in segs])])
    table = segment_table(segs)

    def state(t):
        at = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(segs) - 1)
        pos, v, a, _ = segments_state(segs, table, at, np.minimum(t - starts[at], durations[at]))
        return (pos + starts_s[at]) * scale, v, a

    lo, hi = np.zeros_like(s_query, dtype=float), np.full(np.shape(s_query), starts[-1])
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        below = state(mid)[0] < s_query
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    _, v, a = state(0.5 * (lo + hi))
    return v, a * scale, float(starts[-1])
