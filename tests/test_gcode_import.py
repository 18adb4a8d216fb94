"""G-code import: G0/G1 chains with G90/G91 and G20/G21, G5.2 blocks, several paths and the
selector, three-point curvature on imported polylines, and one clear line for bad input."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzyfeed.cli import main
from fuzzyfeed.errors import PathFormatError, ShapeFileError
from fuzzyfeed.io.gcode import write_gcode, write_gcode_nurbs
from fuzzyfeed.io.shapes import load_shape, load_shapes, sample_shape
from fuzzyfeed.machine.profile import FeedProfile
from fuzzyfeed.geometry.sampling import sample_uniform_u


def write(tmp_path, text, name="prog.ngc"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_exported_program_imports_back_to_the_written_points(tmp_path):
    samples = sample_uniform_u(load_shape("infinity").curve, 2000)
    profile = FeedProfile(samples, np.full(2000, 40.0), "constant", 50.0)
    program = write_gcode(tmp_path / "inf.ngc", profile, line_numbers=True, decimals=7)
    shape = load_shape(str(tmp_path / "inf.ngc"))
    expected = np.vstack([program.start_mm, program.points_mm])
    np.testing.assert_array_equal(shape.polyline, expected)
    np.testing.assert_allclose(shape.polyline, samples.xyz, atol=0.5e-7 + 1e-12)
    # the planners' samples: the vertices with the three-point curvature, close to the NURBS κ
    imported = sample_shape(shape)
    assert len(imported) == 2000
    inner = slice(5, -5)
    rel = np.abs(imported.curvature[inner] - samples.curvature[inner]) / samples.curvature.max()
    assert np.max(rel) < 0.02
    assert imported.length == pytest.approx(samples.length, rel=1e-4)


def test_three_point_curvature_of_an_imported_circle(tmp_path):
    t = np.linspace(0, 1.5 * np.pi, 300)
    lines = ["G21 G90 G17", f"G0 X{10 * np.cos(t[0]):.10f} Y{10 * np.sin(t[0]):.10f}", "G1 F600"]
    lines += [f"X{10 * np.cos(a):.10f} Y{10 * np.sin(a):.10f}" for a in t[1:]]  # modal G1
    lines.append("M2")
    shape = load_shape(str(write(tmp_path, "\n".join(lines) + "\n")))
    assert shape.polyline.shape == (300, 2)
    np.testing.assert_allclose(sample_shape(shape).curvature, 0.1, rtol=1e-4)


def test_incremental_and_inch_units(tmp_path):
    text = """%
(test: inch, incremental)
G20 G91 G17 G94
G0 X1 Y1          ; rapid to (25.4, 25.4)
G1 X1 F10         ; +1 in
Y1
X-0.5 Y0.5 Z-0.1
G21               ; switch to mm, still incremental
X10
G90 X0 Y0
M30
%
"""
    shape = load_shape(str(write(tmp_path, text)))
    # the program starts wherever the machine is: its G91 moves are placed relative to that point,
    # and the G90 move to (0, 0) from it is not (its length depends on where the machine started)
    expected = np.array([[25.4, 25.4, 0], [50.8, 25.4, 0], [50.8, 50.8, 0], [38.1, 63.5, -2.54],
                         [48.1, 63.5, -2.54]])
    np.testing.assert_allclose(shape.polyline, expected, atol=1e-12)
    assert shape.curve.degree == 1 and shape.curve.knots[1] == 0 and shape.curve.knots[-2] == 1


def test_rapids_split_paths_and_selector(tmp_path):
    text = """G21 G90
