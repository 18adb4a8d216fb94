"""The corner chain's compiled held gap times (slw/_floor_jit.py) against floor.py's numpy lines: bit
for bit, on random gaps, feeds and end accelerations of both machines' sizes, and on a chain."""

import numpy as np
import pytest

from fuzzyfeed.slw import floor as fl


def _random_gaps(seed: int, n: int = 300):
    rng = np.random.default_rng(seed)
    feed, jerk = 100.0, 10_000.0
    acc = rng.choice([250.0, 1000.0, 1414.2135623730951], n) * rng.uniform(0.3, 1.0, n)
    gaps = 10.0 ** rng.uniform(-3.0, 1.5, n)
    c1, c2 = rng.uniform(0.0, feed, n), rng.uniform(0.0, feed, n)
    c1[rng.random(n) < 0.1] = 0.0  # rests
    a0 = rng.uniform(0.0, 1.0, n) * acc
    a1 = -rng.uniform(0.0, 1.0, n) * acc
    a0[rng.random(n) < 0.2], a1[rng.random(n) < 0.2] = 0.0, 0.0
    return gaps, c1, c2, feed, acc, jerk, a0, a1


@pytest.mark.parametrize("seed", range(3))
def test_compiled_held_gap_times_are_the_numpy_ones_bit_for_bit(seed):
    gaps, c1, c2, feed, acc, jerk, a0, a1 = _random_gaps(seed)
    fast = fl.gap_times(gaps, c1, c2, feed, acc, jerk, a0, a1)
    ref = fl.gap_times(gaps, c1, c2, feed, acc, jerk, a0, a1, compiled=False)
    assert np.array_equal(fast, ref)
    assert (fast > 0.0).all()


def test_one_acceleration_for_every_gap():
    gaps, c1, c2, feed, acc, jerk, a0, a1 = _random_gaps(7, n=20)
    fast = fl.gap_times(gaps, c1, c2, feed, 1000.0, jerk, a0, a1)
    assert np.array_equal(fast, fl.gap_times(gaps, c1, c2, feed, 1000.0, jerk, a0, a1, compiled=False))


def test_the_chain_is_the_numpy_chain(monkeypatch):
    rng = np.random.default_rng(11)
    gaps = 10.0 ** rng.uniform(-2.0, 1.0, 40)
    v = np.concatenate([[0.0], rng.uniform(1.0, 100.0, 39), [0.0]])
    acc = rng.uniform(200.0, 1414.0, 40)
    fast = fl.held_chain_s(gaps, v, acc, 100.0, 10_000.0)
    plain = fl.gap_times
    monkeypatch.setattr(fl, "gap_times", lambda *a, **k: plain(*a, **k, compiled=False))
    assert fast == fl.held_chain_s(gaps, v, acc, 100.0, 10_000.0)
