"""``advise --machine --report`` on a long program read in windows of lines (issue 36): the uniform
slowdown checked by a whole run and the limit reference run on the scratch store
(program/machine_windows.py ``evaluate_in_windows(check=True)``), the value plot's feed trace drawn
from the store block by block (report/value_trace.py): the CSV, sidecar, program, printed summary
and HTML report are the whole read's, byte for byte (the whole read's HTML is deterministic: the
same run twice gives the same bytes)."""

from __future__ import annotations

import filecmp

import pytest

from test_machine_windows import _advise, _compare, broken, check_scratch_removed
from test_program_windows import _raster


def test_the_whole_reads_html_report_is_deterministic(tmp_path, monkeypatch):
    """What the byte comparisons below rest on."""
    prog = _raster(tmp_path / "r.ngc", cuts=3, rows=3)
    for name in ("a", "b"):
        _advise(tmp_path / name, prog, False, monkeypatch, 400, "--machine", "reference", "--report", "r.html")
    assert filecmp.cmp(tmp_path / "a" / "r.html", tmp_path / "b" / "r.html", shallow=False)


@pytest.mark.parametrize("inch", [False, True])
@pytest.mark.parametrize("window_lines", [160, 400])
def test_the_report_in_windows_is_the_whole_reads(tmp_path, monkeypatch, capsys, inch, window_lines):
    prog = _raster(tmp_path / "r.ngc", inch=inch)
    out = _compare(tmp_path, prog, monkeypatch, capsys, window_lines, "--machine", "reference",
                   "--report", "r.html")
    assert "limit reference" in out and "not run" not in out and "not checked" not in out, out


@pytest.mark.parametrize("inch", [False, True])
def test_a_check_that_breaks_goes_on_below_in_windows(tmp_path, monkeypatch, capsys, inch):
    """The hot stretches of the program as written cut down to its mildest hot segment: the factor
    they hold breaks the tolerance elsewhere, the checking run on the store finds it and the search
    goes on below, as the whole read's does (tests/test_uniform_check.py's device)."""
    import numpy as np

    import fuzzyfeed.program.uniform as uniform
    import fuzzyfeed.report.value as value

    real_init, real_check = uniform._Search.__init__, uniform.check_uniform
    factors = []

    def mildest_only(self, *a, **k):
        real_init(self, *a, **k)
        i, j = min(((i, j) for i, h in enumerate(self.hot0) for j in range(h.size)),
                   key=lambda ij: self.hot0_mm[ij[0]][ij[1]])
        self.hot0 = [h[j:j + 1] if k == i else h[:0] for k, h in enumerate(self.hot0)]
        self.hot0_mm = [e[j:j + 1] if k == i else e[:0] for k, e in enumerate(self.hot0_mm)]

    def check(path, machine, u, *a, **k):
        out = real_check(path, machine, u, *a, **k)
        factors.append((u.factor, out.factor))
        return out
    monkeypatch.setattr(uniform._Search, "__init__", mildest_only)
    monkeypatch.setattr(uniform, "check_uniform", check)
    monkeypatch.setattr(value, "check_uniform", check)            # the whole read's name for it
    prog = _raster(tmp_path / "r.ngc", inch=inch)
    _compare(tmp_path, prog, monkeypatch, capsys, 160, "--machine", "reference", "--report", "r.html")
    assert len(factors) == 2 and factors[0] == factors[1]         # the whole read's, then the windows'
    assert factors[0][1] < factors[0][0]                          # the check went below
    assert np.isfinite(factors[0][1])


@pytest.mark.parametrize("window_lines", [160, 400])
def test_the_report_of_long_chains_read_from_the_store(tmp_path, monkeypatch, capsys, window_lines):
    """Every chain over a few dozen segments read from the store's columns a slice at a time (plan
    windows of 16 segments, parts of 2 windows; the uniform check's feeds a scaled column) and the
    feed trace made in blocks of 7 segments (the arc length carried from block to block): the whole
    read's report, byte for byte."""
    import fuzzyfeed.machine.chain_pass as chain_pass
    import fuzzyfeed.machine.plan_parts as plan_parts
    import fuzzyfeed.program.run as run
    import fuzzyfeed.report.value_trace as value_trace

    monkeypatch.setattr(run, "CARRIED_MIN_SEGMENTS", 40)
    monkeypatch.setattr(plan_parts, "WINDOW_SEGMENTS", 16)
    monkeypatch.setattr(chain_pass, "PART_WINDOWS", 2)
    monkeypatch.setattr(value_trace, "TRACE_BLOCK", 7)
    prog = _raster(tmp_path / "r.ngc", cuts=5, rows=4)
    _compare(tmp_path, prog, monkeypatch, capsys, window_lines, "--machine", "reference", "--report", "r.html")


def test_the_report_of_a_program_that_holds_as_written(tmp_path, monkeypatch, capsys):
    """No cut over the tolerance (a tolerance of 2 mm): no advised run, the trace of the program as
    written against itself, the limit reference row the run as written's."""
    prog = _raster(tmp_path / "r.ngc", cuts=3, rows=3)
    out = _compare(tmp_path, prog, monkeypatch, capsys, 160, "--machine", "reference", "--contour-tol-um", "2000",
                   "--report", "r.html")
    assert "holds the tolerance" in out, out


def test_a_place_set_apart_with_report_falls_back_to_the_whole_read(tmp_path, monkeypatch, capsys):
    """Places the uniform slowdown sets apart are measured on the whole read: with ``--report`` the
    windows fall back too, and the outputs are the whole read's."""
    from test_uniform_apart import PLUNGE_FROM_RAPIDS

    prog = tmp_path / "p.ngc"
    prog.write_text(PLUNGE_FROM_RAPIDS)
    out = _compare(tmp_path, prog, monkeypatch, capsys, 400, "--machine", "reference", "--report", "r.html",
                   windowed=False)
    assert "place(s) set apart" in out


