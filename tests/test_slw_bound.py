"""The acceleration-limited bound's time against closed forms (issue 38: its grid intervals next to
a limit were integrated as one constant acceleration, up to twice their time, and the schedules of
tball-pocket#1 slow-Y and vcarve.ngc#2 ran faster than the bound)."""

import numpy as np
import pytest

import slw_cases
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.slw import path_bound
from fuzzyfeed.slw.floor import _acc_only_s
from fuzzyfeed.slw.preprocess import corners


def _straight_legs_time(curve, lim, feed, acc_along):
    """Σ over the straight legs between the corners of the exact acceleration-limited time from
    the corner feed before to the one after (rest at both ends): v(s) = min(F, √(c₁² + 2As),
    √(c₂² + 2A(L − s))), integrated in closed form (floor._acc_only_s)."""
    s_c, cap = corners(curve, lim)
    s = np.concatenate([[0.0], s_c, [curve.length]])
    v = np.concatenate([[0.0], cap, [0.0]])
    return float(_acc_only_s(np.diff(s), v[:-1], v[1:], feed, np.asarray(acc_along)).sum())


@pytest.mark.parametrize("feed", [0.1, 1.0, 30.0])
def test_line_at_a_program_feed_is_its_closed_form(feed):
    """A line along X under a feed cap F: L/F + F/A exactly (the old grid took the interval
    leaving each rest as one constant acceleration up to F: 2h/F instead of about h/F)."""
    lim = MachineLimits()
    line = slw_cases.polyline(np.array([[0.0, 0.0], [6.2, 0.0]]))
    cap = (np.array([0.0, line.length]), np.array([feed, feed]))
    got = path_bound(line, lim, feed_cap=cap)
    exact = line.length / feed + feed / lim.axis_acc_mm_s2[0]
    assert got.time_s == pytest.approx(exact, rel=1e-9)
    assert got.time_halved_s == pytest.approx(exact, rel=1e-9)
    assert got.interval_s.sum() == pytest.approx(got.time_s, rel=1e-12)


@pytest.mark.parametrize("feed", [1.0, 1.6667, 20.0])
def test_axis_polyline_with_corners_is_its_closed_form(feed):
    """Lines along X and Y on a slow-Y machine, each leg from the corner's cap to the next one's
    under its own axis's acceleration (and F below both axes' velocities): the bound is the sum of
    the legs' closed forms. Corner caps are far below F: every interval leaving a corner reaches F
    within the interval (the case of tball-pocket's pocket at F100 mm/min)."""
    lim = MachineLimits(axis_vel_mm_s=(100, 50, 100), axis_acc_mm_s2=(1000, 250, 1000))
    pts = np.array([[0.0, 0.0], [30.0, 0.0], [30.0, 8.0], [0.0, 8.0], [0.0, 16.0], [30.0, 16.0]])
    curve = slw_cases.polyline(pts)
    cap = (np.array([0.0, curve.length]), np.array([feed, feed]))
    acc_along = [1000.0, 250.0, 1000.0, 250.0, 1000.0]
    exact = _straight_legs_time(curve, lim, feed, acc_along)
    got = path_bound(curve, lim, feed_cap=cap)
    # (1e-6: a grid point 1e-9·L before each knot holds the limit left of it, the corner its cap)
    assert got.time_s == pytest.approx(exact, rel=1e-6), (got.time_s, exact)


def test_smooth_path_time_unchanged_where_acceleration_limited():
    """Where every interval is acceleration-limited end to end (the line x_i → x_i+1 is the
    envelope), the envelope's time is Σ 2·ds/(v_i + v_i+1) as before: infinity's 4.9008 s
    (DESIGN §6, toppra 0.6: 4.9012 s)."""
    from fuzzyfeed.io.shapes import load_shape

    got = path_bound(load_shape("infinity").curve, MachineLimits())
    assert got.time_s == pytest.approx(4.9008, abs=2e-4)
    v = got.feed_mm_s
    old = float(np.sum(2.0 * np.diff(got.s_mm) / (v[:-1] + v[1:])))
    assert got.time_s <= old * (1 + 1e-12)
