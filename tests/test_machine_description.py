"""Machine files (issue 32, item 1): the shipped ones load, one-line refusals name the file, the line,
the key and the rule, flags replace fields, and a refused machine leaves no output behind."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzyfeed.cli import main
from fuzzyfeed.errors import MachineLimitsError
from fuzzyfeed.machine.description import Machine, load_machine, machine_names, parse_machine

GOOD = """\
name = "mill"
[axes]
max_velocity_mm_s = [100.0, 100.0, 50.0]
max_acceleration_mm_s2 = 800.0
[servo]
kv_1_s = 25.0
[controller]
junction_deviation_mm = 0.02
[part]
contour_tolerance_um = 40.0
"""


def test_shipped_machines_load_and_describe_themselves():
    assert {"reference", "hobby-router", "linuxcnc-mill", "production-vmc"} <= set(machine_names())
    for name in machine_names():
        m = load_machine(name)
        assert m.name == name and m.path is not None
        assert name in m.describe()
    ref = load_machine("reference")
    assert ref.servo.kv_1_s == (30.0, 30.0, 30.0) and ref.corner_mm == 0.01
    assert ref.tangential_acc_mm_s2 == 1000.0 and ref.contour_tol_um == 50.0
    assert load_machine("linuxcnc-mill").corner == "path-tolerance"
    assert load_machine("hobby-router").path_limit_mm_s2 is None


def test_fields_not_given_take_the_defaults():
    m = parse_machine(GOOD, "mill.toml")
    assert m.axis_vel_mm_s == (100.0, 100.0, 50.0) and m.axis_acc_mm_s2 == (800.0,) * 3
    assert m.servo.kv_1_s == (25.0,) * 3 and m.corner == "junction-deviation" and m.corner_mm == 0.02
    assert m.chord_tol_mm == Machine().chord_tol_mm and m.lookahead_moves == 0


@pytest.mark.parametrize("text, message", [
    ("[axes]\nmax_velocity = 100.0\n",
     r"m\.toml:2: key 'max_velocity' has no unit; write 'max_velocity_mm_s'"),
    ("[axes]\nmax_speed_mm_s = 100.0\n", r"m\.toml:2: unknown key 'max_speed_mm_s' in \[axes\]; it takes"),
    ("[axes]\nmax_acceleration_mm_s2 = -5.0\n",
     r"m\.toml:2: max_acceleration_mm_s2 = -5.0; must be a finite number > 0"),
    ("[axes]\nmax_velocity_mm_s = [1.0, 2.0]\n", r"m\.toml:2: max_velocity_mm_s = \[1.0, 2.0\]; give one value"),
    ("[part]\ncontour_tolerance_um = 0\n", r"m\.toml:2: contour_tolerance_um = 0; must be a finite number > 0"),
    ("[controller]\ncorner = \"round\"\n", r"m\.toml:2: corner = 'round'; must be one of"),
    ("[controller]\njunction_deviation_mm = 0.01\npath_tolerance_mm = 0.01\n",
     r"m\.toml:3: path_tolerance_mm and junction_deviation_mm both given"),
    ("[controller]\nlookahead_moves = 1\n", r"m\.toml:2: lookahead_moves = 1; must be an integer >= 2"),
    ("[spindle]\nrpm = 3\n", r"m\.toml:1: unknown section \[spindle\]"),
    ("[axes]\nmax_velocity_mm_s = 1\nmax_velocity_mm_s = 2\n", r"m\.toml:3: key 'max_velocity_mm_s' given twice"),
    ("[servo]\nkv_1_s = 30\nnatural_freq_hz = 20\n", r"kv_1_s and natural_freq_hz both given"),
    ("[servo]\nfeedforward = 1.5\n", r"servo feedforward = 1.5; must be a finite number >= 0 and <= 1"),
    ("[axes\n", r"m\.toml: invalid TOML"),
])
def test_bad_machine_files_are_one_line(text, message):
    with pytest.raises(MachineLimitsError, match=message) as info:
        parse_machine(text, "m.toml")
    assert "\n" not in str(info.value)


def test_cli_refuses_a_bad_machine_file_without_touching_outputs(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[axes]\nmax_velocity = 100\n")
    out = tmp_path / "out.csv"
    gcode = tmp_path / "out.ngc"
    gcode.write_text("keep me\n")
    code = main(["advise", "tests/programs/corpus/grbl_02.ngc", "-o", str(out), "--gcode", str(gcode),
                 "--machine", str(bad)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert err[0].startswith("fuzzyfeed: error: ") and "bad.toml:2" in err[0] and "max_velocity_mm_s" in err[0]
    assert not out.exists() and gcode.read_text() == "keep me\n"


def test_cli_refuses_an_unknown_machine_name(tmp_path, capsys):
    code = main(["advise", "trident", "-o", str(tmp_path / "a.csv"), "--machine", "nosuch"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "nosuch" in err[0] and "reference" in err[0]


def test_flags_replace_the_files_fields():
    from fuzzyfeed.cli import build_parser
    from fuzzyfeed.cli._machine import machine_from_args

    parser = build_parser()
    args = parser.parse_args(["advise", "trident", "-o", "x.csv"])
    assert machine_from_args(args) is None                   # no machine: today's behaviour
    args = parser.parse_args(["advise", "trident", "-o", "x.csv", "--contour-tol-um", "20"])
    m = machine_from_args(args)
    assert m.contour_tol_um == 20 and m.servo.kv_1_s == (30.0,) * 3 and m.name == "reference"
    args = parser.parse_args(["advise", "trident", "-o", "x.csv", "--machine", "hobby-router",
                              "--servo-kv-1-s", "45", "--junction-deviation-mm", "0.02",
                              "--axis-acc-mm-s2", "300,300,100"])
    m = machine_from_args(args)
    assert m.name == "hobby-router" and m.servo.kv_1_s == (45.0,) * 3 and m.corner_mm == 0.02
    assert m.axis_acc_mm_s2 == (300.0, 300.0, 100.0) and m.lookahead_moves == 16   # kept from the file


def test_speed_along_a_polyline_is_the_axes_reach_in_each_direction():
    """By hand: axes 100/100/50 mm/s; along X 100, at 45 degrees in XY 100·√2, along Z 50, a
    segment of zero length takes the slowest axis."""
    from dataclasses import replace as _replace

    from fuzzyfeed.machine.description import load_machine

    machine = _replace(load_machine("reference"), axis_vel_mm_s=(100.0, 100.0, 50.0))
    pts = [[0, 0, 0], [10, 0, 0], [20, 10, 0], [20, 10, 5], [20, 10, 5]]
    assert np.allclose(machine.speed_along(pts), [100.0, 100.0 * np.sqrt(2), 50.0, 50.0])


def _along_per_axis(per_axis, unit, cap):
    """Machine._along as every machine computed it before the equal-axes form (a frozen copy: the
    reference): min over the axes of A_j / |u_j|, |u_j| > 1e-12, else the slowest axis's A."""
    u = np.abs(np.asarray(unit, dtype=float))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        each = np.where(u > 1e-12, per_axis[None, :] / u, np.inf)
    out = each[:, 0].copy()
    for j in range(1, each.shape[1]):
        np.minimum(out, each[:, j], out=out)
    out = np.where(np.isfinite(out), out, per_axis.min())
    return out if cap is None else np.minimum(out, cap)


