"""LinuxCNC's planner as the judge (issue 37): the harness (tests/linuxcnc_sim.py) runs tiny programs
through LinuxCNC 2.9's uspace simulator; its per-period joint commands must match the closed forms
(a trapezoid's time and peak speed, the end position, a circle's radius) and fuzzyfeed's planner on
the same machine. Skipped with the reason when LinuxCNC is absent; required when
FUZZYFEED_REQUIRE_LINUXCNC=1 (CI)."""

from __future__ import annotations

import math
import os
import warnings
from pathlib import Path

import numpy as np
import pytest

from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.servo import steady_circle_error_mm
from fuzzyfeed.program.read import read_program
from fuzzyfeed.program.run import program_path, run_program as run_on_machine

import linuxcnc_sim

V_MM_S, A_MM_S2 = 20.0, 500.0
#: LinuxCNC joints pass the planner's positions through a cubic interpolator: a few periods of lag
#: and of smoothing at each end of a run.
ENDS_TICKS = 6
#: fuzzyfeed's planner against LinuxCNC's on one program (the issue's target median, 2 %).
PLANNER_REL = 0.02

MACHINE = Machine(name="judge", axis_vel_mm_s=(60.0, 60.0, 40.0), axis_acc_mm_s2=(A_MM_S2,) * 3,
                  path_acc_mm_s2=A_MM_S2, corner="path-tolerance", corner_mm=0.01, chord_tol_mm=0.001,
                  ts_s=0.001)


def _linuxcnc() -> None:
    reason = linuxcnc_sim.unavailable()
    if reason is None:
        return
    if os.environ.get("FUZZYFEED_REQUIRE_LINUXCNC"):
        pytest.fail(f"LinuxCNC harness: {reason} (FUZZYFEED_REQUIRE_LINUXCNC is set)")
    pytest.skip(f"LinuxCNC harness: {reason}")


def _run(tmp_path: Path, text: str, machine: Machine = MACHINE, expected_s: float = 5.0):
    _linuxcnc()
    prog = tmp_path / "p.ngc"
    prog.write_text(text)
    run = linuxcnc_sim.run_program(machine, prog, expected_s=expected_s)
    if run.realtime_delays:
        warnings.warn(f"LinuxCNC logged {run.realtime_delays} 'Unexpected realtime delay' (a busy "
                      "computer: wall time only, the recorded periods are the planner's)", stacklevel=2)
    return prog, run.moving()


def _fuzzyfeed_time(prog: Path, machine: Machine) -> float:
    return run_on_machine(program_path(read_program(prog), machine.chord_tol_mm), machine).time_s


def test_line_is_the_trapezoid(tmp_path):
    """G64's last move ends in a parabolic blend, for which LinuxCNC 2.9 (tc.c,
    tcGetTangentialMaxAccel) keeps half the acceleration in reserve: a trapezoid at A/2."""
    prog, run = _run(tmp_path, f"G21 G90 G64 P0.01\nG0 X0 Y0 Z0\nG1 X30 F{V_MM_S * 60:g}\nM2\n")
    length, acc = 30.0, A_MM_S2 / 2
    closed = length / V_MM_S + V_MM_S / acc          # accelerate, cruise, decelerate
    assert abs(run.time_s - closed) <= ENDS_TICKS * run.ts_s, (run.time_s, closed)
    np.testing.assert_allclose(run.joints_mm[-1], [length, 0.0, 0.0], atol=1e-9)
    speed = np.linalg.norm(np.diff(run.joints_mm, axis=0), axis=1) / run.ts_s
    assert speed.max() == pytest.approx(V_MM_S, rel=1e-6)
    ramp = np.diff(run.speed_mm_s[run.motion_type == linuxcnc_sim.FEED]) / run.ts_s
    assert np.median(ramp[ramp > 0]) == pytest.approx(acc, rel=1e-6)
    assert set(np.unique(run.line[run.motion_type == linuxcnc_sim.FEED])) == {3}
    predicted = _fuzzyfeed_time(prog, MACHINE)
    assert predicted == pytest.approx(run.time_s, rel=PLANNER_REL), (predicted, run.time_s)


def test_exact_stop_line_positions(tmp_path):
    """G61: the move ends at rest on its end point; every period's position lies on the line."""
    prog, run = _run(tmp_path, "G21 G90 G61\nG0 X0 Y0 Z0\nG1 X12 Y5 Z-2 F900\nM2\n")
    np.testing.assert_allclose(run.joints_mm[-1], [12.0, 5.0, -2.0], atol=1e-9)
    end = np.array([12.0, 5.0, -2.0])
    along = run.joints_mm @ end / (end @ end)
    np.testing.assert_allclose(run.joints_mm, along[:, None] * end[None, :], atol=1e-9)
    assert np.all(np.diff(along) >= -1e-12)
    speed = np.linalg.norm(np.diff(run.joints_mm, axis=0), axis=1) / run.ts_s
    assert speed.max() == pytest.approx(15.0, rel=1e-6)


