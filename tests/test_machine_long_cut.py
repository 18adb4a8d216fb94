"""A cut longer than a window of lines advised on a machine in windows (issue 36;
program/long_cut_machine.py, program/machine_windows.py): the cut read into a scratch folder and
advised in pieces from it (the plan and s of pass 0, the settling levels of pass 1, corner-mean's
guard of pass 1b, the filter's sums of pass 2, the entry rapid's direction from the windows before),
the written run's chains and cut numbers the whole read's — ``advise --machine`` writes the same
CSV, sidecar, program and summary as the whole read, byte for byte. The whole read advises each
cut in one piece; the windows in many pieces of a few hundred samples."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from test_machine_windows import _compare


def _program(path: Path, rows=(30,), inch: bool = False, feed: float = 1500.0, fast_row: int | None = None) -> Path:
    """Cuts of ``rows`` raster rows each (a long cut: many rows), each entered by a rapid and a
    plunge, as posts write them; ``fast_row``: that row of every cut at twice the F."""
    u = 1 / 25.4 if inch else 1.0
    rng = np.random.default_rng(11)
    out = ["%", "(long cut on a machine)", "G20 G90 G94 G17" if inch else "G21 G90 G94 G17", "T1 M6", "G43 H1",
           "S10000 M3"]
    for c, n_rows in enumerate(rows):
        y0 = c * 6.0
        out += [f"G0 Z{5 * u:.4f}", f"G0 X0 Y{y0 * u:.4f}", f"G1 Z{-1 * u:.4f} F{300 * u:.3f}"]
        first = True
        for r in range(n_rows):
            xs = np.linspace(0, 20, 25) if r % 2 == 0 else np.linspace(20, 0, 25)
            for x in xs[1:]:
                z = -1 - 0.3 * np.sin(x / 3 + r) + rng.uniform(-0.01, 0.01)
                word = f" F{feed * u:.3f}" if first else ""
                if fast_row is not None and x == xs[1] and r in (fast_row, fast_row + 1):
                    word = f" F{feed * u * (2 if r == fast_row else 1):.3f}"
                first = False
                out.append(f"G1 X{x * u:.4f} Y{(y0 + 0.4 * r) * u:.4f} Z{z * u:.4f}{word}")
        out += ["(end of cut)", f"G0 Z{5 * u:.4f}"]
    out += ["M5", "M30", "%"]
    path.write_text("\n".join(out) + "\n")
    return path


@pytest.fixture
def long_cuts(monkeypatch):
    """Count the long cuts advised on a machine in pieces, their pieces and the windows' cut
    ``k`` they start as; small pieces and fit windows (the whole read: one piece a cut)."""
    import fuzzyfeed.geometry.polyline_runs as runs
    import fuzzyfeed.program.long_cut as long_cut
    import fuzzyfeed.program.long_cut_machine as lcm
    import fuzzyfeed.program.stream as stream

    monkeypatch.setattr(runs, "COMPILED_MIN_VERTICES", 0)
    monkeypatch.setattr(stream, "DEFAULT_PIECE_POINTS", 300)
    monkeypatch.setattr(long_cut, "FIT_WINDOW", 150)
    seen = {"cuts": 0, "pieces": 0, "ended": 0, "starts": []}
    real = lcm.advise_long_cut_machine

    def spy(path, first, k, *a, **kw):
        seen["cuts"] += 1
        seen["starts"].append((k, first.cut0 + k))
        for p in real(path, first, k, *a, **kw):
            seen["pieces"] += 1
            yield p
        seen["ended"] += 1

    monkeypatch.setattr(lcm, "advise_long_cut_machine", spy)
    return seen


@pytest.mark.parametrize("inch", [False, True])
@pytest.mark.parametrize("window_lines", [60, 130])
def test_a_one_cut_raster_is_advised_in_windows_on_a_machine(tmp_path, monkeypatch, capsys, long_cuts, inch,
                                                            window_lines):
    """One cut over several windows, over the tolerance: advised in pieces from the file and
    rewritten, byte for byte the whole read's (the summary counts one cut: the split cut once)."""
    prog = _program(tmp_path / "r.ngc", inch=inch, fast_row=17)
    out = _compare(tmp_path, prog, monkeypatch, capsys, window_lines, "--machine", "reference")
    assert "1 cut(s)" in out and "advised 1 cut(s)" in out
    assert long_cuts["cuts"] == 1 and long_cuts["ended"] == 1 and long_cuts["pieces"] > 4


def test_a_long_cut_under_the_tolerance_is_left_as_written(tmp_path, monkeypatch, capsys, long_cuts):
    """The same cut at a slow F: under the tolerance, its rows advised 0, the program as written."""
    prog = _program(tmp_path / "r.ngc", feed=60.0)
    out = _compare(tmp_path, prog, monkeypatch, capsys, 60, "--machine", "reference")
    assert "1 cut(s)" in out and "advised 0 cut(s)" in out
    assert (tmp_path / "win" / "y.ngc").read_bytes() == prog.read_bytes()
    assert long_cuts["cuts"] == 1 and long_cuts["ended"] == 1


@pytest.mark.parametrize("window_lines", [60, 100])
def test_a_long_cut_among_short_ones(tmp_path, monkeypatch, capsys, long_cuts, window_lines):
    """Short cuts before and after a long one: the long cut is its window's cut 0, entered by a
    rapid in the window before (the direction carried), and the cuts after it are numbered as the
    whole read numbers them."""
    prog = _program(tmp_path / "r.ngc", rows=(2, 2, 30, 1, 2))
    out = _compare(tmp_path, prog, monkeypatch, capsys, window_lines, "--machine", "reference")
    assert "5 cut(s)" in out
    assert long_cuts["cuts"] == 1 and long_cuts["ended"] == 1 and long_cuts["pieces"] > 4
    assert long_cuts["starts"] == [(0, 2)]


