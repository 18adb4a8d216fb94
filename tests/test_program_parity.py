"""The reader's moves against LinuxCNC's rs274 (issue 40): for every library program rs274 accepts
and for 1000 generated programs (tests/programs/random_programs.py), fuzzyfeed's moves are rs274's
motion calls -- same kinds in the same order, end points and displacements within 1 µm plus
rs274's 4-decimal print resolution, arcs' centres and turns, feeds as LinuxCNC's canonical layer
converts them -- and a move is placed exactly when rs274 places it the same way with other
offsets, home positions and tool lengths (see tests/canon.py ``parity``); or fuzzyfeed refuses
the program with one line naming the construct.

The generated programs run 50 to an rs274 call (twice: parameter file A with zero offsets, B with
other offsets); between two programs a ``G92`` line whose values differ in A and B leaves the
next program's start point and axis offsets unknown, as they are when a program starts on a
machine. A batch rs274 refuses is run program by program."""

from __future__ import annotations

import csv
import random
import sys
from pathlib import Path

import numpy as np
import pytest

from canon import canon_events, marked, parity, rs274_calls, var_file
from fuzzyfeed.errors import PathFormatError
from fuzzyfeed.program.read import parse_program, read_program
from fuzzyfeed.program.tools import read_tool_table

sys.path.insert(0, str(Path(__file__).parent / "programs"))
from random_programs import TOOL_TABLE, TOOL_TABLE_B, random_program  # noqa: E402

LIBRARY = Path(__file__).parent.parent / "benchmarks" / "library"
#: The library's tool table (check_library.py): T1-T999, 0.1 inch, length 0; B: other lengths.
LIB_TABLE = "".join(f"T{t} P{t} D0.1 Z0 ;\n" for t in range(1, 1000))
LIB_TABLE_B = "".join(f"T{t} P{t} D0.1 Z{0.1 + 0.001 * t:.3f} ;\n" for t in range(1, 1000))
N_GENERATED = 1000
BATCH = 50


def _library_rows():
    with open(LIBRARY / "MANIFEST.csv", newline="") as f:
        return [r["file"] for r in csv.DictReader(f) if r["kind"] == "program" and r["rs274_ok"] == "yes"]


def _tools(tmp_path, table):
    (tmp_path / "tools.tbl").write_text(table)
    return read_tool_table(tmp_path / "tools.tbl", units="inch")     # rs274 reads it in inches


def _judge(read, events_a, events_b):
    """'read', 'refused' (one line) or raises: the reader against rs274's two runs."""
    import warnings

    from fuzzyfeed.errors import FuzzyfeedNotice

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FuzzyfeedNotice)
        try:
            program = read()
        except PathFormatError as e:
            assert "\n" not in str(e) and str(e), f"refusal not one line: {e!r}"
            return "refused", str(e)
    return "read", parity(program, events_a, events_b)


@pytest.mark.parametrize("name", _library_rows())
def test_library_program_reads_as_rs274_runs_it(name, tmp_path):
    path = LIBRARY / name
    text = path.read_text(encoding="latin-1")
    calls_a, said = rs274_calls(text, tmp_path / "a", LIB_TABLE)
    assert calls_a is not None, f"rs274 refuses {name}: {said}"
    calls_b, said = rs274_calls(text, tmp_path / "b", LIB_TABLE_B, var_file(1))
    assert calls_b is not None, said
    tools = _tools(tmp_path, LIB_TABLE)
    _judge(lambda: read_program(path, tools=tools), canon_events(calls_a), canon_events(calls_b))


