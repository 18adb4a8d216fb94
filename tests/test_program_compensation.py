"""Cutter radius compensation (G41/G42) against LinuxCNC's interpreter: random contours in G17 and
G18 of lines and arcs (convex and concave corners, arcs inside and outside, arc and line entries, R and IJK
arcs, rapids and Z moves under compensation, both sides, a negative diameter) are compensated by
rs274 and by fuzzyfeed's reader; both refuse the same programs (a gouge, an entry shorter than
the radius) and give the same tool-centre moves on the others: every end point and arc centre
within 1 µm, the same kinds and directions, the corner arcs at the same place."""

from __future__ import annotations

import math
import os
import random
import re
import subprocess

import numpy as np
import pytest

from fuzzyfeed.cli import main
from fuzzyfeed.errors import PathFormatError
from fuzzyfeed.program.model import ARC, LINE, RAPID
from fuzzyfeed.program.read import parse_program
from fuzzyfeed.program.tools import read_tool_table
from test_gcode_export import rs274_binary

_CALL = re.compile(r"^\s*\d+\s+N\S*\s+(STRAIGHT_TRAVERSE|STRAIGHT_FEED|ARC_FEED)\((.*)\)\s*$")
#: rs274 (stand-alone) reads tool-table diameters in inches.
TABLE = "T1 P1 D0.25 Z0 ;quarter inch\nT2 P2 D0.05\nT3 P3 D-0.1\n"
KINDS = {"STRAIGHT_TRAVERSE": RAPID, "STRAIGHT_FEED": LINE, "ARC_FEED": ARC}


def rs274_moves(text: str, folder) -> tuple[list | None, str]:
    folder.mkdir()
    (folder / "t.ngc").write_text(text)
    (folder / "t.tbl").write_text(TABLE)
    done = subprocess.run([rs274_binary(), "-t", "t.tbl", "-g", "t.ngc", "t.out"], cwd=folder,
                          capture_output=True, text=True, stdin=subprocess.DEVNULL, timeout=60,
                          env={**os.environ, "HOME": str(folder)})
    if done.returncode:
        said = [ln for ln in done.stdout.splitlines() if ln.strip() and ln.strip() != "executing"]
        return None, said[0] if said else ""
    moves = []
    for line in (folder / "t.out").read_text().splitlines():
        m = _CALL.match(line)
        if m:
            moves.append((m.group(1), [float(v) for v in m.group(2).split(",")]))
    return moves, ""


def random_contour(rng: random.Random) -> str:
    """A contour in G17, or in G18 (a quarter of them: the same words on Z and X, I and K)."""
    text = _random_xy_contour(rng)
    if rng.random() < 0.25:
        swap = {"X": "Z", "Y": "X", "Z": "Y", "I": "K", "J": "I"}
        text = re.sub(r"(?<![A-Z])([XYZIJ])(?=[-.\d])", lambda m: swap[m.group(1)], text)
        text = text.replace("G17", "G18")
    return text


