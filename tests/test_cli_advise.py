"""CLI: ``fuzzyfeed advise`` writes the advised feed per point, prints a summary, and fails with one
line (exit 2, no output file) on bad input."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from fuzzyfeed.cli import main
from fuzzyfeed.fuzzy.advisor import advise_details
from fuzzyfeed.fuzzy.rule_reader import rules_dir
from fuzzyfeed.io.shapes import load_shape, sample_shape

COLUMNS = ["u", "x_mm", "y_mm", "z_mm", "s_mm", "curvature_1_mm", "curvature_variation",
           "feed_pct", "feed_mm_min"]


def read_csv(path):
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    header = rows[0]
    data = np.array(rows[1:], dtype=float)
    return {name: data[:, i] for i, name in enumerate(header)}


def test_advise_writes_csv_and_summary(tmp_path, capsys):
    out = tmp_path / "inf.csv"
    assert main(["advise", "infinity", "-o", str(out), "--feed-mm-min", "3000", "--points", "800"]) == 0
    cols = read_csv(out)
    assert set(COLUMNS) <= set(cols) and len(cols["u"]) == 800
    # exactly what the library computes (full precision round trip)
    advice = advise_details(sample_shape(load_shape("infinity"), 800), None, 3000 / 60)
    np.testing.assert_array_equal(cols["feed_mm_min"], advice.profile.feed_mm_min)
    np.testing.assert_array_equal(cols["curvature_variation"], advice.features.curvature_variation)
    np.testing.assert_array_equal(cols["feed_pct"], advice.profile.feed_pct)
    assert cols["feed_mm_min"].min() >= 0.05 * 3000 and cols["feed_mm_min"].max() <= 3000
    text = capsys.readouterr().out
    assert "infinity: 800 points" in text and "F = 3000 mm/min" in text
    assert f"min {cols['feed_mm_min'].min():.1f}" in text
    assert f"time at the advised feeds {advice.profile.travel_time_s():.4f} s" in text


def test_advise_with_rules_file_and_plot(tmp_path, capsys):
    rules = tmp_path / "slow.toml"
    rules.write_text((rules_dir() / "paper.toml").read_text().replace(
        "feed_floor_pct = 5.0", "feed_floor_pct = 40.0"))
    out, fig = tmp_path / "t.csv", tmp_path / "t.png"
    assert main(["advise", "trident", "-o", str(out), "--rules", str(rules), "--plot", str(fig)]) == 0
    assert read_csv(out)["feed_pct"].min() == 40.0
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # an edited copy is named after its file, and the sidecar says which table, F and path made the CSV
    assert "rules 'slow'" in capsys.readouterr().out
    import json

    meta = json.loads((tmp_path / "t.csv-metadata.json").read_text())
    record = meta["notes"][0]["fuzzyfeed"]
    assert meta["url"] == "t.csv" and meta["@context"] == "http://www.w3.org/ns/csvw"
    assert [c["name"] for c in meta["tableSchema"]["columns"]] == list(read_csv(out))
    assert record["rules"] == "slow" and record["rules_file"] == str(rules)
    assert record["F_mm_min"] == "6000" and "trident.toml" in record["source"]
    from fuzzyfeed.fuzzy.provenance import table_digest
    from fuzzyfeed.fuzzy.rule_reader import load_rule_table

    assert record["rules_digest"] == table_digest(load_rule_table(rules))
    assert record["rules_digest"] != table_digest(load_rule_table("paper"))
    import pandas as pd

    frame = pd.read_csv(out)                     # the CSV itself stays plain
    assert list(frame.columns) == list(read_csv(out))


def _degenerate_shape(tmp_path):
    # C'(0) = 0: curvature is infinite at the first sample
    path = tmp_path / "cusp.toml"
    path.write_text("degree = 2\nknotvector = [0, 0, 0, 1, 1, 1]\n"
                    "control_points = [[0, 0], [0, 0], [10, 0]]\n")
    return path


def _bad_rules(tmp_path):
    path = tmp_path / "bad_rules.toml"
    path.write_text((rules_dir() / "paper.toml").read_text().replace('"VHF",  "VHF",  "VVLF"',
                                                                     '"VHF",  "FAST", "VVLF"'))
    return path


@pytest.mark.parametrize("extra, message", [
    (["--feed-mm-min", "-5"], "--feed-mm-min = -5; the maximum feed must be a finite number > 0 mm/min"),
    (["--feed-mm-min", "0"], "--feed-mm-min = 0; the maximum feed must be a finite number > 0 mm/min"),
    (["--feed-mm-min", "nan"], "--feed-mm-min = nan; the maximum feed must be"),
    (["--rules", "{bad_rules}"], "bad_rules.toml:{vs_line}: row VS, column H (cell 4): unknown feed label 'FAST'"),
    (["--rules", "nosuch"], "rule table 'nosuch': no such shipped table or file"),
    (["SHAPE={cusp}"], "curvature[0] = inf; curvature must be finite"),
])
def test_bad_input_one_line_exit_2(tmp_path, capsys, monkeypatch, extra, message):
    monkeypatch.chdir(tmp_path)
    names = {"bad_rules": str(_bad_rules(tmp_path)), "cusp": str(_degenerate_shape(tmp_path))}
    shape = "infinity"
    args = []
    for a in extra:
        a = a.format(**names)
        if a.startswith("SHAPE="):
            shape = a[len("SHAPE="):]
        else:
            args.append(a)
    out = tmp_path / "out.csv"
    assert main(["advise", shape, "-o", str(out), *args]) == 2
    err = capsys.readouterr().err
    vs_line = 1 + [ln.startswith("VS      =") for ln in
                   (rules_dir() / "paper.toml").read_text().splitlines()].index(True)
    message = message.replace("{vs_line}", str(vs_line))
    assert err.startswith("fuzzyfeed: error: ") and message in err, err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not out.exists() and not list(tmp_path.glob(".*.part"))


def test_help_shows_the_default_feed(capsys):
    with pytest.raises(SystemExit):
        main(["advise", "--help"])
    out = capsys.readouterr().out
    assert "default: 6000" in out and "--rules" in out and "feed_mm_min" in out


def test_rule_strength_columns(tmp_path):
    out = tmp_path / "w.csv"
    assert main(["advise", "trident", "-o", str(out), "--points", "300", "--rule-strengths"]) == 0
    cols = read_csv(out)
    names = [c for c in cols if c.startswith("w_")]
    assert len(names) == 30 and names[0] == "w_ZO_ZO" and "w_VB_VH" in names
    w = np.stack([cols[c] for c in names], axis=1)
    assert ((w >= 0) & (w <= 1)).all() and (w.max(axis=1) > 0).all()


def test_filter_flag_offers_every_filter_the_advisor_has():
    from fuzzyfeed.cli import build_parser
    from fuzzyfeed.fuzzy.filters import FILTER_KINDS

    advise = build_parser()._subparsers._group_actions[0].choices["advise"]
    flag = next(a for a in advise._actions if "--filter" in a.option_strings)
    assert set(flag.choices) == set(FILTER_KINDS)


def test_a_point_list_is_advised_along_its_long_sides(tmp_path):
    """A CSV rectangle of 60 x 40 mm was advised at its points only: every side at its corners'
    feed (700 mm/min of 6000 over 60 mm of straight line). Samples every 0.25 mm inside long
    segments let the advice rise between the corners; the given points stay samples."""
    points = tmp_path / "rect.csv"
    points.write_text("x_mm,y_mm\n0,0\n60,0\n60,40\n0,40\n0,0\n")
    out = tmp_path / "a.csv"
    assert main(["advise", str(points), "-o", str(out)]) == 0
    with open(out, newline="") as handle:
        rows = list(csv.DictReader(handle))
    s = np.array([float(r["s_mm"]) for r in rows])
    feed = np.array([float(r["feed_mm_min"]) for r in rows])
    assert np.diff(s).max() <= 0.25 + 1e-9
    assert np.all(np.isin([0.0, 60.0, 100.0, 160.0, 200.0], np.round(s, 9)))
    middle = np.abs(s - 30.0) < 1.0        # the middle of the first long side
    assert feed[middle].min() > 0.8 * 6000.0
    corner = np.argmin(np.abs(s - 60.0))
    assert feed[corner] < 0.2 * 6000.0
