"""CLI: ``fuzzyfeed rules show|check|set|surface``."""

from __future__ import annotations

import pytest

from fuzzyfeed.cli import main
from fuzzyfeed.fuzzy.rule_reader import load_rule_table, rules_dir

PAPER_TEXT = (rules_dir() / "paper.toml").read_text(encoding="utf-8")


def test_show_default_table(capsys):
    assert main(["rules", "show"]) == 0
    out = capsys.readouterr().out
    assert "rule table 'paper'" in out and "WS = 30 points" in out
    assert "VS      VVHF    VVHF    VHF     VHF     VVLF" in out


def test_show_csv_and_toml(capsys, tmp_path):
    assert main(["rules", "show", "--format", "csv"]) == 0
    assert capsys.readouterr().out.splitlines()[1] == "ZO,TF,TF,VVHF,VVHF,VVLF"
    assert main(["rules", "show", "paper", "--format", "toml"]) == 0
    assert capsys.readouterr().out == PAPER_TEXT


def test_check(capsys, tmp_path):
    good = tmp_path / "good.toml"
    good.write_text(PAPER_TEXT)
    assert main(["rules", "check", str(good), "paper"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith(f"ok: {good}: table 'good', 30 rules (6 x 5), 8 feed terms")
    bad = tmp_path / "bad.toml"
    bad.write_text(PAPER_TEXT.replace("H  = [0.5, 0.75, 1.0]", "H  = [0.5, 1.0, 0.75]"))
    assert main(["rules", "check", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"{bad}:" in err and "curvature_variation.H = [0.5, 1.0, 0.75]; breakpoints must be non-decreasing" in err


def test_set_keeps_comments(tmp_path, capsys):
    path = tmp_path / "mine.toml"
    path.write_text(PAPER_TEXT)
    assert main(["rules", "set", str(path), "B", "VH", "LF"]) == 0
    assert "-> LF" in capsys.readouterr().out
    text = path.read_text()
    assert load_rule_table(path).grid[4][4] == "LF"
    assert [ln for ln in text.splitlines() if ln.startswith("#")] == \
        [ln for ln in PAPER_TEXT.splitlines() if ln.startswith("#")]


@pytest.mark.parametrize("args, message", [
    (["{file}", "B", "VH", "SLOW"], "label 'SLOW': unknown feed label; feed terms are VVLF"),
    (["{file}", "BB", "VH", "LF"], "row 'BB': unknown curvature label"),
    (["{file}", "B", "XH", "LF"], "column 'XH': unknown curvature_variation label"),
    (["paper", "B", "VH", "LF"], "paper: no such file; `rules set` edits a file"),
])
def test_set_errors_leave_the_file(tmp_path, capsys, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "mine.toml"
    path.write_text(PAPER_TEXT)
    assert main(["rules", "set", *(a.format(file=path) for a in args)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("fuzzyfeed: error: ") and message in err and err.count("\n") == 1
    assert path.read_text() == PAPER_TEXT
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine.toml"]


def test_surface_png(tmp_path, capsys):
    out = tmp_path / "s.png"
    assert main(["rules", "surface", "-o", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["rules", "surface", "-o", str(tmp_path / "no" / "s.png")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_show_fcl(capsys):
    import re

    assert main(["rules", "show", "--format", "fcl"]) == 0
    out = capsys.readouterr().out
    assert out.count("RULE ") == 30 and "METHOD : COG;" in out and "ACCU : MAX;" in out
    # numbered as the paper's R1-R30 (curvature runs fastest): R25 and R26 are the two VVLF rules
    assert "RULE 25 : IF curvature IS ZO AND curvature_variation IS VH THEN feed IS VVLF;" in out
    assert "RULE 26 : IF curvature IS VS AND curvature_variation IS VH THEN feed IS VVLF;" in out
    assert "RULE 2 : IF curvature IS VS AND curvature_variation IS ZO THEN feed IS VVHF;" in out
    assert "TERM VVLF := (0.0, 1.0) (10.0, 0.0);" in out
    assert "TERM VB := (0.2, 0.0) (0.5, 1.0) (1.0, 1.0);" in out
    assert re.search(r"DEFAULT := 5\.0;", out)