def test_the_scratch_directory_is_removed_after_a_report_and_after_an_error(tmp_path, monkeypatch, capsys):
    import fuzzyfeed.program.reference as reference

    check_scratch_removed(tmp_path, monkeypatch, capsys, ("--report", "r.html"),
                          lambda mp: mp.setattr(reference, "limit_reference", broken))


def test_where_the_tool_passed_the_tolerance_summed_in_blocks_is_the_sum_in_one(tmp_path, monkeypatch):
    """The trace's marks beyond the tolerance (arc length along the feed moves) made from the store
    in blocks of 7 segments (the running sum carried from block to block) against the chain's sums in
    one block of the whole read: the same points, the same arc lengths to rounding."""
    import numpy as np

    import fuzzyfeed.program.run as run
    import fuzzyfeed.report.value_trace as value_trace
    from fuzzyfeed.machine.description import load_machine
    from fuzzyfeed.program.chain_store import ChainStore, StoredPath
    from fuzzyfeed.program.machine_windows import build_store
    from fuzzyfeed.program.read import read_program
    from fuzzyfeed.program.run import program_path, run_program

    monkeypatch.setattr(run, "CARRIED_MIN_SEGMENTS", 40)
    machine = load_machine("reference")
    prog = _raster(tmp_path / "r.ngc", cuts=4, rows=4)
    whole = program_path(read_program(prog), machine.chord_tol_mm)
    one = value_trace.feed_trace(whole, run_program(whole, machine), whole, machine.contour_tol_um)
    store = ChainStore(tmp_path / "s", machine.chord_tol_mm)
    build_store(prog, store, None, 150)
    try:
        sp = StoredPath.of(store)
        monkeypatch.setattr(value_trace, "TRACE_BLOCK", 7)
        blocks = value_trace.feed_trace(sp, run_program(sp, machine), sp, machine.contour_tol_um)
    finally:
        store.close()
    assert one.over_s_mm.size > 10 and one.over_s_mm.max() > 100.0
    assert np.array_equal(one.over_xyz, blocks.over_xyz)
    assert np.allclose(one.over_s_mm, blocks.over_s_mm, rtol=1e-12, atol=0.0)


def test_the_report_as_csv_in_windows_is_the_whole_reads(tmp_path, monkeypatch, capsys):
    prog = _raster(tmp_path / "r.ngc", cuts=4, rows=4)
    _compare(tmp_path, prog, monkeypatch, capsys, 160, "--machine", "reference", "--report", "r.csv")
    assert "reference_time_s" in (tmp_path / "win" / "r.csv").read_text()


@pytest.mark.parametrize("inch", [False, True])
def test_the_report_of_a_one_cut_raster_in_windows_is_the_whole_reads(tmp_path, monkeypatch, capsys, inch):
    """One cut over several windows (advised from its file in pieces: tests/test_machine_long_cut.py)
    with ``--report``: the checking run, the limit reference and the trace on the store, byte for
    byte the whole read's."""
    from test_machine_long_cut import _program

    prog = _program(tmp_path / "r.ngc", inch=inch, fast_row=17)
    out = _compare(tmp_path, prog, monkeypatch, capsys, 60, "--machine", "reference", "--report", "r.html")
    assert "1 cut(s)" in out and "limit reference" in out and "not run" not in out


def test_the_whole_reads_value_plot_is_deterministic(tmp_path, monkeypatch):
    """What the PNG comparisons below rest on."""
    prog = _raster(tmp_path / "r.ngc", cuts=3, rows=3)
    for name in ("a", "b"):
        _advise(tmp_path / name, prog, False, monkeypatch, 400, "--machine", "reference", "--plot", "p.png")
    assert filecmp.cmp(tmp_path / "a" / "p.png", tmp_path / "b" / "p.png", shallow=False)


@pytest.mark.parametrize("extra", [(), ("--report", "r.html")])
@pytest.mark.parametrize("inch", [False, True])
def test_the_value_plot_in_windows_is_the_whole_reads(tmp_path, monkeypatch, capsys, inch, extra):
    """``--plot`` beside ``-o``/``--gcode`` no longer reads the program whole: the windows draw the
    value plot's feed trace from the stores (with or without ``--report``); PNG byte for byte."""
    prog = _raster(tmp_path / "r.ngc", inch=inch)
    out = _compare(tmp_path, prog, monkeypatch, capsys, 160, "--machine", "reference", "--plot", "p.png", *extra)
    assert "p.png" in out
    assert (tmp_path / "win" / "p.png").stat().st_size > 10_000   # a drawn plot, not an empty figure



def test_the_uniform_checking_run_on_the_store_keeps_no_error_per_segment_in_memory(tmp_path, monkeypatch, capsys):
    """The checking run of the uniform slowdown (a whole run at the factor) on the store sends its
    largest error per segment to a scratch file, as the runs as written and advised do: none held
    per segment of the program (issue 36: 8 B a segment, twice where the p99 is run again); the
    report is the whole read's, byte for byte."""
    import fuzzyfeed.program.uniform as uniform

    real = uniform.run_program
    seen = []

    def spy(path, *a, **k):
        run = real(path, *a, **k)
        if getattr(path, "store", None) is not None:
            seen.append([getattr(r.stream.seg_max_mm, "stored", False) for r in run.runs])
        return run
    monkeypatch.setattr(uniform, "run_program", spy)
    prog = _raster(tmp_path / "r.ngc")
    _compare(tmp_path, prog, monkeypatch, capsys, 160, "--machine", "reference", "--report", "r.html")
    assert seen and all(all(kept) for kept in seen), seen
