"""``advise --verify-rs274`` on a program advised in windows (issue 36; fuzzyfeed.program.
verify_windows): rs274's calls compared as they come, the same verdict, kept lines, summary and
written program as the whole read's, byte for byte (the whole read stays the reference: each
check is made both ways, in windows of a few dozen lines)."""

from __future__ import annotations

import numpy as np
import pytest

import fuzzyfeed.program.rewrite as rewrite
import fuzzyfeed.program.windows as windows
from fuzzyfeed.program.verify_stream import _cat, _split, count, compare_call_streams
from test_gcode_export import rs274_binary
from test_program_windows import _compare, _raster


@pytest.mark.parametrize("window_lines", [40, 300])
def test_verified_in_windows_is_the_whole_reads_check(tmp_path, monkeypatch, capsys, window_lines):
    rs274_binary()
    prog = _raster(tmp_path / "r.ngc")
    out = _compare(tmp_path, prog, monkeypatch, capsys, window_lines, "--verify-rs274")
    assert "rs274 accepts the rewritten program" in out and "(2 run(s))" in out


def _refused_on(marked: set, monkeypatch):
    """The rewrite of the lines ``marked`` (their text) writes a negative F (rs274 refuses it; fuzzyfeed
    wrote it): a program where rs274 and the rewrite disagree, the same for both reads."""
    real = rewrite.piece_layout

    def layout(program, piece_move, piece_feed_mm_min):
        lo, hi, text = real(program, piece_move, piece_feed_mm_min)
        lines = program.move_line[piece_move]
        return lo, hi, [("-5" if program.lines[int(li)] in marked else t) for t, li in zip(text, lines)]

    monkeypatch.setattr(rewrite, "piece_layout", layout)


@pytest.mark.parametrize("window_lines", [40, 300])
def test_lines_rs274_refuses_are_kept_the_same_way_in_windows(tmp_path, monkeypatch, capsys, window_lines):
    """A line whose rewrite rs274 refuses, late in the program: the bisection over the windows
    keeps the same line with the same runs, the summary names it, the written program is the
    whole read's (the line keeps its text: no F-5)."""
    rs274_binary()
    prog = _raster(tmp_path / "r.ngc")
    text = prog.read_text().split("\n")
    marked = [i for i, ln in enumerate(text) if ln.startswith("G1 X10.0000")]
    line = marked[-2]                                 # in the last cut: a late window
    _refused_on({text[line]}, monkeypatch)
    out = _compare(tmp_path, prog, monkeypatch, capsys, window_lines, "--verify-rs274")
    said = [ln for ln in out.splitlines() if ln.startswith("rs274:")]
    assert said and said[0].startswith(f"rs274: 1 line(s) keep their text ({line + 1}): rewritten")
    assert "rs274 said: Negative f word" in said[0]
    written = (tmp_path / "win" / "y.ngc").read_text().split("\n")
    assert "F-5" not in "\n".join(written)


