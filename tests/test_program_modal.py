"""The modal-group rules of the program reader, judged by LinuxCNC's own interpreter: every safety
line of tests/programs/safety_lines.py (the first lines CAM posts write, and every pairing of G0/G1/G80
with the codes a safety line combines them with) is read by rs274 and by fuzzyfeed; both accept it
or both refuse it."""

from __future__ import annotations

import concurrent.futures
import os
import subprocess
import sys
from pathlib import Path

import pytest

from fuzzyfeed.errors import PathFormatError
from fuzzyfeed.program.read import parse_program
from test_gcode_export import rs274_binary

sys.path.insert(0, str(Path(__file__).parent / "programs"))
from safety_lines import safety_lines  # noqa: E402

LINES = safety_lines()


def _program(line: str) -> str:
    return f"T1 M6\n{line}\nG0 X0 Y0\nG1 X10 Y5 F100\nM2\n"


def _rs274_accepts(binary: str, text: str, folder: Path) -> tuple[bool, str]:
    folder.mkdir()
    (folder / "t.ngc").write_text(text)
    (folder / "tools.tbl").write_text("".join(f"T{t} P{t} Z0.5 D6\n" for t in range(1, 5)))
    done = subprocess.run([binary, "-t", "tools.tbl", "-g", "t.ngc", "t.out"], capture_output=True,
                          text=True, stdin=subprocess.DEVNULL, cwd=folder, timeout=60,
                          env={**os.environ, "HOME": str(folder)})
    said = [ln for ln in done.stdout.splitlines() if ln.strip() and ln.strip() != "executing"]
    return done.returncode == 0, (said[0] if said else "")


def _fuzzyfeed_accepts(text: str) -> tuple[bool, str]:
    try:
        parse_program(text, "t.ngc")
    except PathFormatError as exc:
        return False, str(exc)
    return True, ""


def test_corpus_covers_the_issue_line_and_both_verdicts():
    assert "G00 G17 G21 G40 G49 G80 G90" in LINES and len(LINES) >= 200


def test_every_safety_line_gets_rs274s_verdict(tmp_path):
    binary = rs274_binary()
    with concurrent.futures.ThreadPoolExecutor(max_workers=4) as pool:
        verdicts = list(pool.map(lambda k: _rs274_accepts(binary, _program(LINES[k]), tmp_path / str(k)),
                                 range(len(LINES))))
    disagree = []
    for line, (rs_ok, rs_msg) in zip(LINES, verdicts):
        ff_ok, ff_msg = _fuzzyfeed_accepts(_program(line))
        if ff_ok != rs_ok:
            disagree.append(f"{line!r}: rs274 {'accepts' if rs_ok else 'refuses (' + rs_msg + ')'}, "
                            f"fuzzyfeed {'accepts' if ff_ok else 'refuses (' + ff_msg + ')'}")
    accepted = sum(ok for ok, _ in verdicts)
    assert 0.3 * len(LINES) < accepted < 0.9 * len(LINES)     # both verdicts are exercised
    assert not disagree, "\n".join(disagree)


@pytest.mark.parametrize("line, words", [
    ("G0 G80 X1", "G0"), ("G80 G1 X1 F100", "G1"), ("G80 G80 G0 X1", "G0"),
])
def test_g80_gives_way_to_the_other_motion_code(line, words):
    program = parse_program(f"G0 X0 Y0\n{line}\nM2\n", "t.ngc")
    assert program.kind[-1] == (0 if words == "G0" else 1)
    assert program.end[-1, 0] == 1.0


def test_refusals_name_the_rule():
    for text, rule in (("G0 G28 X0\n", "two G codes that both use the axis words"),
                       ("G80 X1\n", "axis words with G80 in force"),
                       ("G0 G1 X1\n", "two G codes of one modal group on one line: G0 and G1"),
                       ("G53 X1\n", "G53 needs G0 or G1"),
                       ("F10\nG94\nG1 X1\n", "G1 with no F in force")):
        with pytest.raises(PathFormatError, match=rule):
            parse_program(text, "t.ngc")
