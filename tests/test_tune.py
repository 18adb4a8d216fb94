"""Tuning a rule table's feed terms: the partition, the search's guarantees, the CLI."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzyfeed.cli import main
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.fuzzy.tune import evaluate, excess, partition_feed, peaks_of, tune_output_terms
from fuzzyfeed.io.shapes import load_shape, sample_shape
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.machine.servo import ServoModel


def test_the_paper_feed_terms_are_their_own_partition():
    feed = load_rule_table().feed
    again = partition_feed(feed, np.diff(peaks_of(feed)))
    assert [t.label for t in again.terms] == [t.label for t in feed.terms]
    np.testing.assert_allclose([t.points for t in again.terms], [t.points for t in feed.terms], atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(1e-3, 1e3), min_size=7, max_size=7))
def test_partition_is_ordered_and_covers_the_universe(gaps):
    feed = partition_feed(load_rule_table().feed, np.array(gaps))
    peaks = peaks_of(feed)
    assert peaks[0] == 0.0 and peaks[-1] == 100.0 and np.all(np.diff(peaks) > 0)
    # a Ruspini partition: memberships sum to 1 everywhere in the universe
    x = np.linspace(0, 100, 1001)
    total = np.zeros_like(x)
    for t in feed.terms:
        a, b, _, c = t.trapezoid
        up = np.where(b > a, (x - a) / max(b - a, 1e-300), 1.0)
        down = np.where(c > b, (c - x) / max(c - b, 1e-300), 1.0)
        total += np.clip(np.minimum(up, down), 0, 1) * ((x >= a) & (x <= c))
    np.testing.assert_allclose(total, 1.0, atol=1e-9)


def test_tuning_keeps_the_constraints_and_never_gets_slower(tmp_path):
    shapes = {"trident": sample_shape(load_shape("trident"), 500)}
    limits = MachineLimits.from_feed_mm_min(3000)
    table = load_rule_table()
    result = tune_output_terms(table, shapes, limits, contour_tol_um=100.0, max_evaluations=25)
    assert result.feasible and result.evaluations <= 25 + 1
    before, after = result.before["trident"], result.after["trident"]
    assert excess(before, 100.0) == 0.0  # the paper's table already meets them here
    assert after.cycle_time_s < before.cycle_time_s
    # re-simulated from the written file, the tuned table gives the same, admissible result
    path = tmp_path / "tuned.toml"
    from fuzzyfeed.fuzzy.rule_writer import save_rule_table

    save_rule_table(result.table, path)
    again = evaluate(load_rule_table(path), shapes, limits, ServoModel())["trident"]
    assert again.cycle_time_s == pytest.approx(after.cycle_time_s, rel=1e-9)
    assert again.contour_err_max_um <= 100.0
    assert all(worst <= 1.0 + 1e-3 for name, (_, worst) in again.violations.items() if name != "jerk")
    assert load_rule_table(path).grid == table.grid


def test_cli_tune_writes_a_new_table(tmp_path, capsys):
    out = tmp_path / "tuned.toml"
    args = ["tune", "trident", "--points", "400", "--evaluations", "12", "--feed-mm-min", "3000",
            "--contour-tol-um", "120", "-o", str(out)]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "total cycle time" in printed and "feasible" in printed
    assert main(["rules", "check", str(out)]) == 0
    text = out.read_text()
    assert main(args) == 2  # never overwrites
    assert "file exists" in capsys.readouterr().err
    assert out.read_text() == text