G0 X0 Y0
G1 X10 Y0 F100
G1 X10 Y10
G1 X0 Y10
G0 Z5
G0 X50 Y50
G0 Z0
G1 X60 Y50
G1 X60 Y60
G1 X70 Y65
M2
"""
    path = write(tmp_path, text)
    with pytest.raises(PathFormatError, match=r"prog\.ngc: 2 paths \(1 \(line 3\), 2 \(line 9\)\); pick one"):
        load_shape(str(path))
    shapes = load_shapes(str(path))
    assert [s.name for s in shapes] == ["prog#1", "prog#2"]
    second = load_shape(f"{path}#2")
    np.testing.assert_array_equal(second.polyline[0], [50, 50, 0])
    assert load_shape(f"{path}#path=1").polyline.shape == (4, 3)
    with pytest.raises(PathFormatError, match="path 3 does not exist"):
        load_shape(f"{path}#3")
    with pytest.raises(PathFormatError, match="selector must be N or path=N"):
        load_shape(f"{path}#layer=0")


def test_g52_block_imports_as_exact_nurbs_and_mixed_chain_as_polyline(tmp_path):
    curve = load_shape("trident2").curve
    write_gcode_nurbs(tmp_path / "t2.ngc", curve, 600.0)
    back = load_shape(str(tmp_path / "t2.ngc"))
    assert back.polyline is None and back.curve.degree == 2
    np.testing.assert_array_equal(back.curve.knots, curve.knots)
    np.testing.assert_array_equal(back.curve.weights, curve.weights)
    u = np.linspace(0, 1, 1001)
    np.testing.assert_allclose(back.curve(u)[:, :curve.dim], curve(u), atol=1e-9)

    mixed = """G21 G90
G0 X0 Y0
G1 X-1 Y0 F100
G1 X0 Y0
G5.2 L3
X1 Y2 P1
X2 Y0 P2
X3 Y1 P1
G5.3
G1 X4 Y1
M2
"""
    shape = load_shape(str(write(tmp_path, mixed, "mixed.ngc")))
    assert shape.polyline is not None and "G5.2 block(s) sampled" in shape.notes
    assert shape.polyline.shape[1] == 2
    np.testing.assert_array_equal(shape.polyline[[0, 1, 2]], [[0, 0], [-1, 0], [0, 0]])
    np.testing.assert_allclose(shape.polyline[-2:], [[3, 1], [4, 1]])
    # the sampled block's points lie on LinuxCNC's uniform clamped NURBS (order 3, 4 points)
    from fuzzyfeed.io.gcode import linuxcnc_knots
    from fuzzyfeed.geometry.nurbs import Nurbs
    ref = Nurbs(2, linuxcnc_knots(4, 3), [[0, 0], [1, 2], [2, 0], [3, 1]], [1, 1, 2, 1])
    block = shape.polyline[3:-1]
    assert len(block) == 2 * 32
    np.testing.assert_allclose(block, ref(np.linspace(0, 1, 65)[1:]), atol=1e-12)


def test_first_weight_from_g52_line_without_xy(tmp_path):
    text = "G21 G90\nG0 X0 Y0\nG5.2 P2.5 L4 F100\nX1 Y1 P1\nX2 Y1 P1\nX3 Y0 P1\nG5.3\nM2\n"
    curve = load_shape(str(write(tmp_path, text))).curve
    assert curve.degree == 3
    np.testing.assert_array_equal(curve.weights, [2.5, 1, 1, 1])


def test_ignored_words_do_not_change_the_path(tmp_path):
    text = """N10 G17 G21 G90 G40 G49 G54 G64 P0.01 G80 G94
