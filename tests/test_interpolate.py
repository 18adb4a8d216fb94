"""The shared interpolator: Taylor methods, parameter compensation, chord-exact "best"."""

import math

import numpy as np
import pytest

from fuzzyfeed.errors import InputError
from fuzzyfeed.geometry.interpolate import METHODS, feed_fluctuation, interpolate_u, max_fluctuation_pct
from fuzzyfeed.io.shapes import load_shape
from fuzzyfeed.geometry.nurbs import Nurbs


def circle(radius: float) -> Nurbs:
    w = math.sqrt(0.5)
    pts = np.array([[radius, 0], [radius, radius], [0, radius], [-radius, radius], [-radius, 0]])
    return Nurbs(2, [0, 0, 0, 0.5, 0.5, 1, 1, 1], pts, [1, w, 1, w, 1])


@pytest.fixture(scope="module")
def wm():
    return load_shape("wm").curve


def ramp_targets(length: float, n: int) -> np.ndarray:
    """A smooth start-stop arc-length profile (cosine in time)."""
    t = np.linspace(0.0, 1.0, n)
    s = length * (t - np.sin(2 * np.pi * t) / (2 * np.pi))
    s[-1] = length
    return s


@pytest.mark.parametrize("method", METHODS)
def test_every_method_starts_and_ends_exactly(wm, method):
    s = ramp_targets(wm.length, 3000)
    u = interpolate_u(wm, s, method)
    assert u[0] == wm.domain[0] and u[-1] == wm.domain[1]
    assert np.all(np.diff(u) >= 0)


def test_fluctuation_ordering_and_best_below_threshold(wm):
    s = ramp_targets(wm.length, 3000)  # ~20 µm steps, comparable to a chord-limited feed
    f = {m: max_fluctuation_pct(wm, interpolate_u(wm, s, m), s) for m in METHODS}
    assert f["taylor2"] < f["taylor1"]
    assert f["compensated"] < f["taylor2"]
    assert f["best"] <= 0.001
    assert f["best"] < f["arc"]


def test_arc_method_matches_arc_length(wm):
    s = np.linspace(0, wm.length, 500)
    u = interpolate_u(wm, s, "arc")
    assert np.allclose(wm.arc_length(u), s, atol=1e-9)


def test_circle_chords_are_exact_with_best():
    c = circle(2.0)  # half circle, length 2π
    s = np.linspace(0.0, c.length, 400)
    u = interpolate_u(c, s, "best")
    pts = c(u)
    chords = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    # μ·ΔL for every step, μ within rounding of 1 - (arc-chord deficit)/L
    assert np.ptp(chords) < 1e-12
    assert abs(chords[0] / (s[1] - s[0]) - 1) < 1e-5
    # independent reference: the chord of an arc of length a on radius r is 2 r sin(a / 2r)
    dl = s[1] - s[0]
    assert np.nanmax(feed_fluctuation(c, interpolate_u(c, s, "arc"), s)) == pytest.approx(
        1 - 2 * 2.0 * math.sin(dl / 4.0) / dl, rel=1e-6)


def test_bad_targets_are_rejected(wm):
    with pytest.raises(InputError, match="method"):
        interpolate_u(wm, np.array([0, wm.length]), "cubic")
    with pytest.raises(InputError, match="decrease"):
        interpolate_u(wm, np.array([0, 2.0, 1.0, wm.length]))
    with pytest.raises(InputError, match="path length"):
        interpolate_u(wm, np.array([0, 1.0]))
    with pytest.raises(InputError, match="finite"):
        interpolate_u(wm, np.array([0, np.nan, wm.length]))
    with pytest.raises(InputError):
        interpolate_u(wm, np.array([wm.length]))


def test_best_keeps_improving_until_it_stalls_at_sharp_turns():
    # a constant 100 mm/s on butterfly: at its sharp turns no chord can match the arc, and the
    # chord-exact fixed point improves there for three passes (20.5 %, 11.1 %, 7.2 %) before it
    # stalls; stopping once a pass did not halve the error left 11.1 %
    from fuzzyfeed.machine.limits import MachineLimits
    from fuzzyfeed.machine.profile import FeedProfile
    from fuzzyfeed.geometry.sampling import sample_uniform_u
    from fuzzyfeed.machine.simulate import time_law_from_profile

    lim = MachineLimits()
    curve = load_shape("butterfly").curve
    smp = sample_uniform_u(curve, 2000)
    law = time_law_from_profile(FeedProfile(smp, np.full(len(smp), lim.feed_mm_s), "constant",
                                            lim.feed_mm_s), lim.ts_s)
    u = interpolate_u(curve, law.s_mm, "best")
    assert max_fluctuation_pct(curve, u, law.s_mm) < 8.0


