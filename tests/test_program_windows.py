"""A program read, advised and written in windows of lines (issue 36; fuzzyfeed.program.windows):
every window's moves and per-line state are the whole read's, and ``advise`` writes the same CSV,
sidecar, program and summary as the whole read (checked against the whole path, which stays the
reference; each check fails if a piece of carried state is dropped: the F in force, its units, the
position and epochs, the cut numbering, the F tracked by the rewrite)."""

from __future__ import annotations

import filecmp
import glob
import os
import warnings
from pathlib import Path

import numpy as np
import pytest

import fuzzyfeed.program.windows as windows
from fuzzyfeed.program.model import GCODE_SUFFIXES
from fuzzyfeed.program.read import read_program
from fuzzyfeed.program.windows import _PER_LINE, _PER_MOVE, Fallback, read_windows

ROOT = Path(__file__).resolve().parents[1]
LIBRARY = ROOT / "benchmarks" / "library" / "programs"


def _programs(limit_bytes: int = 400_000) -> list[str]:
    files = [p for r in (LIBRARY, ROOT / "tests") for p in glob.glob(str(r / "**" / "*"), recursive=True)
             if os.path.splitext(p)[1].lower() in GCODE_SUFFIXES and os.path.getsize(p) < limit_bytes]
    return sorted(files)


def _stitched(wins) -> dict:
    """The windows' arrays end to end, with the file's line and cut numbers."""
    out = {}
    for name in _PER_LINE:
        out[name] = np.concatenate([getattr(w.program, name) for w in wins])
    for name in _PER_MOVE:
        parts = []
        for w in wins:
            v = getattr(w.program, name)
            if name == "move_line":
                v = v + w.line0
            if name == "cut":
                v = np.where(v >= 0, v + w.cut0, v)
            parts.append(v)
        out[name] = np.concatenate(parts)
    return out


