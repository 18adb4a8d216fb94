"""The controller model and the servo on it, against closed forms derived by hand (issue 32, item 2):
a single move's trapezoid, GRBL's junction speed at a 90° corner, the steady-state error on a
circle, the error of a corner taken at constant speed; and the planner's vectorised passes
against the textbook sequential loop."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.planner import Motion, plan_motion, reachable_squared_speed
from fuzzyfeed.machine.servo import ServoModel
from fuzzyfeed.machine.trace import trace_motion
from fuzzyfeed.program.read import parse_program
from fuzzyfeed.program.run import program_path, run_program


def motion(points, feed_mm_s, rapid=None):
    pts = np.asarray(points, dtype=float)
    n = pts.shape[0] - 1
    return Motion(pts, np.full(n, float(feed_mm_s)), np.zeros(n, bool) if rapid is None else np.asarray(rapid),
                  np.full(n + 1, np.nan))


def test_single_move_is_a_trapezoid():
    # L = 100 mm at F = 50 mm/s, a = 1000 mm/s^2: accelerate 25 ms, cruise, brake 25 ms:
    # t = L/F + F/a = 2.05 s
    m = Machine(acceleration="path", path_acc_mm_s2=1000.0)
    plan = plan_motion(motion([[0, 0, 0], [100, 0, 0]], 50.0), m)
    assert plan.time_s == pytest.approx(2.05, rel=1e-12)
    assert plan.v_peak[0] == pytest.approx(50.0)


def test_short_move_is_a_triangle():
    # L = 1 mm, F far above what 1 mm allows: t = 2 sqrt(L/a), peak sqrt(a L)
    m = Machine()
    plan = plan_motion(motion([[0, 0, 0], [0, 1, 0]], 100.0), m)
    assert plan.time_s == pytest.approx(2 * math.sqrt(1 / 1000), rel=1e-12)
    assert plan.v_peak[0] == pytest.approx(math.sqrt(1000 * 1), rel=1e-12)


def test_grbl_junction_speed_at_a_right_angle():
    # GRBL: v^2 = a_j delta sin(theta/2) / (1 - sin(theta/2)), theta = 90 deg; the acceleration
    # along the junction direction (-1, 1)/sqrt 2 with 1000 mm/s^2 per axis and no path limit is
    # 1000 / cos 45 deg
    m = Machine(acceleration="axes", corner_mm=0.01)
    plan = plan_motion(motion([[0, 0, 0], [50, 0, 0], [50, 50, 0]], 100.0), m)
    a_j = 1000.0 / math.cos(math.radians(45))
    s = math.sin(math.radians(45))
    assert plan.v_exit[0] == pytest.approx(math.sqrt(a_j * 0.01 * s / (1 - s)), rel=1e-9)
    assert plan.v_entry[1] == plan.v_exit[0]
    # along a diagonal an axis-limited machine accelerates sqrt 2 times faster than along an axis
    diag = plan_motion(motion([[0, 0, 0], [1, 1, 0]], 1000.0), m)
    assert diag.acc[0] == pytest.approx(1000 * math.sqrt(2))


def test_a_reversal_stops_and_a_straight_junction_does_not_slow():
    m = Machine()
    back = plan_motion(motion([[0, 0, 0], [10, 0, 0], [0, 0, 0]], 50.0), m)
    assert back.v_exit[0] == 0.0
    straight = plan_motion(motion([[0, 0, 0], [10, 0, 0], [20, 0, 0]], 50.0), m)
    assert straight.v_exit[0] == pytest.approx(50.0)


def _sequential(cap, reach):
    """The textbook planner: a backward then a forward pass, one junction at a time."""
    w = cap.copy()
    for k in range(w.size - 2, -1, -1):
        w[k] = min(w[k], w[k + 1] + reach[k])
    for k in range(1, w.size):
        w[k] = min(w[k], w[k - 1] + reach[k - 1])
    return w


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 1e4), st.floats(0, 1e4)), min_size=1, max_size=40))
def test_running_minimum_passes_equal_the_sequential_planner(pairs):
    cap = np.array([0.0] + [c for c, _ in pairs] + [0.0])
    reach = np.array([r for _, r in pairs] + [5.0])
    got = reachable_squared_speed(cap, reach)
    want = _sequential(cap, reach)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-6)


def test_finite_look_ahead_limits_speed_on_short_segments():
    # 400 segments of 0.1 mm at F = 100 mm/s, a = 1000 mm/s^2, a buffer of N = 16 moves: a segment
    # ends at the speed that stops within the N - 1 segments queued behind it, v^2 = 2 a (N-1) 0.1 mm,
    # and inside it rises by a 0.1 mm more (half the segment to accelerate, half to brake)
    pts = np.column_stack([np.arange(401) * 0.1, np.zeros(401), np.zeros(401)])
    free = plan_motion(motion(pts, 100.0), Machine())
    buffered = plan_motion(motion(pts, 100.0), Machine(lookahead_moves=16))
    assert free.v_peak.max() == pytest.approx(100.0)
    assert buffered.v_exit[200] == pytest.approx(math.sqrt(2 * 1000 * 15 * 0.1), rel=1e-9)
    assert buffered.v_peak.max() == pytest.approx(math.sqrt(2 * 1000 * 15 * 0.1 + 1000 * 0.1), rel=1e-9)


def test_steady_state_error_on_a_circle_matches_the_closed_form():
    # a full circle of radius 10 mm at F = 3000 mm/min (50 mm/s), first-order axes Kv = 30 1/s:
    # the servo settles on a circle of radius r / sqrt(1 + (v/(r Kv))^2)
    r, v, kv = 10.0, 50.0, 30.0
    expected = r * (1 - 1 / math.sqrt(1 + (v / (r * kv)) ** 2))
    text = "G21 G90 G94 G17\nG0 X10 Y0 Z0\nG1 X10 Y0 F3000\nG3 X10 Y0 I-10 J0 P3\nG0 Z5\nM2\n"
    program = parse_program(text, "circle.ngc")
    machine = Machine(servo=ServoModel(kv_1_s=kv), chord_tol_mm=0.0005)
    path = program_path(program, machine.chord_tol_mm)
    chain = trace_motion(path.chains[0].motion, machine, path.chains[0].seg_measured)   # every tick
    # the middle turn (steady state): the chords sag at most 0.5 um inside the circle
    t = chain.tick_time_s
    mid = (t > 0.35 * t.max()) & (t < 0.65 * t.max())
    assert np.median(chain.contour_mm[mid]) == pytest.approx(expected, abs=0.6e-3)
    assert expected > 0.1      # the case is not trivial: 136 um
    # the streamed run (no ticks kept) finds the same largest error
    assert run_program(path, machine).max_um == pytest.approx(chain.max_mm * 1e3, abs=1e-3)


def test_corner_at_constant_speed_matches_the_closed_form():
    # A 90 deg corner taken at a constant v below the junction limit: the lagging axis decays as
    # e^(-Kv t) while the other builds up its lag; the tool is nearest to the path's other leg until
    # Kv t = 1, then to the first, so the largest error is v / (e Kv).
    v, kv = 3.0, 30.0
    machine = Machine(servo=ServoModel(kv_1_s=kv), corner_mm=0.01)
    m = motion([[-20, 0, 0], [0, 0, 0], [0, 20, 0]], v)
    tr = trace_motion(m, machine)
    assert tr.max_mm == pytest.approx(v / (math.e * kv), rel=0.02)


def test_rapids_are_not_measured():
    text = "G21 G90 G94\nG0 X0 Y0 Z0\nG0 X50 Y0\nG0 X50 Y50\nG1 X0 Y50 F600\nM2\n"
    program = parse_program(text, "rapid.ngc")
    machine = Machine()
    path = program_path(program, machine.chord_tol_mm)
    run = run_program(path, machine)
    # the segments where an error was measured belong to feed moves only
    moves = np.concatenate([c.seg_move[r.stream.seg_max_mm > 0] for c, r in zip(path.chains, run.runs)])
    assert moves.size and set(np.unique(program.kind[moves])) == {1}      # LINE only


def test_contour_kernel_forms_agree_bit_for_bit():
    from fuzzyfeed.machine.contour import windowed_distance

    rng = np.random.default_rng(7)
    pts = np.cumsum(rng.normal(size=(801, 3)) * 0.1, axis=0)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    q = pts[rng.integers(0, 800, 5000)] + rng.normal(size=(5000, 3)) * 0.05
    lo = rng.uniform(-1, s[-1], 5000)
    hi = lo + rng.uniform(0, 5, 5000)
    slow = windowed_distance(pts, s, q, lo, hi, compiled=False)
    fast = windowed_distance(pts, s, q, lo, hi, compiled=True)
    for a, b in zip(slow, fast):
        assert np.array_equal(a, b)
    # and the distance is the true distance to the nearest segment of the window (brute force)
    k = 17
    seg = np.flatnonzero((s[1:] > lo[k]) & (s[:-1] < hi[k]))
    a, d = pts[seg], np.diff(pts, axis=0)[seg]
    t = np.clip(np.einsum("ij,ij->i", q[k] - a, d) / np.einsum("ij,ij->i", d, d), 0, 1)
    assert slow[0][k] == pytest.approx(np.linalg.norm(q[k] - (a + d * t[:, None]), axis=1).min(), rel=1e-12)


def test_linuxcnc_stops_between_a_rapid_and_a_feed_move_grbl_blends():
    # LinuxCNC's tp.c (tpCheckCanonType) never blends G0 with G1: the junction ends at rest even
    # when the two are in line; GRBL runs the same junction at the feed move's speed
    pts = [[0, 0, 0], [10, 0, 0], [20, 0, 0], [30, 0, 0]]
    m = Motion(np.asarray(pts, float), np.array([np.nan, 20.0, np.nan]), np.array([True, False, True]),
               np.full(4, np.nan))
    lcnc = plan_motion(m, Machine(corner="path-tolerance"))
    grbl = plan_motion(m, Machine(corner="junction-deviation"))
    assert lcnc.v_exit[0] == 0.0 and lcnc.v_entry[1] == 0.0 and lcnc.v_exit[1] == 0.0
    assert grbl.v_exit[0] == pytest.approx(20.0) and grbl.v_exit[1] == pytest.approx(20.0)


def test_rapid_lag_decays_into_the_next_feed_move_in_the_part():
    # Issue 37, defect 3 (LinuxCNC 3dtest.ngc: 70 um at a slow G1 after two rapids): G0 along x
    # into G1 along y on LinuxCNC. The command stops at the junction; the tool is still
    # e0 = a/Kv^2 (1 - e^(-Kv T)) behind in x (a ramp from v_r to 0 over T = v_r/a through a
    # first-order loop), which decays as e^(-Kv t) while y starts. The tool is nearest the rapid
    # (in the air) until its y passes its x lag, then nearest the G1 (in the part): the largest
    # error in the part is e0 e^(-Kv t*) at that crossing, y(t*) the first-order response to the
    # G1's trapezoid (a/2, v).
    kv, a, v_r, v = 30.0, 1000.0, 100.0, 10.0
    machine = Machine(corner="path-tolerance", servo=ServoModel(kv_1_s=kv), axis_vel_mm_s=v_r,
                      axis_acc_mm_s2=a)
    text = "G21 G90 G94 G17\nG0 X0 Y0 Z0\nG0 X100\nG1 Y10 F600\nM2\n"
    program = parse_program(text, "rapid_into_cut.ngc")
    run = run_program(program_path(program, machine.chord_tol_mm), machine)
    e0 = a / kv**2 * (1 - math.exp(-kv * v_r / a))
    t = np.linspace(0.0, 0.3, 300_001)
    # the G1 is the program's last move: LinuxCNC runs it at half its acceleration (its end is a
    # parabolic blend, tc.c tcGetOverallMaxAccel); the rapid ends in a stop, at the full a
    a_g1 = a / 2
    t_acc = v / a_g1
    y_cmd = np.where(t < t_acc, 0.5 * a_g1 * t * t, 0.5 * a_g1 * t_acc**2 + v * (t - t_acc))
    # first-order response to y_cmd: y' = Kv (y_cmd - y), y(0) = 0 (exact for piecewise-linear steps)
    dt = t[1] - t[0]
    decay = math.exp(-kv * dt)
    slope = np.diff(y_cmd) / (kv * dt) * (1 - decay)
    lag = np.zeros_like(t)                     # y_cmd - y
    for i in range(t.size - 1):
        lag[i + 1] = lag[i] * decay + slope[i]
    y = y_cmd - lag
    e_x = e0 * np.exp(-kv * t)
    cross = int(np.argmax(y > e_x))
    expected_um = e_x[cross] * 1e3
    assert expected_um > 50.0                                   # the case is not trivial
    # the first tick in the part comes within one tick (3 %) after the crossing
    assert expected_um * math.exp(-kv * machine.ts_s) * 0.999 <= run.max_um <= expected_um * 1.001
    # the report says which error is in the air: the tool nearest the rapid, at most its y
    assert 0.0 < run.air_max_um <= expected_um * 1.001
    line, _ = run.worst()
    assert program.lines[line].startswith("G1")


# --- LinuxCNC 2.9's planner (corner = "path-tolerance", issue 37): machine/linuxcnc_tp.py --------

LCNC = Machine(corner="path-tolerance", axis_vel_mm_s=100.0, axis_acc_mm_s2=1000.0, path_acc_mm_s2=1000.0,
               chord_tol_mm=0.001)


def _plans(text: str, machine: Machine = LCNC):
    path = program_path(parse_program(text, "lcnc.ngc"), machine.chord_tol_mm)
    return [plan_motion(c.motion, machine) for c in path.chains]


def test_linuxcnc_arc_keeps_half_its_acceleration_for_the_normal():
    # A full circle r = 10 at F = 20 mm/s from rest to rest, the program's last move. Its speed
    # limit v_ini = min(100, sqrt(a sqrt(3)/2 r) = 93) needs the cutoff (ARC_FEED, then
    # pmCircleActualMaxVel with the move's overall a_o = a/2, its end a parabolic blend):
    # v_ini^2/r = 866 > a_o sqrt(3)/2, so the tangential acceleration is a_o/2 = 250 mm/s^2.
    # Accelerate over v^2/(2 a_t) = 0.8 mm, cruise, brake: t = L/v + v/a_t.
    (plan,) = _plans("G21 G90 G17 G64 P0.01\nG0 X0 Y0 Z0\nG2 X0 Y0 I10 J0 F1200\nM2\n")[-1:]
    a_t, v = 250.0, 20.0
    length = plan.length.sum()
    assert length == pytest.approx(2 * math.pi * 10, rel=1e-4)      # chords within 1 um
    np.testing.assert_allclose(plan.acc, a_t, rtol=1e-12)
    assert plan.time_s == pytest.approx(length / v + v / a_t, rel=1e-9)
    ramp = np.cumsum(plan.length)[np.flatnonzero(plan.v_exit >= v - 1e-9)[0]]
    assert ramp == pytest.approx(v * v / (2 * a_t), abs=plan.length.max())


def test_linuxcnc_large_arc_keeps_what_its_speed_limit_needs():
    # r = 200: v_ini = the axes' 100 mm/s; a_n = v_ini^2/r = 50 <= a_o sqrt(3)/2, so the tangential
    # share is sqrt(1 - (a_n/a_o)^2) of a_o = a/2 (the last move): a_t = 500 sqrt(1 - 0.01)
    (plan,) = _plans("G21 G90 G17 G64 P0.01\nG0 X0 Y0 Z0\nG3 X200 Y200 I200 J0 F3000\nM2\n")[-1:]
    a_t, v = 500.0 * math.sqrt(1 - 0.1 ** 2), 50.0
    np.testing.assert_allclose(plan.acc, a_t, rtol=1e-12)
    assert plan.time_s == pytest.approx(plan.length.sum() / v + v / a_t, rel=1e-9)


def test_linuxcnc_last_move_runs_at_half_and_ignores_the_path_limit():
    # Two lines at a right angle: the first ends in a blend arc (full acceleration, the axes' own:
    # LinuxCNC 2.9 never reads [TRAJ] MAX_ACCELERATION), the last ends the program in a parabolic
    # blend (half). Along x: a = 1200, not the path limit 1000.
    machine = Machine(corner="path-tolerance", axis_vel_mm_s=100.0, axis_acc_mm_s2=1200.0,
                      path_acc_mm_s2=1000.0)
    (plan,) = _plans("G21 G90 G17 G64 P0.01\nG0 X0 Y0 Z0\nG1 X40 F3000\nG1 Y40\nM2\n", machine)[-1:]
    np.testing.assert_allclose(plan.acc, [1200.0, 600.0], rtol=1e-12)
    # the corner: blend radius R = P sin(45°)/(1 − sin(45°)), speed sqrt(a sqrt(3)/2 R)
    s = math.sin(math.pi / 4)
    v_c = math.sqrt(1200.0 * math.sqrt(3) / 2 * 0.01 * s / (1 - s))
    assert plan.v_exit[0] == pytest.approx(v_c, rel=1e-9)
    v = 50.0
    # per move: d/v + the ramps' time lost: (v − v0)^2/(2 a v) for each ramp
    t1 = 40 / v + (v ** 2) / (2 * 1200 * v) + (v - v_c) ** 2 / (2 * 1200 * v)
    t2 = 40 / v + (v - v_c) ** 2 / (2 * 600 * v) + (v ** 2) / (2 * 600 * v)
    assert plan.time_s == pytest.approx(t1 + t2, rel=1e-9)


def test_linuxcnc_queue_drain_stops_the_tool():
    # LinuxCNC's task waits for the motion queue before a spindle command or an S word: the move
    # before it ends at rest, and as the queue's last move its end is parabolic (half acceleration)
    plans = _plans("G21 G90 G17 G64 P0.01\nG0 X0 Y0 Z0\nG1 X40 F3000\nS1000\nG1 X80\nM2\n")
    assert len(plans) == 2
    assert plans[0].v_exit[-1] == 0.0
    np.testing.assert_allclose(plans[0].acc, 500.0)
    np.testing.assert_allclose(plans[1].acc, 500.0)
    one = _plans("G21 G90 G17 G64 P0.01\nG0 X0 Y0 Z0\nG1 X40 F3000\nG1 X80\nM2\n")
    assert len(one) == 1 and one[0].v_exit[0] == pytest.approx(50.0)
