"""Issue 38 (compute): the compiled u(s) (geometry/_arc_jit.py) against the numpy iteration it
replaces (ArcLengthTable._param_block), and against closed-form arc lengths; the chord-exact
interpolator's compiled per-tick terms (geometry/_chord_jit.py) against its numpy lines; the
power-basis conversion over all spans at once against the span-by-span recursion; and whole
schedules against values recorded from main at 55c2bd9 (before these changes).

On the machine they were written on the compiled forms give the numpy code's floats bit for bit
(the same operations in the same order, numpy's einsum lanes and powers included); numpy's SIMD
dispatch may round a last bit otherwise on another CPU, so the tests allow 1e-13 of the scale (as
tests/test_slw_exact.py does)."""

import numpy as np
import pytest

import slw_cases
from fuzzyfeed.geometry import power_basis as PB
from fuzzyfeed.geometry._kernels import nurbs_kernel
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.geometry.polyline_fit import fit_polyline
from fuzzyfeed.geometry import interpolate as I
from fuzzyfeed.io.shapes import load_shape
from fuzzyfeed.slw import schedule


def _curves():
    yield from (slw_cases.random_nurbs(seed)[0] for seed in range(16))   # 2-D, 3-D, rational
    yield slw_cases.cusp_cubic()
    yield load_shape("butterfly").curve
    yield fit_polyline(slw_cases.cam_polyline(1500)).curve


def _numpy_param_at(curve, s):
    table, total = curve.arc_table, curve.length
    s = np.clip(s, 0.0, total)
    return np.concatenate([table._param_block(curve, s[i:i + 8192], 30, False)
                           for i in range(0, s.size, 8192)])


@pytest.mark.parametrize("index", range(19))
def test_compiled_param_at_bit_for_bit(index):
    curve = list(_curves())[index]
    nurbs_kernel()                     # loaded: every call of more than a few points is compiled
    rng = np.random.default_rng(index)
    total = curve.length
    # sorted (servo ticks), unsorted, the ends and repeated values
    s = np.concatenate([[0.0, total, total, 0.5 * total], np.sort(rng.uniform(0.0, total, 20000)),
                        rng.uniform(0.0, total, 3000)])
    got = curve.param_at_length(s)
    want = _numpy_param_at(curve, s)
    span = curve.domain[1] - curve.domain[0]
    assert np.abs(got - want).max() <= 1e-13 * span, np.flatnonzero(got != want)[:5]


@pytest.mark.parametrize("index", [0, 5, 16, 17, 18])
def test_small_calls_compiled_once_loaded(index):
    """Once the u(s) kernel is loaded, a call of a few points runs it too (the look-ahead's samples):
    the numpy iteration's floats, point by point."""
    from fuzzyfeed.geometry._kernels import arc_kernel

    curve = list(_curves())[index]
    arc_kernel()
    rng = np.random.default_rng(index)
    total = curve.length
    span = curve.domain[1] - curve.domain[0]
    for size in (1, 2, 7, 28):
        s = np.sort(rng.uniform(0.0, total, size))
        got = np.atleast_1d(curve.param_at_length(s))
        assert np.abs(got - _numpy_param_at(curve, s)).max() <= 1e-13 * span
    assert curve.param_at_length(0.37 * total) == pytest.approx(_numpy_param_at(curve, np.array([0.37 * total]))[0],
                                                                rel=0, abs=1e-13 * span)


def test_compiled_param_at_closed_forms():
    nurbs_kernel()
    # a straight cubic with uneven control points: s(u) from the polynomial's own closed form;
    # a rational quadratic quarter circle of radius R: s = R·θ
    line = Nurbs(3, [0, 0, 0, 0, 1, 1, 1, 1], [[0, 0], [1, 0], [7, 0], [10, 0]])
    s = np.linspace(0.0, 10.0, 5001)
    u = line.param_at_length(s)
    x = line(u)[:, 0]
    assert np.allclose(x, s, rtol=0, atol=1e-12)
    r = 25.0
    arc = Nurbs(2, [0, 0, 0, 1, 1, 1], [[r, 0], [r, r], [0, r]], weights=[1, np.sqrt(0.5), 1])
    s = np.linspace(0.0, 0.5 * np.pi * r, 7001)
    p = arc(arc.param_at_length(s))
    assert np.allclose(np.arctan2(p[:, 1], p[:, 0]) * r, s, rtol=0, atol=1e-11)


def _old_power_basis(p, knots, points, weights):
    homogeneous = np.hstack([points * weights[:, None], weights[:, None]])
    breaks, coeffs = [knots[p]], []
    for i in range(p, points.shape[0]):
        if knots[i + 1] > knots[i]:
            coeffs.append(PB._span_basis_matrix(p, knots, i) @ homogeneous[i - p: i + 1])
            breaks.append(knots[i + 1])
    return np.array(breaks), np.array(coeffs)