def _straight_then_corner() -> Nurbs:
    """10 mm straight along x, a true corner (C0 knot at u = 1), then down in z into a tight
    start (κ ≈ 67/mm) and a zig-zag cubic: the chords after the corner fall short of their arcs
    by up to 1e-4 mm each, so the chord-exact retarget moves every tick before the corner back."""
    straight = [[0, 0, 0], [10 / 3, 0, 0], [20 / 3, 0, 0], [10, 0, 0]]
    tight = [[10, 0, -0.01], [10, 0.01, -0.01], [10, 2, -1]]
    n = 60
    zigzag = [[10, 2 + 0.4 * (-1) ** i, -1 - 0.3 * i] for i in range(1, n + 1)]
    knots = [0, 0, 0, 0, 1, 1, 1] + list(np.linspace(2, 3, n + 1)[:-1]) + [3, 3, 3, 3]
    return Nurbs(3, knots, np.array(straight + tight + zigzag, dtype=float))


@pytest.mark.parametrize("feed", [50.0, 90.0])
def test_best_keeps_the_chords_before_a_true_corner_exact(feed):
    # issue 38: a tick just short of a corner, whose chord held the corner in the first pass, kept
    # that chord's cut as its retarget (the next pass read as a stall): the chord before the corner
    # 1.5e-7 mm long, the chords' jerk 1.2 % over J (pycut_cnc1310_backlash.nc#1); with ticks that
    # cross the corner between passes, up to 6e-3 mm. Every chord that lies wholly on the straight
    # run must be μ·ΔL, μ the ratio of the run's interior chords.
    curve = _straight_then_corner()
    corner_u, dl = 1.0, feed * 1e-3
    worst = 0.0
    for phase in np.linspace(0.0, dl, 13, endpoint=False):
        s = np.concatenate([[0.0], np.arange(phase + dl, curve.length, dl), [curve.length]])
        u = interpolate_u(curve, s, "best")
        chords = np.linalg.norm(np.diff(curve(u), axis=0), axis=1)
        straight = np.flatnonzero(u[1:] <= corner_u)[1:]  # from C(u_k) to C(u_k+1) before the corner
        mu = np.median(chords[straight[:-3]] / np.diff(s)[straight[:-3]])
        assert abs(mu - 1) < 0.02  # the zig-zag's deficit, spread over the path
        worst = max(worst, float(np.max(np.abs(chords[straight] - mu * np.diff(s)[straight]))))
    assert worst < 1e-12


@pytest.mark.parametrize("dim_pts", [
    [[0, 0], [40, 0], [40, 25], [0, 25], [0, 0]],                        # a rectangle: right angles
    [[0, 0], [10, 3], [14, 12], [3, 20], [-6, 9], [2, 4]],               # a zigzag: sharp and wide corners
])
def test_beside_corners_2d_as_3d(dim_pts):
    """The corner adjustment (interpolate._beside_corners) puts the ticks beside a 2-D path's
    corners where it puts those of the same path in 3-D (z = 0): the chord beside each corner's
    at the ratio to its step of the smooth chord beyond it. (It read a 2-D curve's points with a
    NaN third coordinate, so every chord was NaN and no tick moved.)"""
    from fuzzyfeed.geometry import interpolate as I

    pts2 = np.asarray(dim_pts, dtype=float)
    n = len(pts2)
    knots = np.concatenate([[0.0], np.arange(n), [n - 1.0]])
    flat = Nurbs(1, knots, pts2)
    space = Nurbs(1, knots, np.column_stack([pts2, np.zeros(n)]))
    s = ramp_targets(flat.length, 4001)
    hard = I._c0_knots(flat)
    assert hard.size == n - 2 and np.array_equal(hard, I._c0_knots(space))
    u0 = interpolate_u(space, s, "best")
    steps = np.diff(s)
    knot = I._holds_knot(hard, u0)
    beside = np.flatnonzero(knot[1:] & ~knot[:-1])          # the tick before each corner's chord
    assert beside.size == n - 2
    # ticks moved off the fixed point next to corners (a stalled pass), as test_arc_jit does
    u = u0.copy()
    u[beside] -= np.linspace(0.05, 0.3, beside.size) * (u0[beside] - u0[beside - 1])
    want = I._beside_corners(space, u, steps, hard)
    got = I._beside_corners(flat, u, steps, hard)
    assert (want != u).sum() >= beside.size                 # the 3-D case moves them back
    span = flat.domain[1] - flat.domain[0]
    assert np.abs(got - want).max() <= 1e-13 * span
    # and the chord beside each corner's has the smooth chord's ratio to its step again
    xy = flat.evaluate(got, order=0)[0]
    ch = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    k = beside
    assert np.allclose(ch[k] / steps[k], ch[k - 1] / steps[k - 1], rtol=0.0, atol=1e-9)
