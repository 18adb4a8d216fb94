"""The compact line store of a read program (fuzzyfeed.program.line_store) is the lines as read:
against the list of str it replaces, on odd text (empty lines, CR, non-ASCII, a lone surrogate)
and on every program of a few library files."""

from __future__ import annotations

import pickle
import sys
from pathlib import Path

import pytest

from fuzzyfeed.program.line_store import LineStore
from fuzzyfeed.program.read import parse_program

ODD = ["G21", "", "G1 X1 (é ü ✓)", "  ", "\r", "N10 G0 Z5\t", "(\udcff latin-1 read back)", ""]


@pytest.mark.parametrize("lines", [[], [""], ["G0 X1"], ODD, [f"G1 X{i * 0.1:.4f}" for i in range(40_000)]])
def test_store_is_the_list(lines):
    store = LineStore(lines)
    assert len(store) == len(lines) and list(store) == lines and store == lines and store == tuple(lines)
    assert [store[i] for i in range(len(lines))] == lines
    assert [store[-i - 1] for i in range(len(lines))] == lines[::-1]
    assert store[1:5] == tuple(lines[1:5]) and store[::3] == tuple(lines[::3])
    assert pickle.loads(pickle.dumps(store)) == store
    with pytest.raises(IndexError):
        store[len(lines)]


def test_store_refuses_a_line_break_and_differs_where_the_lines_do():
    with pytest.raises(ValueError):
        LineStore(["a\nb"])
    assert LineStore(["a", "b"]) != ["a", "c"] and LineStore(["a", "b"]) != ["a"]
    assert LineStore(["a", "b"]) != LineStore(["a", "bb"])


def test_a_read_program_holds_its_lines():
    library = Path(__file__).resolve().parents[1] / "benchmarks" / "library" / "programs"
    files = sorted(library.rglob("*.ngc"))[:5]
    if not files:
        pytest.skip("no library")
    for path in files:
        text = path.read_bytes().decode("latin-1")
        program = parse_program(text, path)
        expected = [ln.rstrip("\r") for ln in text.split("\n")]
        if expected and expected[-1] == "":
            expected.pop()
        assert isinstance(program.lines, LineStore) and list(program.lines) == expected
        assert program.lines.nbytes < sum(sys.getsizeof(ln) + 8 for ln in expected)