def test_corner_blends_within_g64_and_agrees_with_the_planner(tmp_path):
    prog, run = _run(tmp_path, "G21 G90 G64 P0.01\nG0 X0 Y0 Z0\nG1 X20 F1200\nG1 Y20\nM2\n")
    np.testing.assert_allclose(run.joints_mm[-1], [20.0, 20.0, 0.0], atol=1e-9)
    # the blend leaves the corner by at most P, and cuts it (the tool never passes x = 20)
    corner = np.linalg.norm(run.joints_mm[:, :2] - [20.0, 0.0], axis=1).min()
    assert 0.0 < corner <= 0.01 * 1.02     # the joints' cubic interpolator rounds it a little more
    assert run.joints_mm[:, 0].max() <= 20.0 + 1e-9
    assert set(np.unique(run.line[run.motion_type == linuxcnc_sim.FEED])) == {3, 4}
    predicted = _fuzzyfeed_time(prog, MACHINE)
    assert predicted == pytest.approx(run.time_s, rel=PLANNER_REL), (predicted, run.time_s)


def test_circle_stays_on_its_radius_and_agrees_with_the_planner(tmp_path):
    r = 8.0
    # from rest on the circle (centre (r, 0)): no rapid before it whose lag the servo still carries
    prog, run = _run(tmp_path, f"G21 G90 G64 P0.01\nG0 X0 Y0 Z0\nG2 X0 Y0 I{r:g} J0 F{V_MM_S * 60:g}\nM2\n")
    arc = run.motion_type == linuxcnc_sim.ARC
    radius = np.linalg.norm(run.joints_mm[arc, :2] - [r, 0.0], axis=1)
    np.testing.assert_allclose(radius, r, atol=1e-5)
    # cruise, plus v/a_t for the two ramps; LinuxCNC keeps at most half of A tangential on an arc
    # (the rest for the normal acceleration), and half of that on a move ending in a G64 blend
    closed = 2 * math.pi * r / V_MM_S
    arc_time = np.count_nonzero(arc) * run.ts_s
    assert closed + V_MM_S / A_MM_S2 <= arc_time <= closed + 4 * V_MM_S / A_MM_S2 + ENDS_TICKS * run.ts_s
    predicted = _fuzzyfeed_time(prog, MACHINE)
    assert predicted == pytest.approx(run.time_s, rel=PLANNER_REL), (predicted, run.time_s)
    # the servo model on LinuxCNC's commands: the steady radial error r (1 - |G(j v/r)|) of the
    # cruise; no rapid moves the tool along a different path, so nothing is in the air
    part, air = linuxcnc_sim.servo_contour_um(run, MACHINE, prog)
    assert part == pytest.approx(steady_circle_error_mm(MACHINE.servo, r, V_MM_S) * 1e3, rel=0.02)
    assert air < 1e-3


def test_arcs_and_sharp_corners_agree_with_the_planner(tmp_path):
    """Arcs (their tangential acceleration reduced for the normal one), tangent and sharp G64
    corners (blend arcs), the last move at half acceleration: fuzzyfeed's planner with LinuxCNC
    2.9's rules (fuzzyfeed/machine/linuxcnc_tp.py) within 2 % of LinuxCNC's time."""
    text = ("G21 G90 G64 P0.01\nG0 X0 Y0 Z0\nG1 X20 F1500\nG3 X30 Y10 I0 J10\nG1 Y20\n"
            "G1 X10 Y25\nG3 X0 Y15 I0 J-10\nG1 Y0\nG1 X15\nG2 X25 Y0 I5 J0\nM2\n")
    prog, run = _run(tmp_path, text, expected_s=8.0)
    np.testing.assert_allclose(run.joints_mm[-1], [25.0, 0.0, 0.0], atol=1e-9)
    predicted = _fuzzyfeed_time(prog, MACHINE)
    assert predicted == pytest.approx(run.time_s, rel=PLANNER_REL), (predicted, run.time_s)


def test_pause_is_resumed_and_noted(tmp_path):
    prog, run = _run(tmp_path, "G21 G90 G61\nG0 X0 Y0 Z0\nG1 X5 F600\nM0\nG1 Y5\nM2\n")
    np.testing.assert_allclose(run.joints_mm[-1], [5.0, 5.0, 0.0], atol=1e-9)
    assert any("resumed a pause" in m for m in run.messages)
