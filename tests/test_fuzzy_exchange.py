"""Rule tables in and out: FCL (IEC and fuzzylite dialects), FLL, MATLAB .fis.

Exact round trips (hypothesis over random tables), and fuzzylite 6 (Debian ``fuzzylite``, an
engine we did not write) reading our exports and computing the same feed to 1e-6 % of F over a
grid of (κ, Dκ). Tests that need fuzzylite skip when the binary is missing, unless
FUZZYFEED_REQUIRE_FUZZYLITE=1 (CI), which turns the skip into a failure.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzyfeed.cli import main
from fuzzyfeed.errors import RuleTableError
from fuzzyfeed.fuzzy.diff import table_differences
from fuzzyfeed.fuzzy.engine import compile_table
from fuzzyfeed.fuzzy.exchange import FLL_RESOLUTION, numbered_rules, spec_to_table
from fuzzyfeed.fuzzy.formats import export_table, parse_text
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.fuzzy.rule_writer import table_to_toml
from fuzzyfeed.fuzzy.rules import RuleTable, Term, Variable

FORMATS = ("fcl", "fcl-fuzzylite", "fll", "fis")
FUZZYLITE = shutil.which("fuzzylite")
REQUIRE = os.environ.get("FUZZYFEED_REQUIRE_FUZZYLITE") == "1"
#: fuzzyfeed's exact centroid against fuzzylite's midpoint rule at FLL_RESOLUTION cells
TOL_PCT = 1e-6


@pytest.fixture
def fuzzylite():
    if FUZZYLITE is None:
        if REQUIRE:
            pytest.fail("FUZZYFEED_REQUIRE_FUZZYLITE=1 but no fuzzylite binary on PATH")
        pytest.skip("fuzzylite (Debian package fuzzylite) is not installed; CI installs it")
    return FUZZYLITE


def _run_fuzzylite(*args: str) -> None:
    """fuzzylite 6 exits 0 even when it cannot read a file: judge by its stderr/stdout."""
    res = subprocess.run([FUZZYLITE, *args], capture_output=True, text=True, timeout=600)
    msg = res.stdout + res.stderr
    assert res.returncode == 0 and "error" not in msg.lower(), msg


def _reimport(table: RuleTable, fmt: str) -> RuleTable:
    text = export_table(table, fmt)
    return spec_to_table(parse_text(text, fmt.split("-")[0], f"x.{fmt}"), settings_from=table)


def _same(a: RuleTable, b: RuleTable) -> None:
    assert table_differences(a, b) == []
    assert [t.points for v in a.variables for t in v.terms] == [t.points for v in b.variables for t in v.terms]
    assert a.grid == b.grid


# ---------------------------------------------------------------------------------------------
# round trips

@pytest.mark.parametrize("fmt", FORMATS)
def test_paper_round_trips_exactly(fmt):
    paper = load_rule_table()
    back = _reimport(paper, fmt)
    _same(paper, back)
    assert back.name == "paper"
    if fmt != "fis":                    # FCL and FLL carry name and source in the settings comment
        assert table_to_toml(back) == table_to_toml(paper)


def _covering(draw, lo: float, hi: float, labels: list[str]) -> Variable:
    """Random terms that cover [lo, hi]: a partition by sorted breakpoints, shoulders at the ends."""
    n = len(labels)
    xs = sorted(draw(st.lists(st.floats(lo, hi, allow_nan=False, exclude_min=True, exclude_max=True),
                              min_size=n - 2, max_size=n - 2, unique=True)))
    xs = [lo, *xs, hi]
    terms = []
    for i, label in enumerate(labels):
        a, b, c = xs[max(i - 1, 0)], xs[i], xs[min(i + 1, n - 1)]
        if draw(st.booleans()) and i not in (0, n - 1):
            terms.append(Term(label, (a, b, b, c)))         # a trapezoid with b = c is a triangle
        elif i == n - 1 and draw(st.booleans()):
            terms.append(Term(label, (a, b, c, c)))
        else:
            terms.append(Term(label, (a, b, c)))
    return Variable("", (lo, hi), tuple(terms))


@st.composite
def tables(draw):
    k_labels = [f"K{i}" for i in range(draw(st.integers(2, 6)))]
    d_labels = [f"D{i}" for i in range(draw(st.integers(2, 5)))]
    f_labels = [f"F{i}" for i in range(draw(st.integers(2, 8)))]
    k_top = draw(st.floats(0.01, 100))
    k = replace(_covering(draw, 0.0, k_top, k_labels), name="curvature")
    d = replace(_covering(draw, 0.0, 1.0, d_labels), name="curvature_variation")
    f = replace(_covering(draw, 0.0, 100.0, f_labels), name="feed")
    grid = tuple(tuple(draw(st.sampled_from(f_labels)) for _ in d_labels) for _ in k_labels)
    return RuleTable(name=draw(st.sampled_from(["t", "my table", "x-1"])), curvature=k,
                     curvature_variation=d, feed=f, grid=grid,
                     window_points=draw(st.integers(1, 60)), dk_clip_1_mm=draw(st.floats(0.1, 10)),
                     filter_points=2 * draw(st.integers(0, 20)) + 1, feed_floor_pct=draw(st.floats(0.5, 50)),
                     filter=draw(st.sampled_from(["mean", "min-mean"])),
                     window_mm=draw(st.none() | st.floats(0.01, 50)), source="random")


def _canonical(t: RuleTable) -> RuleTable:
    """A trapezoid whose top is a point is written as the triangle it is."""
    def var(v):
        return replace(v, terms=tuple(Term(x.label, (x.points[0], x.points[1], x.points[3]))
                                      if len(x.points) == 4 and x.points[1] == x.points[2] else x
                                      for x in v.terms))
    return replace(t, curvature=var(t.curvature), curvature_variation=var(t.curvature_variation),
                   feed=var(t.feed))


@settings(max_examples=60, deadline=None)
@given(tables(), st.sampled_from(FORMATS))
def test_random_tables_round_trip_exactly(table, fmt):
    want = _canonical(table) if fmt in ("fcl",) else table
    back = _reimport(table, fmt)
    _same(want, back)
    x = np.linspace(0, 1, 7)
    k, d = np.meshgrid(x * table.curvature.universe[1], x)
    np.testing.assert_array_equal(compile_table(table).feed_pct(k.ravel(), d.ravel()),
                                  compile_table(back).feed_pct(k.ravel(), d.ravel()))


def test_rule_numbers_are_the_papers():
    paper = load_rule_table()
    rules = {n: (k, d, f) for n, k, d, f in numbered_rules(paper)}
    # seed 002's list: R1 (ZO, ZO) TF, R2 (VS, ZO) VVHF, R6 (VB, ZO) VLF, R7 (ZO, L) TF,
    # R25/R26 the two VVLF rules, R30 (VB, VH) VLF
    assert rules[1] == ("ZO", "ZO", "TF") and rules[2] == ("VS", "ZO", "VVHF")
    assert rules[6] == ("VB", "ZO", "VLF") and rules[7] == ("ZO", "L", "TF")
    assert rules[25] == ("ZO", "VH", "VVLF") and rules[26] == ("VS", "VH", "VVLF")
    assert rules[30] == ("VB", "VH", "VLF") and len(rules) == 30
    fis = export_table(paper, "fis").split("[Rules]")[1].split()
    assert " ".join(fis[:6]) == "1 1, 8 (1) : 1"       # R1: ZO ZO -> TF (8th feed term), AND


@pytest.mark.parametrize("text, fmt, message", [
    ("[System]\nType='sugeno'\n", "fis", "fuzzyfeed reads Mamdani"),
    ("Engine: x\nOutputVariable: feed\n  range: 0 100\n  term: A Gaussian 1 2\n", "fll",
     "reads Triangle and Trapezoid"),
])
def test_foreign_controllers_are_refused(text, fmt, message):
    with pytest.raises(RuleTableError, match=message):
        spec_to_table(parse_text(text, fmt, "f"))


@pytest.mark.parametrize("edit, message", [
    (("ACT : MIN;", "ACT : PROD;"), "implication = PROD; fuzzyfeed computes"),
    (("RULE 30 :", "RULE 31 : IF curvature IS VB AND curvature_variation IS VH THEN feed IS TF;\n RULE 30 :"),
     "two rules for curvature IS VB AND curvature_variation IS VH"),
    (("    RULE 30 : IF curvature IS VB AND curvature_variation IS VH THEN feed IS VLF;\n", ""),
     r"no rule for \(curvature, curvature_variation\) = \(VB, VH\)"),
    (("TERM VVLF := (0.0, 1.0) (10.0, 0.0);", "TERM VVLF := (0.0, 0.5) (10.0, 0.0);"), "rise from 0 to 1"),
])
def test_bad_fcl_is_a_one_line_error(edit, message):
    text = export_table(load_rule_table(), "fcl")
    assert edit[0] in text
    with pytest.raises(RuleTableError, match=message):
        spec_to_table(parse_text(text.replace(*edit), "fcl", "bad.fcl"))


# ---------------------------------------------------------------------------------------------
# fuzzylite reads the exports and computes the same controller

def _grid_points() -> tuple[np.ndarray, np.ndarray]:
    x = np.linspace(0.0, 1.0, 21)
    k, d = np.meshgrid(x, x)
    rng = np.random.default_rng(12)
    k = np.concatenate([k.ravel(), rng.uniform(0, 1, 80)])
    d = np.concatenate([d.ravel(), rng.uniform(0, 1, 80)])
    return k, d


def _evaluate(engine_file: Path, fmt: str, tmp: Path, k: np.ndarray, d: np.ndarray) -> np.ndarray:
    inputs = tmp / "in.fld"
    inputs.write_text("curvature curvature_variation\n"
                      + "".join(f"{float(a)!r} {float(b)!r}\n" for a, b in zip(k, d)))
    out = tmp / "out.fld"
    _run_fuzzylite("-i", str(engine_file), "-if", fmt, "-o", str(out), "-of", "fld", "-d", str(inputs),
                   "-decimals", "12", "-dheader", "true", "-dinputs", "true")
    rows = np.loadtxt(out, skiprows=1, ndmin=2)
    assert rows.shape == (k.size, 3)
    np.testing.assert_array_equal(rows[:, 0], np.round(k, 12))
    return rows[:, 2]


def _fll_from_fuzzylite(src: Path, fmt: str, tmp: Path) -> str:
    """fuzzylite's own FLL of an engine it read (17 decimals: our numbers exactly)."""
    out = tmp / f"{src.stem}.{fmt}.fll"
    _run_fuzzylite("-i", str(src), "-if", fmt, "-o", str(out), "-of", "fll", "-decimals", "17")
    return out.read_text()


