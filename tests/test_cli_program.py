"""``fuzzyfeed advise PROGRAM.ngc``: bad programs are refused in one line naming file:line (exit 2,
no output), a selector advises one cut, --feed-mm-min caps, inch programs keep inch F words, G93
moves and lines after M2 are kept, CRLF files stay CRLF."""

from __future__ import annotations

import csv
import re

import numpy as np
import pytest

from canon import canon, compare
from fuzzyfeed.cli import main
from fuzzyfeed.cli._program import ADVICE_COLUMNS

PROGRAM = """%
(two pockets)
G21 G90 G17 G94
T1 M6
G43 H1
M3 S9000
G0 X0 Y0 Z5
G1 Z-1 F200
G1 X40 F1000
G1 Y30
G1 X0
G1 Y0
G0 Z5
G0 X60 Y0
G1 Z-1 F200
G1 X100 F800
G3 X100 Y20 I0 J10
G1 X60
G1 Y0
G0 Z5
M5
M30
%
"""


def write(tmp_path, text, name="prog.ngc", newline="\n"):
    path = tmp_path / name
    path.write_bytes(text.replace("\n", newline).encode())
    return path


def run(tmp_path, program, *extra):
    out_csv, out_ngc = tmp_path / "a.csv", tmp_path / "a.ngc"
    code = main(["advise", str(program), "-o", str(out_csv), "--gcode", str(out_ngc), *extra])
    return code, out_csv, out_ngc


@pytest.mark.parametrize("text, message", [
    ("G21\nG0 X0 Y0\nG1 X#6000 F100\n", r"prog\.ngc:3: parameter #6000 is out of range \(#1 … #5601\)"),
    ("G21\nG0 X0 Y0\n#1 = 5\nG1 X#5420 F100\n", r"prog\.ngc:4: system parameter #5420 is not supported"),
    ("G21\nG0 X0 Y0\nG1 X[1+2 F100\n", r"prog\.ngc:3: unknown operation at 'f100'"),
    ("G21\no100 sub\nG1 X1 F100\no100 endsub\no101 call\n", r"prog\.ngc:5: subroutine O101 is not defined in this file"),
    ("G21\nG0 X0 Y0\nG41.1\nG1 X10 F100\n", r"prog\.ngc:3: G41\.1 with no D word"),
    ("G21\nG0 X0 Y0\nG42.1 D6\nG1 X2 F100\n", r"prog\.ngc:4: the cutter compensation entry move is not longer"),
    ("G21\nG0 X0 Y0\nG1 X10 F100\nG2 X30 Y0 I5 J0\n", r"prog\.ngc:4: G2: radius to the end 15 differs from radius to the start 5 by 10 .*the arc does not fit"),
    ("G21\nG0 X0 Y0\nG1 X10 F100\nG3 X30 Y0 R5\n", r"prog\.ngc:4: G3 R5: radius 5 is shorter than half the chord \(10\); the arc does not fit"),
    ("G21\nG0 X0 Y0\nG1 X10\nG1 Y10\n", r"prog\.ngc:3: G1 with no F in force"),
    ("G21\nG0 X0 Y0\nM98 P100\n", r"prog\.ngc:3: M98 P100: no 'O100' subroutine in this file"),
])
def test_bad_program_one_line_exit_2_no_output(tmp_path, capsys, text, message):
    code, out_csv, out_ngc = run(tmp_path, write(tmp_path, text))
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("fuzzyfeed: error: ") and err.count("\n") == 1, err
    assert re.search(message, err), err
    assert not out_csv.exists() and not out_ngc.exists()


