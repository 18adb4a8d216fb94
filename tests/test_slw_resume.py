"""A tick repair's pass resumed from the previous pass's look-ahead state (slw/resume.py) against
the whole pass it replaces (trajectory.RESUME = False): the same tick arrays, bit for bit, the
same released blocks and counters — on curves and polylines, both machines and both transitions,
with a breach put at the ticks a third and two thirds of the way (so the resumed pass starts
from a state well inside it)."""

import numpy as np
import pytest

import slw_cases
import fuzzyfeed.slw.check as check_mod
import fuzzyfeed.slw.resume as resume_mod
import fuzzyfeed.slw.trajectory as trajectory
from fuzzyfeed.io.shapes import load_shape
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.slw import schedule
from fuzzyfeed.slw.feed_cap import FeedCap
from fuzzyfeed.slw.resume import same_until

SLOW_Y = MachineLimits(axis_vel_mm_s=(100, 50, 100), axis_acc_mm_s2=(1000, 250, 1000))
FIELDS = ("t_s", "s_mm", "u", "xyz", "feed_mm_s", "acc_mm_s2", "jerk_mm_s3")


def _curve(name):
    if name == "butterfly":
        return load_shape("butterfly").curve
    return slw_cases.square_passes()   # a polyline of 40 corners


def _with_breaches(monkeypatch, at):
    """The tick check (slw/check.breach, as the schedule's checked_positions calls it) reporting a
    made-up breach at the fractions ``at`` of the ticks, one per pass, then the real check."""
    real = check_mod.breach
    left = list(at)

    def fake(xyz, u, j, limits, corner_u):
        if left:
            return ("acceleration y", int(left.pop(0) * (xyz.shape[0] - 1)), 1.01)
        return real(xyz, u, j, limits, corner_u)

    monkeypatch.setattr(check_mod, "breach", fake)


@pytest.mark.parametrize("name", ["butterfly", "passes"])
@pytest.mark.parametrize("transition", ["cosine", "seven-phase"])
def test_a_resumed_repair_is_the_whole_pass(monkeypatch, name, transition):
    curve = _curve(name)
    monkeypatch.setattr(resume_mod, "CHECKPOINT_WINDOWS", 0.5)   # many states on a short path
    starts = []
    real_resume = trajectory.resume

    def spy(*args):
        rec, released = real_resume(*args)
        starts.append((len(rec.prints), len(released)))
        return rec, released

    monkeypatch.setattr(trajectory, "resume", spy)
    for limits in (MachineLimits(), SLOW_Y):
        got = {}
        starts.clear()
        for flag in (True, False):
            monkeypatch.setattr(trajectory, "RESUME", flag)
            _with_breaches(monkeypatch, (1 / 3, 2 / 3))
            got[flag] = schedule(curve, limits, transition=transition, planner="window")
        a, b = got[True], got[False]
        for f in FIELDS:
            x, y = getattr(a, f), getattr(b, f)
            assert x.shape == y.shape and np.array_equal(x, y), (limits.axis_acc_mm_s2, f)
        assert a.blocks == b.blocks and a.stats == b.stats
        # both repairs resumed from inside the path: blocks pulled and released before them kept
        assert len(starts) == 2 and all(p > 0 and r > 0 for p, r in starts), starts


def test_same_until_is_the_last_shared_point():
    old = FeedCap(np.array([0.0, 10.0, 20.0, 30.0]), np.array([50.0, 40.0, 43.0, 60.0]), 30.0)
    new = FeedCap(np.array([0.0, 10.0, 15.0, 15.0, 16.0, 16.0, 20.0, 30.0]),
                  np.array([50.0, 40.0, 41.5, 5.0, 5.0, 42.0, 43.0, 60.0]), 30.0)
    assert same_until(old, new) == 10.0
    s = np.linspace(0.0, 9.999, 1000)
    assert np.array_equal(old(s), new(s))
    assert not np.array_equal(old(np.array([15.5])), new(np.array([15.5])))
    assert same_until(old, old) == 30.0
    assert same_until(None, new) == -np.inf
    # a dip cut into a plateau: the same values up to the dip
    old = FeedCap(np.array([0.0, 10.0, 20.0, 30.0]), np.array([50.0, 40.0, 40.0, 60.0]), 30.0)
    new = FeedCap(np.array([0.0, 10.0, 15.0, 15.0, 16.0, 16.0, 20.0, 30.0]),
                  np.array([50.0, 40.0, 40.0, 5.0, 5.0, 40.0, 40.0, 60.0]), 30.0)
    assert same_until(old, new) == 15.0
    s = np.linspace(0.0, 14.999, 1000)
    assert np.array_equal(old(s), new(s))


# (path, machine, transition, breaches at these fractions of the ticks, ticks, Σ w_k u_k, Σ w_k x_k,
# Σ w_k y_k, Σ w_k z_k, xyz at tick K // 3, cycle time) with w = linspace(1, 2, K), recorded on main
# 2a1349a (every repair a whole pass; general19's row re-recorded the same way, RESUME = False, after
# median6's window change: a block's top lowered instead of a junction, and again after med7's: a
# transition's junction where its stretch allows far more than its worst point, 2.961 -> 2.9555 s;
# the resumed pass equal bit for bit); general19 is random curve 19 of slw_cases.general_nurbs on its
# ratio machine, one real tick repair
RECORDED = [
    ("butterfly", "equal", "cosine", (1 / 3, 2 / 3), 6377, 5295.09195877545, 482665.73523655767,
     313766.6263244132, 0.0, 82.07611690670171, 9.69903035342124, 0.0, 6.376),
    ("passes", "slow-y", "seven-phase", (1 / 3, 2 / 3), 14932, 6266225.363051946, 222485.477492602,
     228580.50676442834, 0.0, 16.910031110515746, 18.0, 0.0, 14.931000000000001),
    ("general19", "ratio", "cosine", (), 5912, 5539.084954818169, 151669.15824902878, -83422.21036240525,
     0.0, 25.879732725538513, -15.504304803343654, 0.0, 2.9555000000000002),
]


@pytest.mark.parametrize("row", RECORDED, ids=lambda r: "/".join(r[:3]))
def test_repaired_schedules_as_recorded_on_main(monkeypatch, row):
    name, machine, transition, at, ticks, *want = row
    if name == "general19":
        rng = np.random.default_rng(19)
        curve = slw_cases.general_nurbs(rng)
        limits = slw_cases.ratio_machine(rng)
    else:
        curve, limits = _curve(name), (MachineLimits() if machine == "equal" else SLOW_Y)
    _with_breaches(monkeypatch, at)
    tr = schedule(curve, limits, transition=transition, planner="window")
    assert tr.u.size == ticks
    w = np.linspace(1.0, 2.0, ticks)
    got = [float(tr.u @ w), *(float(tr.xyz[:, i] @ w) for i in range(3)), *map(float, tr.xyz[ticks // 3]),
           tr.cycle_time_s]
    big = float(np.abs(tr.xyz).max())
    scale = [abs(want[0])] + [big * w.sum()] * 3 + [big] * 3 + [want[-1]]
    for g, v, sc in zip(got, want, scale):
        assert abs(g - v) <= 1e-12 * sc, (g, v)
