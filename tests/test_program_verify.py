"""A rewritten program is never one the controller refuses (issue 40 item 5, issue 37 defect 2):
moves whose split LinuxCNC's compensation rules would refuse stay whole, and ``--verify-rs274``
reads every rewrite with rs274 and the same tool table — where it refuses or the moves differ, the
lines to blame keep their text and the report names them. Checked independently with
tests/canon.py on every library program rs274 accepts, with and without a tool table."""

from __future__ import annotations

import csv
import re
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from canon import canon, compare
from fuzzyfeed.cli import main
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.program.feeds import advise_program
from fuzzyfeed.program.read import read_program
from fuzzyfeed.program.rewrite import rewrite_program
from fuzzyfeed.program.tools import read_tool_table
from fuzzyfeed.program.verify import compare_moves, verified_rewrite
from fuzzyfeed.report.value import evaluate_program
from test_gcode_export import rs274_binary

HERE = Path(__file__).parent
LIBRARY = HERE.parent / "benchmarks" / "library"
GMOCCAPY = LIBRARY / "programs" / "linuxcnc" / "gmoccapy_2_tools_with_cutter_radius_compensation.ngc"
COMP = HERE / "programs" / "linuxcnc" / "comp.ngc"


def _table(tmp_path: Path, inch: float) -> Path:
    """A tool table for rs274 (inches): tools 1-999 of diameter ``inch``."""
    path = tmp_path / f"tools_{inch:g}.tbl"
    path.write_text("".join(f"T{t} P{t} D{inch:g} Z0 ;\n" for t in range(1, 1000)))
    return path


def _quiet_read(path, tools=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_program(path, tools=tools)


@pytest.mark.parametrize("path", [GMOCCAPY, COMP], ids=lambda p: p.stem[:9])
def test_compensation_without_a_tool_table_is_never_split(path, tmp_path, capsys):
    """Advised without a tool table (the programmed contour), run by rs274 with one of 0.3 inch:
    the G41/G42 entry moves and every move under compensation stay whole, so rs274 accepts the
    rewrite with the same moves (it refused it when the entry arc or line was split: "Radius of
    cutter compensation entry arc ..." / "Length of cutter compensation entry move ...")."""
    rs274_binary()
    out = tmp_path / "advised.ngc"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["advise", str(path), "-o", str(tmp_path / "a.csv"), "--gcode", str(out),
                     "--machine", "reference", "--no-reference"]) == 0
    table = _table(tmp_path, 0.3)
    result = compare(canon(path, tmp_path, table), canon(out, tmp_path, table))
    assert result.feed_moves > 0 and result.min_ratio < 1.0       # the advice did change feeds
    program = _quiet_read(path)
    advised = _quiet_read(out)
    assert program.comp_unknown.sum() > 0                           # nothing split under G41/G42
    assert advised.comp_unknown.sum() == program.comp_unknown.sum()


def test_verification_keeps_the_lines_rs274_refuses(tmp_path):
    """Without the rule above (comp_unknown dropped), the advice splits gmoccapy's G3 entry arcs;
    with a 0.3-inch tool rs274 refuses that. The verification finds the lines by bisection, they
    keep their text (only an F word may change), and rs274 accepts the result with the same moves."""
    rs274_binary()
    program = replace(_quiet_read(GMOCCAPY), comp_unknown=None)
    pa = advise_program(program, load_rule_table("machine"), machine=load_machine("reference"))
    tools_mm = {t: 0.3 * 25.4 for t in range(1, 1000)}
    plain = rewrite_program(program, pa.piece_move, pa.piece_end, pa.piece_feed_mm_min)
    text, check = verified_rewrite(program, pa.piece_move, pa.piece_end, pa.piece_feed_mm_min,
                                   rewrite=rewrite_program, tools_mm=tools_mm)
    assert check.status == "kept" and "entry arc is not greater than the tool radius" in check.message
    original = program.lines
    entry_arcs = [i + 1 for i, ln in enumerate(original) if ln.startswith("G3 X") and "Z-1" in ln]
    assert check.kept_lines and set(check.kept_lines) <= set(entry_arcs)    # those lines alone
    assert text != plain
    for li in check.kept_lines:                      # the line, unsplit, with at most its F changed
        assert re.sub(r"\s*F[\d.]+", "", original[li - 1]) in [re.sub(r"\s*F[\d.]+", "", ln)
                                                                for ln in text.splitlines()]
    table = _table(tmp_path, 0.3)
    out = tmp_path / "verified.ngc"
    out.write_text(text)
    compare(canon(GMOCCAPY, tmp_path, table), canon(out, tmp_path, table))
    assert "line(s) keep their text" in check.summary()


