"""The Python API of issue 39: ``AdviceOptions`` (frozen, checked when made, the command's one-line
errors), ``advise_file`` and its result (the same bytes as ``fuzzyfeed advise``, written in one
transaction), the public names loaded lazily, and the value notebook's few lines."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import fuzzyfeed as ff
from fuzzyfeed.cli import main
from fuzzyfeed.errors import FuzzyfeedError, InputError

REPO = Path(__file__).resolve().parents[1]
INCH = REPO / "benchmarks" / "library" / "programs" / "cncjs" / "helical-thread-milling.gcode"


def cli(capsys, *argv) -> tuple[int, str, str]:
    try:
        code = main(["advise", *map(str, argv)])
    except SystemExit as exc:         # argparse's refusals
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


# --------------------------------------------------------------- the options value
def test_options_are_frozen_and_checked_when_made():
    options = ff.AdviceOptions(machine="reference", feed_step_mm_min=50)
    with pytest.raises(dataclasses.FrozenInstanceError):
        options.feed_step_mm_min = 10
    assert isinstance(options.machine, ff.Machine) and options.machine == ff.load_machine("reference")
    assert options.table.name == "machine"                 # a machine's default table
    assert ff.AdviceOptions().table.name == "paper"
    assert options.replace(feed_step_mm_min=10).feed_step_mm_min == 10.0 and options.feed_step_mm_min == 50.0


@pytest.mark.parametrize("argv, fields", [
    (["--feed-mm-min", "-5"], {"feed_mm_min": -5}),
    (["--feed-mm-min", "inf"], {"feed_mm_min": float("inf")}),
    (["--rules", "machine"], {"rules": "machine"}),
    (["--rules", "no-such-table"], {"rules": "no-such-table"}),
    (["--machine", "no-such-machine"], {"machine": "no-such-machine"}),
])
def test_options_refuse_with_the_commands_own_line(argv, fields, capsys, tmp_path):
    code, out, err = cli(capsys, "trident", "-o", tmp_path / "x.csv", *argv)
    assert code == 2 and out == "" and not list(tmp_path.iterdir())
    with pytest.raises(FuzzyfeedError) as info:
        ff.AdviceOptions(**fields)
    assert err == f"fuzzyfeed: error: {info.value}\n"


@pytest.mark.parametrize("flag, value, field, bad", [
    ("--step-mm", "-1", "step_mm", -1), ("--window-mm", "0", "window_mm", 0),
    ("--points", "2", "points", 2), ("--filter", "median", "filter", "median"),
])
def test_options_refuse_what_argparse_refuses_with_the_same_rule(flag, value, field, bad, capsys, tmp_path):
    code, _, err = cli(capsys, "trident", "-o", tmp_path / "x.csv", flag, value)
    with pytest.raises(InputError) as info:
        ff.AdviceOptions(**{field: bad})
    rule = err.split(f"{value!r}" if field != "points" else value, 1)[1].strip()
    assert code == 2 and str(info.value).startswith(flag) and str(info.value).endswith(rule), (err, info.value)


def test_unknown_options_are_one_line():
    with pytest.raises(InputError, match="^feed: not an advice option; they are: rules, machine, "):
        ff.advise_file("trident", feed=100)
    with pytest.raises(InputError, match="options: dict; give an AdviceOptions"):
        ff.advise_file("trident", {"points": 100})


# --------------------------------------------------------------- advise_file = the command
def files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def test_a_program_on_a_machine_writes_the_commands_bytes(tmp_path, capsys):
    (tmp_path / "cli").mkdir()
    (tmp_path / "api").mkdir()
    code, out, _ = cli(capsys, INCH, "-o", tmp_path / "cli" / "h.csv", "--gcode", tmp_path / "cli" / "h.ngc",
                       "--machine", "reference", "--report", tmp_path / "cli" / "h.report.csv")
    assert code == 0
    result = ff.advise_file(INCH, machine="reference")
    wrote = result.write(csv=tmp_path / "api" / "h.csv", gcode=tmp_path / "api" / "h.ngc",
                         report=tmp_path / "api" / "h.report.csv")
    assert files(tmp_path / "cli") == files(tmp_path / "api")
    assert out.replace(str(tmp_path / "cli"), "") == \
        "\n".join([*result.summary(), *wrote]).replace(str(tmp_path / "api"), "") + "\n"
    # the value: four runs, the advised one within the tolerance here, and as a table
    report = result.value
    assert [r.label for r in report.rows][:2] == ["as written", "advised"] and len(report.rows) == 4
    table = result.value_table()
    assert list(table.index) == [r.label for r in report.rows]
    assert table.loc["advised", "holds"] and not table.loc["as written", "holds"]
    assert result.text == (tmp_path / "api" / "h.ngc").read_text()
    frame = result.frame()
    csv = pd.read_csv(tmp_path / "api" / "h.csv")
    assert list(frame.columns) == list(csv.columns) and len(frame) == len(csv)
    np.testing.assert_allclose(frame["feed_mm_min"], csv["feed_mm_min"], rtol=1e-12)
    html = result._repr_html_()
    assert "limit reference" in html and "holds the tolerance" in html
    assert result.plot().data.startswith(b"\x89PNG")
    assert result.figures()["cuts_advised"] == 1


def test_a_shape_and_the_overrides(tmp_path, capsys):
    base = ff.AdviceOptions(points=400, feed_mm_min=3000)
    result = ff.advise_file("wm", base, filter="mean")
    assert result.options == base.replace(filter="mean") and result.value is None
    code, out, _ = cli(capsys, "wm", "-o", tmp_path / "c.csv", "--points", "400", "--feed-mm-min", "3000",
                       "--filter", "mean", "--gcode", tmp_path / "c.ngc")
    result.write(csv=tmp_path / "a.csv", gcode=tmp_path / "a.ngc")
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "c.csv").read_bytes()
    assert (tmp_path / "a.ngc").read_bytes() == (tmp_path / "c.ngc").read_bytes() == result.text.encode()
    meta_a = json.loads((tmp_path / "a.csv-metadata.json").read_text())
    meta_c = json.loads((tmp_path / "c.csv-metadata.json").read_text())
    assert meta_a["notes"] == meta_c["notes"]
    with pytest.raises(FuzzyfeedError, match="the value report runs a G-code program on a machine"):
        result.value_table()


def _polygon_program(path: Path) -> Path:
    """A polygonal circle of 1 mm chords and a square corner: G1 moves whose curvature comes from
    the point-sequence fit, so --point-tolerance and --path-tolerance change the advice."""
    a = np.linspace(0.0, 1.5 * np.pi, 48)
    pts = [(20 * np.cos(t), 20 * np.sin(t)) for t in a] + [(0.0, -20.0), (0.0, -40.0), (30.0, -40.0)]
    lines = ["G21 G90 G17 G94", "G0 X20 Y0 Z2", "G1 Z-1 F300", "G1 X20 Y0 F1500"]
    lines += [f"X{x:.4f} Y{y:.4f}" for x, y in pts[1:]] + ["G0 Z5", "M2"]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("flags, fields", [(["--path-tolerance", "0.5"], {"path_tolerance": 0.5}),
                                           (["--point-tolerance", "0.3"], {"point_tolerance": 0.3})])
def test_the_tolerances_reach_a_result_asked_later(flags, fields, tmp_path, capsys):
    """A program's result advises when asked (``write``), after advise_file returned: it still
    advises with the tolerances it was given, as the command does (the API wrote the defaults')."""
    program = _polygon_program(tmp_path / "poly.ngc")
    code, _, _ = cli(capsys, program, "-o", tmp_path / "cli.csv", "--gcode", tmp_path / "cli.ngc", *flags)
    assert code == 0
    ff.advise_file(program, **fields).write(csv=tmp_path / "api.csv", gcode=tmp_path / "api.ngc")
    ff.advise_file(program).write(csv=tmp_path / "default.csv")
    assert (tmp_path / "api.csv").read_bytes() == (tmp_path / "cli.csv").read_bytes()
    assert (tmp_path / "api.ngc").read_bytes() == (tmp_path / "cli.ngc").read_bytes()
    assert (tmp_path / "api.csv").read_bytes() != (tmp_path / "default.csv").read_bytes()
    result = ff.advise_file(program, **fields)
    np.testing.assert_array_equal(result.frame()["feed_mm_min"], pd.read_csv(tmp_path / "cli.csv")["feed_mm_min"])


def test_write_is_one_transaction(tmp_path):
    result = ff.advise_file(INCH)
    with pytest.raises(FuzzyfeedError, match="--gcode"):
        result.write(csv=tmp_path / "a.csv", gcode=tmp_path / "missing" / "a.ngc")
    with pytest.raises(FuzzyfeedError, match="--report: the value report needs a machine"):
        result.write(csv=tmp_path / "a.csv", report=tmp_path / "r.html")
    assert not list(tmp_path.iterdir())                      # nothing, not even the CSV
    assert result.write(csv=tmp_path / "a.csv") == [f"wrote {tmp_path / 'a.csv'}"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv", "a.csv-metadata.json"]


# --------------------------------------------------------------- public names, lazily
def test_the_public_api_loads_lazily():
    code = ("import sys, fuzzyfeed as ff\n"
            "assert 'numpy' not in sys.modules, 'import fuzzyfeed loaded numpy'\n"
            "names = ['Machine', 'load_machine', 'AdviceOptions', 'advise_file', 'AdviceResult', 'advise_library']\n"
            "assert all(n in ff.__all__ and n in dir(ff) for n in names)\n"
            "assert 'numpy' not in sys.modules\n"
            "assert callable(ff.advise_file) and callable(ff.advise_library)\n"
            "import fuzzyfeed.batch\n"
            "assert not callable(fuzzyfeed.batch)\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr


def test_the_value_notebook_advises_in_five_lines_at_most():
    cells = json.loads((REPO / "notebooks" / "value.ipynb").read_text())["cells"]
    lines = [ln for c in cells if c["cell_type"] == "code" for ln in "".join(c["source"]).splitlines()
             if ln.strip() and not ln.strip().startswith("#")]
    assert len(lines) <= 5, lines
    assert any("advise_file" in ln and "machine=" in ln and "benchmarks/library" in ln for ln in lines)
