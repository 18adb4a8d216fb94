"""The limit reference on a scratch store with memory bounded by a window (issue 36,
program/reference_state.py ``StoredState``): the refined chains, their feeds, profiles and events in
scratch files, every long chain read and written a window at a time.

Held to the whole read (the same function on the path in memory) and to the limit reference with
plans of tests/test_limit_reference.py (an independent copy of main 55c2bd9's loop, whole arrays):
the same passes, feeds, time, largest error, p99 and air; with windows of a few segments so that
every chain spans many plan windows, parts and refine blocks."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.program import reference as R
from fuzzyfeed.program import reference_state
from fuzzyfeed.program.chain_store import ChainStore, StoredColumn, StoredPath
from fuzzyfeed.program.machine_windows import _spilled, build_store
from fuzzyfeed.program.read import read_program
from fuzzyfeed.program.run import program_path
from test_limit_reference import _raster, _reference_with_plans


def _stops(inch: bool = False) -> str:
    """Three chains (an M0 stops the tool at the end of each) of 300 mm passes at F6000 joined by 2 mm steps: the corners
    break the tolerance in every chain; in inches with ``inch``."""
    u = 25.4 if inch else 1.0
    c = lambda v: f"{v / u:.5f}"  # noqa: E731
    out = ["G20 G90 G94" if inch else "G21 G90 G94", f"G0 X0 Y0 Z{c(1)}", f"G1 Z0 F{c(300)}"]
    y = 0.0
    for chain in range(3):
        for k in range(2):
            out.append(f"G1 X{c(300 if k % 2 == 0 else 0)} F{c(6000)}")
            y += 2.0
            out.append(f"G1 Y{c(y)}" + (" M0" if k == 1 else ""))     # the tool stops after the move
    out.append("M2")
    return "\n".join(out) + "\n"


def _small_windows(monkeypatch, refine: int = 7) -> None:
    """Every chain over 40 segments long (read by slices, run part by part), plan windows of 16
    segments, parts of 2 windows, refine blocks of ``refine`` segments."""
    from fuzzyfeed.machine import chain_pass, plan_parts
    from fuzzyfeed.program import run as program_run

    monkeypatch.setattr(program_run, "CARRIED_MIN_SEGMENTS", 40)
    monkeypatch.setattr(plan_parts, "WINDOW_SEGMENTS", 16)
    monkeypatch.setattr(chain_pass, "WINDOW_SEGMENTS", 16)
    monkeypatch.setattr(chain_pass, "PART_WINDOWS", 2)
    monkeypatch.setattr(reference_state, "REFINE_SEGMENTS", refine)


def _on_store(tmp_path, prog, machine, window_lines: int):
    store = ChainStore(tmp_path / "s", machine.chord_tol_mm)
    build_store(prog, store, None, window_lines)
    try:
        return R.limit_reference(StoredPath.of(store), machine, seg_sinks=_spilled(tmp_path / "m", "reference"))
    finally:
        store.close()


def _same(got, whole) -> None:
    assert got.passes == whole.passes and got.converged == whole.converged
    assert len(got.feeds) == len(whole.feeds)
    assert all(a[:].tobytes() == b.tobytes() for a, b in zip(got.feeds, whole.feeds))
    assert (got.run.time_s, got.run.max_um, got.run.p99_um, got.run.air_max_um) == \
        (whole.run.time_s, whole.run.max_um, whole.run.p99_um, whole.run.air_max_um)


@pytest.mark.parametrize("inch", [False, True])
def test_passes_lowering_several_chains_on_the_store_in_tiny_windows_are_the_whole_reads(tmp_path, monkeypatch,
                                                                                         inch):
    machine = load_machine("reference")
    prog = tmp_path / "p.ngc"
    prog.write_text(_stops(inch))
    program = read_program(prog)
    whole = R.limit_reference(program_path(program, machine.chord_tol_mm), machine)
    feeds, passes, with_plans = _reference_with_plans(program_path(program, machine.chord_tol_mm), machine)
    lowered = []
    real = reference_state.StoredState.lower
    monkeypatch.setattr(reference_state.StoredState, "lower",
                        lambda self, i, at, v: lowered.append(i) or real(self, i, at, v))
    _small_windows(monkeypatch)
    got = _on_store(tmp_path, prog, machine, 5)
    try:
        assert len(got.feeds) == 3 and len(set(lowered)) == 3          # every chain's feeds lowered
        assert got.passes >= 3
        _same(got, whole)
        # and the limit reference with plans, whole arrays (its final runs not p99-settled)
        assert got.passes == passes
        assert all(a[:].tobytes() == b.tobytes() for a, b in zip(got.feeds, feeds))
        assert (got.run.time_s, got.run.max_um) == (with_plans.time_s, with_plans.max_um)
    finally:
        got.close()


def test_a_long_chain_spanning_windows_of_lines_and_plan_windows_is_the_whole_reads(tmp_path, monkeypatch):
    """The one-cut raster (one chain of its 3231 moves) built from windows of 150 lines
    into the store, refined 5 segments at a time, its passes in plan windows of 16 segments."""
    machine = load_machine("reference")
    program = _raster(tmp_path, 3000)
    whole = R.limit_reference(program_path(program, machine.chord_tol_mm), machine)
    _small_windows(monkeypatch, refine=5)
    got = _on_store(tmp_path, tmp_path / "raster.ngc", machine, 150)
    try:
        assert max(c.size for c in got.feeds) > 3000 and got.passes >= 3
        _same(got, whole)
    finally:
        got.close()


def test_no_chain_is_read_whole_nor_refined_in_memory_on_the_store(tmp_path, monkeypatch):
    """A spy on every read of a stored column: with plan windows of 16 segments, move-boundary
    scans of 64 and gathered reads spanning at most 64 items, no read of the store's chains (or of
    the refined store, its feeds and profiles) takes more than a few hundred items of a chain of
    thousands; ``refine_chain`` (a whole chain in memory) is never called."""
    from fuzzyfeed.machine import plan_windows
    from fuzzyfeed.program import chain_store

    machine = load_machine("reference")
    prog = tmp_path / "p.ngc"
    prog.write_text(_stops())
    _small_windows(monkeypatch)
    monkeypatch.setattr(plan_windows, "_SCAN", 64)
    monkeypatch.setattr(chain_store, "_GATHER_SPAN", 64)
    reads, refined = [], []
    real_read = StoredColumn._read
    monkeypatch.setattr(StoredColumn, "_read", lambda self, a, b: reads.append(b - a) or real_read(self, a, b))
    real_refine = R.refine_chain
    for module in (R, reference_state):
        monkeypatch.setattr(module, "refine_chain", lambda *a: refined.append(1) or real_refine(*a))
    got = _on_store(tmp_path, prog, machine, 5)
    try:
        longest = max(c.size for c in got.feeds)
        assert longest > 600 and got.passes >= 3
        assert not refined
        assert max(reads) <= 300 < longest, (max(reads), longest)
    finally:
        got.close()


def test_the_reference_scratch_is_gone_after_success_and_after_an_error(tmp_path, monkeypatch):
    """The refined store, feeds, profiles and events live in ``<store>.reference`` while the passes
    run, and are removed when the reference is closed, or when a pass fails halfway."""
    machine = load_machine("reference")
    prog = tmp_path / "p.ngc"
    prog.write_text(_stops())
    scratch = tmp_path / "s.reference"
    seen = []
    real = R.stream_parts

    def spy(*a, **k):
        seen.append(sorted(p.name for p in scratch.iterdir()))
        return real(*a, **k)
    monkeypatch.setattr(R, "stream_parts", spy)
    got = _on_store(tmp_path, prog, machine, 1000)
    assert seen and "feeds" in seen[0] and "v_peak" in seen[0] and any(n.startswith("events") for n in seen[0])
    got.close()
    assert not scratch.exists()

    def broken(*a, **k):
        raise RuntimeError("a failure halfway")
    monkeypatch.setattr(R, "stream_parts", broken)
    with pytest.raises(RuntimeError):
        _on_store(tmp_path / "again", prog, machine, 1000) if (tmp_path / "again").mkdir() is None else None
    assert not (tmp_path / "again" / "s.reference").exists()
    assert (tmp_path / "again" / "s").exists()         # the caller's store is the caller's


def test_a_stored_column_written_by_slices_and_scattered_reads_back_as_an_array(tmp_path, monkeypatch):
    from fuzzyfeed.program import chain_store

    monkeypatch.setattr(chain_store, "_GATHER_GAP", 5)
    monkeypatch.setattr(chain_store, "_GATHER_SPAN", 11)
    rng = np.random.default_rng(3)
    want = rng.normal(size=500)
    with open(tmp_path / "c", "wb") as f:
        np.zeros(600).tofile(f)
    with open(tmp_path / "c", "r+b") as handle:
        col = StoredColumn(handle, np.float64, 1, 50, 500)
        col[:] = want
        at = np.unique(rng.integers(0, 500, 80))
        new = rng.normal(size=at.size)
        want[at] = new
        col.scatter(at, new)
        col[10:20] = want[10:20] * 2
        want[10:20] *= 2
        assert col[:].tobytes() == want.tobytes()
        idx = rng.integers(0, 500, (7, 9))
        assert np.array_equal(col.gather(idx), want[idx])
    assert np.fromfile(tmp_path / "c")[:50].tobytes() == np.zeros(50).tobytes()      # nothing before its start