def test_fuzzylite_computes_the_fll_export(fuzzylite, tmp_path):
    paper = load_rule_table()
    path = tmp_path / "paper.fll"
    path.write_text(export_table(paper, "fll"))
    k, d = _grid_points()
    theirs = _evaluate(path, "fll", tmp_path, k, d)
    ours = compile_table(paper).feed_pct(k, d)
    assert np.abs(theirs - ours).max() <= TOL_PCT, np.abs(theirs - ours).max()


@pytest.mark.parametrize("fmt, suffix", [("fcl-fuzzylite", "fcl"), ("fis", "fis")])
def test_fuzzylite_reads_the_fcl_and_fis_exports(fuzzylite, tmp_path, fmt, suffix):
    """fuzzylite reads the file; the engine it built (written back by fuzzylite as FLL) is our
    table term for term, and computes our feed to 1e-6 % once its centroid resolution (which FCL
    and .fis cannot state; fuzzylite's default is 100 cells) is set to ours."""
    paper = load_rule_table()
    src = tmp_path / f"paper.{suffix}"
    src.write_text(export_table(paper, fmt))
    fll = _fll_from_fuzzylite(src, suffix, tmp_path)
    _same(paper, spec_to_table(parse_text(fll, "fll", "fuzzylite.fll"), settings_from=paper))
    k, d = _grid_points()
    ours = compile_table(paper).feed_pct(k, d)
    coarse = _evaluate(src, suffix, tmp_path, k, d)            # as a fuzzylite user would get it
    assert np.abs(coarse - ours).max() < 0.05
    fine = tmp_path / "fine.fll"
    fine.write_text(re.sub(r"Centroid \d+", f"Centroid {FLL_RESOLUTION}", fll))
    theirs = _evaluate(fine, "fll", tmp_path, k, d)
    assert np.abs(theirs - ours).max() <= TOL_PCT, np.abs(theirs - ours).max()