def _random_xy_contour(rng: random.Random) -> str:
    side = rng.choice(["G41", "G42"])
    tool = rng.choice(["T1 M6", "T2 M6", "T3 M6"])
    n = rng.randint(3, 8)
    angles = sorted(rng.uniform(0, 2 * math.pi) for _ in range(n))
    pts = [(round(20 * math.cos(a) * rng.uniform(0.5, 1.5), 3), round(20 * math.sin(a) * rng.uniform(0.5, 1.5), 3))
           for a in angles]
    start = (pts[0][0] + rng.uniform(-40, 40), pts[0][1] + rng.uniform(-40, 40))
    out = ["G21 G90 G17 F300", tool, f"G0 X{start[0]:.3f} Y{start[1]:.3f} Z5",
           side + (f" D{rng.choice([1, 2])}" if rng.random() < 0.3 else "")]

    def arc(p, q, word):
        mx, my = (p[0] + q[0]) / 2, (p[1] + q[1]) / 2
        dx, dy = q[0] - p[0], q[1] - p[1]
        length = math.hypot(dx, dy)
        h = rng.uniform(-1.5, 1.5) * length
        cx, cy = mx - dy / length * h, my + dx / length * h
        g = rng.choice(["G2", "G3"])
        if word == "R":
            r = math.hypot(cx - p[0], cy - p[1])
            sign = 1 if (g == "G3") == (dx * (cy - p[1]) - dy * (cx - p[0]) > 0) else -1
            return f"{g} X{q[0]} Y{q[1]} R{sign * r:.4f}"
        return f"{g} X{q[0]} Y{q[1]} I{cx - p[0]:.4f} J{cy - p[1]:.4f}"

    if rng.random() < 0.2:
        out.append(arc(start, pts[0], "IJ"))          # an arc as the entry move
    else:
        out.append(f"{rng.choice(['G1', 'G0'])} X{pts[0][0]} Y{pts[0][1]}")
    out.append("G1 Z-1")                              # no XY motion: queued, moved with the corner
    for k in range(1, n + 1):
        p, q = pts[k - 1], pts[k % n]
        roll = rng.random()
        if roll < 0.3:
            out.append(arc(p, q, "IJ" if rng.random() < 0.6 else "R"))
        elif roll < 0.37:
            out.append(f"G0 X{q[0]} Y{q[1]}")
        else:
            out.append(f"G1 X{q[0]} Y{q[1]}")
    out += ["G0 Z5", "G40 G0 X0 Y0", "M2"]
    return "\n".join(out) + "\n"


def test_random_contours_equal_rs274(tmp_path):
    rng = random.Random(41)
    tools = read_tool_table_text(tmp_path)
    accepted = refused = 0
    for k in range(90):
        text = random_contour(rng)
        theirs, why = rs274_moves(text, tmp_path / str(k))
        try:
            ours = parse_program(text, "t.ngc", tools)
        except PathFormatError as exc:
            assert theirs is None, f"program {k}: rs274 accepts, fuzzyfeed refuses ({exc})\n{text}"
            refused += 1
            continue
        assert theirs is not None, f"program {k}: rs274 refuses ({why}), fuzzyfeed accepts\n{text}"
        accepted += 1
        assert ours.kind.size == len(theirs), f"program {k}\n{text}"
        xz = "G18" in text
        for j, (call, nums) in enumerate(theirs):
            end = nums[:3]
            if call == "ARC_FEED":     # first, second plane axis, centre, turn, normal axis
                end = [nums[1], nums[5], nums[0]] if xz else [nums[0], nums[1], nums[5]]
                centre = ours.centre[j, [2, 0]] if xz else ours.centre[j, :2]
                np.testing.assert_allclose(centre, nums[2:4], atol=1e-3)
                assert np.sign(ours.turns[j]) == np.sign(nums[4])
            assert ours.kind[j] == KINDS[call], (k, j, call)
            np.testing.assert_allclose(ours.end[j], end, atol=1e-3, err_msg=f"program {k} move {j}\n{text}")
    assert accepted >= 30 and refused >= 10, (accepted, refused)


def read_tool_table_text(folder):
    path = folder / "tools.tbl"
    path.write_text(TABLE)
    return read_tool_table(path, "inch")


def test_square_pocket_closed_form(tmp_path):
    """G41 around a 10 mm square, counter-clockwise (the tool inside): inside corners cut back
    by the radius, a corner arc of the radius at the entry's convex corner."""
    text = "G21 G90 F100\nG0 X-10 Y-10\nG41.1 D2.54\nG1 X0 Y0\nG1 X10\nG1 Y10\nG1 X0\nG1 Y0\nG40 G1 X-10 Y-10\nM2\n"
    program = parse_program(text, "sq.ngc")
    r = 1.27
    np.testing.assert_allclose(program.end[3:7, :2], [[10 - r, r], [10 - r, 10 - r], [r, 10 - r], [r, 0]], atol=1e-12)
    assert program.kind[2] == ARC and program.move_line[2] == program.move_line[3] == 4
    assert program.no_split[1:7].all()


def test_without_a_diameter_the_contour_is_advised_with_a_notice(tmp_path, capsys):
    program = tmp_path / "p.ngc"
    program.write_text("G21 G90 F300\nT1 M6\nG0 X-10 Y-10\nG41\nG1 X0 Y0\nG1 X10\nG1 Y10\nG40 G0 X-10 Y-10\nM2\n")
    code = main(["advise", str(program), "-o", str(tmp_path / "a.csv"), "--gcode", str(tmp_path / "a.ngc")])
    err = capsys.readouterr().err
    assert code == 0
    assert err.count("\n") == 1 and "notice" in err and "no tool diameter" in err and "p.ngc:4" in err


