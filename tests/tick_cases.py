"""Cases the tick-pass tests share (tests/test_machine_stream.py, test_tick_search.py,
test_tick_fast.py): the library programs fuzzyfeed reads, one read into the path a machine runs,
and random polylines with or without rapids."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from fuzzyfeed.errors import FuzzyfeedError
from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.planner import Motion
from fuzzyfeed.program.read import read_program
from fuzzyfeed.program.run import program_path

LIBRARY = Path(__file__).resolve().parents[1] / "benchmarks" / "library"


def library_programs(every: int = 1) -> list[str]:
    """The library's programs fuzzyfeed reads (benchmarks/library/MANIFEST.csv), every ``every``-th."""
    with open(LIBRARY / "MANIFEST.csv", newline="") as f:
        rows = [row["file"] for row in csv.DictReader(f)
                if row["kind"] == "program" and row["fuzzyfeed_reads"] == "ok"]
    return rows[::every]


def library_path(rel: str, machine: Machine):
    """The library program ``rel`` as the path ``machine`` runs; the test is skipped where the
    program is not read or the machine runs nothing of it."""
    try:
        program = read_program(LIBRARY / rel)
    except FuzzyfeedError as exc:
        pytest.skip(f"not read: {exc}")
    path = program_path(program, machine.chord_tol_mm)
    if not path.chains:
        pytest.skip("nothing the machine runs")
    return path


def random_polyline(rng: np.random.Generator, n: int, scale: float, rapids: bool) -> Motion | None:
    """A random walk of ``n`` moves (steps of ``scale`` mm in x and y, a fifth of it in z), 15 % of
    them rapids if ``rapids``, feeds 2-90 mm/s; None where fewer than two distinct points remain."""
    pts = np.cumsum(rng.normal(size=(n + 1, 3)) * [scale, scale, 0.2 * scale], axis=0)
    pts = pts[np.concatenate([[True], np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-6])]
    if pts.shape[0] < 2:
        return None
    m = pts.shape[0] - 1
    rapid = rng.random(m) < (0.15 if rapids else 0.0)
    feed = np.where(rapid, np.nan, rng.uniform(2.0, 90.0, m))
    return Motion(pts, feed, rapid, np.full(m + 1, np.nan))
