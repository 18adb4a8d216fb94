"""Issue 38 (compute): the tick check compiled (slw/_check_jit.py) against its numpy form
(slw/check.py tick_ratios, worst): for every ratio the same largest value and the same first tick,
bit for bit, and breach's verdict the same; on random motions with repeated values, corners and
still ticks, and on a scheduled path."""

import numpy as np
import pytest

import slw_cases
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.slw import check as C
from fuzzyfeed.slw._check_jit import N_RATIOS


def _motion(seed, n=4000):
    rng = np.random.default_rng(seed)
    step = rng.normal(0.0, 0.05, (n, 3)).cumsum(axis=0) * 0.01
    step[rng.integers(0, n, n // 20)] = 0.0                          # still ticks
    step[n // 2: n // 2 + 50] = step[n // 2]                           # a run of equal chords: ties
    xyz = np.vstack([np.zeros((1, 3)), np.cumsum(step, axis=0)])
    jerk = np.round(rng.normal(0.0, 3e3, n + 1), 0)                    # ties in the jerk too
    corners = np.unique(rng.integers(0, n, 30))
    return xyz, jerk, corners


def _limits(seed):
    rng = np.random.default_rng(100 + seed)
    return MachineLimits(feed_mm_s=float(rng.uniform(5, 80)), axis_vel_mm_s=tuple(rng.uniform(5, 80, 3)),
                         axis_acc_mm_s2=tuple(rng.uniform(100, 3000, 3)), jerk_mm_s3=float(rng.uniform(1e3, 3e4)))


def _kernel_picks(xyz, jerk, limits, corners, scale):
    skip = np.zeros(xyz.shape[0] - 1, dtype=bool)
    skip[np.clip((corners[:, None] + np.arange(-1, 2)[None, :]).ravel(), 0, skip.size - 1)] = True
    best, where = np.empty(N_RATIOS + 1), np.empty(N_RATIOS, dtype=np.int64)
    C._worst_kernel()(xyz, jerk, limits.ts_s, limits.feed_mm_s, np.array(limits.axis_vel_mm_s),
                      np.array(limits.axis_acc_mm_s2), limits.jerk_mm_s3, scale, skip, best, where)
    return best, where


@pytest.mark.parametrize("seed", range(12))
def test_each_ratio_as_numpy_bit_for_bit(seed):
    xyz, jerk, corners = _motion(seed)
    limits = _limits(seed)
    ratios = C.tick_ratios(xyz, jerk, limits, corners)
    scale = 1.0 + C.PATH_JERK_RTOL
    best, where = _kernel_picks(xyz, jerk, limits, corners, scale)
    slots = {"feed": 0, "velocity x": 1, "velocity y": 2, "velocity z": 3, "acceleration x": 4,
             "acceleration y": 5, "acceleration z": 6, "jerk": 7, "path jerk": 8}
    for key, arr in ratios.items():   # each ratio: its largest value and first tick, bit for bit
        judged = arr / scale if key == "path jerk" else arr
        k = int(np.nanargmax(judged))
        assert (int(where[slots[key]]), best[slots[key]]) == (k, judged[k]), key
    assert best[9] == ratios["path jerk"][where[8]]
    name, k, r = C.worst(dict(ratios, **{"path jerk": ratios["path jerk"] / scale}))
    got = C._worst_compiled(xyz, jerk, limits, corners, scale)
    assert got == (name, k, r, float(ratios[name][k]))


def test_ties_take_the_first_tick():
    xyz = np.zeros((9, 3))
    xyz[:, 0] = [0, 1, 2, 3, 4, 5, 6, 7, 8]       # equal chords: every feed and velocity ties
    jerk = np.array([0, 5, 5, 1, 5, 0, 0, 0, 0], dtype=float)
    limits = MachineLimits(feed_mm_s=1.0, axis_vel_mm_s=(1.0, 1.0, 1.0), axis_acc_mm_s2=(1.0, 1.0, 1.0), jerk_mm_s3=1.0)
    best, where = _kernel_picks(xyz, jerk, limits, np.array([], dtype=int), 1.0)
    assert where[0] == 0 and where[1] == 0 and where[7] == 1
    assert where[2] == 0 and best[2] == 0.0       # all zero: the first


@pytest.mark.parametrize("seed", range(6))
def test_breach_verdict_as_numpy(seed, monkeypatch):
    xyz0, jerk0, corners = _motion(seed, 70_000)
    u = np.linspace(0.0, 1.0, xyz0.shape[0])
    corner_u = u[corners] + 1e-9
    limits = _limits(seed)
    top = C.worst(C.tick_ratios(xyz0, jerk0, limits, C.corner_ticks(u, corner_u)))[2]
    for factor in (0.5, 0.99, 1.0, 3.0):   # the motion scaled around its worst: over, at, under the limits
        xyz, jerk = xyz0 / (top * factor), jerk0 / (top * factor)
        got = C.breach(xyz, u, jerk, limits, corner_u)
        monkeypatch.setattr(C, "use_compiled", lambda n: False)
        want = C.breach(xyz, u, jerk, limits, corner_u)
        monkeypatch.undo()
        assert got == want
        assert (got is None) == (factor >= 1.0)


def test_scheduled_path_as_numpy():
    tr = slw_cases.recorded_schedule("cam1000", "slow-y")
    xyz, jerk = np.array(tr.xyz), np.array(tr.jerk_mm_s3)
    corners = C.corner_ticks(np.array(tr.u), np.array([0.25, 0.5]) * tr.u[-1])
    scale = 1.0 + C.PATH_JERK_RTOL
    for limits in (tr.limits, MachineLimits(feed_mm_s=10.0, axis_vel_mm_s=(8, 5, 8), axis_acc_mm_s2=(300, 100, 300),
                                            jerk_mm_s3=2000.0)):
        ratios = C.tick_ratios(xyz, jerk, limits, corners)
        name, k, r = C.worst(dict(ratios, **{"path jerk": ratios["path jerk"] / scale}))
        assert C._worst_compiled(xyz, jerk, limits, corners, scale) == (name, k, r, float(ratios[name][k]))
