"""The plain advice in pieces (fuzzyfeed.program.stream) equals the advice of the whole cut at once,
bit for bit; `advise PROGRAM` no longer refuses a cut over the sample budget; the benchmark raster
(benchmarks/make_raster.py) is a program LinuxCNC's rs274 runs."""

from __future__ import annotations

import importlib.util
import io
from pathlib import Path

import numpy as np
import pytest

from fuzzyfeed.cli import main
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.program.feeds import advice_columns, advise_program
from fuzzyfeed.program.read import parse_program, read_program
from fuzzyfeed.program.stream import concat_pieces, plan_pieces, stream_program_advice

ROOT = Path(__file__).resolve().parents[1]
LIBRARY = ROOT / "benchmarks" / "library" / "programs"


def _raster_module():
    spec = importlib.util.spec_from_file_location("make_raster", ROOT / "benchmarks" / "make_raster.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def raster_text(lines: int, cuts: int, seed: int = 3) -> str:
    out = io.StringIO()
    _raster_module().write_raster(out, lines, cuts, seed)
    return out.getvalue()


def assert_same_advice(program, table, piece_points, **kw):
    whole = advise_program(program, table, **kw)
    cols = advice_columns(whole)
    pieces = list(stream_program_advice(program, table, piece_points=piece_points, **kw))
    streamed = {k: np.concatenate([p.columns[k] for p in pieces]) for k in pieces[0].columns}
    assert list(streamed) == list(cols)
    for k in cols:
        assert streamed[k].dtype.kind == cols[k].dtype.kind, k
        assert np.array_equal(streamed[k], cols[k]), (k, float(np.max(np.abs(streamed[k] - cols[k]))))
    pm, pe, pf = concat_pieces(pieces)
    assert np.array_equal(pm, whole.piece_move)
    assert np.array_equal(pe, whole.piece_end)
    assert np.array_equal(pf, whole.piece_feed_mm_min)
    return len(pieces)


@pytest.mark.parametrize("piece_points", [29, 300, 5000])
def test_raster_in_pieces_is_the_whole_cut(piece_points):
    """Two zig-zag cuts over a freeform surface (curvature everywhere, many corners at the
    step-overs): every CSV value and every written piece as advising each cut at once."""
    program = parse_program(raster_text(4000, 2), "raster.ngc")
    n = assert_same_advice(program, load_rule_table(), piece_points)
    assert n >= (2 if piece_points == 5000 else 6)


@pytest.mark.parametrize("name, rules", [("linuxcnc/arcspiral.ngc", "paper"),
                                         ("linuxcnc/3D_Chips.ngc", "paper"),
                                         ("linuxcnc/arcspiral.ngc", None)])
def test_library_programs_in_pieces(name, rules, tmp_path):
    """Arcs beside lines (arcspiral), 3-D surfacing with short G1 (3D_Chips), another filter
    (min-mean through a table file) and a feed cap."""
    path = LIBRARY / name
    if not path.exists():
        pytest.skip(f"{path} not in the library")
    table = load_rule_table(rules or "paper")
    if rules is None:
        from dataclasses import replace
        table = replace(table, filter="min-mean")
    program = read_program(path)
    assert_same_advice(program, table, 211, cap_mm_min=700.0 if rules is None else None)


def test_pieces_fail_without_the_carried_sums(monkeypatch):
    """The check can fail: advising each piece's samples on their own (no carried s, Dk range or
    filter sums) differs from the whole cut."""
    from fuzzyfeed.fuzzy.advisor import advise_details
    from fuzzyfeed.program.cuts import sample_cut

    program = parse_program(raster_text(2000, 1), "raster.ngc")
    table = load_rule_table()
    whole = advise_program(program, table).advice[0].feed_pct
    cs = sample_cut(program, 0)
    half = len(cs.samples) // 2
    from fuzzyfeed.geometry.sampling import PathSamples
    sm = cs.samples
    tail = PathSamples(u=sm.u[half:], xyz=sm.xyz[half:], s=sm.s[half:] - sm.s[half], tangent=sm.tangent[half:],
                       curvature=sm.curvature[half:], d1=sm.d1[half:], d2=sm.d2[half:], dim=3)
    alone = advise_details(tail, table, 100.0).feed_pct
    assert not np.array_equal(alone[200:-200], whole[half + 200:-200])


def test_plan_covers_the_cut_with_margins():
    lengths = np.full(1000, 0.1)
    counts = np.ones(1000, int)
    plan = plan_pieces(lengths, counts, 100, 12.0)
    assert plan.cores[0] == 0 and plan.cores[-1] == 1000
    assert np.all(np.diff(plan.cores) >= 100)
    a, b = plan.cores[:-1], plan.cores[1:]
    assert np.all((a == 0) | (0.1 * (a - plan.lo) >= 12.0 - 1e-9))
    assert np.all((b == 1000) | (0.1 * (plan.hi - b) >= 12.0 - 1e-9))
    assert np.all(plan.lo[1:] >= a[:-1])      # a margin lies in the core before it


def test_cli_advises_a_cut_over_the_budget(tmp_path, monkeypatch):
    """With the budget lowered below one cut's samples, the whole-cut advice refuses, `advise`
    writes the same CSV and program as the whole-cut advice under the normal budget."""
    import fuzzyfeed.geometry.sampling as sampling
    import fuzzyfeed.program.stream as stream
    from fuzzyfeed.program.rewrite import rewrite_program

    src = tmp_path / "r.ngc"
    src.write_text(raster_text(3000, 1))
    program = read_program(src)
    table = load_rule_table()
    ref = advise_program(program, table)
    ref_cols = advice_columns(ref)
    ref_text = rewrite_program(program, ref.piece_move, ref.piece_end, ref.piece_feed_mm_min)
    budget = sampling.MAX_POINTS
    monkeypatch.setattr(sampling, "MAX_POINTS", 1000)
    monkeypatch.setattr(stream, "MAX_POINTS", 1000)
    with pytest.raises(ValueError, match="budget of 1,000"):
        advise_program(program, table)
    monkeypatch.setattr(sampling, "MAX_POINTS", budget)   # the options' --points check reads it too
    out, ngc = tmp_path / "a.csv", tmp_path / "a.ngc"
    assert main(["advise", str(src), "-o", str(out), "--gcode", str(ngc)]) == 0
    assert ngc.read_text() == ref_text
    import csv
    with open(out) as handle:
        rows = list(csv.reader(handle))
    assert rows[0] == list(ref_cols)
    got = np.array(rows[1:], dtype=float)
    for j, k in enumerate(ref_cols):
        assert np.array_equal(got[:, j], ref_cols[k].astype(float)), k


def test_one_move_over_the_budget_is_refused(tmp_path, monkeypatch, capsys):
    import fuzzyfeed.program.stream as stream

    src = tmp_path / "long.ngc"
    src.write_text("G21 G90 G94\nG0 X0 Y0 Z1\nG1 Z0 F100\nG1 X400 F1000\nG1 Y10\nG0 Z5\nM30\n")
    monkeypatch.setattr(stream, "MAX_POINTS", 1000)
    out = tmp_path / "x.csv"
    assert main(["advise", str(src), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "long.ngc:4: cut 1: one move" in err and "1601 points" in err and "raise --step-mm" in err
    assert "Traceback" not in err
    assert not out.exists()


def test_raster_is_deterministic_and_shaped():
    a, b = raster_text(3000, 3, seed=5), raster_text(3000, 3, seed=5)
    assert a == b and a != raster_text(3000, 3, seed=6)
    program = parse_program(a, "r.ngc")
    assert program.n_cuts == 3
    cutting = (program.cut >= 0) & (program.feed_mm_min == 2000.0)      # the plunges aside
    lengths = program.move_lengths()[cutting]
    assert lengths.max() <= 0.25 and 0.05 <= np.median(lengths) <= 0.2
    assert np.all(program.feed_mm_min[(program.cut >= 0) & ~cutting] == 300.0)
    for word in ("G21 G90 G94 G17", "T1 M6", "G43 H1", "S12000 M3", "M5", "M30"):
        assert word in a


def test_raster_runs_through_rs274(tmp_path):
    """rs274 accepts the raster and moves through the same points the reader reads."""
    from canon import canon

    src = tmp_path / "r.ngc"
    src.write_text(raster_text(1500, 2))
    calls = canon(src, tmp_path)
    feeds = np.array([[float(x) for x in args.split(",")[:3]] for name, args in calls if name == "STRAIGHT_FEED"])
    program = read_program(src)
    from fuzzyfeed.program.model import LINE
    ends = program.end[program.kind == LINE]
    assert feeds.shape == ends.shape
    assert np.allclose(feeds[:, :2], ends[:, :2], atol=1e-4)
    dz = feeds[:, 2] - ends[:, 2]            # the tool length offset (G43 H1) shifts Z only
    assert np.ptp(dz) < 1e-4


def test_corner_cap_on_a_piece_needs_the_paths_lowest_peak():
    """corner_cap holds its cones above the path's lowest peak value (rounding guard): a piece of
    the path gets the whole path's caps only with that value carried (the stream's pass 1). Here the
    cone of the peak at 12.9 mm rounds 6e-14 below its peak 5 samples away; the guard of the whole
    path (12.5) lets it, a piece's own lowest peak would not."""
    from fuzzyfeed.fuzzy.filters import corner_cap

    x = 0.1 * np.arange(200)
    at = np.full(200, np.inf)
    at[49], at[129] = 12.5, 43.59996224117373
    whole = corner_cap(at, x, 0.5, 25.0)
    assert whole[124] < at[129]                  # the rounding the guard lets through
    span = (float(x[0]), float(x[-1]))
    carried = corner_cap(at[100:], x[100:], 0.5, 25.0, span, lowest=12.5)
    assert np.array_equal(carried, whole[100:])
    alone = corner_cap(at[100:], x[100:], 0.5, 25.0, span)
    assert not np.array_equal(alone, whole[100:])


def test_advise_file_in_pieces_is_the_whole_advice(tmp_path, monkeypatch):
    """The Python API's program result (advice/program.py) advised in pieces: its frame, text,
    summary figures and written files are the whole-cut advice's."""
    import fuzzyfeed.program.stream as stream
    from fuzzyfeed.advice.pipeline import advise_file
    from fuzzyfeed.program.feeds import program_times
    from fuzzyfeed.program.rewrite import rewrite_program

    src = tmp_path / "r.ngc"
    src.write_text(raster_text(3000, 2))
    program = read_program(src)
    table = load_rule_table()
    ref = advise_program(program, table, feed_step_mm_min=10.0)
    ref_cols = advice_columns(ref)
    ref_text = rewrite_program(program, ref.piece_move, ref.piece_end, ref.piece_feed_mm_min)
    monkeypatch.setattr(stream, "MAX_POINTS", 700)
    assert len(list(stream_program_advice(program, table))) >= 4         # really in pieces
    result = advise_file(src)
    out, ngc = tmp_path / "a.csv", tmp_path / "a.ngc"
    result.write(csv=out, gcode=ngc)
    assert ngc.read_text() == ref_text == result.text
    frame = result.frame()
    assert list(frame.columns) == list(ref_cols)
    for name, col in ref_cols.items():
        assert np.array_equal(frame[name].to_numpy(), col), name
    import csv
    with open(out) as handle:
        rows = list(csv.reader(handle))
    assert np.array_equal(np.array(rows[1:], dtype=float)[:, list(ref_cols).index("feed_mm_min")],
                          ref_cols["feed_mm_min"])
    fig = result.figures()
    fr = ref_cols["feed_pct"]
    assert (fig["feed_pct_min"], fig["feed_pct_mean"]) == (float(fr.min()), float(fr.mean()))
    assert (fig["time_written_s"], fig["time_advised_s"]) == program_times(ref)
    assert fig["cuts_advised"] == 2 and result.summary()[3].startswith("judged:")