@pytest.mark.parametrize("fmt", ["fcl", "fis", "fll"])
def test_fuzzyliles_own_exports_import_to_the_same_table(fuzzylite, tmp_path, fmt):
    """Files written by fuzzylite (not by us) import to the table they came from."""
    paper = load_rule_table()
    src = tmp_path / "paper.fll"
    src.write_text(export_table(paper, "fll"))
    out = tmp_path / f"theirs.{fmt}"
    _run_fuzzylite("-i", str(src), "-if", "fll", "-o", str(out), "-of", fmt, "-decimals", "17")
    table = tmp_path / "back.toml"
    assert main(["rules", "import", str(out), "-o", str(table)]) == 0
    back = load_rule_table(table)
    _same(paper, back)
    assert back.name == "back"


def test_fuzzylite_cannot_read_the_iec_form(fuzzylite, tmp_path):
    """Why the fuzzylite dialect exists: fuzzylite 6 refuses the standard's (* *) comments."""
    src = tmp_path / "iec.fcl"
    src.write_text(export_table(load_rule_table(), "fcl"))
    res = subprocess.run([FUZZYLITE, "-i", str(src), "-if", "fcl", "-o", str(tmp_path / "x.fll"),
                          "-of", "fll"], capture_output=True, text=True, timeout=60)
    assert "syntax error" in res.stdout + res.stderr


