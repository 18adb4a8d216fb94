"""The batch's parts without a cluster: which files a batch finds and where their results go,
advise's options passed on exactly, the manifest's keys, the chunks, the summary and its page,
and the command's one-line refusals (nothing created)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from fuzzyfeed.batch.discover import Source, find_sources
from fuzzyfeed.batch.manifest import file_key, is_current, options_sha256, sha256_file
from fuzzyfeed.batch.run import MAX_FILES_PER_CHUNK, make_chunks
from fuzzyfeed.batch.summary import pairs, summary_frame, summary_html
from fuzzyfeed.batch.work import Job
from fuzzyfeed.cli.batch import advise_options, forwarded_actions
from fuzzyfeed.errors import BatchError
from fuzzyfeed.program.model import GCODE_SUFFIXES

FUZZYFEED = [sys.executable, "-m", "fuzzyfeed"]


@pytest.fixture()
def tree(tmp_path) -> Path:
    shop = tmp_path / "shop"
    for rel in ("a/p1.ngc", "a/deep/p2.NC", "b/p3.tap", "b/d1.dxf", "b/readme.txt", "c.gcode"):
        (shop / rel).parent.mkdir(parents=True, exist_ok=True)
        (shop / rel).write_text("G21\n")
    return shop


def rels(sources) -> list[str]:
    return [s.rel for s in sources]


def test_folders_are_searched_recursively_by_suffix(tree, tmp_path):
    found = find_sources([str(tree)], tmp_path / "out", GCODE_SUFFIXES)
    assert rels(found) == ["a/deep/p2.NC", "a/p1.ngc", "b/d1.dxf", "b/p3.tap", "c.gcode"]
    assert {s.rel: s.kind for s in found}["b/d1.dxf"] == "drawing"
    assert all(s.path == os.path.normpath(str(tree / s.rel)) for s in found)


def test_several_arguments_share_their_common_folder(tree, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    found = find_sources(["shop/a", "shop/b/p3.tap", "shop/a/deep"], "out", GCODE_SUFFIXES)   # overlap: once
    assert rels(found) == ["a/deep/p2.NC", "a/p1.ngc", "b/p3.tap"]
    assert [s.path for s in found] == ["shop/a/deep/p2.NC", "shop/a/p1.ngc", "shop/b/p3.tap"]
    globbed = find_sources(["shop/**/*.ngc", "shop/*/*.tap"], "out", GCODE_SUFFIXES)
    assert rels(globbed) == ["a/p1.ngc", "b/p3.tap"]
    assert rels(find_sources(["shop/*"], "out", GCODE_SUFFIXES)) == \
        ["a/deep/p2.NC", "a/p1.ngc", "b/d1.dxf", "b/p3.tap", "c.gcode"]   # readme.txt left out


def test_a_results_folder_inside_the_library_is_not_searched(tree):
    out = tree / "results"
    (out / "a").mkdir(parents=True)
    (out / "a" / "p1.ngc").write_text("an advised program of an earlier run")
    assert "results/a/p1.ngc" not in rels(find_sources([str(tree)], out, GCODE_SUFFIXES))


@pytest.mark.parametrize("specs, out, message", [
    (["nowhere"], "out", "nowhere: no such file or folder"),
    (["shop/*.zip"], "out", r"shop/\*.zip: matches no file or folder"),
    (["shop/b/readme.txt"], "out", r"shop/b/readme.txt: not a program \(.ngc, .nc"),
    (["shop"], "shop", "--out shop: is or holds the input folder shop; results never go beside"),
    (["shop/a"], ".", r"--out \.: is or holds the input folder shop/a"),
    (["shop/c.gcode"], "shop", "--out shop: holds the input shop/c.gcode"),
    (["shop/b/readme.txt", "shop/a"], "out", "readme.txt: not a program"),
])
def test_bad_inputs_are_one_line(tree, tmp_path, monkeypatch, specs, out, message):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(BatchError, match=message):
        find_sources(specs, out, GCODE_SUFFIXES)


def test_an_empty_library_is_refused(tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(BatchError, match="no program .* or drawing .* found"):
        find_sources([str(tmp_path / "empty")], tmp_path / "out", GCODE_SUFFIXES)


def test_a_source_stays_inside_the_results():
    with pytest.raises(BatchError, match="leaves the results folder"):
        Source(path="x.ngc", rel="../x.ngc", kind="program")


# --------------------------------------------------------------- advise's options, passed on exactly
def test_options_are_passed_on_with_their_exact_values():
    words = advise_options({"feed_step_mm_min": 0.1, "step_mm": 1e-5 * 3, "path_tolerance": 0.01,
                            "points": 4000, "units": "inch", "filter": "mean", "line_numbers": False,
                            "rule_strengths": True})
    assert words["program"] == ["--path-tolerance", "0.01", "--step-mm", "3.0000000000000004e-05",
                                "--filter", "mean", "--feed-step-mm-min", "0.1"]   # advise's order
    assert words["drawing"] == ["--units", "inch", "--path-tolerance", "0.01", "--points", "4000",
                                "--filter", "mean", "--rule-strengths"]
    assert float("3.0000000000000004e-05") == 1e-5 * 3
    machine = advise_options({"axis_acc_mm_s2": (1000.0, 0.1, 800), "contour_tol_um": 50})
    assert machine["program"] == machine["drawing"] == ["--axis-acc-mm-s2", "1000.0,0.1,800.0", "--contour-tol-um", "50.0"]
    assert machine["machine"].axis_acc_mm_s2 == (1000.0, 0.1, 800.0) and machine["machine"].contour_tol_um == 50.0
    assert advise_options({"no_reference": True})["drawing"] == []        # the value report: programs only
    assert advise_options({})["machine"] is None


def test_every_advise_option_but_the_output_files_is_offered():
    from fuzzyfeed.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    advise = {a.dest for a in sub.choices["advise"]._actions if a.option_strings}
    batch = {a.dest.removeprefix("advise__") for a in sub.choices["batch"]._actions if a.dest.startswith("advise__")}
    assert batch == advise - {"help", "output", "gcode", "gcode_g52", "plot", "report"}
    assert {a.dest for a in forwarded_actions()} == batch


@pytest.mark.parametrize("options, message", [
    ({"feed_mm_minute": 100}, "feed_mm_minute: not an advise option"),
    ({"step_mm": -1}, "argument --step-mm: '-1' must be a finite number > 0"),
    ({"filter": "median"}, "argument --filter: invalid choice: 'median'"),
    ({"points": 2}, "argument --points: 2 is too few"),
    ({"machine": "no-such-machine"}, "no-such-machine"),
])
def test_bad_options_are_one_line(options, message):
    from fuzzyfeed.errors import FuzzyfeedError

    with pytest.raises(FuzzyfeedError, match=message):      # a bad machine is the machine's own error
        advise_options(options)


# --------------------------------------------------------------- manifest keys
def test_the_options_digest_covers_the_files_they_name(tmp_path):
    rules = tmp_path / "r.toml"
    rules.write_text("a")
    before = options_sha256(["--rules", str(rules)])
    assert options_sha256(["--rules", str(rules)]) == before
    rules.write_text("b")
    assert options_sha256(["--rules", str(rules)]) != before
    assert options_sha256(["--rules", "paper"]) != options_sha256(["--rules", "mean"])
    # a file's key also holds its own arguments: its path as given (the results record it)
    assert file_key(before, ["lib/a.ngc", "-o", "R/a.ngc.csv"]) != file_key(before, ["/x/lib/a.ngc", "-o", "R/a.ngc.csv"])
    assert file_key(before, ["a"]) == file_key(before, ["a"])


def test_an_entry_is_current_only_for_the_same_input_options_version_and_results(tmp_path):
    result = tmp_path / "p.ngc.csv"
    result.write_text("x")
    entry = {"status": "ok", "input_sha256": "i", "options_sha256": "o", "fuzzyfeed": "v",
             "outputs": [str(result)]}
    outputs = [str(result)]
    assert is_current(entry, "i", "o", "v", outputs)
    assert not is_current(entry, "j", "o", "v", outputs) and not is_current(entry, "i", "p", "v", outputs)
    assert not is_current(entry, "i", "o", "w", outputs) and not is_current(entry, None, "o", "v", outputs)
    assert is_current({**entry, "status": "refused"}, "i", "o", "v", outputs)
    assert not is_current({**entry, "status": "failed"}, "i", "o", "v", outputs)        # tried again
    result.unlink()
    assert not is_current(entry, "i", "o", "v", outputs)
    assert is_current({**entry, "status": "refused"}, "i", "o", "v", outputs)       # it had none
    assert sha256_file(__file__) == __import__("hashlib").sha256(Path(__file__).read_bytes()).hexdigest()


def test_chunks_hold_every_job_once_the_largest_alone():
    jobs = [Job(rel=f"f{n}", source="", argv=(), outputs=(), entry="", size=s)
            for n, s in enumerate([10_000, 9_000] + [10] * 100)]
    chunks = make_chunks(jobs, workers=2)
    flat = [j.rel for c in chunks for j in c]
    assert sorted(flat) == sorted(j.rel for j in jobs) and len(flat) == len(set(flat))
    assert [j.rel for j in chunks[0]] == ["f0"] and [j.rel for j in chunks[1]] == ["f1"]
    assert max(len(c) for c in chunks) <= MAX_FILES_PER_CHUNK


# --------------------------------------------------------------- summary
def entry(status="ok", **figures):
    return {"status": status, "reason": "" if status == "ok" else "why", "figures": figures,
            "compute_s": 0.5, "notes": ""}


def test_the_summary_has_a_row_per_file_and_the_machine_columns_only_when_given():
    sources = [Source("a.ngc", "a.ngc", "program"), Source("b.ngc", "b.ngc", "program"),
               Source("c.dxf", "c.dxf", "drawing")]
    plain = {"a.ngc": entry(cuts=2, cuts_advised=2, time_written_s=10.0, time_advised_s=12.5,
                            feed_pct_min=5.0, feed_pct_mean=60.0),
             "b.ngc": entry("refused")}
    frame = summary_frame(sources, plain, kept={"b.ngc"})
    assert list(frame.columns) == ["file", "kind", "status", "reason", "cuts", "time_written_s",
                                   "time_advised_s", "time_saved_s", "feed_pct_min", "feed_pct_mean",
                                   "judged_length_pct", "not_judged",
                                   "cuts_advised", "compute_s", "earlier_run", "notes"]
    assert frame["status"].tolist() == ["ok", "refused", "not run"]
    assert frame.loc[0, "time_saved_s"] == -2.5
    assert frame["earlier_run"].iloc[:2].tolist() == [False, True]
    assert pairs(frame) == [("time_s", "time_written_s", "time_advised_s")]
    page = summary_html(frame)
    assert page.count("<img") == 1 and "reports it when a machine is given" in page
    # the value report's row, as advise returns it with a machine
    machine = {"a.ngc": entry(**plain["a.ngc"]["figures"], contour_tol_um=50.0, written_max_um=254.0,
                              advised_max_um=19.0, written_p99_um=200.0, advised_p99_um=15.0,
                              uniform_time_s=30.0, uniform_max_um=50.0)}
    frame = summary_frame(sources[:1], machine, kept=set())
    assert "written_max_um" in frame.columns and "advised_p99_um" in frame.columns
    assert pairs(frame) == [("time_s", "time_written_s", "time_advised_s"),
                            ("max_um", "written_max_um", "advised_max_um"),
                            ("p99_um", "written_p99_um", "advised_p99_um")]
    assert summary_html(frame).count("<img") == 3


def test_the_page_escapes_file_names_and_reasons():
    sources = [Source("<b>.ngc", "<b>.ngc", "program")]
    page = summary_html(summary_frame(sources, {"<b>.ngc": {**entry("refused"), "reason": "<script>x"}}, set()))
    assert "<script>x" not in page and "&lt;script&gt;x" in page


# --------------------------------------------------------------- the command's refusals
@pytest.mark.parametrize("argv, message", [
    (["nowhere", "--out", "R"], "fuzzyfeed: error: nowhere: no such file or folder"),
    (["lib", "--out", "R", "--step-mm", "-1"], "fuzzyfeed: error: batch: argument --step-mm: '-1' must be"),
    (["lib", "--out", "R", "--workers", "0"], "fuzzyfeed: error: batch: argument --workers: 0 is too few"),
    (["lib", "--out", "R", "--workers", "2", "--scheduler", "tcp://127.0.0.1:9"],
     "fuzzyfeed: error: --workers: sizes a local cluster"),
    (["lib", "--out", "R", "--scheduler", "tcp://127.0.0.1:9"],
     "fuzzyfeed: error: --scheduler tcp://127.0.0.1:9: cannot connect"),
    (["lib", "--out", "R", "--scheduler", "tcp://nohost"], "fuzzyfeed: error: --scheduler tcp://nohost: not an address"),
    (["lib", "--out", "R", "-o", "x.csv"], "fuzzyfeed: error: batch: -o: the batch writes every file's results"),
    (["lib", "--out", "R", "--report", "x.html"], "fuzzyfeed: error: batch: --report: the batch writes every"),
    (["lib", "--out", "R", "--reports", "html"], "fuzzyfeed: error: --reports html: the value report needs a machine"),
    (["lib", "--out", "lib/p.ngc/R"], "fuzzyfeed: error: --out lib/p.ngc/R: lib/p.ngc is a file, not a folder"),
    (["lib", "--out", "R", "--gcode", "x.ngc"], "fuzzyfeed: error: batch: --gcode: the batch writes every file's results itself"),
])
def test_the_command_refuses_in_one_line_and_creates_nothing(tmp_path, monkeypatch, capsys, argv, message):
    from fuzzyfeed.cli import main

    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "p.ngc").write_text("G21\nG1 X1 F100\n")
    monkeypatch.chdir(tmp_path)
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    try:
        code = main(["batch", *argv])
    except SystemExit as exc:       # argparse's own refusals
        code = exc.code
    assert code == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith(message), captured.err
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before


def test_the_console_script_refuses_without_a_traceback(tmp_path):
    run = subprocess.run(FUZZYFEED + ["batch", "nowhere", "--out", "R"], cwd=tmp_path, capture_output=True,
                         text=True, timeout=120)
    assert (run.returncode, run.stderr, run.stdout) == (2, "fuzzyfeed: error: nowhere: no such file or folder\n", "")
    assert not (tmp_path / "R").exists()


def test_fuzzyfeed_batch_is_the_package_and_the_function(tmp_path):
    import importlib

    import fuzzyfeed

    assert "batch" in dir(fuzzyfeed) and callable(fuzzyfeed.batch)
    importlib.import_module("fuzzyfeed.batch.run")          # importing a submodule keeps it callable
    assert callable(fuzzyfeed.batch) and fuzzyfeed.batch is importlib.import_module("fuzzyfeed.batch")
    with pytest.raises(BatchError, match="nowhere: no such file or folder"):
        fuzzyfeed.batch(tmp_path / "nowhere", tmp_path / "out")
    with pytest.raises(BatchError, match="rule_table: not an advise option"):
        fuzzyfeed.batch(tmp_path, tmp_path / "out", rule_table="paper")
    assert not (tmp_path / "out").exists()