def _same_as_whole(path, window_lines: int):
    """None when the windows fall back, else the number of windows (asserting they equal the whole read)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            whole = read_program(path)
        except Exception:
            return None              # the whole read refuses it: the windows fall back to it
        try:
            wins = list(read_windows(path, window_lines=window_lines))
        except Fallback:
            return None
    got = _stitched(wins)
    lines = [ln for w in wins for ln in w.program.lines]
    assert lines == list(whole.lines)[:len(lines)], path
    for name in _PER_LINE:
        assert np.array_equal(got[name], getattr(whole, name)[:len(lines)]), (path, name)
    for name in _PER_MOVE:
        want = getattr(whole, name)
        assert got[name].shape == want.shape and np.array_equal(got[name], want, equal_nan=want.dtype.kind == "f"), \
            (path, name)
    return len(wins)


def test_windows_equal_the_whole_read_on_the_library(monkeypatch):
    """Windows of 40 and 300 lines (grown to hold a cut) on every program of the library and the
    tests: the same lines, per-line state and moves as the whole read (or a fallback, never a
    different program)."""
    monkeypatch.setattr(windows, "MAX_GROWTH", 1 << 20)
    files = _programs()
    assert len(files) > 50
    joined = 0
    for w in (40, 300):
        counts = [_same_as_whole(p, w) for p in files]
        joined += sum(1 for c in counts if c is not None and c > 1)
    assert joined > 60          # most programs are read in several windows, not sent back whole


def _raster(path: Path, cuts: int = 6, rows: int = 6, inch: bool = False, tail: bool = True) -> Path:
    """A small multi-cut program as posts write them: header, cuts entered by a rapid and a plunge
    with its F (F on the plunge line and on the first cutting move), spindle and coolant codes,
    a tool change, lines after M30."""
    u = 1 / 25.4 if inch else 1.0
    rng = np.random.default_rng(7)
    out = ["%", "(windowed test raster)", "G20 G90 G94 G17" if inch else "G21 G90 G94 G17", "T1 M6", "G43 H1",
           "S10000 M3"]
    for c in range(cuts):
        y0 = c * 3.0
        out += [f"G0 Z{5 * u:.4f}", f"G0 X0 Y{y0 * u:.4f}", f"G1 Z{-1 * u:.4f} F{300 * u:.3f}"]
        first = True
        for r in range(rows):
            xs = np.linspace(0, 20, 25) if r % 2 == 0 else np.linspace(20, 0, 25)
            for x in xs[1:]:
                z = -1 - 0.3 * np.sin(x / 3 + r) + rng.uniform(-0.01, 0.01)
                word = f" F{1500 * u:.3f}" if first else ""
                first = False
                out.append(f"G1 X{x * u:.4f} Y{(y0 + 0.4 * r) * u:.4f} Z{z * u:.4f}{word}")
        out += ["(end of cut)", f"G0 Z{5 * u:.4f}"]
        if c == cuts // 2:
            out += ["M5", "T2 M6", "G43 H2", "S8000 M3"]
    out += ["M5", "M30", "(after the end)", "G1 X1 Y1", "%"] if tail else ["M5", "M30"]
    path.write_text("\n".join(out) + "\n")
    return path


def _advise(tmp: Path, prog: Path, windowed: bool, monkeypatch, window_lines: int, *extra):
    from fuzzyfeed.cli import main

    monkeypatch.setattr(windows, "MIN_LINES", 1 if windowed else 10 ** 12)
    monkeypatch.setattr(windows, "WINDOW_LINES", window_lines)
    tmp.mkdir()
    monkeypatch.chdir(tmp)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        rc = main(["advise", str(prog), "-o", "x.csv", "--gcode", "y.ngc", *extra])
    return rc, [str(w.message) for w in said]


def _compare(tmp_path, prog, monkeypatch, capsys, window_lines, *extra):
    import fuzzyfeed.program.window_advice as window_advice

    used = []
    real = window_advice.advise_in_windows
    monkeypatch.setattr(window_advice, "advise_in_windows", lambda *a, **k: used.append(1) or real(*a, **k))
    a = _advise(tmp_path / "whole", prog, False, monkeypatch, window_lines, *extra)
    out_a = capsys.readouterr().out
    b = _advise(tmp_path / "win", prog, True, monkeypatch, window_lines, *extra)
    out_b = capsys.readouterr().out
    assert used, "the windowed path was not taken"
    assert a == b and out_a == out_b
    names = sorted(os.listdir(tmp_path / "whole"))
    assert names == sorted(os.listdir(tmp_path / "win")) and "y.ngc" in names
    for name in names:
        assert filecmp.cmp(tmp_path / "whole" / name, tmp_path / "win" / name, shallow=False), name
    return out_b


@pytest.mark.parametrize("inch", [False, True])
@pytest.mark.parametrize("window_lines", [60, 400])
def test_advise_in_windows_is_the_whole_advice(tmp_path, monkeypatch, capsys, inch, window_lines):
    """CSV, its sidecar, the rewritten program and the summary byte for byte the whole path's,
    in mm and in inches (an F on a window's first line is read in the units before it)."""
    prog = _raster(tmp_path / "r.ngc", inch=inch)
    out = _compare(tmp_path, prog, monkeypatch, capsys, window_lines)
    assert "6 cut(s)" in out


def test_a_cut_longer_than_a_window_grows_it(tmp_path, monkeypatch, capsys):
    prog = _raster(tmp_path / "r.ngc", cuts=2, rows=12)
    monkeypatch.setattr(windows, "SPLIT_CUTS", False)
    with pytest.raises(Fallback):           # by default a window does not grow: read whole
        list(read_windows(prog, window_lines=80))
    monkeypatch.setattr(windows, "MAX_GROWTH", 4)
    with pytest.raises(Fallback):           # a cut over MAX_GROWTH windows: read whole
        list(read_windows(prog, window_lines=20))
    wins = list(read_windows(prog, window_lines=80))
    assert [w.program.n_cuts for w in wins] == [0, 1, 1]         # the header, then one cut a window
    assert min(len(w.program.lines) for w in wins[1:]) > 12 * 24     # each grown to hold its cut
    _compare(tmp_path, prog, monkeypatch, capsys, 80, "--feed-mm-min", "1200")


def test_a_cut_longer_than_a_window_is_split_inside_it(tmp_path):
    """Without a line where a cut starts or ends, a window ends inside its last cut and the next
    goes on with it: the windows stitched are the whole read (one cut numbered once); read again
    from a window's start, the same windows."""
    prog = _raster(tmp_path / "r.ngc", cuts=2, rows=12)
    assert _same_as_whole(prog, 80) > 6
    wins = list(read_windows(prog, window_lines=80))
    assert sum(w.continues for w in wins) > 4
    assert [w.continued for w in wins[1:]] == [w.continues for w in wins[:-1]]
    again = list(read_windows(prog, window_lines=80, start=wins[3]))
    assert len(again) == len(wins) - 3
    for w, v in zip(wins[3:], again):
        assert (w.line0, w.cut0, w.continues, w.continued) == (v.line0, v.cut0, v.continues, v.continued)
        assert list(w.program.lines) == list(v.program.lines)
        for name in _PER_MOVE:
            x, y = getattr(w.program, name), getattr(v.program, name)
            assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), name