def test_long_cuts_one_after_another(tmp_path, monkeypatch, capsys, long_cuts):
    """Two long cuts with a short one between, with a plain table on the machine too (its long
    cut: :func:`~fuzzyfeed.program.long_cut.advise_long_cut`)."""
    prog = _program(tmp_path / "r.ngc", rows=(30, 1, 30))
    out = _compare(tmp_path, prog, monkeypatch, capsys, 100, "--machine", "reference")
    assert "3 cut(s)" in out and long_cuts["cuts"] == 2 and long_cuts["ended"] == 2
    assert [c for _, c in long_cuts["starts"]] == [0, 2]
    import fuzzyfeed.program.long_cut as long_cut

    plain = []
    real = long_cut.advise_long_cut
    monkeypatch.setattr(long_cut, "advise_long_cut", lambda *a, **k: plain.append(1) or real(*a, **k))
    (tmp_path / "paper").mkdir()
    _compare(tmp_path / "paper", prog, monkeypatch, capsys, 100, "--machine", "reference", "--rules", "paper")
    assert len(plain) == 2 and long_cuts["cuts"] == 2


@pytest.mark.parametrize("filt", ["corner-mean", "mean", "min-mean"])
def test_a_long_cut_with_a_filter_in_mm(tmp_path, monkeypatch, capsys, long_cuts, filt):
    """The machine table with a filter over 3 mm (corner-mean: its guard from pass 1b; the
    filter's sums handed from piece to piece)."""
    prog = _program(tmp_path / "r.ngc", rows=(1, 30, 1), fast_row=17)
    _compare(tmp_path, prog, monkeypatch, capsys, 60, "--machine", "reference", "--filter", filt, "--filter-mm", "3")
    assert long_cuts["cuts"] == 1 and long_cuts["ended"] == 1 and long_cuts["pieces"] > 4


def test_the_entry_of_a_long_cut_is_carried(tmp_path, monkeypatch, capsys, long_cuts):
    """The check can fail: without the entry rapid's direction carried from the window before
    (the long cut is its window's cut 0), another CSV."""
    import fuzzyfeed.program.machine_windows as mw

    monkeypatch.setattr(mw._Entry, "first_cut", lambda self, wp: None if wp.n_cuts == 0 else (np.nan,) * 3)
    prog = _program(tmp_path / "r.ngc")
    with pytest.raises(AssertionError):
        _compare(tmp_path, prog, monkeypatch, capsys, 60, "--machine", "reference")
    assert long_cuts["starts"] == [(0, 0)] and long_cuts["pieces"] > 4


def test_the_settling_levels_are_carried(tmp_path, monkeypatch, capsys, long_cuts):
    """The check can fail: each piece's own settling levels (pass 1's dropped) give another CSV
    (the whole read, in one piece, is not changed)."""
    import fuzzyfeed.program.stream_machine as sm

    real = sm.settling_min
    monkeypatch.setattr(sm, "settling_min", lambda *a, levels=None, span=None: real(*a, levels=None, span=span))
    prog = _program(tmp_path / "r.ngc", fast_row=17)
    with pytest.raises(AssertionError):
        _compare(tmp_path, prog, monkeypatch, capsys, 60, "--machine", "reference")
    assert long_cuts["pieces"] > 4


def test_the_filters_sums_are_carried(tmp_path, monkeypatch, capsys, long_cuts):
    """The check can fail: the filter's cumulative sums begun afresh in every piece (not handed
    on from the piece before) give another CSV. (Corner-mean's guard from pass 1b, the lowest
    output at a peak, only holds the cones' envelope against rounding; the cut's span only
    reaches samples within a filter window of its ends, which the margins cover: no program here
    shows either dropped.)"""
    import fuzzyfeed.program.stream_machine as sm
    from fuzzyfeed.fuzzy.windows import window_mean

    class Fresh(sm.CarriedSums):
        def smooth(self, v, wlo, whi, w, g_lo, c0, c1, nxt):
            return v.copy() if wlo is None else window_mean(v, wlo, whi, w)

    monkeypatch.setattr(sm, "CarriedSums", Fresh)
    prog = _program(tmp_path / "r.ngc", rows=(1, 30, 1), fast_row=17)
    with pytest.raises(AssertionError):
        _compare(tmp_path, prog, monkeypatch, capsys, 60, "--machine", "reference", "--filter", "mean",
                 "--filter-mm", "3")
    assert long_cuts["pieces"] > 4


def test_the_arc_length_is_carried(tmp_path, monkeypatch, capsys, long_cuts):
    """The check can fail: pieces whose s is not carried from pass 0 (each summed from 0) give
    another CSV."""
    import fuzzyfeed.program.long_cut as long_cut

    real = long_cut.path_length
    monkeypatch.setattr(long_cut, "path_length", lambda pts, anchor, s0: real(pts, anchor, 0.0))
    prog = _program(tmp_path / "r.ngc")
    with pytest.raises(AssertionError):
        _compare(tmp_path, prog, monkeypatch, capsys, 60, "--machine", "reference")
    assert long_cuts["pieces"] > 4


def test_a_long_cut_with_arcs_falls_back_to_the_whole_read(tmp_path, monkeypatch, capsys, long_cuts):
    """Arcs in a cut longer than a window: not advised in pieces from the file; the program is
    read whole (the same outputs), found when the windows are first read (no long cut begun)."""
    from test_program_windows import _spiral

    prog = _spiral(tmp_path / "a.ngc", arcs=True)
    _compare(tmp_path, prog, monkeypatch, capsys, 200, "--machine", "reference", windowed=False)
    assert long_cuts["cuts"] == 0