@pytest.mark.parametrize("seed", range(40))
def test_power_basis_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    p = int(rng.integers(2, 6))
    n = int(rng.integers(p + 1, 40))
    inner = np.sort(np.round(rng.uniform(0.0, 1.0, n - p - 1), 1))     # repeated knots too
    knots = np.concatenate([np.zeros(p + 1), inner, np.ones(p + 1)])
    points = rng.normal(0.0, 10.0, (n, 2 + seed % 2))
    weights = rng.uniform(0.2, 1.0, n) if seed % 3 else np.ones(n)
    old = _old_power_basis(p, knots, points, weights)
    new = PB.power_basis(p, knots, points, weights)
    assert np.array_equal(old[0], new[0])
    assert old[1].shape == new[1].shape
    assert np.abs(old[1] - new[1]).max() <= 1e-13 * np.abs(old[1]).max()


# (path, machine, transition, ticks, Σ w_k u_k, Σ w_k x_k, Σ w_k y_k, Σ w_k z_k, xyz at tick K // 3)
# with w = linspace(1, 2, K), recorded with the NURBS kernel loaded and the numpy u(s) and interpolation
# (main 55c2bd9; the slow-Y rows from branch sched38j's window, which changed those schedules, then
# from branch median6's window with the compiled u(s), which gives the numpy floats; the slow-Y
# seven-phase rows again from branch med7's window: a transition's junction where its stretch allows
# far more than its worst point)
RECORDED = [
    ("cam1000", "equal", "cosine", 5383, 2323871.00233069, 5472.421197684773, 4448.3467980342375, 1176.448420314293, -7.92646246949247, 15.90653574126969, 1.2051992294489047),
    ("cam1000", "slow-y", "seven-phase", 8989, 3884763.467481805, 6489.389704985676, 6352.364756116811, 1784.0394573553342, -10.14860371571941, 15.09258678159406, 1.142165682673324),
    ("butterfly", "slow-y", "seven-phase", 9666, 7993.121758683099, 729935.2636027777, 474076.94849720516, 0.0, 80.63112063425824, 11.844472999783836, 0.0),
    ("nurbs7", "equal", "cosine", 1501, 1136.8265535702642, -44728.405214985105, -101231.04995862367, -6044.685054969323, -24.502631583533887, -29.309268062632114, 5.657365260518162),
    ("cusp", "slow-y", "cosine", 6531, 5062.820657421897, 519363.9790409798, 407785.55509119236, 0.0, 46.29217486413195, 35.2031556725922, 0.0),
    ("trident2", "equal", "seven-phase", 1559, 1324.7695276940003, 22016.221912148536, 25198.052517966295, 0.0, 14.450755359658865, 12.007605408774932, 0.0),
]