def test_compare_moves_sees_moved_points_and_dropped_calls_not_feeds():
    line = [("SET_FEED_RATE", "100.0000"), ("STRAIGHT_FEED", "10.0000, 0.0000, 0.0000, 0, 0, 0")]
    split = [("SET_FEED_RATE", "50.0000"), ("STRAIGHT_FEED", "4.0000, 0.0000, 0.0000, 0, 0, 0"),
             ("SET_FEED_RATE", "80.0000"), ("STRAIGHT_FEED", "10.0000, 0.0000, 0.0000, 0, 0, 0")]
    start = [("STRAIGHT_TRAVERSE", "0.0000, 0.0000, 0.0000, 0, 0, 0")]
    assert compare_moves(start + line, start + split) is None
    bent = [split[0], ("STRAIGHT_FEED", "4.0000, 0.0100, 0.0000, 0, 0, 0"), *split[2:]]
    assert "off the line" in compare_moves(start + line, start + bent)
    assert "became the end" in compare_moves(start + line + [("PROGRAM_END", "")], start + line)
    # a quarter arc (XY, centre (0, 0), from (1, 0) to (0, 1)) in two pieces, and one that stops short
    arc = [("ARC_FEED", "0.0000, 1.0000, 0.0000, 0.0000, 1, 0.0000, 0, 0, 0")]
    s2 = np.sqrt(0.5)
    pieces = [("ARC_FEED", f"{s2:.6f}, {s2:.6f}, 0.0000, 0.0000, 1, 0.0000, 0, 0, 0"), arc[0]]
    begin = [("STRAIGHT_TRAVERSE", "1.0000, 0.0000, 0.0000, 0, 0, 0")]
    assert compare_moves(begin + arc, begin + pieces) is None
    assert compare_moves(begin + arc, begin + pieces[:1]) is not None


def test_the_flag_is_refused_where_it_cannot_check(tmp_path, capsys):
    """No rewrite to check (no --gcode, no machine) or a shape: one line naming the flag, exit 2,
    no file written."""
    out = tmp_path / "x.csv"
    assert main(["advise", str(COMP), "-o", str(out), "--verify-rs274"]) == 2
    err = capsys.readouterr().err
    assert "--verify-rs274" in err and "--gcode" in err and len(err.strip().splitlines()) == 1
    assert main(["advise", "butterfly", "-o", str(out), "--verify-rs274"]) == 2
    assert "--verify-rs274 applies to G-code programs only" in capsys.readouterr().err
    assert not out.exists()


def test_the_flag_without_rs274_is_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))
    out = tmp_path / "x.csv"
    assert main(["advise", str(COMP), "-o", str(out), "--gcode", str(tmp_path / "y.ngc"), "--verify-rs274"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "rs274 not found on PATH" in err[0]
    assert not out.exists() and not (tmp_path / "y.ngc").exists()


_COMP = re.compile(r"G\s*0*4[12]\b", re.IGNORECASE)


def _library():
    """(program, with a tool table) for every library program rs274 accepts and fuzzyfeed reads;
    with a tool table only those that use cutter compensation (for the others the table changes
    nothing fuzzyfeed reads: rs274 gets the same one either way)."""
    with open(LIBRARY / "MANIFEST.csv", newline="") as handle:
        rows = [r for r in csv.DictReader(handle) if r["kind"] == "program" and r["rs274_ok"] == "yes"
                and r["fuzzyfeed_reads"] == "ok"]
    paths = [LIBRARY / r["file"] for r in rows]
    comp = [p for p in paths if _COMP.search(p.read_text(errors="replace"))]
    return [(p, False) for p in paths] + [(p, True) for p in comp]


@pytest.mark.parametrize("path, with_tools", _library(),
                         ids=lambda v: v.name[:28] if isinstance(v, Path) else ("table" if v else "no-table"))
def test_every_library_program_rs274_accepts_is_accepted_after_the_rewrite(path, with_tools, tmp_path):
    """Advised (default table) with or without a tool table (0.1-inch tools), the verified rewrite
    is accepted by rs274 with that table — 0.1 inch also where the advice had none, as the
    controller has one — and gives the same moves apart from the feeds (tests/canon.py)."""
    rs274_binary()
    table = _table(tmp_path, 0.1)
    tools = read_tool_table(table, "inch") if with_tools else None
    program = _quiet_read(path, tools)
    pa = advise_program(program, load_rule_table(None))
    text, check = verified_rewrite(program, pa.piece_move, pa.piece_end, pa.piece_feed_mm_min,
                                   rewrite=rewrite_program, tools_mm=tools)
    assert check.status in ("accepted", "kept"), check.summary()
    out = tmp_path / path.name
    out.write_text(text, newline="")
    compare(canon(path, tmp_path, table), canon(out, tmp_path, table))
