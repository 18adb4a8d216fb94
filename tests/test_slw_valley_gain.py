"""benchmarks/slw_valley_gain.py (issue 38): the local re-plan of a valley's two blocks reproduces
the released schedule at zero junction acceleration, and its stretches are the integral of their
own acceleration."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import slw_valley_gain as vg  # noqa: E402
from slw_junction_kinds import junction_kinds  # noqa: E402

from fuzzyfeed.io.shapes import load_shape  # noqa: E402
from fuzzyfeed.machine.limits import MachineLimits  # noqa: E402
from fuzzyfeed.slw import schedule  # noqa: E402
from fuzzyfeed.slw.acc_profile import acc_transition  # noqa: E402

EQUAL = MachineLimits()
SLOW_Y = MachineLimits(axis_vel_mm_s=(100, 50, 100), axis_acc_mm_s2=(1000, 250, 1000))


@pytest.fixture(scope="module")
def trident2():
    curve = load_shape("trident2").curve
    traj = schedule(curve, SLOW_Y, transition="seven-phase", planner="window")
    at = {round(s, 9) for s, kind, _ in junction_kinds(traj, np.empty(0), 0.0) if kind == "valley"}
    pairs = [(a, b) for a, b in zip(traj.blocks[:-1], traj.blocks[1:]) if round(a.s1, 9) in at]
    assert pairs, "trident2 on a slow Y axis has valley junctions (bench_slw: 8)"
    return curve, traj, pairs


def test_baseline_is_the_released_schedule(trident2):
    """At the schedule's own junction feed and a = 0, the two blocks re-planned from their outer
    junctions take the time the released blocks take (the scheduler's segments, not this tool's),
    and their ticks pass the trajectory's own tick check."""
    _, traj, pairs = trident2
    for left, right in pairs:
        out = vg.valley_gain(traj, SLOW_Y, None, left, right, levels=4, max_checks=8)
        assert out is not None
        assert out["base"] == pytest.approx(left.duration_s + right.duration_s, rel=1e-9, abs=1e-12)
        assert out["base_ok"]
        assert out["best"] <= out["base"]
        if out["reason"] == "gain":  # only ever a higher junction feed
            assert out["v"] > out["v_j"] and out["v"] <= max(out["v_any"], out["v_j"]) * (1 + 1e-12)


def test_stretch_is_the_integral_of_its_acceleration():
    """stretch_state over cruise, fall to (v, a < 0), rise from there, cruise: v is the trapezoid
    integral of a and s that of v (a fine grid), both continuous across the pieces."""
    fall = acc_transition(60.0, 0.0, 25.0, -300.0, 1000.0, 1e4)
    rise = acc_transition(25.0, -300.0, 70.0, 0.0, 1000.0, 1e4)
    pieces = [vg._cruise(60.0, 2.0), ("acc", fall.duration_s, fall), ("acc", rise.duration_s, rise),
              vg._cruise(70.0, 1.5)]
    total = sum(p[1] for p in pieces)
    t = np.linspace(0.0, total, 400_001)
    s, v, a, j = vg.stretch_state(pieces, t)
    dt = t[1] - t[0]
    v_int = v[0] + np.concatenate([[0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * dt)])
    s_int = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
    assert np.abs(v_int - v).max() < 1e-3
    assert np.abs(s_int - s).max() < 1e-6
    assert s[-1] == pytest.approx(2.0 + fall.length_mm + rise.length_mm + 1.5, rel=1e-12)
    assert np.abs(np.diff(v)).max() < 1e-3 and np.abs(np.diff(a)).max() < 1e4 * dt * 1.01
    assert np.abs(j).max() <= 1e4 * (1 + 1e-12)


def test_ticks_are_interpolated_with_the_whole_path():
    """The stretch's ticks are interpolated together with the schedule's ticks before and after it
    (the chord-exact interpolator scales every chord by one factor over the path): at the
    schedule's own feeds every valley of random curve 38 on equal axes passes, as the schedule's
    ticks do (targets jumping from 0 to the stretch and on to the end read one at 3.5 x A_y)."""
    import slw_cases

    curve, _ = slw_cases.random_nurbs(38)
    traj = schedule(curve, EQUAL, transition="seven-phase", planner="window")
    at = {round(s, 9) for s, kind, _ in junction_kinds(traj, np.empty(0), 0.0) if kind == "valley"}
    pairs = [(a, b) for a, b in zip(traj.blocks[:-1], traj.blocks[1:]) if round(a.s1, 9) in at]
    assert len(pairs) >= 3
    for left, right in pairs:
        out = vg.valley_gain(traj, EQUAL, None, left, right, levels=1, max_checks=1)
        assert out["base"] == pytest.approx(left.duration_s + right.duration_s, rel=1e-9, abs=1e-12)
        assert out["base_ok"], left.s1
