"""``fuzzyfeed schedule`` as a user runs it."""

import csv
import sys

import numpy as np
import pytest

from fuzzyfeed.cli import main


def read_csv(path):
    with open(path, newline="") as handle:
        rows = list(csv.reader(handle))
    return rows[0], np.array(rows[1:], dtype=float)


def test_schedule_writes_trajectory_and_summary(tmp_path, capsys):
    out = tmp_path / "traj.csv"
    assert main(["schedule", "wm", "-o", str(out)]) == 0
    header, data = read_csv(out)
    for col in ("t_s", "u", "x_mm", "y_mm", "z_mm", "feed_mm_s", "acc_mm_s2", "jerk_mm_s3"):
        assert col in header
    t = data[:, header.index("t_s")]
    assert np.allclose(np.diff(t), 0.001)
    feed = data[:, header.index("feed_mm_s")]
    assert feed[0] == 0 and feed[-1] == 0 and feed.max() <= 100 + 1e-9
    text = capsys.readouterr().out
    for word in ("cycle time", "critical points", "chord error", "axis acc", "jerk", "ratio"):
        assert word in text
    assert "planner           whole-path LP (the look-ahead window's 1.3820 s was slower)" in text  # the default
    assert main(["schedule", "wm", "-o", str(out), "--planner", "window"]) == 0
    text = capsys.readouterr().out
    assert "planner           look-ahead window\n" in text and "blocks 10" in text


def test_limit_flags_are_used(tmp_path, capsys):
    out = tmp_path / "traj.csv"
    assert main(["schedule", "infinity", "-o", str(out), "--feed-mm-min", "3000", "--axis-acc-mm-s2",
                 "500,800,1000", "--jerk-mm-s3", "5000", "--chord-tol-mm", "0.002", "--ts-s", "0.002"]) == 0
    header, data = read_csv(out)
    assert np.allclose(np.diff(data[:, header.index("t_s")]), 0.002)
    assert data[:, header.index("feed_mm_s")].max() <= 50 + 1e-9


@pytest.mark.parametrize("flag, value", [("--feed-mm-min", "0"), ("--jerk-mm-s3", "-5"), ("--ts-s", "abc"),
                                         ("--axis-vel-mm-s", "1,2"), ("--chord-tol-mm", "nan")])
def test_bad_limit_flags_exit_2(tmp_path, capsys, flag, value):
    out = tmp_path / "traj.csv"
    with pytest.raises(SystemExit) as exc:
        main(["schedule", "wm", "-o", str(out), flag, value])
    assert exc.value.code == 2
    assert flag in capsys.readouterr().err
    assert not out.exists()


def test_unknown_shape_is_one_line_error(tmp_path, capsys):
    out = tmp_path / "traj.csv"
    assert main(["schedule", "no-such-shape", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("fuzzyfeed: error:") and err.count("\n") == 1
    assert not out.exists()


def test_too_long_servo_period_is_refused(tmp_path, capsys):
    out = tmp_path / "traj.csv"
    assert main(["schedule", "wm", "-o", str(out), "--ts-s", "5"]) == 2
    assert "ts_s" in capsys.readouterr().err
    assert not out.exists()


def test_plot(tmp_path):
    pytest.importorskip("matplotlib")
    out, fig = tmp_path / "traj.csv", tmp_path / "fig.png"
    assert main(["schedule", "trident", "-o", str(out), "--plot", str(fig)]) == 0
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_help_lists_limit_flags(capsys):
    with pytest.raises(SystemExit):
        main(["schedule", "--help"])
    text = capsys.readouterr().out
    for flag in ("--feed-mm-min", "--axis-vel-mm-s", "--axis-acc-mm-s2", "--jerk-mm-s3", "--chord-tol-mm",
                 "--ts-s", "6000", "--plot"):
        assert flag in text


def test_planner_optimal_is_the_faster_schedule_and_says_so(tmp_path, capsys):
    """``--planner optimal`` keeps the whole-path LP's schedule where it beats the window (trident
    on the hobby router, whose slow axes the LP follows more closely), and the summary says which."""
    times = {}
    for planner in ("window", "optimal"):
        out = tmp_path / f"{planner}.csv"
        assert main(["schedule", "trident", "-o", str(out), "--machine", "hobby-router",
                     "--transition", "seven-phase", "--planner", planner]) == 0
        text = capsys.readouterr().out
        times[planner] = float(text.split("cycle time")[1].split()[0])
        assert ("whole-path LP" in text) == (planner == "optimal"), text
        with out.open() as fh:
            rows = list(csv.DictReader(fh))
        assert abs(float(rows[-1]["t_s"]) - times[planner]) < 1e-9
    assert times["optimal"] < times["window"]


def test_bad_planner_is_one_line_exit_2(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["schedule", "trident", "-o", str(tmp_path / "t.csv"), "--planner", "fast"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--planner" in err[0] and "fast" in err[0]
    assert not (tmp_path / "t.csv").exists()
