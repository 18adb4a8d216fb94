"""A long program advised on a machine in windows of lines (issue 36; program/machine_windows.py):
the chains built from the windows into a scratch store and run part by part, the advice made window
by window — ``advise --machine`` writes the same CSV, sidecar, program and summary as the whole read,
byte for byte; the scratch directory is gone after success and after an error; a join that would
not be exact falls back to the whole read."""

from __future__ import annotations

import filecmp
import os
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest

import fuzzyfeed.program.windows as windows
from test_program_windows import _raster

ROOT = Path(__file__).resolve().parents[1]


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


def _compare(tmp_path, prog, monkeypatch, capsys, window_lines, *extra, windowed=True):
    import fuzzyfeed.program.machine_windows as mw

    used, done = [], []
    real = mw.evaluate_in_windows

    def spy(*a, **k):
        used.append(1)
        out = real(*a, **k)
        done.append(1)
        return out
    monkeypatch.setattr(mw, "evaluate_in_windows", spy)
    a = _advise(tmp_path / "whole", prog, False, monkeypatch, window_lines, *extra)
    out_a = capsys.readouterr().out
    assert not used
    b = _advise(tmp_path / "win", prog, True, monkeypatch, window_lines, *extra)
    out_b = capsys.readouterr().out
    assert used, "the windowed path was not taken"
    assert bool(done) == windowed, "the windows gave a result" if done else "the windows fell back"
    assert a == b and out_a == out_b
    names = sorted(os.listdir(tmp_path / "whole"))
    assert names == sorted(os.listdir(tmp_path / "win")) and "y.ngc" in names
    for name in names:
        assert filecmp.cmp(tmp_path / "whole" / name, tmp_path / "win" / name, shallow=False), name
    return out_b


@pytest.mark.parametrize("inch", [False, True])
@pytest.mark.parametrize("window_lines", [160, 400])
def test_machine_advice_in_windows_is_the_whole_reads(tmp_path, monkeypatch, capsys, inch, window_lines):
    """Windows of a cut or two (each window's first cut entered by a rapid in the window before:
    its entry direction carried), a tool change, lines after M30; the cuts over the tolerance
    advised, the rest left as written."""
    prog = _raster(tmp_path / "r.ngc", inch=inch)
    out = _compare(tmp_path, prog, monkeypatch, capsys, window_lines, "--machine", "reference")
    assert "6 cut(s)" in out and "advised 6 cut(s)" in out


def test_a_cut_split_between_windows_is_advised_in_windows(tmp_path, monkeypatch, capsys):
    prog = _raster(tmp_path / "r.ngc")
    _compare(tmp_path, prog, monkeypatch, capsys, 60, "--machine", "reference")


def test_the_entry_rapid_of_a_windows_first_cut_is_carried(tmp_path, monkeypatch, capsys):
    """Without the entry direction carried from the window before, the advice differs: the test
    above would fail (so it checks the carry)."""
    import fuzzyfeed.program.machine_windows as mw

    monkeypatch.setattr(mw._Entry, "first_cut", lambda self, wp: None if wp.n_cuts == 0 else (np.nan,) * 3)
    prog = _raster(tmp_path / "r.ngc")
    with pytest.raises(AssertionError):
        _compare(tmp_path, prog, monkeypatch, capsys, 160, "--machine", "reference")


@pytest.mark.parametrize("window_lines", [160, 400])
def test_long_chains_run_from_the_store_part_by_part(tmp_path, monkeypatch, capsys, window_lines):
    """Chains run from the scratch store's columns a slice at a time (every chain over a few dozen
    segments; plan windows of 16 segments, parts of 2 windows): the whole read's outputs."""
    import fuzzyfeed.machine.chain_pass as chain_pass
    import fuzzyfeed.machine.plan_parts as plan_parts
    import fuzzyfeed.program.run as run

    monkeypatch.setattr(run, "CARRIED_MIN_SEGMENTS", 40)
    monkeypatch.setattr(plan_parts, "WINDOW_SEGMENTS", 16)
    monkeypatch.setattr(chain_pass, "PART_WINDOWS", 2)
    prog = _raster(tmp_path / "r.ngc", cuts=5, rows=4)
    _compare(tmp_path, prog, monkeypatch, capsys, window_lines, "--machine", "reference")