def _run_batch(texts, workdir, seed):
    """rs274's events of every program of ``texts`` run one after another in one call (A and B),
    or None when rs274 refuses the batch."""
    rng = random.Random(seed)
    runs = []
    for run, (table, var) in enumerate(((TOOL_TABLE, None), (TOOL_TABLE_B, var_file(seed)))):
        parts, base, ranges = [], 0, []
        for text in texts:
            body = text.rstrip("\n").split("\n")
            assert body[-1] == "M2"
            body = body[:-1]
            # the next program starts at an unknown point with unknown axis offsets (the machine
            # moved by other amounts in A and B, a G92 of other values)
            v = [rng.uniform(-9, 9) for _ in range(6)] if run else [1.0] * 6
            # and G54-G59.3 offsets of other values (a G10 L2 of the program before stays)
            systems = "".join(f"G10 L2 P{p} X{rng.uniform(-9, 9) * run:.3f} Y{rng.uniform(-9, 9) * run:.3f} "
                              f"Z{rng.uniform(-9, 9) * run:.3f}\n" for p in range(1, 10))
            parts.append(f"(FFLINE -1)\nG91 G0 X{v[0]:.3f} Y{v[1]:.3f} Z{v[2]:.3f}\nG90\n{systems}"
                         f"G92 X{v[3]:.3f} Y{v[4]:.3f} Z{v[5]:.3f}")
            parts.append(marked("\n".join(body), base))
            ranges.append((base, base + len(body)))
            base += len(body)
        calls, _ = rs274_calls("\n".join(parts) + "\nM2\n", workdir / f"batch{run}", table, var, mark=False)
        if calls is None:
            return None
        events = canon_events(calls)
        per_program = [[e for e in events if lo <= e.line < hi] for lo, hi in ranges]
        for (lo, _), evs in zip(ranges, per_program):
            for e in evs:
                e.line -= lo
        runs.append(per_program)
    return runs


def _events_of(seeds, texts, workdir, out):
    """rs274's events (A, B) of every program into ``out`` by seed: the batch at once; a batch
    rs274 refuses in halves, down to single programs ((None, None) for one it refuses)."""
    runs = _run_batch(texts, workdir, seeds[0]) if len(texts) > 1 else None
    if runs is not None:
        for k, seed in enumerate(seeds):
            out[seed] = (runs[0][k], runs[1][k])
        return
    if len(texts) == 1:
        seed, text = seeds[0], texts[0]
        calls_a, _ = rs274_calls(text, workdir / f"s{seed}a", TOOL_TABLE)
        calls_b, _ = rs274_calls(text, workdir / f"s{seed}b", TOOL_TABLE_B, var_file(seed))
        out[seed] = (None, None) if calls_a is None else (canon_events(calls_a), canon_events(calls_b))
        return
    half = len(texts) // 2
    _events_of(seeds[:half], texts[:half], workdir / "l", out)
    _events_of(seeds[half:], texts[half:], workdir / "r", out)


def test_generated_programs_read_as_rs274_runs_them(tmp_path):
    tools = _tools(tmp_path, TOOL_TABLE)
    counts = {"read": 0, "refused": 0, "rs274 refuses": 0, "moves": 0, "placed": 0, "feeds": 0}
    refusals = {}
    for first in range(0, N_GENERATED, BATCH):
        seeds = list(range(first, min(first + BATCH, N_GENERATED)))
        texts = [random_program(4000 + s, tag=s + 1) for s in seeds]
        events = {}
        _events_of(seeds, texts, tmp_path / f"b{first}", events)
        for k, (seed, text) in enumerate(zip(seeds, texts)):
            ev_a, ev_b = events[seed]
            if ev_a is None:
                counts["rs274 refuses"] += 1
                continue
            try:
                verdict, what = _judge(lambda: parse_program(text, f"gen{seed}.ngc", tools), ev_a, ev_b)
            except AssertionError as e:
                raise AssertionError(f"generated program {seed} (random_program({4000 + seed}, tag={seed + 1})):"
                                     f" {e}\n{text}") from None
            counts[verdict] += 1
            if verdict == "read":
                for key in ("moves", "placed", "feeds"):
                    counts[key] += what[key]
            else:
                rule = what.split(": ", 2)[-1][:40]
                refusals[rule] = refusals.get(rule, 0) + 1
    print(counts, refusals)
    judged = counts["read"] + counts["refused"]
    assert judged >= 0.9 * N_GENERATED, counts            # the generator writes programs rs274 runs
    assert counts["read"] >= 0.85 * judged, (counts, refusals)   # and the reader reads most of them
    assert counts["placed"] >= 0.8 * counts["moves"], counts


def _feeds(text, tmp_path):
    calls, said = rs274_calls(text, tmp_path, TOOL_TABLE)
    assert calls is not None, said
    return [e.feed for e in canon_events(calls) if e.name != "STRAIGHT_TRAVERSE"]


