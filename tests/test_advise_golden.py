"""``fuzzyfeed advise`` byte for byte on a fixed set of inputs (issue 39): the advice pipeline moved
out of the command line must not change one byte the command writes or prints.

The golden file (``tests/golden/advise_outputs.json``) was recorded from the command as it was
before the move (commit 18c4c45): per case the exit code, stdout and stderr in full, and the SHA-256
and size of every file written (the CSV, its metadata sidecar, the program, the value report).
Paths of this checkout and of the test's folder are replaced by ``<repo>`` and ``<out>`` first, and
the value report's inline PNG by a placeholder (matplotlib's bytes are not ours); the plots are
checked to be PNG files. Record again (only when a change of output is intended and said so in the
commit) with ``FUZZYFEED_RECORD_GOLDEN=1 pytest tests/test_advise_golden.py``.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from pathlib import Path

import pytest

from fuzzyfeed.cli import main

REPO = Path(__file__).resolve().parents[1]
LIB = REPO / "benchmarks" / "library"
GOLDEN = REPO / "tests" / "golden" / "advise_outputs.json"
RECORD = os.environ.get("FUZZYFEED_RECORD_GOLDEN") == "1"

ARCS = LIB / "programs" / "dxf2gcode" / "IFluegel Rippen b2 0201 a.ngc"       # G2/G3, G41 without D
INCH = LIB / "programs" / "cncjs" / "helical-thread-milling.gcode"            # G20, helices
SPLINES = LIB / "programs" / "linuxcnc" / "butterfly-xy.ngc"                  # G5 cubic splines
DRAWING = LIB / "drawings" / "dxf-parser" / "arcs-as-splines.dxf"             # 3 contours, no $INSUNITS
NO_CUT = "G21 G90\nG0 X10 Y10\nG0 Z5\nM2\n"                                  # written in the test's folder

#: name -> the command's arguments (``{out}`` is the test's folder, ``{nocut}`` the program with no cut).
CASES = {
    "program_arcs": [ARCS, "-o", "a.csv", "--gcode", "a.ngc", "--feed-step-mm-min", "50"],
    "program_arcs_cut2": [f"{ARCS}#2", "-o", "a.csv", "--gcode", "a.ngc", "--step-mm", "0.5"],
    "program_inch_cap": [INCH, "-o", "h.csv", "--gcode", "h.ngc", "--feed-mm-min", "300", "--filter", "mean"],
    "program_inch_machine": [INCH, "-o", "h.csv", "--gcode", "h.ngc", "--machine", "reference",
                             "--report", "h.report.csv", "--plot", "h.png"],
    "program_inch_machine_html": [INCH, "-o", "h.csv", "--machine", "reference", "--report", "h.html",
                                  "--feed-step-mm-min", "20"],
    "program_splines_flags_machine": [SPLINES, "-o", "b.csv", "--gcode", "b.ngc", "--contour-tol-um", "20",
                                      "--servo-kv-1-s", "40", "--no-reference", "--report", "b.csv.report.csv"],
    "program_no_cut": ["{nocut}", "-o", "n.csv", "--gcode", "n.ngc"],
    "drawing_paths": [DRAWING, "-o", "d.csv", "--points", "300"],
    "drawing_one_path": [f"{DRAWING}#path=2", "-o", "d.csv", "--gcode", "d.ngc", "--units", "inch",
                         "--points", "400"],
    "drawing_machine": [DRAWING, "-o", "d.csv", "--points", "200", "--machine", "hobby-router"],
    "shape": ["trident", "-o", "t.csv", "--gcode", "t.ngc", "--gcode-g52", "t52.ngc", "--points", "600",
              "--rule-strengths", "--plot", "t.png"],
    "shape_options": ["wm", "-o", "w.csv", "--gcode", "w.ngc", "--filter", "min-mean", "--window-mm", "5",
                      "--filter-mm", "3", "--feed-mm-min", "3000", "--feed-step-mm-min", "100",
                      "--line-numbers", "--safe-z-mm", "10", "--gcode-decimals", "3", "--points", "500"],
    "shape_machine": ["butterfly", "-o", "m.csv", "--gcode", "m.ngc", "--machine", "reference",
                      "--points", "500", "--rules", "machine-tuned"],
    # refusals: one line, exit 2, nothing written
    "refuse_points_on_program": [INCH, "-o", "x.csv", "--points", "500"],
    "refuse_report_without_machine": [INCH, "-o", "x.csv", "--report", "r.html"],
    "refuse_report_on_shape": ["trident", "-o", "x.csv", "--report", "r.html", "--machine", "reference"],
    "refuse_units_on_program": [INCH, "-o", "x.csv", "--units", "inch"],
    "refuse_gcode_on_paths": [DRAWING, "-o", "x.csv", "--gcode", "x.ngc"],
    "refuse_feed": ["trident", "-o", "x.csv", "--feed-mm-min", "-5"],
    "refuse_machine_rules": ["trident", "-o", "x.csv", "--rules", "machine"],
    "refuse_step_on_shape": ["trident", "-o", "x.csv", "--step-mm", "0.5"],
    "refuse_g52_on_program": [INCH, "-o", "x.csv", "--gcode-g52", "x.ngc"],
    "refuse_line_numbers_on_program": [INCH, "-o", "x.csv", "--gcode", "x.ngc", "--line-numbers"],
    "refuse_same_outputs": ["trident", "-o", "x.csv", "--gcode", "x.csv"],
    "refuse_step_without_gcode": ["trident", "-o", "x.csv", "--feed-step-mm-min", "10"],
    "refuse_tool_table_on_shape": ["trident", "-o", "x.csv", "--tool-table", "tools.tbl"],
    "refuse_no_reference_on_drawing": [DRAWING, "-o", "x.csv", "--no-reference", "--machine", "reference"],
}

_PNG = re.compile(rb'src="data:image/png;base64,[A-Za-z0-9+/=]+"')


def normalise(data: bytes, out: Path) -> bytes:
    data = data.replace(str(out).encode(), b"<out>").replace(str(REPO).encode(), b"<repo>")
    return _PNG.sub(b'src="data:image/png;base64,<png>"', data)


def run_case(name: str, tmp_path: Path, capsys) -> dict:
    (tmp_path / "nocut.ngc").write_text(NO_CUT)
    (tmp_path / "tools.tbl").write_text("T1 P1 D6.0 Z0\n")
    argv = ["advise", *(str(a).replace("{nocut}", str(tmp_path / "nocut.ngc")) for a in CASES[name])]
    before = set(os.listdir(tmp_path))
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        code = main(argv)
    finally:
        os.chdir(cwd)
    captured = capsys.readouterr()
    files = {}
    for file in sorted(set(os.listdir(tmp_path)) - before):
        data = (tmp_path / file).read_bytes()
        if file.endswith(".png"):
            assert data.startswith(b"\x89PNG"), file
            files[file] = "png"
            continue
        data = normalise(data, tmp_path)
        files[file] = f"{hashlib.sha256(data).hexdigest()} {len(data)}"
    return {"code": code, "stdout": normalise(captured.out.encode(), tmp_path).decode(),
            "stderr": normalise(captured.err.encode(), tmp_path).decode(), "files": files}


def _golden() -> dict:
    return json.loads(GOLDEN.read_text()) if GOLDEN.exists() else {}


@pytest.mark.parametrize("name", sorted(CASES))
def test_advise_outputs_are_byte_identical(name, tmp_path, capsys):
    got = run_case(name, tmp_path, capsys)
    if RECORD:
        golden = _golden()
        golden[name] = got
        GOLDEN.write_text(json.dumps(dict(sorted(golden.items())), indent=1, ensure_ascii=False) + "\n")
        return
    want = _golden().get(name)
    assert want is not None, f"{name}: no golden record; record it with FUZZYFEED_RECORD_GOLDEN=1"
    assert got["code"] == want["code"]
    assert got["stderr"] == want["stderr"]
    assert got["stdout"] == want["stdout"]
    assert got["files"] == want["files"]
    if name.startswith("refuse_"):
        assert got["code"] == 2 and not got["files"] and got["stderr"].count("\n") == 1


def test_the_golden_set_covers_what_issue_39_names():
    """Programs (arcs, inch, splines, no cut), a drawing, a shipped shape; with and without a
    machine; --gcode, -o CSV, --report: all recorded, each case recorded once."""
    golden = _golden()
    assert set(golden) == set(CASES)
    written = [f for case in golden.values() for f in case["files"]]
    assert any(f.endswith(".ngc") for f in written) and any(f.endswith(".report.csv") for f in written)
    assert any(f.endswith(".html") for f in written) and any(f.endswith("-metadata.json") for f in written)
