"""``fuzzyfeed filter`` as LinuxCNC's AXIS runs a [FILTER] program (issue 37): ``sh -c "<filter>
'PROGRAM'"``, standard output loaded as the program, ``FILTER_PROGRESS=N`` lines of standard error
as progress, a non-zero exit shown with standard error. The advised program must be what ``advise
--gcode`` writes, and LinuxCNC must run it (the harness) to the same end point, in the time
fuzzyfeed's planner predicts."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import linuxcnc_sim
from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.program.read import read_program
from fuzzyfeed.program.run import program_path, run_program

ROOT = Path(__file__).resolve().parents[1]
PROGRAM = ("G21 G90 G64 P0.01\nG0 X0 Y0 Z1\nG1 Z-1 F300\nG1 X20 F3000\nG3 X20 Y4 I0 J2\nG1 X0\n"
           "G3 X0 Y8 I0 J2\nG1 X20\nG0 Z1\nM2\n")


def _as_axis(args: str, program: Path) -> subprocess.CompletedProcess:
    """What AXIS's filter_program does: the INI's command line and the program path, quoted, in sh."""
    env = dict(os.environ, AXIS_PROGRESS_BAR="1", PYTHONPATH=str(ROOT))
    quoted = str(program).replace("'", "'\\''")
    command = f"{sys.executable} -m fuzzyfeed filter {args} '{quoted}'"
    return subprocess.run(["sh", "-c", command], capture_output=True, env=env, timeout=600)


def test_filter_writes_the_advised_program_with_progress(tmp_path):
    prog = tmp_path / "it's a zigzag.ngc"        # a quote in the name, as AXIS quotes it
    prog.write_text(PROGRAM)
    done = _as_axis("--machine linuxcnc-mill", prog)
    assert done.returncode == 0, done.stderr
    progress = [int(m) for m in re.findall(rb"^FILTER_PROGRESS=(\d+)$", done.stderr, re.MULTILINE)]
    assert progress[0] == 0 and progress[-1] == 100 and progress == sorted(progress)
    advised = tmp_path / "advised.ngc"
    advised.write_bytes(done.stdout)
    # the same text advise --gcode writes
    from fuzzyfeed.cli import main
    ref = tmp_path / "ref.ngc"
    assert main(["advise", str(prog), "--machine", "linuxcnc-mill", "--no-reference", "-o",
                 str(tmp_path / "a.csv"), "--gcode", str(ref)]) == 0
    assert advised.read_bytes() == ref.read_bytes()
    assert advised.read_text() != PROGRAM               # this program breaks 30 um as written


def test_filter_errors_as_axis_shows_them(tmp_path):
    prog = tmp_path / "p.ngc"
    prog.write_text(PROGRAM)
    done = _as_axis("--machine no-such-machine", prog)
    assert done.returncode == 2 and done.stdout == b""
    lines = [l for l in done.stderr.decode().splitlines() if not l.startswith("FILTER_PROGRESS=")]
    assert len(lines) == 1 and "no-such-machine" in lines[0]
    bad = tmp_path / "bad.ngc"
    bad.write_text("G21\nG1 X10 F\nM2\n")
    done = _as_axis("--machine linuxcnc-mill", bad)
    assert done.returncode == 2 and done.stdout == b""
    assert "bad.ngc" in done.stderr.decode()


def test_filter_passes_a_program_without_cuts_through(tmp_path):
    prog = tmp_path / "rapids.ngc"
    prog.write_bytes(b"G21 G90\r\nG0 X5 Y5\r\nM2\r\n")
    done = _as_axis("--machine linuxcnc-mill", prog)
    assert done.returncode == 0 and done.stdout == prog.read_bytes()


def test_filtered_program_runs_in_linuxcnc(tmp_path):
    reason = linuxcnc_sim.unavailable()
    if reason:
        if os.environ.get("FUZZYFEED_REQUIRE_LINUXCNC"):
            pytest.fail(f"LinuxCNC harness: {reason} (FUZZYFEED_REQUIRE_LINUXCNC is set)")
        pytest.skip(f"LinuxCNC harness: {reason}")
    prog = tmp_path / "p.ngc"
    prog.write_text(PROGRAM)
    done = _as_axis("--machine linuxcnc-mill", prog)
    assert done.returncode == 0, done.stderr
    advised = tmp_path / "advised.ngc"
    advised.write_bytes(done.stdout)
    machine = load_machine("linuxcnc-mill")
    run = linuxcnc_sim.run_program(machine, advised, expected_s=10).moving()
    assert run.joints_mm[-1] == pytest.approx([20.0, 8.0, 1.0], abs=1e-9)
    predicted = run_program(program_path(read_program(advised), machine.chord_tol_mm), machine).time_s
    assert predicted == pytest.approx(run.time_s, rel=0.05), (predicted, run.time_s)