@pytest.mark.parametrize("text, want", [
    # issue 37: F is set (order of execution step 4) before the units change (step 14)
    ("G21 G90 F100\nG1 X1\nG20 F6\nG1 X1\nG21\nG1 X2\nM2\n", [100, 6, 6]),
    ("G20 G90 F10\nG1 X1\nG21 F300\nG1 X2\nG20\nG1 X3\nM2\n", [10, 7620, 7620]),   # the start: mm
    # F on a line that changes units and moves: the move is in the new units, its F in the old
    ("G21 G90 F100\nG1 X1\nG20 G1 X1 F6\nG1 X2\nM2\n", [100, 6, 6]),
    # G94 sets F to 0 (step 3) before the F of its line (step 4)
    ("G21 G90 F100\nG1 X1\nG94 F50\nG1 X2\nM2\n", [100, 50]),
])
def test_units_and_feed_on_one_line(text, want, tmp_path):
    """``G21`` then ``G20 F6`` runs at 6 mm/min (LinuxCNC converts F with the units in force when it
    is set); fuzzyfeed read 152.4. The feeds equal rs274's as the canonical layer converts them."""
    program = parse_program(text)
    feeds = program.feed_mm_min[~np.isnan(program.feed_mm_min)]
    np.testing.assert_allclose(feeds, want, rtol=1e-9)
    np.testing.assert_allclose(_feeds(text, tmp_path), want, rtol=1e-5)


def test_incremental_polar_spiral(tmp_path):
    """LinuxCNC's nc_files/spiral.ngc (same words): ``g91 g1 @-.0025 ^4.5`` 800 times from (2, 0) inch
    adds to the radius and the angle about the origin; rs274 gives 801 STRAIGHT_FEEDs, the first
    polar one to (1.9913, 0.1567). All are placed and advised as one cut."""
    text = ("g20 g64 g90\ns3400 m3\ng0 z1\ng0 x2 y0\ng1 z-.1 f24\no100 repeat [800]\n"
            "g91 g1 @-.0025 ^4.5\no100 endrepeat\ng90 g0 z1\nm2\n")
    program = parse_program(text)
    lines = np.flatnonzero(program.kind == 1)
    assert lines.size == 801 and program.known[lines].all() and (program.cut[lines] == 0).all()
    np.testing.assert_allclose(program.end[lines[1], :2] / 25.4, [1.99134, 0.15672], atol=1e-5)
    theta = np.radians(4.5 * np.arange(1, 801))
    radius = 2 - 0.0025 * np.arange(1, 801)
    np.testing.assert_allclose(program.end[lines[1:], :2] / 25.4,
                               np.column_stack([radius * np.cos(theta), radius * np.sin(theta)]), atol=1e-9)
    calls_a, _ = rs274_calls(text, tmp_path / "a", TOOL_TABLE)
    calls_b, _ = rs274_calls(text, tmp_path / "b", TOOL_TABLE_B, var_file(3))
    stats = parity(program, canon_events(calls_a), canon_events(calls_b))
    assert stats["placed"] == 802


def test_offsets_the_program_sets_are_followed(tmp_path):
    """G92 with axis words, G52, G92.1/.2/.3: the points the program determines are placed (rs274
    gives the same displacement whatever the machine's offsets), the others are not."""
    text = ("G21 G90 G17 F100\nG0 X1 Y1 Z1\nG92 X0 Y0\nG1 X5 Y5\nG92.2\nG1 X1\nG92.3\nG1 Y2\n"
            "G52 X3\nG1 X4 Y4\nG52 X0\nG1 X0\nG92.1\nG1 Y0\nG92.3\nG1 X1\nM2\n")
    program = parse_program(text)
    calls_a, _ = rs274_calls(text, tmp_path / "a", TOOL_TABLE)
    calls_b, _ = rs274_calls(text, tmp_path / "b", TOOL_TABLE_B, var_file(5))
    stats = parity(program, canon_events(calls_a), canon_events(calls_b))
    assert stats["placed"] >= 5 and stats["not_placed"] >= 1
