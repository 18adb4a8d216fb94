"""CLI: shapes table, plot, --version, and one-line errors with exit code 2."""

from __future__ import annotations

import subprocess
import sys

import pytest

from fuzzyfeed import __version__
from fuzzyfeed.cli import main


def test_shapes_table(capsys):
    assert main(["shapes"]) == 0
    out = capsys.readouterr().out
    lines = {line.split()[0]: line.split() for line in out.splitlines()[2:]}
    assert lines["infinity"][1:4] == ["3", "7", "475.162"]
    assert lines["trident"][3] == "97.991"
    assert lines["butterfly"][3] == "382.860"
    assert float(lines["infinity"][4]) == pytest.approx(0.2304, abs=1e-4)


def test_plot_writes_png(tmp_path, capsys):
    out = tmp_path / "inf.png"
    assert main(["plot", "infinity", "-o", str(out), "--points", "500"]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert list(tmp_path.iterdir()) == [out]


@pytest.mark.parametrize("args, message", [
    (["plot", "nosuch", "-o", "x.png"], "shape 'nosuch': no such shipped shape or file"),
    (["plot", "{bad}", "-o", "x.png"], "invalid TOML"),
    (["plot", "{knots}", "-o", "x.png"], "knots[2] = 0.5 < knots[1] = 1; knots must be non-decreasing"),
    (["plot", "{unclamped}", "-o", "x.png"], "the knot vector must be clamped"),
    (["plot", "{weight}", "-o", "x.png"], "weights[0] = 0.0; weights must be finite and > 0"),
    (["plot", "{nan_point}", "-o", "x.png"], "control_points[1][0] = nan; coordinates must be finite"),
    (["plot", "{degree0}", "-o", "x.png"], "degree: 0 is not allowed"),
    (["plot", "{length}", "-o", "x.png"], "knots: length 3, expected n + p + 1"),
    (["plot", "{binary}", "-o", "x.png"], "binary file"),
    (["plot", "infinity", "-o", "{missing_dir}/x.png"], "does not exist"),
])
def test_bad_input_one_line_exit_2(tmp_path, capsys, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    files = {
        "bad": "degree = [\n",
        "knots": "degree = 1\nknotvector = [0, 1, 0.5, 1]\ncontrol_points = [[0, 0], [1, 0]]\n",
        "unclamped": "degree = 2\nknotvector = [0, 0, 0.2, 1, 1, 1]\ncontrol_points = [[0, 0], [1, 1], [2, 0]]\n",
        "weight": "degree = 1\nknotvector = [0, 0, 1, 1]\ncontrol_points = [[0, 0], [1, 0]]\nweights = [0, 1]\n",
        "nan_point": "degree = 1\nknotvector = [0, 0, 1, 1]\ncontrol_points = [[0, 0], [nan, 0]]\n",
        "degree0": "degree = 0\nknotvector = [0, 0.5, 1]\ncontrol_points = [[0, 0], [1, 0]]\n",
        "length": "degree = 1\nknotvector = [0, 0, 1]\ncontrol_points = [[0, 0], [1, 0]]\n",
    }
    names = {}
    for key, text in files.items():
        (tmp_path / f"{key}.toml").write_text(text)
        names[key] = f"{key}.toml"
    (tmp_path / "binary.toml").write_bytes(b"\x00\xff\x00")
    names["binary"] = "binary.toml"
    names["missing_dir"] = "no/such/dir"
    args = [a.format(**names) for a in args]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("fuzzyfeed: error: ") and message in err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not list(tmp_path.glob("*.png")) and not list(tmp_path.glob(".*.part"))


def test_version_does_not_import_matplotlib():
    code = ("import sys; from fuzzyfeed.cli import main\n"
            "try:\n    main(['--version'])\nexcept SystemExit:\n    pass\n"
            "bad = [m for m in ('matplotlib', 'pandas', 'ezdxf', 'skfuzzy') if m in sys.modules]\n"
            "print(','.join(bad))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    version_line, heavy = result.stdout.split("\n")[:2]
    assert version_line == f"fuzzyfeed {__version__}"
    assert heavy == "", f"--version imported {heavy}"


def test_help_explains_units(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "mm/min" in out and "SHAPE" in out