@pytest.mark.parametrize("change, why", [
    ("G91 G1 X0.1", "G91"), ("G55", "frames"), ("G52 X1", "frames"), ("G41.1 D3", "compensation"), ("#1=2", "parameters"),
    ("G81 X1 Y1 Z-1 R1", "cycles"),
])
def test_what_cannot_be_joined_falls_back(tmp_path, change, why):
    """Where a join would not be exact the windows give up (the whole read is taken)."""
    lines = _raster(tmp_path / "r.ngc").read_text().split("\n")
    lines.insert(len(lines) // 2, change)
    prog = tmp_path / "c.ngc"
    prog.write_text("\n".join(lines))
    with pytest.raises(Fallback):
        list(read_windows(prog, window_lines=50))


def test_an_error_halfway_leaves_the_outputs_and_says_what_the_whole_read_says(tmp_path, monkeypatch, capsys):
    from fuzzyfeed.cli import main

    lines = _raster(tmp_path / "r.ngc").read_text().split("\n")
    lines.insert(len(lines) * 2 // 3, "G1 X1 Q")
    prog = tmp_path / "bad.ngc"
    prog.write_text("\n".join(lines))
    monkeypatch.setattr(windows, "WINDOW_LINES", 50)
    said = []
    for windowed in (False, True):
        monkeypatch.setattr(windows, "MIN_LINES", 1 if windowed else 10 ** 12)
        (tmp_path / "x.csv").write_text("mine")
        rc = main(["advise", str(prog), "-o", str(tmp_path / "x.csv"), "--gcode", str(tmp_path / "y.ngc")])
        assert rc == 2
        assert (tmp_path / "x.csv").read_text() == "mine" and not (tmp_path / "y.ngc").exists()
        said.append(capsys.readouterr().err)
    assert said[0] == said[1] and str(prog) in said[0]


def test_a_fallback_keeps_no_window_alive_during_the_whole_read(tmp_path, monkeypatch, capsys):
    """When the windows give up, the whole read runs with no window's read program still held (the
    fallback once ran inside the ``except``, whose traceback kept the last window read alive: a
    10⁶-line one-cut raster's peak 646 → 717 MB)."""
    import gc

    import fuzzyfeed.program.read as read
    from fuzzyfeed.cli import main
    from fuzzyfeed.program.model import Program

    prog = _raster(tmp_path / "r.ngc", cuts=2, rows=12)
    monkeypatch.setattr(windows, "MIN_LINES", 1)
    monkeypatch.setattr(windows, "WINDOW_LINES", 80)
    monkeypatch.setattr(windows, "SPLIT_CUTS", False)       # a cut longer than a window: read whole
    alive = []
    real = read.read_program

    def whole_read(*a, **k):
        gc.collect()
        alive.append(sum(type(o) is Program for o in gc.get_objects()))   # type(): a dead weakproxy raises on isinstance
        return real(*a, **k)

    monkeypatch.setattr(read, "read_program", whole_read)
    monkeypatch.chdir(tmp_path)
    assert main(["advise", str(prog), "-o", "x.csv", "--gcode", "y.ngc"]) == 0
    assert alive == [0]


def _spiral(path: Path, n: int = 1500, tiny: bool = False, arcs: bool = False, inch: bool = False) -> Path:
    """One long cut: an Archimedean spiral of G1 moves to 4 decimals (``tiny``: repeated points and
    0.1 µm jogs, merged by the fit; ``arcs``: a few G2 moves inside the cut)."""
    u = 1 / 25.4 if inch else 1.0
    rng = np.random.default_rng(11)
    t = np.linspace(0, 12 * np.pi, n)
    r = 2 + 1.5 * t
    xs, ys = r * np.cos(t), r * np.sin(t)
    out = ["%", "G20 G90 G94 G17" if inch else "G21 G90 G94 G17", "T1 M6", "S9000 M3",
           f"G0 X{xs[0] * u:.4f} Y{ys[0] * u:.4f} Z{5 * u:.4f}", f"G1 Z{-1 * u:.4f} F{200 * u:.3f}"]
    for i in range(1, n):
        word = f" F{1800 * u:.3f}" if i == 1 else ""
        if arcs and i % 400 == 0:
            out.append(f"G1 X{xs[i] * u:.4f} Y{ys[i] * u:.4f}")
            out.append(f"G2 X{xs[i] * u + 1:.4f} Y{ys[i] * u:.4f} I0.5 J0")
            out.append(f"G1 X{xs[i] * u:.4f} Y{ys[i] * u:.4f}")
            continue
        out.append(f"G1 X{xs[i] * u:.4f} Y{ys[i] * u:.4f}{word}")
        if tiny and rng.random() < 0.1:
            out.append(f"G1 X{xs[i] * u:.4f} Y{ys[i] * u:.4f}")                         # a repeated point
        if tiny and rng.random() < 0.05:
            out.append(f"G1 X{(xs[i] * u + 0.0001):.4f} Y{ys[i] * u:.4f}")              # a 0.1 µm jog
    out += [f"G0 Z{5 * u:.4f}", "M5", "M30", "%"]
    path.write_text("\n".join(out) + "\n")
    return path


@pytest.fixture
def long_cuts(monkeypatch):
    """Count the long cuts advised in pieces and their pieces; small pieces, a small fit window
    (the fit in chunks), the compiled run search on both sides."""
    import fuzzyfeed.geometry.polyline_runs as runs
    import fuzzyfeed.program.long_cut as long_cut
    import fuzzyfeed.program.stream as stream

    monkeypatch.setattr(runs, "COMPILED_MIN_VERTICES", 0)
    monkeypatch.setattr(stream, "DEFAULT_PIECE_POINTS", 300)
    monkeypatch.setattr(long_cut, "FIT_WINDOW", 150)
    seen = {"cuts": 0, "pieces": 0, "ended": 0}
    real = long_cut.advise_long_cut

    def spy(*a, **k):
        seen["cuts"] += 1
        for p in real(*a, **k):
            seen["pieces"] += 1
            yield p
        seen["ended"] += 1

    monkeypatch.setattr(long_cut, "advise_long_cut", spy)
    return seen


@pytest.mark.parametrize("inch", [False, True])
@pytest.mark.parametrize("window_lines", [60, 130])
def test_a_cut_longer_than_a_window_is_advised_in_pieces(tmp_path, monkeypatch, capsys, long_cuts, inch,
                                                        window_lines):
    """A cut over many windows, advised from the file in pieces (the fit in chunks, the plan and s
    carried, the Dκ range and the peaks from their passes, the filter's sums handed on): CSV,
    sidecar, program and summary byte for byte the whole read's, in mm and in inches."""
    prog = _raster(tmp_path / "r.ngc", cuts=2, rows=12, inch=inch)
    _compare(tmp_path, prog, monkeypatch, capsys, window_lines)
    assert long_cuts["cuts"] == 2 and long_cuts["ended"] == 2 and long_cuts["pieces"] > 4


@pytest.mark.parametrize("case", ["spiral", "tiny moves", "inch spiral", "capped"])
def test_one_long_cut_is_the_whole_advice(tmp_path, monkeypatch, capsys, long_cuts, case):
    prog = _spiral(tmp_path / "s.ngc", tiny=case == "tiny moves", inch=case == "inch spiral")
    extra = ("--feed-mm-min", "900") if case == "capped" else ()
    _compare(tmp_path, prog, monkeypatch, capsys, 200, *extra)
    assert long_cuts["cuts"] == 1 and long_cuts["ended"] == 1 and long_cuts["pieces"] > 4


def test_a_long_cut_with_arcs_falls_back_to_the_whole_read(tmp_path, monkeypatch, capsys, long_cuts):
    """Arcs in a cut longer than a window: not advised in pieces from the file (the whole read
    gives the same outputs)."""
    prog = _spiral(tmp_path / "a.ngc", arcs=True)
    _compare(tmp_path, prog, monkeypatch, capsys, 200)
    assert long_cuts["cuts"] == 1 and long_cuts["pieces"] == 0


def test_the_pieces_need_their_carried_state(tmp_path, monkeypatch, capsys, long_cuts):
    """The check can fail: pieces whose arc length is not carried from the piece before (each
    summed from 0) give another CSV."""
    import fuzzyfeed.program.long_cut as long_cut

    prog = _spiral(tmp_path / "s.ngc")
    real = long_cut.path_length
    monkeypatch.setattr(long_cut, "path_length", lambda pts, anchor, s0: real(pts, anchor, 0.0))
    with pytest.raises(AssertionError):
        _compare(tmp_path, prog, monkeypatch, capsys, 200)
    assert long_cuts["pieces"] > 4