@pytest.mark.parametrize("row", RECORDED, ids=lambda r: "/".join(r[:3]))
def test_schedules_as_recorded_on_main(row):
    name, machine, transition, ticks, *want = row
    nurbs_kernel()
    tr = slw_cases.recorded_schedule(name, machine, transition=transition)
    assert tr.u.size == ticks
    w = np.linspace(1.0, 2.0, ticks)
    got = [float(tr.u @ w), *(float(tr.xyz[:, i] @ w) for i in range(3)), *map(float, tr.xyz[ticks // 3])]
    scale = [abs(want[0])] + [float(np.abs(tr.xyz).max()) * w.sum()] * 3 + [float(np.abs(tr.xyz).max())] * 3
    for g, v, sc in zip(got, want, scale):
        assert abs(g - v) <= 1e-12 * sc, (g, v)


@pytest.mark.parametrize("name, machine", [("cam1000", "slow-y"), ("butterfly", "equal"), ("cusp", "equal"),
                                           ("nurbs4", "slow-y")])
def test_chord_exact_terms_compiled_bit_for_bit(name, machine, monkeypatch):
    """The chord-exact interpolator with its per-tick terms compiled (geometry/_chord_jit.py)
    against its numpy lines, on a scheduled tick array (corners, near-cusp, 2-D and 3-D)."""
    from fuzzyfeed.geometry import interpolate as I

    nurbs_kernel()
    tr = slw_cases.recorded_schedule(name, machine)
    curve, s = tr.curve, np.array(tr.s_mm)
    got = I.interpolate_u(curve, s, "best")
    monkeypatch.setattr(I, "nurbs_compiled", lambda n: False)
    want = I.interpolate_u(curve, s, "best")
    span = curve.domain[1] - curve.domain[0]
    assert np.abs(got - want).max() <= 1e-13 * span, np.flatnonzero(got != want)[:5]
    assert np.abs(got - tr.u).max() <= 1e-13 * span


# the corner adjustment as main had it (whole-path arrays), the reference of the one that evaluates only the
# points near corners; with a 2-D curve's points in two columns, as the fix of its NaN third coordinate has them
def _old_beside_corners(curve: Nurbs, u: np.ndarray, steps: np.ndarray, hard: np.ndarray,
                    rounds: int = 60) -> np.ndarray:
    """``u`` with the chords beside a corner's chord in the ratio to their ``steps`` of the smooth
    chord beyond them: where the
    fixed point stalls with a tick that crossed the corner between passes, the smooth chord next
    to the corner's keeps the corner's cut as its retarget (up to 6e-3 mm). The tick shared with
    the corner's chord is moved, on its own side of the corner knot, until the chord from its
    other end has the wanted length (bisection: the distance from a point grows along a smooth
    piece shorter than a servo step); the corner's chord, which cuts the corner anyway, takes the
    difference."""
    if hard.size == 0 or u.size < 3:
        return u
    knot = I._holds_knot(hard, u)
    n = knot.size
    before = np.flatnonzero(~knot[:-1] & knot[1:])     # chord k, then the corner's chord k + 1
    after = np.flatnonzero(~knot[1:] & knot[:-1]) + 1  # the corner's chord k - 1, then chord k
    before = before[(before >= 1) & ~knot[np.maximum(before - 1, 0)]]
    after = after[(after <= n - 2) & ~knot[np.minimum(after + 1, n - 1)]]
    # the ratio chord / step the fixed point reached on the smooth chord beyond (μ up to its own
    # last digits) is the wanted one of the chord beside the corner's; points near corners only
    near = np.unique(np.concatenate([before - 1, before, before + 1, after, after + 1, after + 2]))
    pts = np.full((u.size, curve.dim), np.nan)   # (main had 3 columns: a 2-D curve's z NaN, nothing moved)
    if near.size:
        pts[near] = curve.evaluate(u[near], order=0)[0]
    chord = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(steps > 0, chord / steps, 1.0)
    want = np.zeros(n)
    want[before] = steps[before] * ratio[before - 1]
    want[after] = steps[after] * ratio[after + 1]
    off = np.abs(chord - want) > 1e-12 * np.maximum(steps, 1.0)
    before, after = before[off[before]], after[off[after]]
    after = after[~np.isin(after - 1, before + 1)]      # a tick moved once
    u = u.copy()
    for chords, moving, anchor, sign in ((before, before + 1, before, 1.0), (after, after, after + 1, -1.0)):
        if chords.size == 0:
            continue
        # the bracket: from the anchor's side to the corner knot (exclusive)
        k_at = np.searchsorted(hard, u[moving], side="left" if sign > 0 else "right") - (sign < 0)
        end = hard[np.clip(k_at, 0, hard.size - 1)]
        a, b = u[anchor], end - sign * 1e-12 * (curve.domain[1] - curve.domain[0])
        p0 = pts[anchor]
        length = lambda x: np.linalg.norm(curve.evaluate(x, order=0)[0] - p0, axis=1)  # noqa: E731
        ok = (length(b) >= want[chords]) & (sign * (b - a) > 0)
        a, b, chords, moving, p0 = a[ok], b[ok], chords[ok], moving[ok], p0[ok]
        for _ in range(rounds):
            mid = 0.5 * (a + b)
            short = length(mid) < want[chords]
            a, b = np.where(short, mid, a), np.where(short, b, mid)
        u[moving] = 0.5 * (a + b)
    return u


def _corner_schedules():
    for curve in (slw_cases.rectangle(), slw_cases.cam_polyline(300)):      # 2-D and 3-D, every vertex a corner
        for machine in ("equal", "slow-y"):
            yield schedule(curve, slw_cases.RECORDED_MACHINES[machine], blend=False, planner="window", transition="cosine")


@pytest.mark.parametrize("case", range(4))
def test_chord_exact_passes_compiled_at_corners(case, monkeypatch):
    """The compiled passes (corner chords capped in numpy) against the numpy lines on paths whose
    every vertex is a corner: the same parameters."""
    nurbs_kernel()
    tr = list(_corner_schedules())[case]
    s = np.array(tr.s_mm)
    got = I.interpolate_u(tr.curve, s, "best")
    monkeypatch.setattr(I, "nurbs_compiled", lambda n: False)
    want = I.interpolate_u(tr.curve, s, "best")
    span = tr.curve.domain[1] - tr.curve.domain[0]
    assert np.abs(got - want).max() <= 1e-13 * span
    assert np.array_equal(got, tr.u)


@pytest.mark.parametrize("case", range(4))
def test_beside_corners_as_main(case):
    """The chords beside corners set as main's whole-array form sets them, from ticks moved off the
    fixed point next to corners (a stalled pass), with the corner flags given or found."""
    tr = list(_corner_schedules())[case]
    curve, u0 = tr.curve, np.array(tr.u)
    steps = np.diff(np.array(tr.s_mm))
    hard = I._c0_knots(curve)
    knot = I._holds_knot(hard, u0)
    rng = np.random.default_rng(case)
    beside = np.flatnonzero(knot[1:] & ~knot[:-1])          # the tick before each corner's chord
    u = u0.copy()
    u[beside] -= rng.uniform(0.0, 0.3, beside.size) * (u0[beside] - u0[beside - 1])
    knot = I._holds_knot(hard, u)
    want = _old_beside_corners(curve, u, steps, hard)
    moved = int((want != u).sum())
    assert moved > 0                           # 2-D too (main kept a 2-D curve's z NaN: none moved)
    assert np.array_equal(I._beside_corners(curve, u, steps, hard), want)
    assert np.array_equal(I._beside_corners(curve, u, steps, hard, knot=knot), want)
