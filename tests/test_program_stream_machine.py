"""The machine table's advice in pieces (fuzzyfeed.program.stream_machine) equals the machine advice
of the whole cut at once, bit for bit; the check fails with short margins or without the carried
settling levels; `advise --machine` no longer refuses a cut over the sample budget."""

from __future__ import annotations

import csv
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fuzzyfeed.cli import main
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.machine.description import load_machine
from fuzzyfeed.program.feeds import advice_columns, advise_program
from fuzzyfeed.program.read import parse_program, read_program
from fuzzyfeed.program.stream import concat_pieces
from fuzzyfeed.program.stream_machine import stream_machine_advice
from test_program_stream import raster_text

ROOT = Path(__file__).resolve().parents[1]
LIBRARY = ROOT / "benchmarks" / "library" / "programs"


def _compare(program, table, machine, piece_points, **kw):
    whole = advise_program(program, table, machine=machine, **kw)
    cols = advice_columns(whole)
    pieces = list(stream_machine_advice(program, table, machine, piece_points=piece_points, **kw))
    streamed = {k: np.concatenate([p.columns[k] for p in pieces]) for k in pieces[0].columns}
    assert list(streamed) == list(cols)
    differ = [k for k in cols if not np.array_equal(streamed[k], cols[k])]
    pm, pe, pf = concat_pieces(pieces)
    same_pieces = (np.array_equal(pm, whole.piece_move) and np.array_equal(pe, whole.piece_end)
                   and np.array_equal(pf, whole.piece_feed_mm_min))
    return differ, same_pieces, len(pieces), cols


@pytest.mark.parametrize("piece_points", [29, 300, 5000, 10**6])
def test_raster_machine_advice_in_pieces_is_the_whole_cut(piece_points):
    """Two zig-zag cuts over a freeform surface: hot junctions at every step-over (the settling
    minimum at work), the entries behind rapids: every CSV value and written piece as the whole cut's."""
    program = parse_program(raster_text(4000, 2), "raster.ngc")
    differ, same, n, cols = _compare(program, load_rule_table("machine"), load_machine("reference"), piece_points)
    assert differ == [] and same
    assert n == 2 if piece_points >= 5000 else n >= 6     # 5000 and 10⁶: each cut one piece
    assert cols["feed_pct"].min() < 50.0 < cols["feed_pct"].max()     # the advice slows somewhere
    assert np.any(cols["safe_feed_ratio_near"] < cols["safe_feed_ratio"])


@pytest.mark.parametrize("name, filt", [("linuxcnc/arcspiral.ngc", None),
                                        ("linuxcnc/3D_Chips.ngc", "corner-mean"),
                                        ("linuxcnc/arcspiral.ngc", "min-mean")])
def test_library_machine_advice_in_pieces(name, filt):
    """Arcs beside lines, 3-D surfacing of short G1, the filters that average over mm (their
    cumulative sums and corner-mean's guard carried), a feed cap."""
    path = LIBRARY / name
    if not path.exists():
        pytest.skip(f"{path} not in the library")
    table = load_rule_table("machine")
    if filt is not None:
        table = replace(table, filter=filt, filter_mm=3.0)
    program = read_program(path)
    differ, same, n, _ = _compare(program, table, load_machine("reference"), 41,
                                  cap_mm_min=700.0 if filt == "min-mean" else None)
    assert differ == [] and same and n > 2


def test_fails_with_short_margins(monkeypatch):
    """Margins shorter than the settling reach: the near input differs from the whole cut's."""
    import fuzzyfeed.program.stream_machine as sm

    monkeypatch.setattr(sm, "machine_margin_mm", lambda table, machine, top: 0.3)
    program = parse_program(raster_text(3000, 1), "raster.ngc")
    differ, _, _, _ = _compare(program, load_rule_table("machine"), load_machine("reference"), 200)
    assert "safe_feed_ratio_near" in differ


def test_fails_without_the_carried_levels(monkeypatch):
    """Each piece's own settling levels (its slowest hot spot and fastest feed) instead of the cut's."""
    import fuzzyfeed.program.stream_machine as sm

    real = sm.settling_min
    monkeypatch.setattr(sm, "settling_min", lambda *a, levels=None, span=None: real(*a, span=span))
    program = parse_program(raster_text(3000, 1), "raster.ngc")
    differ, _, _, _ = _compare(program, load_rule_table("machine"), load_machine("reference"), 200)
    assert "safe_feed_ratio_near" in differ


def test_fails_without_the_entry_feed(monkeypatch):
    """The entry's safe feed on the first piece only: taken away, the first samples differ."""
    import fuzzyfeed.program.stream_machine as sm

    monkeypatch.setattr(sm, "entry_safe_feed", lambda *a: float("inf"))
    moves = "\n".join(f"G1 X{0.1 * i:.1f} Y{0.02 * (i % 2):.2f}" for i in range(1, 3000))
    program = parse_program(f"G21 G90 G94\nG0 X0 Y-20 Z0\nG0 Y0\nF3000\n{moves}\nM30\n", "entry.ngc")
    differ, _, _, _ = _compare(program, load_rule_table("machine"), load_machine("reference"), 200)
    assert "safe_feed_mm_min" in differ


def test_cli_machine_advice_of_a_cut_over_the_budget(tmp_path, monkeypatch):
    """With the sample budget below one cut's samples the whole-cut machine advice refuses;
    `advise --machine` writes the CSV and program the whole-cut advice writes under the normal budget."""
    import fuzzyfeed.geometry.sampling as sampling
    import fuzzyfeed.program.stream_machine as sm

    src = tmp_path / "r.ngc"
    src.write_text(raster_text(3000, 1))
    ref_csv, ref_ngc = tmp_path / "ref.csv", tmp_path / "ref.ngc"
    monkeypatch.setattr(sm, "streams", lambda table: False)          # the whole cut's advice
    assert main(["advise", str(src), "--machine", "reference", "-o", str(ref_csv), "--gcode", str(ref_ngc)]) == 0
    monkeypatch.undo()
    budget = sampling.MAX_POINTS
    monkeypatch.setattr(sampling, "MAX_POINTS", 1000)
    program = read_program(src)
    with pytest.raises(ValueError, match="budget of 1,000"):
        advise_program(program, load_rule_table("machine"), machine=load_machine("reference"))
    monkeypatch.setattr(sampling, "MAX_POINTS", budget)
    monkeypatch.setattr(sm, "MAX_POINTS", 1000)
    out, ngc = tmp_path / "a.csv", tmp_path / "a.ngc"
    assert main(["advise", str(src), "--machine", "reference", "-o", str(out), "--gcode", str(ngc)]) == 0
    assert ngc.read_text() == ref_ngc.read_text()
    assert "F" in ngc.read_text() and ngc.read_text() != src.read_text()     # advised: F words changed
    with open(out) as a, open(ref_csv) as b:
        assert a.read() == b.read()
    with open(out) as handle:
        header = next(csv.reader(handle))
    assert header[-1] == "advised" and "safe_feed_ratio_near" in header
