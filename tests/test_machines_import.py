"""``fuzzyfeed machines import`` (issue 37): machine files from a LinuxCNC INI (+ HAL) and from GRBL's
``$$`` settings. Checked against the files' own figures (unit conversions by hand), against every
sample configuration Debian's linuxcnc-uspace ships, and — through the LinuxCNC harness — against
the speed and acceleration LinuxCNC itself runs the imported limits at."""

from __future__ import annotations

import glob
import os
from pathlib import Path

import numpy as np
import pytest

from fuzzyfeed.cli import main
from fuzzyfeed.machine.description import load_machine, parse_machine
from fuzzyfeed.machine.grbl_settings import read_grbl_settings
from fuzzyfeed.machine.imported import ImportSettingsError, machine_toml
from fuzzyfeed.machine.linuxcnc_ini import read_linuxcnc_ini

import linuxcnc_sim

SAMPLES = "/usr/share/doc/linuxcnc/examples/sample-configs"
GRBL_DEFAULTS = Path(__file__).parent / "machines" / "grbl_1.1h_defaults.txt"
#: a third-party dump (cncjs's GRBL parser test, MIT; see tests/machines/README.md)
GRBL_CNCJS = Path(__file__).parent / "machines" / "cncjs_grbl_0.9j_settings.txt"

INI = """\
[EMCMOT]
SERVO_PERIOD = 500000
[RS274NGC]
RS274NGC_STARTUP_CODE = G17 G20 G40 G64 P0.002 G90
[KINS]
KINEMATICS = trivkins coordinates=XYYZ
JOINTS = 4
[TRAJ]
COORDINATES = X Y Y Z
LINEAR_UNITS = inch
MAX_LINEAR_VELOCITY = 4
MAX_LINEAR_ACCELERATION = 30
[AXIS_X]
MAX_VELOCITY = 5
MAX_ACCELERATION = 40
[AXIS_Y]
MAX_VELOCITY = 3
MAX_ACCELERATION = 40
[AXIS_Z]
MAX_VELOCITY = 2
MAX_ACCELERATION = 20
[JOINT_0]
MAX_VELOCITY = 5
MAX_ACCELERATION = 35
P = 50
FF1 = 0.5
[JOINT_1]
MAX_VELOCITY = 3
MAX_ACCELERATION = 40
[JOINT_2]
MAX_VELOCITY = 2.5
MAX_ACCELERATION = 25
[JOINT_3]
MAX_VELOCITY = 2
MAX_ACCELERATION = 20
[DISPLAY]
DISPLAY = axis
"""
HAL = """\
loadrt pid names=pid.x,pid.y,pid.y2,pid.z
setp pid.x.Pgain [JOINT_0]P
setp pid.x.FF1gain [JOINT_0]FF1
setp pid.y.Pgain 40
setp pid.y2.Pgain 45   # the gantry's second Y joint, which only its net would name
setp pid.z.Pgain 60
setp pid.z.FF1gain 0.25
"""


def test_linuxcnc_ini_by_hand():
    im = read_linuxcnc_ini(INI, "m.ini")
    m = im.machine
    # inch -> mm; an axis is its own and its joints' smallest; TRAJ 4 in/s caps X's 5
    np.testing.assert_allclose(m.axis_vel_mm_s, [4 * 25.4, 2.5 * 25.4, 2 * 25.4])
    np.testing.assert_allclose(m.axis_acc_mm_s2, [35 * 25.4, 25 * 25.4, 20 * 25.4])
    assert m.path_acc_mm_s2 == pytest.approx(30 * 25.4)
    assert m.ts_s == pytest.approx(0.0005)
    assert m.corner == "path-tolerance" and m.corner_mm == pytest.approx(0.002 * 25.4)
    used = {s.key for s in im.used}
    assert {"[TRAJ] LINEAR_UNITS", "[EMCMOT] SERVO_PERIOD", "[RS274NGC] RS274NGC_STARTUP_CODE",
            "[JOINT_2] MAX_ACCELERATION", "[TRAJ] MAX_LINEAR_VELOCITY"} <= used
    assert "[DISPLAY] DISPLAY" in {s.key for s in im.ignored}
    assert any("servo Kv 30" in a for a in im.assumed)


def test_linuxcnc_hal_gains():
    im = read_linuxcnc_ini(INI, "m.ini", hal_text=HAL, hal_path="m.hal")
    servo = im.machine.servo
    assert servo.kv_1_s == (50.0, 40.0, 60.0)
    assert servo.feedforward == (0.5, 0.0, 0.25)
    assert any(s.where == "m.hal:4" and "Y Kv" in s.note for s in im.used)
    # pid.y2 names no joint (its net would): named, not guessed
    assert any(s.where == "m.hal:5" and "names no joint" in s.note for s in im.ignored)


