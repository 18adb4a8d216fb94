"""Issue 10's catalogue run as tests: every hostile input one line, exit 2, no traceback, no warning,
nothing created or changed (tests/hostile_cases.py holds the cases). Resource bombs run in a
subprocess under a 500 MB address-space limit and must fail within 5 s."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from fuzzyfeed.cli import main
from hostile_cases import MESSAGES, SHAPE, _line, api_cases, cli_cases, correct_cases

CLI_CASES = cli_cases()
API_CASES = api_cases()


def snapshot(folder: Path) -> dict:
    out = {}
    for p in sorted(folder.rglob("*")):
        st = p.lstat()
        if stat.S_ISLNK(st.st_mode):
            out[str(p)] = ("link", os.readlink(p))
        elif stat.S_ISREG(st.st_mode):
            out[str(p)] = ("file", stat.S_IMODE(st.st_mode), st.st_mtime_ns, p.read_bytes())
        else:
            out[str(p)] = ("other", stat.S_IFMT(st.st_mode), stat.S_IMODE(st.st_mode))
    return out


def test_catalogue_size():
    assert len(CLI_CASES) + len(API_CASES) >= 300
    assert len({c[0] for c in CLI_CASES}) == len(CLI_CASES)


@pytest.mark.parametrize("argv, files", [pytest.param(a, f, id=i) for i, a, f in CLI_CASES])
def test_hostile_cli(tmp_path, monkeypatch, capsys, request, argv, files):
    work = tmp_path / "w"
    work.mkdir()
    monkeypatch.chdir(work)
    for name, content in files.items():
        target = work / name
        if callable(content):
            content(target)
        elif isinstance(content, bytes):
            target.write_bytes(content)
        else:
            target.write_text(content, encoding="utf-8")
    before = snapshot(tmp_path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse
            code = exc.code
    out, err = capsys.readouterr()
    assert code == 2, f"exit {code}\nstdout: {out}\nstderr: {err}"
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("fuzzyfeed: error: "), err
    assert "Traceback" not in err and ".part" not in err, err
    assert len(lines[0]) > len("fuzzyfeed: error: ") + 10
    assert not [str(w.message) for w in caught], [str(w.message) for w in caught]
    assert snapshot(tmp_path) == before
    expected = MESSAGES.get(request.node.callspec.id)
    assert expected is None or expected in lines[0], f"{expected!r} not in {lines[0]!r}"


def test_messages_name_existing_cases():
    assert set(MESSAGES) <= {c[0] for c in CLI_CASES}


@pytest.mark.parametrize("argv, files, made", [pytest.param(a, f, m, id=i) for i, a, f, m in correct_cases()])
def test_hostile_looking_inputs_with_a_correct_result(tmp_path, monkeypatch, capsys, argv, files, made):
    """Issue 28: these gave a warning, a traceback or a refusal; each has a correct result: exit
    0, the outputs written, at most notices on stderr, no Python warning."""
    monkeypatch.chdir(tmp_path)
    for name, content in files.items():
        (tmp_path / name).write_text(content, encoding="utf-8")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code = main(argv)
    out, err = capsys.readouterr()
    assert code == 0, err
    assert all(ln.startswith("fuzzyfeed: notice: ") for ln in err.splitlines()), err
    assert not [str(w.message) for w in caught], [str(w.message) for w in caught]
    for name in made:
        assert (tmp_path / name).exists(), name


@pytest.mark.parametrize("call", [pytest.param(c, id=i) for i, c in API_CASES])
def test_hostile_api(call):
    from fuzzyfeed.errors import FuzzyfeedError

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(FuzzyfeedError) as info:
            call()
    message = str(info.value)
    assert message and "\n" not in message
    assert not [str(w.message) for w in caught]


# -------------------------------------------------------------------------------- resource bombs
BOMB_RUNNER = """
import resource, sys
limit = 500 * 1024 * 1024
resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
from fuzzyfeed.cli import main
sys.exit(main(sys.argv[1:]))
"""

BOMBS = {
    "weights-1e308": {"s.toml": _line(SHAPE, "weights", "[1, 1e308, 1, 1]")},
    "weights-1e-300": {"s.toml": _line(SHAPE, "weights", "[1e-300, 1, 1e300, 1]")},
    "points-1e300": {"s.toml": _line(SHAPE, "control_points", "[[0, 0], [1e300, 5], [20, -5], [30, 0]]")},
    "knots-4e-300": {"s.toml": _line(SHAPE, "knotvector", "[0, 0, 0, 2e-300, 4e-300, 4e-300, 4e-300]")},
    "deep-toml": {"s.toml": "a = " + "[" * 100000 + "]" * 100000 + "\n"},
    "deep-json": {"s.json": "[" * 100000 + "]" * 100000},
}


def _big_csv(megabytes: int) -> str:
    """A point list of about ``megabytes`` MB: a 1000-row block of distinct points, repeated."""
    block = "".join(f"{k * 0.01:.4f},{(k * 7919) % 1000 / 100:.4f}\n" for k in range(1000))
    return "x_mm,y_mm\n" + block * (megabytes * 1_000_000 // len(block) + 1)


def test_big_point_file_refused_fast_naming_the_limit(tmp_path):
    """Issue 28: a 50 MB point file ran past 60 s; it is refused after counting 1e6 rows."""
    proc = _run_bomb(tmp_path, {"p.csv": _big_csv(50)}, ["advise", "p.csv", "-o", "o.csv"])
    assert proc.returncode == 2, proc.stderr
    assert len(proc.stderr.splitlines()) == 1 and "1,000,000" in proc.stderr and "p.csv" in proc.stderr


def test_endless_loop_refused_fast_naming_the_limit(tmp_path):
    text = "G21\nG0 X0 Y0\no1 while [1]\nG0 X[#1 mod 10]\n#1 = [#1 + 1]\no1 endwhile\nM2\n"
    proc = _run_bomb(tmp_path, {"p.ngc": text}, ["advise", "p.ngc", "-o", "o.csv"])
    assert proc.returncode == 2, proc.stderr
    assert len(proc.stderr.splitlines()) == 1 and "250,000" in proc.stderr and "p.ngc:" in proc.stderr


def _run_bomb(tmp_path, files, argv):
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    # the timeout catches a hang, it does not time the refusal (tests do not time things; the import
    # alone can take seconds on a loaded CI machine): the memory limit above is what a bomb hits
    proc = subprocess.run([sys.executable, "-c", BOMB_RUNNER, *argv], cwd=tmp_path, capture_output=True,
                          text=True, timeout=120)
    return proc


@pytest.mark.parametrize("name", list(BOMBS))
def test_shape_bombs_fail_fast_and_small(tmp_path, name):
    files = BOMBS[name]
    shape = next(iter(files))
    proc = _run_bomb(tmp_path, files, ["advise", shape, "-o", "o.csv"])
    assert proc.returncode == 2, proc.stderr
    assert len(proc.stderr.splitlines()) == 1 and proc.stderr.startswith("fuzzyfeed: error: "), proc.stderr
    assert not (tmp_path / "o.csv").exists()


@pytest.mark.parametrize("argv, files", [
    (["advise", "s.toml", "-o", "o.csv", "--points", "1000000000"], {"s.toml": SHAPE}),
    (["plot", "s.toml", "-o", "o.png", "--points", "1000000000"], {"s.toml": SHAPE}),
    (["schedule", "s.toml", "-o", "o.csv", "--chord-tol-mm", "1e308"], {"s.toml": SHAPE}),
    (["schedule", "s.toml", "-o", "o.csv", "--ts-s", "1e-9"], {"s.toml": SHAPE}),
    (["schedule", "s.toml", "-o", "o.csv", "--feed-mm-min", "1e-6"], {"s.toml": SHAPE}),
    (["advise", "p.ngc", "-o", "o.csv"],
     {"p.ngc": "G21 G90\nG0 X0 Y0\nG2 X10 Y0 I5 J0 P1000000000 F100\nM2\n"}),
    (["advise", "p.ngc", "-o", "o.csv"],
     {"p.ngc": "G21 G90\nG0 X0 Y0\nG2 X10 Y0 I500000 J0 P100 F100\nM2\n"}),
    (["advise", "d.dxf", "-o", "o.csv"],
     {"d.dxf": "0\nSECTION\n2\nENTITIES\n0\nLWPOLYLINE\n5\nA1\n8\n0\n90\n3\n70\n0\n10\n0\n20\n0\n42\n"
               "1e10\n10\n10\n20\n0\n10\n10\n20\n10\n0\nENDSEC\n0\nEOF\n"}),
], ids=["points-1e9", "plot-points-1e9", "chord-1e308", "ts-1e-9", "feed-1e-6", "g2-p-1e9",
        "g2-radius-5e5-100-turns", "bulge-1e10"])
def test_flag_and_file_bombs_fail_fast_and_small(tmp_path, argv, files):
    proc = _run_bomb(tmp_path, files, argv)
    assert proc.returncode == 2, proc.stderr
    assert len(proc.stderr.splitlines()) == 1 and proc.stderr.startswith("fuzzyfeed: error: "), proc.stderr


def test_tiny_bulge_is_a_straight_segment(tmp_path, capsys):
    """A bulge of 1e-300 is an arc whose sagitta is 1e-300 mm: a straight segment, no overflow."""
    from fuzzyfeed.io.dxf import bulge_points
    import numpy as np

    pts = bulge_points(np.array([0.0, 0.0]), np.array([10.0, 0.0]), 1e-300, 1e-4)
    assert pts.tolist() == [[10.0, 0.0]]


def test_tangent_breaks_find_corners_not_tangent_continuous_double_knots():
    """The 9-point circle has double knots (C1 lost in u) but a continuous tangent: no corner; a
    unit square of degree 1 turns 90 deg at each of its 3 interior vertices (closed form)."""
    import numpy as np
    from conftest import circle_nurbs
    from fuzzyfeed.geometry.nurbs import Nurbs
    from fuzzyfeed.geometry.sampling import tangent_breaks

    u, angle = tangent_breaks(circle_nurbs(5.0))
    assert u.size == 0
    square = Nurbs(1, [0, 0, 0.25, 0.5, 0.75, 1, 1], [[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]])
    u, angle = tangent_breaks(square)
    np.testing.assert_allclose(u, [0.25, 0.5, 0.75])
    np.testing.assert_allclose(angle, 90.0, atol=1e-6)
