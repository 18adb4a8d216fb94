"""Rule-table files: the shipped paper table, round trips, cell edits that keep comments, and one
clear error (file:line, value, rule) for every kind of bad table."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzyfeed.errors import RuleTableError
from fuzzyfeed.fuzzy.engine import membership
from fuzzyfeed.fuzzy.rule_reader import load_rule_table, parse_rule_table, resolve_rules_path, rules_dir, table_names
from fuzzyfeed.fuzzy.rule_writer import grid_text, set_cell, set_cell_text, table_to_toml
from fuzzyfeed.fuzzy.rules import Term, Variable, uncovered

PAPER = rules_dir() / "paper.toml"
PAPER_TEXT = PAPER.read_text(encoding="utf-8")

# DESIGN.md §3 / seed 002 rules R1-R30 (rows κ, columns Dκ = ZO L M H VH)
TABLE_6 = {
    "ZO": ["TF", "TF", "VVHF", "VVHF", "VVLF"],
    "VS": ["VVHF", "VVHF", "VHF", "VHF", "VVLF"],
    "S": ["VHF", "HF", "HF", "HF", "MF"],
    "M": ["HF", "HF", "MF", "MF", "MF"],
    "B": ["MF", "LF", "LF", "VLF", "VLF"],
    "VB": ["VLF", "VLF", "VLF", "VLF", "VLF"],
}


def line_of(text: str, needle: str) -> int:
    for n, line in enumerate(text.splitlines(), start=1):
        if line.startswith(needle):
            return n
    raise AssertionError(needle)


def test_paper_table_is_the_default_and_matches_table_6():
    t = load_rule_table()
    assert t.path == PAPER and "paper" in table_names()
    assert t.curvature.labels == ("ZO", "VS", "S", "M", "B", "VB")
    assert t.curvature_variation.labels == ("ZO", "L", "M", "H", "VH")
    assert t.feed.labels == ("VVLF", "VLF", "LF", "MF", "HF", "VHF", "VVHF", "TF")
    assert {k: list(t.grid[i]) for i, k in enumerate(t.curvature.labels)} == TABLE_6
    assert (t.window_points, t.dk_clip_1_mm) == (30, 3.0)
    assert t.filter_points >= 1 and 0 < t.feed_floor_pct < 100
    assert len(t.rules) == 30 and t.rules[4] == ("ZO", "VH", "VVLF")
    # R25 and R26 (κ ZO/VS, Dκ VH) use VVLF, which the file declares explicitly with a comment
    assert t.grid[0][4] == t.grid[1][4] == "VVLF"
    assert "VVLF" in PAPER_TEXT.split("[feed]")[1].split("universe")[0]


def test_resolve_names_and_paths(tmp_path):
    assert resolve_rules_path(None) == PAPER
    assert resolve_rules_path("paper") == PAPER
    with pytest.raises(RuleTableError, match="rule table 'nosuch': no such shipped table or file; "
                                             "shipped tables are: machine, machine-tuned, paper"):
        load_rule_table("nosuch")
    with pytest.raises(RuleTableError, match="no such file"):
        load_rule_table(tmp_path / "missing.toml")


def test_round_trip_through_toml():
    t = load_rule_table()
    again = parse_rule_table(table_to_toml(t))
    assert again.grid == t.grid and again.variables == t.variables
    assert (again.window_points, again.dk_clip_1_mm, again.filter_points, again.feed_floor_pct) == (
        t.window_points, t.dk_clip_1_mm, t.filter_points, t.feed_floor_pct)


def test_grid_text_for_spreadsheets():
    t = load_rule_table()
    csv_lines = grid_text(t, sep=",").splitlines()
    assert csv_lines[0] == "k \\ Dk,ZO,L,M,H,VH"
    assert csv_lines[2] == "VS,VVHF,VVHF,VHF,VHF,VVLF"
    assert grid_text(t).splitlines()[1].split() == ["ZO", *TABLE_6["ZO"]]


def test_set_cell_keeps_comments_and_changes_one_cell(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(PAPER_TEXT, encoding="utf-8")
    t = set_cell(path, "VS", "M", "HF")
    assert t.grid[1][2] == "HF"
    new = path.read_text(encoding="utf-8")
    old_lines, new_lines = PAPER_TEXT.splitlines(), new.splitlines()
    changed = [i for i, (a, b) in enumerate(zip(old_lines, new_lines)) if a != b]
    assert len(old_lines) == len(new_lines) and len(changed) == 1
    assert new_lines[changed[0]].startswith("VS") and '"HF"' in new_lines[changed[0]]
    assert sum(line.lstrip().startswith("#") for line in new_lines) == \
        sum(line.lstrip().startswith("#") for line in old_lines)
    # columns stay aligned: every grid line has its cells at the same offsets
    grid_lines = [ln for ln in new.split("\n[rules]")[1].splitlines() if "= [" in ln]
    assert len(grid_lines) == 7
    starts = {tuple(m.start() for m in re.finditer(r'"', ln))[::2] for ln in grid_lines}
    assert len(starts) == 1
    assert load_rule_table(path).grid[1][2] == "HF"


def test_set_cell_on_a_file_in_another_layout():
    text = table_to_toml(load_rule_table()).replace('VS      = [', 'VS = [\n  ')
    new = set_cell_text(text, "VS", "VH", "TF")
    assert parse_rule_table(new).grid[1][4] == "TF"


@pytest.mark.parametrize("row, col, label, message", [
    ("VS", "M", "FAST", "label 'FAST': unknown feed label; feed terms are VVLF, VLF"),
    ("XX", "M", "HF", "row 'XX': unknown curvature label"),
    ("VS", "Q", "HF", "column 'Q': unknown curvature_variation label"),
])
def test_set_cell_rejects_bad_labels_and_leaves_the_file(tmp_path, row, col, label, message):
    path = tmp_path / "mine.toml"
    path.write_text(PAPER_TEXT, encoding="utf-8")
    with pytest.raises(RuleTableError, match=message):
        set_cell(path, row, col, label)
    assert path.read_text(encoding="utf-8") == PAPER_TEXT


def test_in_memory_table_validation_and_with_cell():
    t = load_rule_table()
    assert t.with_cell("B", "ZO", "HF").grid[4][0] == "HF"
    with pytest.raises(RuleTableError, match=r"rule table 'paper': rules.VS: row VS, column M "
                                             r"\(cell 3\): unknown feed label 'FAST'"):
        t.with_cell("VS", "M", "FAST")
    with pytest.raises(RuleTableError, match="features.window_points: window_points = 0"):
        replace(t, window_points=0)


# ---------------------------------------------------------------------------------------------
# every rule-file error: one line with file:line, the bad value and the rule broken

def edit(old: str, new: str, count: int = 1) -> str:
    assert old in PAPER_TEXT, old
    return PAPER_TEXT.replace(old, new, count)


BAD_FILES = [
    # unknown label in a cell
    ('VS      = ["VVHF", "VVHF", "VHF",  "VHF",  "VVLF"]',
     'VS      = ["VVHF", "VVHF", "VHX",  "VHF",  "VVLF"]',
     "VS      =", r"row VS, column M \(cell 3\): unknown feed label 'VHX'; feed terms are VVLF"),
    # unknown row label
    ('B       = ["MF",', 'BIG     = ["MF",', "BIG     =",
     r"row 'BIG': unknown curvature label; curvature terms are ZO, VS, S, M, B, VB"),
    # unknown column label
    ('columns = ["ZO",   "L",', 'columns = ["ZO",   "LL",', "columns =",
     r"column 2 'LL': unknown curvature_variation label"),
    # missing cell: short row
    ('M       = ["HF",   "HF",   "MF",   "MF",   "MF"]', 'M       = ["HF",   "HF",   "MF",   "MF"]',
     'M       = ["HF"', r"row M has 4 cells for 5 columns \(missing cell\)"),
    # missing cell: empty string
    ('S       = ["VHF",  "HF",', 'S       = ["",  "HF",', 'S       = [""',
     r"row S, column ZO \(cell 1\): ''; missing cell, give a feed label"),
    # missing row
    ('VB      = ["VLF",  "VLF",  "VLF",  "VLF",  "VLF"]\n', '', "[rules]",
     r"no row for curvature VB; missing cells"),
    # duplicate row (duplicate cells)
    ('VB      = ["VLF",  "VLF",  "VLF",  "VLF",  "VLF"]\n',
     'VB      = ["VLF",  "VLF",  "VLF",  "VLF",  "VLF"]\nVB = ["LF", "LF", "LF", "LF", "LF"]\n',
     'VB = ["LF"', r"duplicate row 'VB' in \[rules\] \(first at line \d+\); give each once"),
    # duplicate column
    ('columns = ["ZO",   "L",    "M",    "H",    "VH"]', 'columns = ["ZO",   "L",    "M",    "M",    "VH"]',
     "columns =", r"column 'M' given twice \(columns 3 and 4\)"),
    # duplicate term
    ('B  = [0.1, 0.2, 0.5]\n', 'B  = [0.1, 0.2, 0.5]\nB = [0.1, 0.3, 0.5]\n', "B = [0.1, 0.3",
     r"duplicate term 'B' in \[curvature\]"),
    # non-monotone breakpoints
    ('M  = [0.05, 0.1, 0.2]', 'M  = [0.05, 0.2, 0.1]', "M  = [0.05, 0.2",
     r"curvature.M = \[0.05, 0.2, 0.1\]; breakpoints must be non-decreasing \(0.1 follows 0.2\)"),
    # uncovered stretch of a universe
    ('VB = [0.2, 0.5, 1.0, 1.0]', 'VB = [0.6, 0.7, 1.0, 1.0]', "[curvature]",
     r"no curvature term covers 0.5 to 0.6 1/mm; no rule can fire for curvature = 0.5 to 0.6;"),
    # uncovered single point (two triangles meeting at 0)
    ('S  = [0.02, 0.05, 0.1]', 'S  = [0.05, 0.07, 0.1]', "[curvature]",
     r"no curvature term covers 0.05 1/mm; no rule can fire for curvature = 0.05;"),
    # term outside the universe
    ('VB = [0.2, 0.5, 1.0, 1.0]', 'VB = [0.2, 0.5, 1.0, 1.5]', "VB = [0.2",
     r"curvature.VB = \[0.2, 0.5, 1.0, 1.5\] leaves the universe \[0, 1\] 1/mm"),
    # wrong number of breakpoints
    ('LF   = [10.0, 25.0, 40.0]', 'LF   = [10.0, 40.0]', "LF   = [10.0, 40.0]",
     r"feed.LF = \[10.0, 40.0\]; a term is 3 numbers"),
    # zero-width term
    ('MF   = [25.0, 40.0, 55.0]', 'MF   = [40.0, 40.0, 40.0]', "MF   = [40.0",
     r"first breakpoint < last"),
    # bad universe
    ('universe = [0.0, 100.0]', 'universe = [100.0, 0.0]', "universe = [100.0",
     r"universe = \[100.0, 0.0\]; must be \[lo, hi\]"),
    # bad features
    ('window_points = 30', 'window_points = 0', "window_points = 0", r"window_points = 0; must be an integer >= 1"),
    ('feed_floor_pct = 5.0', 'feed_floor_pct = 0.0', "feed_floor_pct = 0.0", r"feed_floor_pct = 0.0; must be in \(0, 100\]"),
    ('dk_clip_1_mm = 3.0', 'dk_clip_1_mm = -3.0', "dk_clip_1_mm = -3.0", r"dk_clip_1_mm = -3.0; must be a finite number > 0"),
    ('filter_points = 21', 'filter_pints = 21', "filter_pints", r"unknown setting 'filter_pints'"),
]


@pytest.mark.parametrize("old, new, where, message", BAD_FILES, ids=range(len(BAD_FILES)))
def test_bad_rule_files(tmp_path, old, new, where, message):
    text = edit(old, new)
    path = tmp_path / "bad.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(RuleTableError) as info:
        load_rule_table(path)
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith(f"{path}:{line_of(text, where)}: "), msg
    assert re.search(message, msg), msg


def test_invalid_toml_and_missing_section(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("name = \n", encoding="utf-8")
    with pytest.raises(RuleTableError, match=r"bad.toml: invalid TOML: .*line 1"):
        load_rule_table(path)
    path.write_text(PAPER_TEXT.split("\n[rules]")[0], encoding="utf-8")
    with pytest.raises(RuleTableError, match=r"bad.toml: section \[rules\] is missing"):
        load_rule_table(path)


def test_terms_that_do_not_match_the_grid(tmp_path):
    """A file whose curvature terms were renamed but whose grid still uses the old labels."""
    text = PAPER_TEXT.replace("\nVS = [0.0, 0.02, 0.05]", "\nXS = [0.0, 0.02, 0.05]")
    assert text != PAPER_TEXT
    path = tmp_path / "renamed.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(RuleTableError, match=r"renamed.toml:\d+: row 'VS': unknown curvature label; "
                                             r"curvature terms are ZO, XS, S"):
        load_rule_table(path)


# ---------------------------------------------------------------------------------------------
# coverage check against a dense scan

@st.composite
def term_sets(draw):
    n = draw(st.integers(1, 5))
    terms = []
    for i in range(n):
        xs = sorted(draw(st.lists(st.integers(0, 20), min_size=3, max_size=4)))
        if xs[0] == xs[-1]:
            xs[-1] += 1
        terms.append(Term(f"T{i}", tuple(x / 2 for x in xs)))
    hi = max(t.points[-1] for t in terms)
    return Variable("curvature", (0.0, float(hi)), tuple(terms))


@settings(max_examples=300, deadline=None)
@given(term_sets())
def test_uncovered_agrees_with_a_dense_scan(var):
    gap = uncovered(var)
    # memberships on a grid that holds every breakpoint and the midpoints between them
    xs = np.union1d(np.arange(0, 2 * var.universe[1] + 1) / 2, np.arange(0, 4 * var.universe[1] + 1) / 4)
    covered = membership(var, xs).max(axis=1) > 0
    if gap is None:
        assert covered.all()
    else:
        a, b = gap
        probe = a if a == b else 0.5 * (a + b)
        assert membership(var, np.array([probe])).max() == 0
        first_bad = xs[~covered][0]
        assert a <= first_bad <= b or (a < first_bad and first_bad - a < 0.5)