def test_linuxcnc_ini_round_trips_through_the_machine_file():
    im = read_linuxcnc_ini(INI, "m.ini", hal_text=HAL, hal_path="m.hal")
    assert parse_machine(machine_toml(im), "m.toml").as_dict() == im.machine.as_dict()


@pytest.mark.parametrize("bad, message", [
    (("MAX_LINEAR_ACCELERATION = 30", "MAX_LINEAR_ACCELERATION = fast"),
     "m.ini:12: [TRAJ] MAX_LINEAR_ACCELERATION = 'fast'; must be a finite number > 0"),
    (("LINEAR_UNITS = inch", "LINEAR_UNITS = furlong"), "m.ini:10: [TRAJ] LINEAR_UNITS = 'furlong'"),
    (("G64 P0.002", "G64 P-1"), "m.ini:4: [RS274NGC] RS274NGC_STARTUP_CODE"),
    (("MAX_ACCELERATION = 25", "MAX_ACCELERATION = -25"), "m.ini:32: [JOINT_2] MAX_ACCELERATION = '-25'"),
])
def test_linuxcnc_bad_values_name_file_line_key(bad, message):
    with pytest.raises(ImportSettingsError) as exc:
        read_linuxcnc_ini(INI.replace(*bad), "m.ini")
    assert str(exc.value).startswith(message)


def test_every_debian_sample_config_with_joints_reads():
    files = [f for f in sorted(glob.glob(f"{SAMPLES}/**/*.ini", recursive=True))
             if "[JOINT_0]" in Path(f).read_text(errors="replace")]
    if not files:
        if os.environ.get("FUZZYFEED_REQUIRE_LINUXCNC"):
            pytest.fail(f"no sample configs under {SAMPLES} (FUZZYFEED_REQUIRE_LINUXCNC is set)")
        pytest.skip(f"no LinuxCNC sample configs under {SAMPLES}")
    for f in files:
        im = read_linuxcnc_ini(Path(f).read_text(errors="replace"), f)
        assert parse_machine(machine_toml(im), "x.toml").as_dict() == im.machine.as_dict(), f
        assert im.used, f
    assert len(files) >= 200


def test_grbl_defaults_by_hand():
    im = read_grbl_settings(GRBL_DEFAULTS.read_text(), GRBL_DEFAULTS)
    m = im.machine
    np.testing.assert_allclose(m.axis_vel_mm_s, [500 / 60] * 3)
    np.testing.assert_allclose(m.axis_acc_mm_s2, [10.0] * 3)
    assert (m.corner, m.corner_mm, m.chord_tol_mm, m.acceleration) == ("junction-deviation", 0.01, 0.002, "axes")
    assert m.lookahead_moves == 16
    assert [s.key for s in im.used] == ["$110", "$111", "$112", "$120", "$121", "$122", "$11", "$12", "$13"]
    assert "$100" in {s.key for s in im.ignored} and "$32" in {s.key for s in im.ignored}
    assert parse_machine(machine_toml(im), "g.toml").as_dict() == m.as_dict()


def test_grbl_third_party_dump(tmp_path, capsys):
    # cncjs's GRBL 0.9j settings, read by hand: $110-$112 mm/min -> mm/s, $120-$122 mm/s^2,
    # $11 junction deviation, $12 arc tolerance; no $0 line (it is not needed)
    im = read_grbl_settings(GRBL_CNCJS.read_text(), GRBL_CNCJS)
    m = im.machine
    np.testing.assert_allclose(m.axis_vel_mm_s, [2500 / 60, 2500 / 60, 500 / 60])
    np.testing.assert_allclose(m.axis_acc_mm_s2, [250.0, 250.0, 50.0])
    assert (m.corner, m.corner_mm, m.chord_tol_mm, m.acceleration) == ("junction-deviation", 0.02, 0.002, "axes")
    assert [s.key for s in im.used] == ["$110", "$111", "$112", "$120", "$121", "$122", "$11", "$12", "$13"]
    assert {s.key for s in im.ignored} == {"$1", "$2", "$3", "$4", "$5", "$6", "$10", "$20", "$21", "$22",
                                           "$23", "$24", "$25", "$26", "$27", "$100", "$101", "$102",
                                           "$130", "$131", "$132"}
    out = tmp_path / "cncjs.toml"
    assert main(["machines", "import", str(GRBL_CNCJS), "-o", str(out)]) == 0
    assert "$132" in capsys.readouterr().out
    assert load_machine(out).as_dict() == m.as_dict()


