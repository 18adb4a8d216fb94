"""Cosine transitions and block types of the SLW scheduler (seed 000, eq. (16)-(22), Table 1)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzyfeed.slw.profile import (Segment, block_segments, max_end_speed, max_start_speed,
                                   min_end_speed, peak_speed, segment_state, segment_table, segments_state,
                                   stop_distance, transition_distance, transition_time)

A, J = 1000.0, 10_000.0


def test_transition_time_closed_form():
    # jerk-limited: pi*sqrt(dv/2J); acceleration-limited: pi*dv/2A
    assert transition_time(0, 100, A, J) == pytest.approx(math.pi * math.sqrt(100 / 20000))
    assert transition_time(0, 100, 100, 1e9) == pytest.approx(math.pi * 100 / 200)
    assert transition_time(50, 50, A, J) == 0.0
    assert stop_distance(100, A, J) == pytest.approx(100 * math.pi * math.sqrt(100 / 20000) / 2)


@given(st.floats(0, 300), st.floats(0, 300), st.floats(50, 5000), st.floats(500, 1e5))
def test_segment_respects_acc_and_jerk_and_distance(v0, v1, acc, jerk):
    seg = Segment(v0, v1, transition_time(v0, v1, acc, jerk))
    if seg.duration_s == 0:
        return
    tau = np.linspace(0, seg.duration_s, 2001)
    s, v, a, j = segment_state(seg, tau)
    assert np.abs(a).max() <= acc * (1 + 1e-9)
    assert np.abs(j).max() <= jerk * (1 + 1e-9)
    assert v[0] == pytest.approx(v0) and v[-1] == pytest.approx(v1)
    assert s[-1] == pytest.approx(transition_distance(v0, v1, acc, jerk), rel=1e-9, abs=1e-12)
    # independent check: derivatives by finite differences
    assert np.allclose(np.gradient(s, tau), v, atol=1e-6 * max(v0, v1, 1))


@settings(deadline=None)  # the first example loads the compiled bisections
@given(st.floats(0, 200), st.floats(0.01, 50), st.floats(0, 200))
def test_bisection_corrections_are_tight(v, length, cap):
    up = max_end_speed(v, length, cap, A, J)
    assert up <= max(cap, v) + 1e-12
    if up > v:
        assert transition_distance(v, up, A, J) <= length * (1 + 1e-9)
        if up < cap:  # tight: a bit faster is not reachable
            assert transition_distance(v, up * 1.001 + 1e-9, A, J) > length
    start = max_start_speed(v, length, cap, A, J)
    if start > v:
        assert transition_distance(start, v, A, J) <= length * (1 + 1e-9)
    low = min_end_speed(v, length, A, J)
    assert transition_distance(v, low, A, J) <= length * (1 + 1e-9)


@pytest.mark.parametrize("length, v_s, v_e, kind", [
    (100.0, 0.0, 0.0, 1), (100.0, 20.0, 60.0, 1), (7.0, 20.0, 60.0, 2), (7.0, 60.0, 20.0, 3),
])
def test_block_types_cover_the_length(length, v_s, v_e, kind):
    got, segs = block_segments(length, v_s, v_e, 100.0, A, J)
    assert got == kind
    assert sum(s.length_mm for s in segs) == pytest.approx(length, rel=1e-12)
    assert segs[0].v0 == v_s and segs[-1].v1 == v_e
    for a, b in zip(segs, segs[1:]):
        assert a.v1 == b.v0
    if kind == 2:  # approach 1: the cruise is at the higher (end) feed
        assert segs[-1].v0 == segs[-1].v1 == v_e
    if kind == 3:
        assert segs[0].v0 == segs[0].v1 == v_s


def test_type4_is_refused_and_rest_to_rest_short_block_uses_a_peak():
    with pytest.raises(ValueError, match="type-4"):
        block_segments(0.01, 100.0, 0.0, 100.0, A, J)
    kind, segs = block_segments(0.5, 0.0, 0.0, 100.0, A, J)
    assert sum(s.length_mm for s in segs) == pytest.approx(0.5)
    assert max(s.v1 for s in segs) > 0


@settings(deadline=None)
@given(st.floats(0, 200), st.floats(0, 200), st.floats(0.01, 50), st.sampled_from(["cosine", "seven-phase"]))
def test_compiled_transitions_match_the_formulas_and_the_peak_is_tight(v_s, v_e, length, shape):
    import fuzzyfeed.slw._kernels as kernels

    seven = shape == "seven-phase"
    assert kernels.transition_time(v_s, v_e, A, J, seven) == transition_time(v_s, v_e, A, J, shape)
    d_se = transition_distance(v_s, v_e, A, J, shape)
    if d_se > length:
        return
    v_p = peak_speed(v_s, v_e, length, 300.0, A, J, shape)
    used = transition_distance(v_s, v_p, A, J, shape) + transition_distance(v_p, v_e, A, J, shape)
    assert v_p >= max(v_s, v_e) and used <= length * (1 + 1e-12)
    if v_p < 300.0:  # tight: 0.1 % faster does not fit
        up = v_p * 1.001 + 1e-9
        assert transition_distance(v_s, up, A, J, shape) + transition_distance(up, v_e, A, J, shape) > length


@settings(deadline=None)
@given(st.lists(st.tuples(st.floats(0, 200), st.floats(0, 200), st.sampled_from(["cosine", "seven-phase"]),
                          st.floats(1.0, 3.0)), min_size=1, max_size=4), st.floats(-50, 50))
def test_compiled_block_sampling_is_segment_state(pieces, start):
    """The look-ahead's compiled sampling of a block equals segment_state on the same times."""
    import fuzzyfeed.slw._kernels as kernels

    segs = []
    for v0, v1, shape, stretch in pieces:  # transitions at least as long as the shortest
        T = transition_time(v0, v1, A, J, shape) * stretch if v0 != v1 else 0.01 * stretch
        segs.append(Segment(v0, v1, T, J if shape == "seven-phase" else None))
    arr = np.array([(g.v0, g.v1, g.duration_s, math.nan if g.jerk_mm_s3 is None else g.jerk_mm_s3) for g in segs])
    s, v, a, which = kernels.sample_segments(arr[:, 0], arr[:, 1], arr[:, 2], arr[:, 3], start, 5e-4)
    offset, at = start, 0
    for k, g in enumerate(segs):
        n = int(min(max(math.ceil(g.duration_s / 5e-4), 8), 20000))
        pos, vel, acc, _ = segment_state(g, np.linspace(0.0, g.duration_s, n + 1))
        part = slice(at, at + n + 1)
        assert (which[part] == k).all()
        assert np.allclose(s[part], pos + offset, rtol=1e-12, atol=1e-9)
        assert np.allclose(v[part], vel, rtol=1e-12, atol=1e-9) and np.allclose(a[part], acc, rtol=1e-12, atol=1e-6)
        offset += g.length_mm
        at += n + 1
    assert at == s.size


