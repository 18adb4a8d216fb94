"""A cut longer than a window is read from its file once (issue 36, lc8): its moves go to a scratch
folder (:class:`fuzzyfeed.base.spill.Spill`) that every later pass reads back, and the folder is
gone after the advice, whether it ends normally or by an error."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest

import fuzzyfeed.program.long_cut as long_cut
import fuzzyfeed.program.windows as windows
from fuzzyfeed.base.spill import Spill, scratch_folder
from fuzzyfeed.errors import InputError

from test_program_windows import _advise, _spiral


# --- the spill ---------------------------------------------------------------------------------


def test_a_spill_gives_back_its_rows_bit_for_bit(tmp_path):
    """Rows appended in uneven chunks come back equal byte for byte (NaN payloads, bools, rows of
    three), in any chunks and from any row, as new arrays (nothing mapped)."""
    rng = np.random.default_rng(3)
    n = 1000
    xyz = rng.normal(size=(n, 3))
    val = rng.normal(size=n)
    val[::17] = np.nan
    val.view(np.uint64)[5] = 0x7FF8_0000_0000_0BAD      # a NaN with a payload
    flag = rng.random(n) < 0.3
    line = rng.integers(0, 10 ** 9, n)
    spill = Spill(tmp_path, "m")
    cuts = [0, 1, 2, 250, 251, 700, n]
    for a, b in zip(cuts[:-1], cuts[1:]):
        spill.append({"xyz": xyz[a:b], "val": val[a:b], "flag": flag[a:b], "line": line[a:b]})
    assert len(spill) == n and spill.fields == ("xyz", "val", "flag", "line")
    for rows, start, stop in [(1, 0, n), (64, 0, n), (999, 3, n), (n + 5, 0, n), (7, 500, 517)]:
        got = list(spill.chunks(rows, start, stop))
        assert [len(c["val"]) for c in got[:-1]] == [rows] * (len(got) - 1)
        for name, want in (("xyz", xyz), ("val", val), ("flag", flag), ("line", line)):
            joined = np.concatenate([c[name] for c in got])
            assert joined.dtype == want.dtype and joined.shape == want[start:stop].shape
            assert joined.tobytes() == want[start:stop].tobytes(), name
            assert all(type(c[name]) is np.ndarray and not isinstance(c[name].base, np.memmap) for c in got)
    part = spill.read(10, 13)
    assert part["xyz"].tobytes() == xyz[10:13].tobytes()
    assert list(spill.chunks(5, fields=("line",)))[0].keys() == {"line"}
    assert list(spill.chunks(5, 7, 7)) == []


def test_a_spill_refuses_what_does_not_fit(tmp_path):
    spill = Spill(tmp_path, "m")
    spill.append({"a": np.zeros(3), "b": np.zeros((3, 2))})
    with pytest.raises(ValueError, match="one count"):
        spill.append({"a": np.zeros(2), "b": np.zeros((3, 2))})
    with pytest.raises(ValueError, match="after"):
        spill.append({"a": np.zeros(2, np.float32), "b": np.zeros((2, 2))})
    with pytest.raises(ValueError, match="asked"):
        list(spill.chunks(2, 0, 4))
    with pytest.raises(ValueError, match="rows"):
        list(spill.chunks(0))


def test_a_scratch_folder_is_removed_on_an_error():
    with pytest.raises(KeyError):
        with scratch_folder("fuzzyfeed-test-") as folder:
            Spill(folder, "x").append({"a": np.arange(4)})
            assert (folder / "x.a").stat().st_size == 32
            raise KeyError("late")
    assert not folder.exists()


# --- the long cut --------------------------------------------------------------------------------


@pytest.fixture
def small(monkeypatch, tmp_path):
    """Small pieces and fit windows (the long cut's passes in many chunks), scratch folders made in
    ``tmp_path/tmp`` and recorded, every open of a program by the windowed reader counted."""
    import fuzzyfeed.geometry.polyline_runs as runs
    import fuzzyfeed.program.stream as stream

    monkeypatch.setattr(runs, "COMPILED_MIN_VERTICES", 0)
    monkeypatch.setattr(stream, "DEFAULT_PIECE_POINTS", 300)
    monkeypatch.setattr(long_cut, "FIT_WINDOW", 150)
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    seen = {"folders": [], "opens": [], "long_reads": 0, "pieces": 0}
    real_folder = long_cut.scratch_folder

    def folder(*a, **k):
        cm = real_folder(*a, **k)

        class Recorded:
            def __enter__(self):
                path = cm.__enter__()
                seen["folders"].append(path)
                return path

            def __exit__(self, *exc):
                return cm.__exit__(*exc)

        return Recorded()

    monkeypatch.setattr(long_cut, "scratch_folder", folder)
    real_open = open

    def counted_open(file, *a, **k):
        seen["opens"].append(Path(file).name)
        return real_open(file, *a, **k)

    monkeypatch.setattr(windows, "open", counted_open, raising=False)
    real_read = long_cut.read_windows

    def long_read(*a, **k):
        seen["long_reads"] += 1
        return real_read(*a, **k)

    monkeypatch.setattr(long_cut, "read_windows", long_read)
    real_piece = long_cut.piece_advice

    def piece(*a, **k):
        seen["pieces"] += 1
        return real_piece(*a, **k)

    monkeypatch.setattr(long_cut, "piece_advice", piece)
    seen["scratch"] = scratch
    return seen


def test_the_long_cut_reads_its_file_once(tmp_path, monkeypatch, small):
    """The program's file is opened by the scan that decides the windows, by the windows' read and
    once more by the long cut (each read: the scan of its line breaks, then its lines), not once for
    every pass (five more reads before: the fit's two scans, passes 0, 1 and 2)."""
    prog = _spiral(tmp_path / "s.ngc")
    rc, _ = _advise(tmp_path / "run", prog, True, monkeypatch, 200)
    assert rc == 0 and small["pieces"] > 4
    assert small["long_reads"] == 1
    assert small["opens"].count("s.ngc") == 1 + 2 + 2


def test_the_scratch_folder_is_gone_after_the_advice(tmp_path, monkeypatch, small):
    prog = _spiral(tmp_path / "s.ngc")
    rc, _ = _advise(tmp_path / "run", prog, True, monkeypatch, 200)
    assert rc == 0 and small["pieces"] > 4 and len(small["folders"]) == 1
    assert not small["folders"][0].exists() and not list(small["scratch"].iterdir())


def test_the_scratch_folder_is_gone_after_a_bad_move_later_in_the_file(tmp_path, monkeypatch, capsys, small):
    """A bad word near the end of the long cut: the cut's read stops there (its folder removed),
    the whole read names it (exit 2), nothing written."""
    lines = _spiral(tmp_path / "s.ngc").read_text().split("\n")
    lines.insert(len(lines) - 30, "G1 X1 Q")
    prog = tmp_path / "bad.ngc"
    prog.write_text("\n".join(lines))
    rc, _ = _advise(tmp_path / "run", prog, True, monkeypatch, 200)
    assert rc == 2 and "bad.ngc" in capsys.readouterr().err
    assert not (tmp_path / "run" / "y.ngc").exists()
    assert len(small["folders"]) == 1 and small["pieces"] == 0
    assert not small["folders"][0].exists() and not list(small["scratch"].iterdir())


def test_the_scratch_folder_is_gone_before_the_whole_read_after_an_error_in_a_pass(tmp_path, monkeypatch, small):
    """An error in the advice's last pass, after pieces were handed out: the windows give up, and the
    long cut's folder is removed before the whole read starts."""
    import fuzzyfeed.program.read as read

    prog = _spiral(tmp_path / "s.ngc")
    real_piece = long_cut.piece_advice
    calls = []

    def failing(*a, **k):
        calls.append(1)
        if len(calls) == 3:
            raise InputError("a piece that fails")
        return real_piece(*a, **k)

    monkeypatch.setattr(long_cut, "piece_advice", failing)
    during = []
    real_read = read.read_program

    def whole_read(*a, **k):
        during.append([f.exists() for f in small["folders"]])
        return real_read(*a, **k)

    monkeypatch.setattr(read, "read_program", whole_read)
    rc, _ = _advise(tmp_path / "run", prog, True, monkeypatch, 200)
    assert rc == 0 and len(calls) == 3
    assert during == [[False]]
    assert not list(small["scratch"].iterdir())