def test_grbl_09_comments_and_spaces():
    text = ("Grbl 0.9j ['$' for help]\n$11=0.020 (junction deviation, mm)\n$12 = 0.005 (arc tolerance, mm)\n"
            "$13=1 (report inches, bool)\n$110=6000.000 (x max rate, mm/min)\n$111=3000 ; y\n$112=600\n"
            "$120=300\n$121=200\n$122=50\nok\n")
    m = read_grbl_settings(text, "g.txt").machine
    np.testing.assert_allclose(m.axis_vel_mm_s, [100.0, 50.0, 10.0])
    assert (m.corner_mm, m.chord_tol_mm) == (0.02, 0.005)


@pytest.mark.parametrize("edit, message", [
    (("$111=500.000", "$111=fast"), "g.txt:28: $111 = 'fast' (Y max rate); must be a finite number > 0"),
    (("$12=0.002\n", ""), "g.txt: $12 (arc tolerance) missing"),
    (("$130=200.000", "$110=9"), "g.txt:33: $110 = 9 given twice (first at line 27)"),
    (("ok", "G0 X1"), "g.txt:36: 'G0 X1'; a $$ dump has lines $N=value"),
])
def test_grbl_bad_settings(edit, message):
    with pytest.raises(ImportSettingsError) as exc:
        read_grbl_settings(GRBL_DEFAULTS.read_text().replace(*edit), "g.txt")
    assert str(exc.value).startswith(message)


def test_cli_writes_the_file_and_names_every_setting(tmp_path, capsys):
    out = tmp_path / "g.toml"
    assert main(["machines", "import", str(GRBL_DEFAULTS), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "used     " in text and "ignored  " in text and "$130" in text
    assert load_machine(out).axis_acc_mm_s2 == (10.0, 10.0, 10.0)
    (tmp_path / "m.ini").write_text(INI)
    (tmp_path / "m.hal").write_text(HAL)
    assert main(["machines", "import", str(tmp_path / "m.ini"), "--hal", str(tmp_path / "m.hal"),
                 "-o", str(tmp_path / "m.toml")]) == 0
    assert load_machine(tmp_path / "m.toml").servo.kv_1_s == (50.0, 40.0, 60.0)


def test_cli_bad_file_one_line_exit_2_nothing_written(tmp_path, capsys):
    bad = tmp_path / "bad.txt"
    bad.write_text(GRBL_DEFAULTS.read_text().replace("$120=10.000", "$120=nan"))
    out = tmp_path / "bad.toml"
    assert main(["machines", "import", str(bad), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{bad}:30: $120 = 'nan'" in err[0]
    assert not out.exists()
    (tmp_path / "notes.txt").write_text("hello\n")
    assert main(["machines", "import", str(tmp_path / "notes.txt"), "-o", str(out)]) == 2
    assert "neither a LinuxCNC INI" in capsys.readouterr().err


def test_imported_machine_reproduces_the_ini_limits_in_linuxcnc(tmp_path):
    """axis_mm.ini imported, run by LinuxCNC from the machine file: a long rapid on each axis
    reaches the INI's MAX_VELOCITY and never exceeds its MAX_ACCELERATION."""
    ini = Path(f"{SAMPLES}/sim/axis/axis_mm.ini")
    reason = linuxcnc_sim.unavailable() or (None if ini.exists() else f"{ini} missing")
    if reason:
        if os.environ.get("FUZZYFEED_REQUIRE_LINUXCNC"):
            pytest.fail(f"{reason} (FUZZYFEED_REQUIRE_LINUXCNC is set)")
        pytest.skip(reason)
    out = tmp_path / "axis_mm.toml"
    assert main(["machines", "import", str(ini), "-o", str(out)]) == 0
    machine = load_machine(out)
    prog = tmp_path / "rapids.ngc"
    prog.write_text("G21 G90 G61\nG0 X60\nG0 Y60\nG0 Z40\nM2\n")
    run = linuxcnc_sim.run_program(machine, prog, expected_s=8).moving()
    vel = np.abs(np.diff(run.joints_mm, axis=0)) / run.ts_s
    acc = np.abs(np.diff(run.speed_mm_s)) / run.ts_s
    for j, axis in enumerate("XYZ"):
        assert vel[:, j].max() == pytest.approx(30.48, rel=1e-6), axis      # [AXIS_x] MAX_VELOCITY
    assert acc.max() <= 508.0 * (1 + 1e-6)                                     # MAX_ACCELERATION
    assert acc.max() >= 0.5 * 508.0