N20 T1 M6
N30 S12000 M3 M8
N40 G0 X0 Y0
N50 G1 X1 Y0 F300 (cut)
N60 G4 P0.5
N70 G1 X2 Y1
N80 G1 X3 Y1 ; done
N90 M5 M9
N100 M2
G1 X99 Y99 (after program end: not read)
"""
    shape = load_shape(str(write(tmp_path, text)))
    np.testing.assert_array_equal(shape.polyline, [[0, 0], [1, 0], [2, 1], [3, 1]])


@pytest.mark.parametrize("text, message", [
    ("G21\nG1 X1 Y1 F100\nG1 X1..2\n", r"prog\.ngc:3: malformed word at 'X1\.\.2'"),
    ("G21\nG1 X1 Y1 F100\nG1 X\n", r"prog\.ngc:3: malformed word at 'X'"),
    ("G21\nG1 Xnan Y1 F100\n", r"prog\.ngc:2: malformed word at 'XNAN"),
    ("G21\nG1 X1 Y1 F100\nG2 X3 Y1 I0.5 J0\n", r"prog\.ngc:3: G2: radius to the end 1\.5 differs from radius to the start 0\.5 by 1 \(LinuxCNC allows 0\.02"),
    ("G21\nG1 X1 Y1 F100\nG3 X5 Y2 R1\n", r"prog\.ngc:3: G3 R1: radius 1 is shorter than half the chord"),
    ("G21\nG2 X2 Y2 F100\n", r"prog\.ngc:2: G2 needs I/J \(centre\) or R \(radius\)"),
    ("G21\nG2 X2 Y2 R1 I1 F100\n", r"prog\.ngc:2: G2 with both R and I/J"),
    ("G21\nG1 X2 Y2 I1 F10\n", r"prog\.ngc:2: I with G1: arc words belong to G2/G3"),
    ("G21\nG17 G2 X2 Y0 K1 I1 F100\n", r"prog\.ngc:2: K1 with G2 in the G17 plane: the centre words of this plane are I/J"),
    ("G21\nG5 X2 Y0 P1 Q1 F100\n", r"prog\.ngc:2: G5 without I and J must follow a G5"),
    ("G21\nG5.1 X2 Y0 F100\n", r"prog\.ngc:2: G5\.1 needs I and J"),
    ("G21\nG76 X2 Z-1 P1 I1 J1 K1\n", r"prog\.ngc:2: G76 \(threading cycle\) is not supported"),
    ("G21\nG18\nG2 X1 Z1 I1 J0 F10\n", r"prog\.ngc:3: J0 with G2 in the G18 plane: the centre words of this plane are K/I"),
    ("G21\nG92 X0\n", r"prog\.ngc: no feed move"),
    ("G21\nG1 X1 A90 F10\n", r"prog\.ngc: no feed move"),  # a rotary move is kept, not advised
    ("G21\nG41.1 X1\n", r"prog\.ngc:2: G41\.1 with no D word"),
    ("G21\nO100 sub\n", r"prog\.ngc:2: 'O100 sub' has no 'O100 endsub'"),
    ("G21\nG1 X#<nope> F10\n", r"prog\.ngc:2: named parameter #<nope> is not defined in 'G1 X#<nope> F10'"),
    ("G21\n#<holes> = [4 / [2 - 2]]\n", r"prog\.ngc:2: attempt to divide by zero in '#<holes> = \[4 / \[2 - 2\]\]'"),
    ("G21\nM98 P100\n", r"prog\.ngc:2: M98 P100: no 'O100' subroutine in this file"),
    ("G21\nG83 X1 Y1 Z-1 R1 Q1 F100\n", r"prog\.ngc: no feed move"),  # a drilling cycle is kept
    ("G21\nG1 X1 F10 (open comment\n", r"prog\.ngc:2: comment '\(' not closed"),
    ("G0 X0 Y0\nG5.2 L3\nX1 Y1 P1\nX2 Y0 P1\n", r"prog\.ngc:4: G5\.2 block from line 2 is not closed"),
    ("G0 X0 Y0\nG5.2 L4\nX1 Y1 P1\nG5.3\n", r"prog\.ngc:4: .*2 control points .* L = 4 needs at least 4"),
    ("G0 X0 Y0\nG5.2 L3\nX1 Y1\nG5.3\n", r"prog\.ngc:3: G5\.2 control point weight P = 0"),
    ("G0 X0 Y0\nG5.3\n", r"prog\.ngc:2: G5\.3 without an open G5\.2 block"),
    ("G21 G90\nG0 X1 Y1\nG0 X5\nM2\n", r"prog\.ngc: no feed move"),
    ("X1 Y1\n", r"prog\.ngc:1: axis words with no motion mode"),
    ("G21\nG1 X1 P2 P3\n", r"prog\.ngc:2: P given twice"),
])
def test_bad_gcode_one_clear_line(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(PathFormatError, match=message) as info:
        load_shape(str(path))
    assert "\n" not in str(info.value)


def test_binary_and_missing_files(tmp_path):
    binary = tmp_path / "blob.ngc"
    binary.write_bytes(b"G1 X1\x00\x01\x02\xff" * 10)
    with pytest.raises(PathFormatError, match=r"blob\.ngc: binary file; expected a G-code text file"):
        load_shape(str(binary))
    with pytest.raises(ShapeFileError, match="no such file"):
        load_shape(str(tmp_path / "missing.ngc"))


def test_cli_plot_takes_a_gcode_file_and_reports_errors(tmp_path, capsys):
    samples = sample_uniform_u(load_shape("trident").curve, 300)
    write_gcode(tmp_path / "t.ngc", FeedProfile(samples, np.full(300, 10.0), "c", 10.0))
    out = tmp_path / "t.png"
    assert main(["plot", str(tmp_path / "t.ngc"), "-o", str(out)]) == 0
    assert out.stat().st_size > 0
    bad = write(tmp_path, "G21\nG1 X1 Y1 F10\nG1 X1..2\n", "bad.ngc")
    assert main(["plot", str(bad), "-o", str(tmp_path / "bad.png")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("fuzzyfeed: error: ") and "bad.ngc:3:" in err[0]
    assert not (tmp_path / "bad.png").exists()


def test_arcs_ij_r_helical_and_full_circle_on_the_exact_arc(tmp_path):
    from fuzzyfeed.io.gcode import ARC_TOLERANCE_MM

    text = """G21 G90 G17