def test_a_program_rs274_refuses_is_unchecked_the_same_way(tmp_path, monkeypatch, capsys):
    """rs274 refuses the program as written (an M-code it does not know, M100 with no user file,
    which fuzzyfeed passes over): not checked, the rewrite written, the same line in the
    summary, windowed or whole."""
    rs274_binary()
    prog = _raster(tmp_path / "r.ngc")
    lines = prog.read_text().split("\n")
    lines.insert(len(lines) // 2, "M100")
    prog.write_text("\n".join(lines))
    out = _compare(tmp_path, prog, monkeypatch, capsys, 40, "--verify-rs274")
    assert "not checked with rs274: it refuses the program as written (Unknown m code used: M100" in out


def test_no_gcode_is_refused_before_the_windows(tmp_path, monkeypatch, capsys):
    from fuzzyfeed.cli import main

    prog = _raster(tmp_path / "r.ngc")
    monkeypatch.setattr(windows, "MIN_LINES", 1)
    monkeypatch.setattr(windows, "WINDOW_LINES", 40)
    assert main(["advise", str(prog), "-o", str(tmp_path / "x.csv"), "--verify-rs274"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--verify-rs274" in err[0] and "--gcode" in err[0]
    assert not (tmp_path / "x.csv").exists()


def test_the_streamed_comparison_is_the_lists_one_and_ranges_split_as_lists():
    start = [("STRAIGHT_TRAVERSE", "0.0000, 0.0000, 0.0000, 0, 0, 0")]
    line = [("STRAIGHT_FEED", "10.0000, 0.0000, 0.0000, 0, 0, 0")]
    more = [("STRAIGHT_FEED", "4.0000, 0.0000, 0.0000, 0, 0, 0"), ("PROGRAM_END", "")]
    assert compare_call_streams(iter(start + line), iter(start + more[:1] + line)) is None
    assert "1 more call(s)" in compare_call_streams(iter(start + line), iter(start + line + more[1:]))
    rng = np.random.default_rng(3)
    for _ in range(200):                   # ranges cut and joined as the lists of indices they stand for
        cuts = np.sort(rng.choice(40, size=6, replace=False))
        sel = [(int(a), int(b)) for a, b in zip(cuts[::2], cuts[1::2])]
        flat = [i for a, b in sel for i in range(a, b)]
        k = int(rng.integers(0, len(flat) + 1))
        a, b = _split(sel, k)
        assert [i for x, y in a for i in range(x, y)] == flat[:k]
        assert [i for x, y in b for i in range(x, y)] == flat[k:]
        assert [i for x, y in _cat(a, b) for i in range(x, y)] == flat and count(sel) == len(flat)


@pytest.mark.parametrize("window_lines", [40, 300])
def test_the_plot_in_windows_is_the_whole_reads(tmp_path, monkeypatch, capsys, window_lines):
    """--plot in windows: the thinned trace is kept as the rows come, the same PNG byte for byte as
    the whole read's (with the CSV, the program and the summary)."""
    out = _compare(tmp_path, _raster(tmp_path / "r.ngc"), monkeypatch, capsys, window_lines, "--plot", "p.png")
    assert "wrote x.csv and p.png" in out


def test_outputs_the_whole_read_refuses_are_refused_before_any_read(tmp_path, monkeypatch, capsys):
    """--report without a machine and --gcode-g52: one line, exit 2, nothing written, and the
    program never read (neither whole nor in windows)."""
    import fuzzyfeed.program.read as read
    import fuzzyfeed.program.window_advice as window_advice
    from fuzzyfeed.cli import main

    prog = _raster(tmp_path / "r.ngc")
    monkeypatch.setattr(windows, "MIN_LINES", 1)
    monkeypatch.setattr(window_advice, "read_windows", lambda *a, **k: pytest.fail("read in windows"))
    monkeypatch.setattr(read, "read_program", lambda *a, **k: pytest.fail("read whole"))
    for extra, said in ((["--report", str(tmp_path / "r.html")], "--report"),
                        (["--gcode-g52", str(tmp_path / "g.ngc")], "--gcode-g52")):
        assert main(["advise", str(prog), "-o", str(tmp_path / "x.csv"), *extra]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and said in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.ngc"]


def test_long_cuts_checked_and_plotted_in_windows_are_the_whole_reads(tmp_path, monkeypatch, capsys):
    """Cuts longer than a window (advised from the file in pieces, split at the windows' ends) with
    rs274's check and the plot: the windows' first pass hands each window its own moves, the
    check's rewrites read the same windows again; outputs byte for byte the whole read's."""
    import fuzzyfeed.geometry.polyline_runs as runs
    import fuzzyfeed.program.long_cut as long_cut
    import fuzzyfeed.program.stream as stream

    rs274_binary()
    monkeypatch.setattr(runs, "COMPILED_MIN_VERTICES", 0)   # as on a real long cut: compiled both ways
    monkeypatch.setattr(stream, "DEFAULT_PIECE_POINTS", 300)
    monkeypatch.setattr(long_cut, "FIT_WINDOW", 150)
    seen = []
    real = long_cut.advise_long_cut
    monkeypatch.setattr(long_cut, "advise_long_cut", lambda *a, **k: seen.append(1) or real(*a, **k))
    prog = _raster(tmp_path / "r.ngc", cuts=2, rows=12)
    out = _compare(tmp_path, prog, monkeypatch, capsys, 60, "--verify-rs274", "--plot", "p.png")
    assert seen and "rs274 accepts the rewritten program" in out