def test_all_ticks_at_once_are_segment_state_bit_for_bit():
    """profile.segments_state (the trajectory's ticks sampled at once) against segment_state one
    segment at a time: cruises, cosines, seven-phase ramps (one rounded short, t_j = T/2), rises and
    falls, and an AccSegment (read on its own)."""
    from fuzzyfeed.slw.acc_profile import AccSegment

    rng = np.random.default_rng(5)
    segs = [AccSegment(10.0, 0.0, 20.0, 0.0, 400.0, 0.01, 0.02, 0.01)]
    for _ in range(300):
        v0, v1, dur = rng.uniform(0.0, 200.0), rng.uniform(0.0, 200.0), rng.uniform(1e-3, 0.5)
        kind = rng.integers(0, 4)
        jerk = None if kind < 2 else (rng.uniform(1e3, 1e5) if kind == 2 else 4.0 * abs(v1 - v0) / dur ** 2)
        segs.append(Segment(v0, v0 if kind == 0 else v1, dur, jerk))
    which = np.sort(rng.integers(0, len(segs), 20_000))
    tau = np.array([rng.uniform(-0.1, 1.1) * segs[i].duration_s for i in which])
    got = segments_state(segs, segment_table(segs), which, tau)
    for i in np.unique(which):
        sel = which == i
        for x, y in zip(got, segment_state(segs[i], tau[sel])):
            assert np.array_equal(x[sel], y), (i, segs[i])
