"""PathBuilder's chunks of lines and rapids built in arrays (``_add_plain``) against its
move-by-move rules (the same moves forced through the per-move loop): the same ``on_chunk`` /
``on_close`` calls, in the same order, with the same arrays bit for bit, whatever the chunk, with
zero-length and tiny moves, stops, breaks, moves not run and a chain carried from one ``add`` to
the next."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from fuzzyfeed.program import path_builder
from fuzzyfeed.program.read import parse_program

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE / "programs"))


def line_program(seed: int) -> str:
    """Lines and rapids on a coarse grid (repeated points: zero-length moves), 1e-10 mm steps,
    stops (M0, M1), G28, G93 moves (not run) and F changes."""
    rng = np.random.default_rng(seed)
    out = ["G21 G90 G94 G17 F600", "G0 Z5", "G0 X0 Y0"]
    for _ in range(400):
        r = rng.random()
        x, y, z = rng.integers(0, 3, 3)
        if r < 0.55:
            out.append(f"G1 X{x} Y{y} Z{-z * 0.5:g} F{rng.choice([300, 600, 1200])}")
        elif r < 0.65:
            out.append("G1 X0.0000000001")
        elif r < 0.75:
            out.append(f"G0 X{x} Y{y} Z{z}")
        elif r < 0.8:
            out.append(f"G1 X{x} Y{y} {rng.choice(['M0', 'M1'])}")
        elif r < 0.84:
            out.append("G28")
        elif r < 0.88:
            out += [f"G93 G1 X{x} Y{y} F10", "G94 F600"]
        else:
            out.append(f"G1 X{x + 0.25} Y{y}")
    out.append("M30")
    return "\n".join(out) + "\n"


def events(program, chunk: int, monkeypatch, per_move: bool) -> list:
    monkeypatch.setattr(path_builder, "PATH_CHUNK_MOVES", chunk)
    if per_move:
        monkeypatch.setattr(path_builder, "_plain_moves", lambda p, run: np.zeros(p.kind.size, dtype=bool))
    got = []
    b = path_builder.PathBuilder(0.002, lambda prog, tag, *arrays: got.append(("chunk", tag, arrays)),
                                 lambda has: got.append(("close", has)))
    b.add(program, "a")
    b.add(program, "b")      # the second starts where the first's chain may still be open
    b.finish(program, "b")
    monkeypatch.undo()
    return got


def _same(a: list, b: list) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert x[0] == y[0] and x[1] == y[1]
        if x[0] == "chunk":
            assert len(x[2]) == len(y[2])
            for u, v in zip(x[2], y[2]):
                assert u.dtype == v.dtype and u.shape == v.shape and u.tobytes() == v.tobytes()


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("chunk", [1, 5, 64, 1 << 15])
def test_plain_chunks_are_the_per_move_rules(seed, chunk, monkeypatch):
    program = parse_program(line_program(seed), Path(f"lines_{seed}.ngc"))
    fast = events(program, chunk, monkeypatch, per_move=False)
    assert sum(e[0] == "close" for e in fast) > 5
    _same(fast, events(program, chunk, monkeypatch, per_move=True))


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("chunk", [3, 50])
def test_plain_and_arc_chunks_mixed(seed, chunk, monkeypatch):
    from random_programs import random_program

    program = parse_program(random_program(seed), Path(f"random_{seed}.ngc"))
    _same(events(program, chunk, monkeypatch, per_move=False), events(program, chunk, monkeypatch, per_move=True))


def test_a_raster_takes_the_arrays(monkeypatch):
    from test_program_stream import raster_text

    program = parse_program(raster_text(3000, 4), "r.ngc")
    assert path_builder._plain_moves(program, program.known).all()    # the first move is not run (not known)
    _same(events(program, 700, monkeypatch, per_move=False), events(program, 700, monkeypatch, per_move=True))
