"""A tick repair's pass resumed from the previous pass's look-ahead state (slw/resume.py) against
the whole pass it replaces (trajectory.RESUME = False): the same tick arrays, bit for bit, the
same released blocks and counters — on curves and polylines, both machines and both transitions,
with a breach put at the ticks a third and two thirds of the way (so the resumed pass starts
from a state well inside it)."""

import numpy as np
import pytest

import slw_cases
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
    """trajectory.breach reporting a made-up breach at the fractions ``at`` of the ticks, one per
    pass, then the real check."""
    real = trajectory.breach
    left = list(at)

    def fake(xyz, u, j, limits, corner_u):
        if left:
            return ("acceleration y", int(left.pop(0) * (xyz.shape[0] - 1)), 1.01)
        return real(xyz, u, j, limits, corner_u)

    monkeypatch.setattr(trajectory, "breach", fake)


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
            got[flag] = schedule(curve, limits, transition=transition)
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
