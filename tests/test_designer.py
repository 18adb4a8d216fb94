"""The rule designer without a browser: the document it edits (text edits that keep comments,
validation by field with rules check's messages, undo/redo, save and its conflicts, export), what
it draws (surface, 3-D projection, membership data) and the view's redraw after an edit."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fuzzyfeed.designer.compute import (breakpoint_axis, breakpoint_rows, control_surface, path_advice,
                                        project_surface)
from fuzzyfeed.designer.document import Document, FieldError, set_list_item, validate_text
from fuzzyfeed.errors import FileConflictError, RuleTableError
from fuzzyfeed.fuzzy.rule_reader import load_rule_table, parse_rule_table, resolve_rules_path
from fuzzyfeed.fuzzy.rule_writer import set_cell_text

PAPER = resolve_rules_path("paper")


@pytest.fixture
def mine(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(PAPER.read_text())
    return path


def test_cell_edit_is_the_text_rules_set_writes(mine):
    doc = Document(mine)
    for row, col, label in (("VS", "M", "HF"), ("ZO", "VH", "TF"), ("B", "L", "VVLF")):
        expected = set_cell_text(doc.text, row, col, label, mine)
        doc.set_cell(row, col, label)
        assert doc.text == expected        # the project's own in-place edit, aligned columns and all
    assert doc.table.grid[1][2] == "HF" and doc.valid


def test_breakpoint_edit_keeps_every_comment_and_changes_one_line(mine):
    doc = Document(mine)
    before = doc.text
    doc.set_point("curvature", "S", 1, 0.06)
    changed = [(a, b) for a, b in zip(before.splitlines(), doc.text.splitlines()) if a != b]
    assert changed == [("S  = [0.02, 0.05, 0.1]", "S  = [0.02, 0.06, 0.1]")]
    assert doc.table.curvature.term("S").points == (0.02, 0.06, 0.1)
    assert parse_rule_table(doc.text, mine).curvature.term("S").points == (0.02, 0.06, 0.1)


def test_a_list_over_several_lines_is_edited_through_tomlkit(tmp_path):
    text = PAPER.read_text().replace("S  = [0.02, 0.05, 0.1]", "S  = [0.02,   # rises\n  0.05, 0.1]")
    assert set_list_item(text, "curvature", "S", 1, "0.06") is None
    path = tmp_path / "multi.toml"
    path.write_text(text)
    doc = Document(path)
    doc.set_point("curvature", "S", 1, 0.06)
    assert "# rises" in doc.text and doc.table.curvature.term("S").points == (0.02, 0.06, 0.1)


def test_validation_gives_rules_checks_message_and_the_field(mine):
    doc = Document(mine)
    cases = [(lambda: doc.set_point("curvature", "VS", 1, 0.9), ("curvature", "VS")),
             (lambda: doc.set_point("curvature_variation", "L", 2, 0.1), ("curvature_variation", "L")),
             (lambda: doc.set_universe("curvature_variation", 1, 2.0), ("curvature_variation", None)),
             (lambda: doc.set_universe("feed", 1, 90.0), ("feed", "VVHF")),
             (lambda: doc.set_universe("curvature", 1, -1.0), ("curvature", "universe")),
             (lambda: doc.set_feature("filter_points", 20), ("features", "filter_points"))]
    for edit, field in cases:
        edit()
        assert isinstance(doc.error, FieldError) and (doc.error.section, doc.error.key) == field
        with pytest.raises(RuleTableError) as exc:          # what `rules check` says of this text
            parse_rule_table(doc.text, mine)
        reference = str(exc.value).split(": ", 1)[1]         # without its file:line
        assert doc.error.message == reference
        doc.undo()
        assert doc.valid
    assert "no rule can fire" in validate_text(
        PAPER.read_text().replace("M  = [0.25, 0.5, 0.75]", "M  = [0.6, 0.6, 0.75]"), None).message


def test_an_invalid_draft_keeps_the_last_valid_table_and_is_never_saved(mine):
    doc = Document(mine)
    table = doc.table
    doc.set_point("curvature", "VS", 1, 0.9)
    assert doc.table is table and not doc.valid
    with pytest.raises(RuleTableError, match="not saved"):
        doc.save()
    with pytest.raises(RuleTableError, match="not exported"):
        doc.export("fcl")
    assert mine.read_text() == PAPER.read_text()


def test_undo_redo_walk_the_history(mine):
    doc = Document(mine)
    texts = [doc.text]
    doc.set_cell("ZO", "ZO", "VHF")
    texts.append(doc.text)
    doc.set_points("curvature", [("ZO", 2, 0.03), ("S", 0, 0.03)])    # one step for both
    texts.append(doc.text)
    doc.undo()
    assert doc.text == texts[1]
    doc.undo()
    assert doc.text == texts[0] and not doc.can_undo
    doc.redo()
    doc.redo()
    assert doc.text == texts[2] and not doc.can_redo
    doc.undo()
    doc.set_cell("M", "M", "LF")            # a new edit drops the redo branch
    assert not doc.can_redo


def test_save_writes_the_draft_and_the_diff_is_rules_diff(mine):
    doc = Document(mine)
    doc.set_cell("VS", "M", "HF")
    doc.set_point("feed", "TF", 0, 80.0)
    assert doc.differences() == ["feed.TF: [85, 100, 100] -> [80, 100, 100]",
                                 "rule (curvature VS, curvature_variation M): VHF -> HF"]
    doc.save()
    assert mine.read_text() == doc.text and doc.differences() == []
    out = subprocess.run([sys.executable, "-m", "fuzzyfeed", "rules", "diff", str(PAPER), str(mine)],
                         capture_output=True, text=True, check=True).stdout
    assert "rule (curvature VS, curvature_variation M): VHF -> HF" in out and "feed.TF" in out


def test_save_never_overwrites_a_file_changed_on_disk_unasked(mine):
    doc = Document(mine)
    doc.set_cell("VS", "M", "HF")
    edited_elsewhere = mine.read_text().replace("filter_points = 21", "filter_points = 23")
    mine.write_text(edited_elsewhere)
    assert "changed on disk" in doc.conflict()
    with pytest.raises(FileConflictError, match="changed on disk"):
        doc.save()
    assert mine.read_text() == edited_elsewhere
    doc.save(overwrite=True)
    assert mine.read_text() == doc.text


def test_save_as_refuses_an_existing_other_file_and_shipped_tables_save_here(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    doc = Document("paper")
    assert doc.save_path == tmp_path / "paper.toml"
    other = tmp_path / "other.toml"
    other.write_text("# someone's\n")
    with pytest.raises(FileConflictError, match="exists"):
        doc.save(other)
    assert other.read_text() == "# someone's\n"
    assert doc.save() == tmp_path / "paper.toml"
    assert (tmp_path / "paper.toml").read_text() == PAPER.read_text()
    with pytest.raises(RuleTableError, match=r"\.toml"):
        doc.save(tmp_path / "x.fcl")


def test_reload_takes_the_disk_file_undoably(mine):
    doc = Document(mine)
    doc.set_cell("VS", "M", "HF")
    mine.write_text(mine.read_text().replace('"TF",   "TF"', '"TF",   "VLF"'))
    doc.reload()
    assert doc.text == mine.read_text() and doc.differences() == []
    doc.undo()
    assert doc.table.grid[1][2] == "HF"


def test_export_is_rules_show(mine):
    doc = Document(mine)
    doc.set_cell("VS", "M", "HF")
    doc.save()
    for fmt in ("fcl", "fll", "fis"):
        shown = subprocess.run([sys.executable, "-m", "fuzzyfeed", "rules", "show", str(mine), "--format", fmt],
                               capture_output=True, text=True, check=True).stdout
        assert doc.export(fmt) == shown


def test_a_bad_table_is_refused_at_open(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(PAPER.read_text().replace("VS = [0.0, 0.02, 0.05]", "VS = [0.0, 0.06, 0.05]"))
    with pytest.raises(RuleTableError, match=r"bad.toml:\d+: curvature.VS"):
        Document(bad)


def test_surface_is_the_engine_on_breakpoint_axes():
    from fuzzyfeed.fuzzy.engine import feed_pct

    table = load_rule_table()
    np.testing.assert_array_equal(breakpoint_axis(table.curvature), [0, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0])
    s = control_surface(table, n=25)
    assert s.pu[0] == 0 and s.pu[-1] == 6 and s.u[4] == 0.02       # 4 positions per interval
    j, i = 7, 9
    assert s.z[j, i] == feed_pct(table, np.array([s.u[i]]), np.array([s.v[j]]))[0]
    # between breakpoints the axis is linear in the value
    assert s.u[2] == pytest.approx(0.01)


def test_projection_draws_far_quadrilaterals_first():
    s = control_surface(load_rule_table(), n=21)
    p = project_surface(s, (0.0, 100.0), azimuth_deg=-60.0, elevation_deg=30.0, step=1)
    assert len(p.xs) == 20 * 20 and all(len(q) == 4 for q in p.xs)
    # seen from azimuth -60 the corner (u=1, v=0) is nearest: it is drawn last
    a = np.radians(-60.0)
    toward = np.array([np.cos(a), np.sin(a)])
    centres = [(np.mean(x), np.mean(y)) for x, y in zip(p.xs, p.ys)]
    assert len(centres) == 400
    top = project_surface(s, (0.0, 100.0), azimuth_deg=-90.0, elevation_deg=85.0, step=1)
    assert np.ptp(np.concatenate(top.xs)) == pytest.approx(1.0, abs=1e-9)   # u spans the width
    assert toward @ np.array([0.5, -0.5]) > toward @ np.array([-0.5, 0.5])


def test_breakpoint_rows_mark_peaks():
    table = load_rule_table()
    rows = breakpoint_rows(table.curvature)
    vb = [y for t, y in zip(rows["term"], rows["y"]) if t == "VB"]
    assert vb == [0.0, 1.0, 1.0, 0.0] and len(rows["x"]) == 3 * 5 + 4


def test_path_advice_is_advise_details():
    from fuzzyfeed.fuzzy.advisor import advise_details
    from fuzzyfeed.io.shapes import load_shape, sample_shape

    samples = sample_shape(load_shape("trident"), 500)
    table = load_rule_table()
    np.testing.assert_array_equal(path_advice(samples, table, 50.0).feed_pct,
                                  advise_details(samples, table, 50.0).feed_pct)


def test_view_redraws_after_typed_and_dragged_edits(mine):
    from fuzzyfeed.designer.app import Designer

    designer = Designer(mine, shape="trident", points=400)
    view = designer.view()
    surface0 = np.array(view.surface.image.data["image"][0])
    feed0 = np.array(view.path.path.data["feed"])
    view.point_inputs[("curvature", "S", 1)].value = 0.07
    assert designer.document.table.curvature.term("S").points[1] == 0.07
    assert not np.array_equal(view.surface.image.data["image"][0], surface0)
    assert not np.array_equal(view.path.path.data["feed"], feed0)
    assert "curvature.S" in view.diff.object and not view.save.disabled
    # a drag: the browser moves the B peak (position 5 of the axis) half-way to 0.5 (position 6)
    fig = view.mf[0]
    old = dict(fig.points.data)
    new = dict(old, x=[x + 0.5 if (t, k) == ("B", 1) else x
                       for x, t, k in zip(old["x"], old["term"], old["index"])])
    fig.points.data = new          # as the browser's edit arrives: the source's on_change runs
    assert designer.document.table.curvature.term("B").points == (0.1, 0.35, 0.5)
    view.cells[("ZO", "ZO")].value = "LF"
    assert designer.document.table.grid[0][0] == "LF"
    view.point_inputs[("curvature", "B", 1)].value = 0.6
    assert "breakpoints must be non-decreasing" in view.errors[("curvature", "B")].object
    assert view.save.disabled and all(w.disabled for w in view.exports)
    view.undo.clicks += 1
    assert view.errors[("curvature", "B")].object == "" and not view.save.disabled


def test_a_machine_table_is_edited_by_its_own_names():
    from fuzzyfeed.designer.app import Designer

    designer = Designer("machine", shape="trident", points=300)
    view = designer.view()
    first, second, out = designer.document.table.variables
    assert (first.name, second.name) == ("safe_feed_ratio", "safe_feed_ratio_near")
    assert set(view.cells) == {(r, c) for r in first.labels for c in second.labels}
    assert "--machine" in view.summary.object                  # the path panel waits for a machine
    before = np.array(view.surface.image.data["image"][0])
    view.cells[(first.labels[-1], second.labels[-1])].value = out.labels[0]
    assert not np.array_equal(view.surface.image.data["image"][0], before)
    assert designer.document.differences()[0].startswith(f"rule ({first.name} {first.labels[-1]}")


def test_with_a_machine_the_path_panel_shows_time_and_contour_error():
    from fuzzyfeed.designer.app import Designer
    from fuzzyfeed.designer.compute import path_on_machine
    from fuzzyfeed.fuzzy.advisor import advise_details
    from fuzzyfeed.machine.description import load_machine

    machine = load_machine("reference")
    designer = Designer("machine", shape="trident", points=600, machine=machine)
    view = designer.view()
    advice = advise_details(designer.samples, designer.document.table, designer.max_feed_mm_s, machine=machine)
    t, err = path_on_machine(designer.samples, advice.profile.feed_mm_s, machine)
    assert f"{t:.3f} s, max contour error" in view.summary.object
    assert f">{err:.1f}</span> um" in view.summary.object
    # the paper's table on the same machine runs faster and breaks the 50 um the machine table holds
    paper = advise_details(designer.samples, None, designer.max_feed_mm_s)
    t_paper, err_paper = path_on_machine(designer.samples, paper.profile.feed_mm_s, machine)
    assert err <= machine.contour_tol_um < err_paper and t_paper < t


def test_a_program_path_is_its_cut_on_exact_geometry():
    from fuzzyfeed.designer.app import load_path
    from fuzzyfeed.program.cuts import sample_cut
    from fuzzyfeed.program.read import read_program

    program = Path(__file__).parent / "programs" / "corpus" / "freecad_00.ngc"
    samples, name = load_path(program=str(program))
    expected = sample_cut(read_program(program), 0).samples
    np.testing.assert_array_equal(samples.xyz, expected.xyz)
    assert name == "freecad_00.ngc cut 1"
    with pytest.raises(Exception, match="path 2 does not exist"):
        load_path(program=f"{program}#2")