# ---------------------------------------------------------------------------------------------
# command line

def test_cli_import_and_diff(tmp_path, capsys):
    src = tmp_path / "p.fll"
    assert main(["rules", "show", "--format", "fll"]) == 0
    src.write_text(capsys.readouterr().out)
    out = tmp_path / "mine.toml"
    assert main(["rules", "import", str(src), "-o", str(out)]) == 0
    assert "table 'mine'" in capsys.readouterr().out
    assert load_rule_table(out).name == "mine"
    assert main(["rules", "diff", "paper", str(out)]) == 0
    assert "the same controller and settings" in capsys.readouterr().out
    assert main(["rules", "set", str(out), "VB", "ZO", "LF"]) == 0
    capsys.readouterr()
    assert main(["rules", "diff", "paper", str(out), "--shape", "trident", "--points", "500"]) == 0
    text = capsys.readouterr().out
    assert "rule (curvature VB, curvature_variation ZO): VLF -> LF" in text
    assert re.search(r"trident: [1-9]\d* stretch", text) and "s = " in text
    # bad input: one line, exit 2, nothing written
    bad = tmp_path / "bad.fll"
    bad.write_text(src.read_text().replace("conjunction: Minimum", "conjunction: AlgebraicProduct"))
    target = tmp_path / "never.toml"
    assert main(["rules", "import", str(bad), "-o", str(target)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "and = AlgebraicProduct" in err and not target.exists()


def test_provenance_names_the_table_and_survives_a_gcode_comment():
    from fuzzyfeed.fuzzy.provenance import provenance, provenance_lines, table_digest

    paper = load_rule_table()
    edited = paper.with_cell("VB", "ZO", "LF")
    renamed = replace(paper, name="other", source="elsewhere (copy)")
    assert table_digest(renamed) == table_digest(paper) != table_digest(edited)
    record = provenance(edited, 6000.0, "shapes/trident.toml (Lin (2021))", 2000)
    assert record["rules"] == "paper" and record["F_mm_min"] == "6000" and record["points"] == "2000"
    assert record["filter"] == "corner-mean over 21 points" and record["window"] == "30 points"
    lines = provenance_lines(record)
    assert all("(" not in x and ")" not in x and "\n" not in x for x in lines)
    assert "source: shapes/trident.toml [Lin [2021]]" in lines
