"""The plan made window by window (fuzzyfeed.machine.plan_windows) against the whole plan
(plan_motion): every array bit for bit, on random chains (lines, flattened arcs, rapids, reversals,
tiny and long segments), both corner models, with and without a finite look-ahead, every window
size from one segment up; and on a real program's chains (G-code with arcs, linuxcnc-mill)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.plan_windows import plan_windows, planned_time, window_bounds
from fuzzyfeed.machine.planner import Motion, plan_motion

ROOT = Path(__file__).resolve().parents[1]
FIELDS = ("length", "unit", "acc", "v_entry", "v_peak", "v_exit", "t_acc", "t_cruise", "t_dec")


def assert_windows_equal(motion: Motion, machine: Machine, size: int, scale: float = 1.0) -> None:
    whole = plan_motion(motion if scale == 1.0 else Motion(motion.points, motion.feed_mm_s * scale, motion.rapid,
                                                           motion.arc_radius_mm), machine)
    s_whole = whole.segment_arc_start()
    seen = 0
    for pw in plan_windows(motion, machine, size, feed_scale=scale):
        assert pw.first == seen
        sl = slice(pw.first, pw.stop)
        for name in FIELDS:
            got, want = getattr(pw, name), getattr(whole, name)[sl]
            # bit for bit: the same float64 bits, not only equal values (-0.0 vs 0.0 included)
            assert got.tobytes() == np.ascontiguousarray(want).tobytes(), (name, pw.first)
        assert pw.t_start.tobytes() == whole.t_start[pw.first:pw.stop + 1].tobytes()
        assert pw.s_start.tobytes() == s_whole[pw.first:pw.stop + 1].tobytes()
        seen = pw.stop
    assert seen == motion.n_segments
    assert planned_time(motion, machine, size, feed_scale=scale) == whole.time_s


@st.composite
def chains(draw):
    """A random chain: moves of lines or flattened arcs (several chords of one radius), feeds and
    rapids, occasional reversals and very short segments."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n_moves = draw(st.integers(1, 14))
    pts = [np.zeros(3)]
    radius = [np.nan]
    feed, rapid = [], []
    for _ in range(n_moves):
        is_rapid = bool(rng.random() < 0.15)
        f = np.nan if is_rapid else float(rng.choice([5.0, 20.0, 80.0, 400.0]) * rng.uniform(0.5, 1.5))
        kind = rng.random()
        if kind < 0.35 and not is_rapid:         # an arc: k chords on a circle in a random plane
            r = float(rng.uniform(0.3, 20.0))
            k = int(rng.integers(1, 6))
            sweep = float(rng.uniform(0.2, 3.0)) * rng.choice([-1, 1])
            e1 = rng.normal(size=3)
            e1 /= np.linalg.norm(e1)
            e2 = np.cross(e1, rng.normal(size=3))
            e2 /= np.linalg.norm(e2)
            c = pts[-1] - r * e1
            for i in range(1, k + 1):
                ang = sweep * i / k
                pts.append(c + r * (np.cos(ang) * e1 + np.sin(ang) * e2))
                radius.append(r if i < k else np.nan)
                feed.append(f)
                rapid.append(False)
        else:
            if kind < 0.45 and len(pts) > 1:        # a reversal
                step = -(pts[-1] - pts[-2]) * rng.uniform(0.1, 2.0)
            else:
                step = rng.normal(size=3) * rng.choice([0.001, 0.05, 1.0, 30.0])
                if rng.random() < 0.5:
                    step[2] = 0.0
            if np.linalg.norm(step) < 1e-6:
                step = np.array([0.01, 0.0, 0.0])
            pts.append(pts[-1] + step)
            radius.append(np.nan)
            feed.append(f)
            rapid.append(is_rapid)
    return Motion(np.array(pts), np.array(feed), np.array(rapid), np.array(radius))


MACHINES = [Machine(),
            Machine(acceleration="axes", corner_mm=0.02, lookahead_moves=2),
            Machine(lookahead_moves=5),
            Machine(corner="path-tolerance", corner_mm=0.05, acceleration="axes"),
            Machine(corner="path-tolerance", corner_mm=0.01, acceleration="axes", lookahead_moves=3,
                    axis_acc_mm_s2=(800.0, 1200.0, 300.0), axis_vel_mm_s=(200.0, 150.0, 50.0)),
            Machine(corner="path-tolerance", corner_mm=0.2, lookahead_moves=16)]


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(motion=chains(), which=st.integers(0, len(MACHINES) - 1), size=st.integers(1, 12),
       scale=st.sampled_from([1.0, 0.37, 0.9]))
def test_windows_are_the_whole_plan_bit_for_bit(motion, which, size, scale):
    assert_windows_equal(motion, MACHINES[which], size, scale)


def test_windows_end_at_move_boundaries():
    # an arc of 5 chords (vertices 2..5 inside it; boundaries at 1 and 6) between lines: no window ends inside the arc
    pts = np.array([[0, 0, 0], [1, 0, 0]] + [[1 + np.sin(a), 1 - np.cos(a), 0] for a in np.linspace(0.3, 1.5, 5)]
                   + [[5, 5, 0]], dtype=float)
    radius = np.array([np.nan, np.nan, 1, 1, 1, 1, np.nan, np.nan])
    m = Motion(pts, np.full(7, 10.0), np.zeros(7, bool), radius)
    assert window_bounds(m, 2) == [(0, 6), (6, 7)]
    assert window_bounds(m, 1) == [(0, 1), (1, 6), (6, 7)]
    assert window_bounds(m, 100) == [(0, 7)]
    with pytest.raises(ValueError):
        window_bounds(m, 0)


@pytest.mark.parametrize("machine_file", [None, "linuxcnc-mill"])
def test_windows_on_a_programs_chains(machine_file):
    from fuzzyfeed.machine.description import load_machine
    from fuzzyfeed.program.read import read_program
    from fuzzyfeed.program.run import program_path

    machine = Machine(lookahead_moves=16) if machine_file is None else load_machine(machine_file)
    program = read_program(ROOT / "benchmarks" / "library" / "programs" / "linuxcnc" / "arcspiral.ngc")
    path = program_path(program, machine.chord_tol_mm)
    assert path.chains
    for chain in path.chains:
        for size in (1, 7, 300):
            assert_windows_equal(chain.motion, machine, size)