def test_the_store_holds_the_whole_reads_chains_across_window_joins(tmp_path):
    """The chains built window by window (the open chain, last end and vertex carried across each
    join) are program_path's on the whole read, bit for bit; closing them at every join instead
    (the state dropped) gives other chains and another run."""
    from fuzzyfeed.machine.description import load_machine
    from fuzzyfeed.program.chain_store import ChainStore, StoredPath
    from fuzzyfeed.program.machine_windows import build_store
    from fuzzyfeed.program.read import read_program
    from fuzzyfeed.program.run import program_path, run_program

    machine = load_machine("reference")
    prog = _raster(tmp_path / "r.ngc", cuts=4, rows=4)
    whole = program_path(read_program(prog), machine.chord_tol_mm)
    store = ChainStore(tmp_path / "s", machine.chord_tol_mm)
    totals = build_store(prog, store, None, 150)
    assert totals.windows > 2
    sp = StoredPath.of(store, whole_below=1)        # every chain read from the columns
    assert len(sp.chains) == len(whole.chains) == 2   # rapids do not stop the tool, the tool change does
    for a, b in zip(whole.chains, sp.chains):
        for x, y in ((a.motion.points, b.motion.points), (a.motion.feed_mm_s, b.motion.feed_mm_s),
                     (a.motion.rapid, b.motion.rapid), (a.motion.arc_radius_mm, b.motion.arc_radius_mm),
                     (a.seg_move, b.seg_move), (a.seg_measured, b.seg_measured)):
            y = y[:]
            assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True)
    r_whole = run_program(whole, machine, keep_plans=False)
    r_store = run_program(sp, machine, keep_plans=False)
    assert (r_whole.time_s, r_whole.max_um, r_whole.p99_um) == (r_store.time_s, r_store.max_um, r_store.p99_um)
    assert r_whole.runs[0].stream.seg_max_mm.tobytes() == r_store.runs[0].stream.seg_max_mm.tobytes()
    store.close()
    # the state dropped at every join: each window's moves a chain from rest
    cut = ChainStore(tmp_path / "c", machine.chord_tol_mm)
    from fuzzyfeed.program.windows import read_windows

    move0 = 0
    for win in read_windows(prog, window_lines=150):
        b = cut.builder()
        b.add(win.program, (move0, win.line0, win.cut0))
        b.finish()
        move0 += win.program.kind.size
    cut.close_writing()
    r_cut = run_program(StoredPath.of(cut), machine, keep_plans=False)
    assert len(r_cut.runs) > 2 and r_cut.time_s != r_whole.time_s
    cut.close()


def check_scratch_removed(tmp_path, monkeypatch, capsys, extra: tuple, break_halfway) -> None:
    """The windowed run's scratch directories (``fuzzyfeed-machine-*``) are gone after a run with
    ``extra`` flags that succeeds and after one that ``break_halfway(monkeypatch)`` makes fail
    (nothing written in its folder)."""
    made = []
    real_mkdtemp = tempfile.mkdtemp

    def mkdtemp(*a, **k):
        d = real_mkdtemp(*a, **k)
        if "fuzzyfeed-machine-" in os.path.basename(d):
            made.append(d)
        return d
    monkeypatch.setattr(tempfile, "mkdtemp", mkdtemp)
    prog = _raster(tmp_path / "r.ngc")
    _compare(tmp_path, prog, monkeypatch, capsys, 400, "--machine", "reference", *extra)
    assert made and not any(os.path.exists(d) for d in made)
    made.clear()
    break_halfway(monkeypatch)
    monkeypatch.setattr(windows, "MIN_LINES", 1)
    monkeypatch.setattr(windows, "WINDOW_LINES", 400)
    (tmp_path / "err").mkdir()
    monkeypatch.chdir(tmp_path / "err")
    from fuzzyfeed.cli import main

    with pytest.raises(RuntimeError):
        main(["advise", str(prog), "-o", "x.csv", "--gcode", "y.ngc", "--machine", "reference", *extra])
    assert made and not any(os.path.exists(d) for d in made)
    assert os.listdir(tmp_path / "err") == []


def broken(*a, **k):
    raise RuntimeError("a failure halfway")


def test_the_scratch_directory_is_removed_after_success_and_after_an_error(tmp_path, monkeypatch, capsys):
    import fuzzyfeed.program.machine_windows as mw
    import fuzzyfeed.program.uniform as uniform

    def break_halfway(mp):
        mp.setattr(mw, "uniform_slowdown", broken, raising=False)
        mp.setattr(uniform, "uniform_slowdown", broken)
    check_scratch_removed(tmp_path, monkeypatch, capsys, (), break_halfway)


@pytest.mark.parametrize("rel", ["dxf2gcode/erin7.ngc", "linuxcnc/tort.ngc", "linuxcnc/cds.ngc",
                                 "pcb2gcode/split_config_milldrill.ngc"])
def test_library_programs_in_windows_are_the_whole_reads(tmp_path, monkeypatch, capsys, rel):
    """Library programs of several cuts (mm; inch: cds, split_config_milldrill; arcs: tort, cds)
    read in windows of 100 lines (3 to 6 windows, no cut split) on a machine: byte for byte."""
    prog = ROOT / "benchmarks" / "library" / "programs" / rel
    _compare(tmp_path, prog, monkeypatch, capsys, 100, "--machine", "reference")


def test_the_freed_heap_is_given_back_after_every_window_of_every_read(tmp_path, monkeypatch, capsys):
    """The heap a window frees goes back to the system before the next window is read, in each of
    the three reads (the written store, the advice, the advised store): kept, its free pages pile up
    window by window and the peak grows with the program (issue 36: 323 / 329 / 335 MB at 1 M / 2 M
    / 4 M lines: glibc's free heap ~33 -> ~52 MB over ten windows, live Python objects flat).
    The outputs stay the whole read's."""
    import fuzzyfeed.program.machine_windows as mw

    events = []
    real_read, real_release = mw.read_windows, mw.release_free_memory

    def read(*a, **k):
        events.append("read")
        for win in real_read(*a, **k):
            events.append("window")
            yield win

    def release():
        events.append("release")
        return real_release()
    monkeypatch.setattr(mw, "read_windows", read)
    monkeypatch.setattr(mw, "release_free_memory", release)
    _compare(tmp_path, _raster(tmp_path / "r.ngc"), monkeypatch, capsys, 160, "--machine", "reference")
    assert events.count("read") == 3 and events.count("window") > 9
    for i, e in enumerate(events):
        if e == "window":      # a window's heap released before the next window or read
            after = events[i + 1:]
            nxt = next((j for j, f in enumerate(after) if f != "release"), len(after))
            assert nxt > 0, f"no release after window {events[:i + 1].count('window')}: {events}"