def test_selector_advises_one_cut_and_cap(tmp_path, capsys):
    program = write(tmp_path, PROGRAM)
    code, out_csv, out_ngc = run(tmp_path, str(program) + "#2", "--feed-mm-min", "600")
    assert code == 0
    with open(out_csv, newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert {r["cut"] for r in rows} == {"2"}
    assert min(int(r["source_line"]) for r in rows) == 15
    new = out_ngc.read_text().splitlines()
    old = PROGRAM.splitlines()
    # cut 1 (lines 8-12) is unchanged, cut 2 is capped at 600 mm/min
    assert new[:13] == old[:13]
    fs = [float(f) for line in new[13:] for f in re.findall(r"F([\d.]+)", line)]
    assert max(fs) <= 600 and min(fs) < 300
    result = compare(canon(program, tmp_path), canon(out_ngc, tmp_path))
    assert result.min_ratio < 0.5


def test_inch_program_keeps_inch_feeds_and_g93_moves_and_lines_after_m2(tmp_path):
    text = ("G20 G90 G17 G94\nG0 X0 Y0 Z0.2\nG1 Z-0.04 F8\nG1 X2 F40\nG1 Y1\nG1 X0\nG0 Z0.2\n"
            "G93 G1 X1 Y0.5 F30\nG94\nM2\n(after the end: copied)\nG1 X99\n")
    program = write(tmp_path, text, newline="\r\n")
    code, out_csv, out_ngc = run(tmp_path, program)
    assert code == 0
    data = out_ngc.read_bytes()
    assert b"\r\n" in data and data.replace(b"\r\n", b"").count(b"\n") == 0
    new = data.decode().split("\r\n")
    assert "G93 G1 X1 Y0.5 F30" in new
    assert new[-3:] == ["(after the end: copied)", "G1 X99", ""]
    fs = [float(f) for line in new[2:7] for f in re.findall(r"F([\d.]+)", line)]
    assert fs and max(fs) <= 40 and min(fs) < 20     # inch/min, never above the program's F
    compare(canon(program, tmp_path), canon(out_ngc, tmp_path))


def test_program_csv_and_summary(tmp_path, capsys):
    program = write(tmp_path, PROGRAM)
    code, out_csv, _ = run(tmp_path, program, "--plot", str(tmp_path / "a.png"))
    assert code == 0
    out = capsys.readouterr().out
    assert "2 cut(s), 2 advised" in out and "at the programmed F" in out
    with open(out_csv, newline="") as handle:
        rows = list(csv.DictReader(handle))
    feed = np.array([float(r["feed_mm_min"]) for r in rows])
    prog = np.array([float(r["programmed_feed_mm_min"]) for r in rows])
    assert np.all(feed <= prog) and set(np.unique(prog)) <= {200.0, 800.0, 1000.0}
    assert (tmp_path / "a.png").stat().st_size > 10000


def test_program_from_a_cut_starts_above_it(tmp_path):
    """A cut that starts at 5 mm (its approach move) is written from 10 mm; an explicit safe
    height below the path is refused before anything is written."""
    program = write(tmp_path, PROGRAM.replace("G1 Z-1 F200\nG1 X40", "G1 Z-1 F200\nG1 X40 Z-1"))
    out = tmp_path / "s.ngc"
    assert main(["schedule", str(program) + "#1", "-o", str(tmp_path / "s.csv"), "--gcode", str(out)]) == 0
    calls = canon(out, tmp_path)
    traverses = [c for c in calls if c[0] == "STRAIGHT_TRAVERSE"]
    assert traverses[0][1].startswith("0.0000, 0.0000, 10.0000") and traverses[-1][1].split(", ")[2] == "10.0000"
    bad = tmp_path / "b.ngc"
    assert main(["advise", str(program) + "#1", "-o", str(tmp_path / "b.csv")]) == 0
    assert main(["schedule", str(program) + "#1", "-o", str(tmp_path / "c.csv"), "--gcode", str(bad),
                 "--safe-z-mm", "2"]) == 2
    assert not bad.exists() and not (tmp_path / "c.csv").exists()


def test_schedule_and_compare_run_a_cut_at_its_own_f(tmp_path, capsys):
    """A cut is scheduled at the program's F words (the plunge at F200, the contour at F1000),
    each capped by --feed-mm-min, as DESIGN's "Feeds in a program" says: at the default 6000 a
    compass program written at F400 was reported at 10.4 s instead of 118 s."""
    program = write(tmp_path, PROGRAM)
    out = tmp_path / "s.csv"
    assert main(["schedule", str(program) + "#1", "-o", str(out)]) == 0
    assert "the program's F200-F1000 mm/min" in capsys.readouterr().out
    with open(out, newline="") as handle:
        rows = list(csv.DictReader(handle))
    s = np.array([float(r["s_mm"]) for r in rows])
    feed = np.array([float(r["feed_mm_min"]) for r in rows])
    assert feed[s < 6.0 - 1e-6].max() <= 200.0 + 1e-6     # the 6 mm plunge
    assert 900.0 < feed.max() <= 1000.0 + 1e-6
    assert main(["schedule", str(program) + "#1", "-o", str(out), "--feed-mm-min", "500"]) == 0
    assert "above --feed-mm-min 500 capped to it" in capsys.readouterr().out
    with open(out, newline="") as handle:
        assert max(float(r["feed_mm_min"]) for r in csv.DictReader(handle)) <= 500.0 + 1e-6
    # compare: the constant row is the program as written, every row under its F
    report = tmp_path / "c.csv"
    assert main(["compare", str(program) + "#2", "-o", str(report)]) == 0
    with open(report, newline="") as handle:
        rows = {r["method"]: r for r in csv.DictReader(handle)}
    plunge, rest = 6.0, 40.0 + np.pi * 10.0 + 40.0 + 20.0   # mm at F200, mm at F800
    written = plunge / (200 / 60) + rest / (800 / 60)
    assert float(rows["constant"]["cycle_time_s"]) == pytest.approx(written, rel=0.01)
    for method in ("slw", "bound", "fuzzy", "fuzzy-safe"):
        assert float(rows[method]["cycle_time_s"]) > written


def test_schedule_refuses_a_cut_without_f(tmp_path, capsys):
    program = write(tmp_path, "G21 G90\nG0 X0 Y0\nG1 X10 Y0\nG1 X10 Y10\nM2\n")
    out = tmp_path / "s.csv"
    assert main(["schedule", str(program), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "no F in force" in err and "prog.ngc" in err
    assert not out.exists()


@pytest.mark.parametrize("text, why", [
    ("G21 G90\r\nG0 X0 Y0 Z5 (caf\xe9)\r\nG0 X10\r\nM30\r\n", "2 rapid move"),
    ("G21 G90\nG0 X0 Y0\nG1 A90 F100\nG1 B45 C10\nM2\n", "2 move(s) turning a rotary axis"),
    ("G21 G90 G98\nG0 X0 Y0 Z5\nG81 X1 Y1 Z-2 R1 F100\nX5\nX9 Y3\nG80\nM2\n", "3 drilling cycle(s)"),
    ("G21 G90\nG0 X0 Y0\nG93 G1 X10 F2\nM2\n", "1 feed move(s) in G93/G95"),
    # G92 X5 places X (issue 40); a change to G55, whose offsets the machine holds, does not
    ("G21 G90\nG0 X0 Y0\nG55\nG1 X10 F100\nM2\n", "1 move(s) from a position the offsets"),
])
def test_nothing_to_advise_is_written_back_byte_identical(tmp_path, capsys, text, why):
    """A program with no cut to advise (only rapids, rotary moves, drilling cycles, G93 moves,
    moves from unknown positions) is written back byte for byte, with one notice and exit 0."""
    program = tmp_path / "prog.ngc"
    program.write_bytes(text.encode("latin-1"))
    code, out_csv, out_ngc = run(tmp_path, program)
    err = capsys.readouterr().err
    assert code == 0
    assert out_ngc.read_bytes() == program.read_bytes()
    assert err.count("\n") == 1 and err.startswith("fuzzyfeed: notice: ") and why in err, err
    assert "nothing to advise" in err and "written back unchanged" in err
    assert out_csv.read_text().splitlines() == [",".join(ADVICE_COLUMNS)]


def test_pass_through_header_is_the_advice_header(tmp_path, capsys):
    """The header written for a program with nothing to advise is the one an advised program gets."""
    code, out_csv, _ = run(tmp_path, write(tmp_path, PROGRAM))
    assert code == 0
    assert out_csv.read_text().splitlines()[0] == ",".join(ADVICE_COLUMNS)


def test_a_program_without_units_is_read_in_mm_and_says_so(tmp_path, capsys):
    # LinuxCNC starts in the machine's units (an inch machine reads this 25.4 x larger): no silent guess
    prog = tmp_path / "nounits.ngc"
    prog.write_text("G90\nG0 X0 Y0 Z1\nG1 Z0 F100\nG1 X10\nG1 Y10\nM2\n")
    assert main(["advise", str(prog), "-o", str(tmp_path / "a.csv")]) == 0
    err = capsys.readouterr().err
    assert err.startswith("fuzzyfeed: notice: ") and "nounits.ngc:2: no G20/G21 before the first move: read in mm" in err
    prog.write_text("G21 G90\nG0 X0 Y0 Z1\nG1 Z0 F100\nG1 X10\nG1 Y10\nM2\n")
    assert main(["advise", str(prog), "-o", str(tmp_path / "b.csv")]) == 0
    assert "G20/G21" not in capsys.readouterr().err