G0 X10 Y0 Z0
G3 X0 Y10 I-10 J0 F500      ; quarter turn CCW about the origin
G2 X-10 Y0 Z-1 R-10         ; CW with R < 0: the long way (270 degrees), helical down to Z-1
G3 X10 Y0 R10               ; half turn CCW (R > 0 takes the short way: exactly 180 degrees)
G2 I-10 J0                  ; full circle CW about the origin (no axis words)
M2
"""
    shape = load_shape(str(write(tmp_path, text)))
    pts = shape.polyline
    assert "arcs flattened" in shape.notes
    # every arc here lies on the circle of radius 10 about the origin
    np.testing.assert_allclose(np.linalg.norm(pts[:, :2], axis=1), 10.0, atol=1e-9)
    np.testing.assert_allclose(pts[-1], [10, 0, -1], atol=1e-12)
    # arc 1 stays in the first quadrant; chords within the tolerance of the arc, not needlessly fine
    end1 = int(np.argmax(np.all(np.isclose(pts[:, :2], [0, 10], atol=1e-12), axis=1)))
    first = pts[: end1 + 1]
    assert np.all(first[:, :2] >= -1e-12)
    sag = 10.0 - np.linalg.norm(0.5 * (first[1:, :2] + first[:-1, :2]), axis=1)
    assert 0.5 * ARC_TOLERANCE_MM < sag.max() <= ARC_TOLERANCE_MM
    # arc 2 goes clockwise from (0, 10) through (10, 0) and (0, -10) to (-10, 0), Z falling to -1
    end2 = end1 + 1 + int(np.argmax(np.all(np.isclose(pts[end1 + 1:, :2], [-10, 0], atol=1e-12), axis=1)))
    second = pts[end1: end2 + 1]
    assert second[:, 0].max() > 9.99 and second[:, 1].min() < -9.99
    np.testing.assert_allclose(second[[0, -1], 2], [0, -1])
    assert np.all(np.diff(second[:, 2]) < 0)
    angle = np.unwrap(np.arctan2(second[:, 1], second[:, 0]))
    assert angle[-1] - angle[0] == pytest.approx(-1.5 * np.pi)
    # the rest (half turn + full circle) is 540 degrees CCW then CW: total turning of the path
    kappa = sample_shape(shape).curvature
    assert np.median(kappa) == pytest.approx(0.1, rel=1e-3)


def test_arcs_read_as_linuxcnc_reads_them(tmp_path):
    """Centre, direction and turns of G2/G3 (I/J, R > 0, R < 0, P, helical) as rs274 reports
    them in ARC_FEED: every imported point lies on rs274's circle and sweeps its angle."""
    from test_gcode_export import rs274_binary

    import re
    import subprocess

    rs274 = rs274_binary()
    rng = np.random.default_rng(7)
    for case in range(14):
        start = rng.uniform(-50, 50, 2)
        radius = rng.uniform(0.5, 30)
        a0, a1 = rng.uniform(0, 2 * np.pi, 2)
        center = start - radius * np.array([np.cos(a0), np.sin(a0)])
        end = center + radius * np.array([np.cos(a1), np.sin(a1)])
        code = "G2" if case % 2 else "G3"
        if case % 3 == 0:
            words = f"R{(radius if case % 4 else -radius):.10f}"
        else:
            words = f"I{center[0] - start[0]:.10f} J{center[1] - start[1]:.10f}" + (" P2" if case % 5 == 1 else "")
        z = " Z-2.5" if case % 4 == 1 else ""
        text = (f"G21 G90 G17\nG0 X{start[0]:.10f} Y{start[1]:.10f} Z0\n"
                f"{code} X{end[0]:.10f} Y{end[1]:.10f}{z} {words} F300\nM2\n")
        path = write(tmp_path, text, f"arc{case}.ngc")
        out = tmp_path / f"arc{case}.canon"
        done = subprocess.run([rs274, "-g", str(path), str(out)], capture_output=True, text=True,
                              stdin=subprocess.DEVNULL, timeout=60)
        assert done.returncode == 0, done.stdout + done.stderr
        arc = re.search(r"ARC_FEED\(([^)]*)\)", out.read_text()).group(1).split(",")
        cx, cy, rotation = float(arc[2]), float(arc[3]), int(arc[4])
        pts = load_shape(str(path)).polyline
        r = np.linalg.norm(pts[:, :2] - [cx, cy], axis=1)
        np.testing.assert_allclose(r, r[0], atol=1.5e-4, err_msg=text)  # rs274 prints the centre to 4 decimals
        sweep = np.unwrap(np.arctan2(pts[:, 1] - cy, pts[:, 0] - cx))
        total = sweep[-1] - sweep[0]
        assert np.sign(total) == np.sign(rotation), text
        assert abs(total) > 2 * np.pi * (abs(rotation) - 1) and abs(total) <= 2 * np.pi * abs(rotation) + 1e-9, text