def test_round_trip_with_a_tool_table_advises_the_tool_centre(tmp_path, capsys):
    """The advised program, run by rs274 with the same table, makes the same moves (only feeds
    change; a corner arc runs at the F of its line) and is slower where the tool path turns."""
    from canon import _CALL as CALL, compare

    def calls(path, folder):
        folder.mkdir()
        done = subprocess.run([rs274_binary(), "-t", str(table), "-g", str(path), "c.out"], cwd=folder,
                              capture_output=True, text=True, stdin=subprocess.DEVNULL, timeout=60,
                              env={**os.environ, "HOME": str(folder)})
        assert done.returncode == 0, done.stdout[-300:]
        return [(m.group(1), m.group(2)) for m in map(CALL.match, (folder / "c.out").read_text().splitlines()) if m]

    program = tmp_path / "p.ngc"
    program.write_text("G21 G90 G17 F600\nT1 M6\nG0 X-20 Y-20 Z5\nG41\nG1 X0 Y0\nG1 Z-1\nG1 X30\n"
                       "G3 X30 Y20 R10\nG1 X0\nG1 Y0\nG0 Z5\nG40 G0 X-20 Y-20\nM2\n")
    table = tmp_path / "tools.tbl"
    table.write_text("".join(f"T{t} P{t} Z{0.5 + 0.1 * t:.3f} D{0.25 if t == 1 else 0.1} ;\n" for t in range(1, 21)))
    out = tmp_path / "a.ngc"
    assert main(["advise", str(program), "-o", str(tmp_path / "a.csv"), "--gcode", str(out),
                 "--tool-table", str(table), "--tool-units", "inch"]) == 0
    result = compare(calls(program, tmp_path / "a"), calls(out, tmp_path / "b"))
    assert result.min_ratio < 0.5


@pytest.mark.parametrize("text, rule", [
    ("G21 F100\nG0 X0 Y0\nG41.1 D4\nG1 X1 Y0\n", "entry move is not longer than the tool radius"),
    ("G21 F100\nG0 X0 Y0\nG41.1\nG1 X10 Y0\n", "G41.1 with no D word"),
    ("G21 F100\nG19\nG0 X0 Y0\nG41.1 D1\nG1 Y10\n", "G17 \\(XY\\) and G18 \\(XZ\\) only"),
    ("G21 F100\nG0 X0 Y0\nG41.1 D1\nG1 X10\nG42.1 D1\nG1 Y10\n", "while cutter compensation is on"),
    ("G21 F100\nG0 X-10 Y-10\nG41.1 D2\nG1 X0 Y0\nG1 X10\nG81 X5 Y5 Z-1 R1\n", "only G0, G1, G2 and G3"),
    ("G21 F100\nG0 X-10 Y0\nG41.1 D6\nG1 X0 Y0\nG1 X10 Y0\nG1 X10 Y2\nG1 X20 Y2\n", "without gouging"),
])
def test_compensation_refusals_one_line(text, rule):
    with pytest.raises(PathFormatError, match=rule) as info:
        parse_program(text, "c.ngc")
    assert "\n" not in str(info.value)


def test_tool_table_errors_name_file_and_line(tmp_path):
    path = tmp_path / "t.tbl"
    for text, rule in (("T1 P1 D6\nP2 D3\n", ":2: no T word"), ("T1 D6\nT1 D4\n", ":2: tool T1 is given twice"),
                       ("T1 D6 Q1 K5\n", ":1: K is not a tool table word"), ("T1 Dx\n", ":1: ")):
        path.write_text(text)
        with pytest.raises(PathFormatError, match=rule):
            read_tool_table(path)
    path.write_text("; header\nT1 P1 D6.0 Z0.5 ;end mill\n\nT7 P3 D0.5\n")
    assert read_tool_table(path) == {1: 6.0, 7: 0.5}
    assert read_tool_table(path, "inch") == {1: 6.0 * 25.4, 7: 0.5 * 25.4}
