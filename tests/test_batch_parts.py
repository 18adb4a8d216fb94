"""The batch's parts without a cluster: which files a batch finds and where their results go,
the options value each kind of file gets, the manifest's keys, the chunks, the summary and its page,
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
from fuzzyfeed.advice.options import AdviceOptions, make_options
from fuzzyfeed.cli.batch import forwarded_actions
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


# --------------------------------------------------------------- the options each file gets
def test_each_kind_of_file_gets_the_options_that_apply_to_it_exactly():
    options = AdviceOptions(feed_step_mm_min=0.1, step_mm=1e-5 * 3, path_tolerance=0.01, points=4000,
                            units="inch", filter="mean", line_numbers=False, rule_strengths=True)
    program, drawing = options.for_kind("program"), options.for_kind("drawing")
    assert program.changed() == {"feed_step_mm_min": 0.1, "step_mm": 1e-5 * 3, "filter": "mean",
                                 "path_tolerance": 0.01}                       # exact values, no text
    assert drawing.changed() == {"points": 4000, "filter": "mean", "rule_strengths": True, "units": "inch",
                                 "path_tolerance": 0.01}
    assert program.step_mm == 3.0000000000000004e-05
    machine = AdviceOptions(machine="reference").replace(machine=None)
    assert machine == AdviceOptions()
    with_machine = make_options(None, machine="reference", feed_mm_min=500)
    assert with_machine.for_kind("drawing").machine == with_machine.for_kind("program").machine
    assert with_machine.machine.contour_tol_um == 50.0 and with_machine.table.name == "machine"
    assert AdviceOptions(reference=False).for_kind("drawing").changed() == {}   # the value report: programs only
    assert AdviceOptions().changed() == {}


def test_the_options_value_goes_to_a_worker_as_it_is():
    import pickle

    options = AdviceOptions(machine="hobby-router", rules="machine-tuned", step_mm=0.5)
    again = pickle.loads(pickle.dumps(options))
    assert again == options and again.machine == options.machine
    assert (again.table.name, again.table.rules, again.table.variables) == \
        (options.table.name, options.table.rules, options.table.variables)


def test_every_advise_option_but_the_output_files_is_offered():
    from fuzzyfeed.advice.options import option_names
    from fuzzyfeed.cli import build_parser
    from fuzzyfeed.cli._machine import MACHINE_FLAGS, SERVO_FLAGS

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    advise = {a.dest for a in sub.choices["advise"]._actions if a.option_strings}
    batch = {a.dest.removeprefix("advise__") for a in sub.choices["batch"]._actions if a.dest.startswith("advise__")}
    assert batch == advise - {"help", "output", "gcode", "gcode_g52", "plot", "report"}
    assert {a.dest for a in forwarded_actions()} == batch
    # every one of them is a field of the options value (the machine flags make its machine)
    fields = set(option_names()) - {"reference"} | {"no_reference"}
    assert batch - set(MACHINE_FLAGS) - set(SERVO_FLAGS) == fields


@pytest.mark.parametrize("options, message", [
    ({"feed_mm_minute": 100}, "feed_mm_minute: not an advice option"),
    ({"step_mm": -1}, "--step-mm: -1 must be a finite number > 0"),
    ({"filter": "median"}, "--filter: invalid choice: 'median'"),
    ({"points": 2}, "--points: 2 is too few"),
    ({"feed_mm_min": float("nan")}, "--feed-mm-min = nan; the maximum feed must be a finite number > 0"),
    ({"rules": "machine"}, "--rules machine: table 'machine' reads the machine's terms"),
    ({"machine": "no-such-machine"}, "no-such-machine"),
])
def test_bad_options_are_one_line(options, message):
    from fuzzyfeed.errors import FuzzyfeedError, InputError, MachineLimitsError

    with pytest.raises(FuzzyfeedError, match=message) as info:     # a bad machine is the machine's own error
        make_options(None, **options)
    assert isinstance(info.value, (InputError, MachineLimitsError)) and "\n" not in str(info.value)


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
    jobs = [Job(rel=f"f{n}", source="", files=(), options=None, outputs=(), entry="", size=s)
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


def test_advise_library_is_the_python_api_and_the_batch_package_is_no_function(tmp_path):
    import importlib

    import fuzzyfeed
    from fuzzyfeed.errors import InputError

    assert not callable(importlib.import_module("fuzzyfeed.batch"))
    assert fuzzyfeed.advise_library is importlib.import_module("fuzzyfeed.batch.library").advise_library
    with pytest.raises(BatchError, match="nowhere: no such file or folder"):
        fuzzyfeed.advise_library(tmp_path / "nowhere", tmp_path / "out")
    with pytest.raises(InputError, match="rule_table: not an advice option"):
        fuzzyfeed.advise_library(tmp_path, tmp_path / "out", rule_table="paper")
    with pytest.raises(BatchError, match="--reports html: the value report needs a machine"):
        fuzzyfeed.advise_library(tmp_path, tmp_path / "out", reports="html")
    assert not (tmp_path / "out").exists()