def test_incremental_inch_program_read_as_rs274_reads_it(tmp_path):
    """The G90/G91, G20/G21 program above through LinuxCNC: its STRAIGHT_* targets (in the units
    of the last USE_LENGTH_UNITS) equal the imported polyline."""
    import re
    import subprocess

    from test_gcode_export import rs274_binary

    text = "G20 G91 G17 G94\nG0 X1 Y1\nG1 X1 F10\nY1\nX-0.5 Y0.5 Z-0.1\nG21\nX10\nG90 X0 Y0\nG91 Y-3.25\nM30\n"
    path = write(tmp_path, text)
    out = tmp_path / "prog.canon"
    done = subprocess.run([rs274_binary(), "-g", str(path), str(out)], capture_output=True,
                          text=True, stdin=subprocess.DEVNULL, timeout=60)
    assert done.returncode == 0, done.stdout + done.stderr
    scale, targets = 1.0, []
    for line in out.read_text().splitlines():
        if "USE_LENGTH_UNITS" in line:
            scale = 25.4 if "INCHES" in line else 1.0
        m = re.search(r"STRAIGHT_(FEED|TRAVERSE)\(([^)]*)\)", line)
        if m:
            targets.append([float(v) * scale for v in m.group(2).split(",")[:3]])
    # the G90 move from the G91 moves made from the machine's (unknown) start point is not placed:
    # the path ends before it and a second one starts at its end (rs274 starts at 0)
    np.testing.assert_allclose(load_shape(f"{path}#path=1").polyline, targets[:5], atol=0.5e-4 * 25.4)
    second = sample_shape(load_shape(f"{path}#path=2"), 3).xyz
    np.testing.assert_allclose(second[[0, -1], :2], np.array(targets[5:7])[:, :2], atol=0.5e-4 * 25.4)


@pytest.mark.parametrize("short_mm", [0.00045, 0.0012, 0.0014, 0.003])
def test_r_arc_tolerance_is_linuxcncs(tmp_path, short_mm):
    """An R arc a little shorter than half its chord (a CAM post's rounded R: Fusion's R1.508 on a
    3.0169 mm chord) is read exactly when LinuxCNC's interpreter reads it (RADIUS_TOLERANCE_MM)."""
    import subprocess

    from test_gcode_export import rs274_binary

    half = 1.5
    prog = write(tmp_path, f"G21 G90 G17\nG0 X0 Y0\nG1 X0 Y0 F100\nG3 X{2 * half:.4f} Y0 R{half - short_mm:.5f}\n"
                           "G1 X4 Y0\nM2\n")
    run = subprocess.run([rs274_binary(), "-g", str(prog), str(tmp_path / "out.canon")], capture_output=True,
                         text=True, stdin=subprocess.DEVNULL, timeout=120)
    rs274_reads = "too small" not in (run.stdout + run.stderr) and "PROGRAM_END" in (tmp_path / "out.canon").read_text()
    try:
        shape = load_shape(str(prog))
    except PathFormatError as exc:
        assert not rs274_reads, exc
        assert "shorter than half the chord" in str(exc)
    else:
        assert rs274_reads
        assert shape.polyline[-1][0] == pytest.approx(4.0)