@pytest.mark.parametrize("a", [100.0, 1000.0, 3.3, 0.1, 7e5])
@pytest.mark.parametrize("cap", [None, 500.0])
def test_the_reach_along_a_direction_with_equal_axes_is_the_per_axis_ones_bit_for_bit(a, cap):
    """Equal axes take A / max_j |u_j| (one division instead of one per axis): the same floats as the
    per-axis minimum on random directions, axis-aligned ones, directions with components at and
    around the 1e-12 cut, zero, NaN and inf components (fails if the cut, the NaN rule or the
    fallback to the slowest axis differ)."""
    rng = np.random.default_rng(int(a * 10) + (cap is None))
    u = rng.normal(size=(20000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    u[:100, 1:] = 0.0
    u[100:200] = 0.0
    u[200:300, 0] = 1e-13
    u[300:400] = [1e-12, -1e-12, 0.0]
    u[400:500] = [1e-12, np.nextafter(1e-12, 1.0), 0.0]
    u[500:600] = np.nan
    u[600:700, 1] = np.nan
    u[700:800, 2] = np.inf
    u[800:900] = [-1e-300, 0.0, 1e-300]
    per_axis = np.full(3, a)
    with np.errstate(over="ignore"):
        got = Machine._along(per_axis, u, cap)
    assert got.tobytes() == _along_per_axis(per_axis, u, cap).tobytes()
    m = Machine(axis_vel_mm_s=(a, a, a), axis_acc_mm_s2=(a, a, a))
    assert m.move_velocity(u[900:]).tobytes() == _along_per_axis(per_axis, u[900:], None).tobytes()
