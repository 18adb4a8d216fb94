"""Claim only what was judged (issue 40 item 4): per feed move whether it is judged and why not,
the share of moves, length and time judged, and no "holds the tolerance" verdict for a program of
which a part was not judged — in the value report's text, HTML and CSV, the CLI's summary and the
batch summary."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from canon import canon
from fuzzyfeed.cli import main
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.program.coverage import REASONS, move_reasons, program_coverage
from fuzzyfeed.program.read import parse_program, read_program
from fuzzyfeed.program.tools import read_tool_table
from fuzzyfeed.report.value import evaluate_program

LCNC = Path(__file__).parent / "programs" / "linuxcnc"
LIBRARY = Path(__file__).parent.parent / "benchmarks" / "library" / "programs"
KEYS = [k for k, _ in REASONS]


def _reasons(program) -> dict[str, int]:
    r = move_reasons(program)
    return {KEYS[k]: int((r == k).sum()) for k in np.unique(r[r >= 0])}


def test_shares_follow_the_closed_form_time_and_length():
    """G1 X10 at F600 (10 mm, 1 s), G93 G1 X30 F60 (20 mm, 1/60 min = 1 s), G94 G95 G1 X40 F0.1
    (10 mm, time per revolution unknown): 1 of 3 moves judged, 10/40 of the length, 1/2 of the
    time known."""
    text = "G21 G90 G94 F600 G0 X0 Y0 Z0\nG1 X10\nG93 G1 X30 F60\nG94\nG95 G1 X40 F0.1\nM2\n"
    program = parse_program(text, Path("t.ngc"))
    cov = program_coverage(program)
    assert (cov.moves, cov.judged_moves) == (3, 1)
    assert cov.length_mm == pytest.approx(40.0) and cov.judged_length_mm == pytest.approx(10.0)
    assert cov.time_s == pytest.approx(2.0) and cov.judged_time_s == pytest.approx(1.0)
    assert cov.unknown_time_moves == 1 and cov.unknown_length_moves == 0
    assert _reasons(program) == {"inverse_time": 1, "per_rev": 1}
    assert [n.first_lines for n in cov.not_judged] == [(5,), (3,)]
    assert "at most 50.0 % of the time" in cov.summary() and "25.0 % of the length" in cov.summary()


def test_compensation_without_a_tool_table_is_not_judged_and_with_one_is(tmp_path):
    """comp.ngc: G42/G41 D1 with no tool table: the moves under compensation and the move after
    G40 (24 of 36) are the programmed contour, not judged; with a tool table everything is."""
    with pytest.warns(Warning, match="cutter compensation with no tool diameter"):
        bare = read_program(LCNC / "comp.ngc")
    cov = program_coverage(bare)
    assert not cov.complete and _reasons(bare) == {"comp_no_tool": 24}
    assert cov.not_judged[0].first_lines == (13, 14, 15)          # g42 d1 is on line 12
    assert (bare.comp_unknown & (bare.kind != 0)).sum() == 24        # and the rapids after G40
    (tmp_path / "t.tbl").write_text("T1 P1 D0.1\n")
    tooled = read_program(LCNC / "comp.ngc", tools=read_tool_table(tmp_path / "t.tbl", "inch"))
    assert program_coverage(tooled).complete
    assert not tooled.comp_unknown.any()


def _feed_calls(path: Path, tmp_path: Path) -> int:
    return sum(name in ("STRAIGHT_FEED", "ARC_FEED", "NURBS_FEED") for name, _ in canon(path, tmp_path))


@pytest.mark.parametrize("name, key", [("spiral.ngc", None), ("threading.ngc", "synced")])
def test_every_feed_move_rs274_runs_is_counted(name, key, tmp_path):
    """As many feed moves as rs274 gives feed calls (spiral.ngc: 801, the plunge and 800 polar
    moves); G33 moves are never judged; a move fuzzyfeed keeps as written (spiral's polar moves
    until the reader places them) is never judged. (threading.ngc: fuzzyfeed's reader runs its
    while loop once more than rs274, 242 feed moves against 239: a reader matter, not counted.)"""
    program = read_program(LCNC / name)
    cov = program_coverage(program)
    if name == "spiral.ngc":
        assert cov.moves == _feed_calls(LCNC / name, tmp_path) == 801
    reasons = _reasons(program)
    if key is not None:
        assert reasons[key] == int((program.kind == 7).sum()) > 0     # SYNCED
    feed = ~np.isin(program.kind, (0, 6))                                # not RAPID, HOME
    kept = int((((program.kind == 5) | ~program.known) & feed).sum())  # KEPT or unknown
    assert reasons.get("unknown", 0) == kept
    assert cov.complete == (not reasons)


@pytest.fixture(scope="module")
def reports():
    machine, table = load_machine("reference"), load_rule_table("machine")
    out = {}
    for name in ("comp.ngc", "spiral.ngc", "threading.ngc"):
        import warnings
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            program = read_program(LCNC / name)
            out[name] = evaluate_program(program, machine, table, reference=False).report
    return out


@pytest.mark.parametrize("name", ["comp.ngc", "spiral.ngc", "threading.ngc"])
def test_no_verdict_beyond_the_judged_part(reports, name):
    """A program of which a part is not judged never gets the bare "holds the tolerance": the
    verdict names the judged share and what was not judged (spiral.ngc: until the reader places
    its polar moves; then it is judged whole and may hold)."""
    r = reports[name]
    verdict = r.verdict()
    if r.coverage.complete:
        assert name == "spiral.ngc" and "not judged" not in verdict
        return
    assert "not judged: " in verdict and r.coverage.not_judged_text() in verdict
    bare = verdict.replace("holds the tolerance on the judged part", "")
    assert "holds the tolerance" not in bare and "holds the tolerance (max" not in bare
    if r.advised.max_um <= r.tol_um:
        assert "holds the tolerance on the judged part (" in verdict
    text = "\n".join(r.lines())
    assert r.coverage.summary() in text
    row = r.csv_row()
    assert row["not_judged"] == r.coverage.not_judged_text() and row["judged_moves_pct"] < 100
    share = row["judged_length_pct"]          # NaN: lengths unknown (spiral's polar moves)
    assert (0 <= share < 100) if r.coverage.unknown_length_moves == 0 else np.isnan(share)


def test_value_report_files_and_cli_carry_the_judged_share(tmp_path, capsys):
    out = tmp_path / "x.csv"
    report_csv, report_html = tmp_path / "r.csv", tmp_path / "r.html"
    for report in (report_csv, report_html):
        assert main(["advise", str(LCNC / "threading.ngc"), "-o", str(out), "--machine", "reference",
                     "--no-reference", "--report", str(report)]) == 0
    printed = capsys.readouterr().out
    assert "not judged: " in printed and "spindle-synchronised" in printed
    with open(report_csv, newline="") as handle:
        row = next(csv.DictReader(handle))
    assert float(row["judged_length_pct"]) < 100 and "G33" in row["not_judged"]
    page = report_html.read_text()
    assert "not judged: " in page and "on the judged part" in page
    # without a machine: the summary line and the figures batch takes
    from fuzzyfeed import advise_file

    result = advise_file(LCNC / "threading.ngc")
    figures = result.figures()
    assert figures["not_judged"].startswith("156 move(s) spindle-synchronised")
    assert any("judged: 86 of 242 feed moves" in line for line in result.summary())


def test_a_program_judged_whole_keeps_its_verdict():
    program = read_program(LIBRARY / "linuxcnc" / "tort.ngc")
    cov = program_coverage(program)
    assert cov.complete and cov.length_pct == 100.0 and cov.not_judged_text() == ""
    assert cov.judged_length_mm == pytest.approx(float(program.move_lengths()[program.cut >= 0].sum()))


def test_batch_summary_carries_the_judged_share():
    from fuzzyfeed.batch.discover import Source
    from fuzzyfeed.batch.summary import summary_frame, summary_html

    entries = {"a.ngc": {"status": "ok", "reason": "", "compute_s": 0.1, "notes": "",
                         "figures": {"cuts": 1, "time_written_s": 1.0, "time_advised_s": 1.0,
                                     "judged_length_pct": 14.2, "not_judged": "156 move(s) spindle"}},
               "b.ngc": {"status": "ok", "reason": "", "compute_s": 0.1, "notes": "",
                         "figures": {"cuts": 1, "time_written_s": 1.0, "time_advised_s": 1.0,
                                     "judged_length_pct": 100.0, "not_judged": ""}}}
    frame = summary_frame([Source("a.ngc", "a.ngc", "program"), Source("b.ngc", "b.ngc", "program")],
                          entries, kept=set())
    assert frame["not_judged"].tolist() == ["156 move(s) spindle", ""]
    page = summary_html(frame)
    assert "Judged in part (1)" in page and "156 move(s) spindle" in page
