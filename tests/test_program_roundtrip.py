"""Whole programs in, the same programs out with advised feeds, checked by LinuxCNC's own
interpreter: for each of the 44 corpus programs (FreeCAD's LinuxCNC post, Fusion/Mastercam-style
posts, GRBL-style sender files, LinuxCNC examples; see tests/programs/make_corpus.py),
``fuzzyfeed advise PROGRAM -o CSV --gcode OUT`` writes a program that ``rs274 -g`` accepts and
whose canonical calls equal the original's except SET_FEED_RATE values and split points (see
tests/canon.py), with every feed > 0 and at most the programmed feed, and slower than programmed
where the path turns tightly."""

from __future__ import annotations

import csv
import re
from pathlib import Path

import numpy as np
import pytest

from canon import canon, compare
from fuzzyfeed.cli import main

_F = re.compile(r"[Ff]\s*[-+]?[\d.]+")
_GEOMETRY = re.compile(r"[XxYyZzIiJjKkRr]\s*[-+]?[\d.]+")


def _same_line(old: str, new: str) -> bool:
    """``new`` is ``old`` with only its F word changed or added, or (a split move's first piece)
    also its end point / centre words."""
    if new == old:
        return True
    if "(" in old or ";" in old:
        code_old, code_new = old.split("(")[0].split(";")[0], new.split("(")[0].split(";")[0]
        if old[len(code_old):] != new[len(code_new):]:
            return False
        old, new = code_old, code_new
    words = lambda s, rx: " ".join(rx.sub("", s).split())
    if words(old, _F) == words(new, _F):
        return True
    return words(_F.sub("", old), _GEOMETRY) == words(_F.sub("", new), _GEOMETRY) \
        and _GEOMETRY.search(old) is not None


CORPUS = sorted((Path(__file__).parent / "programs" / "corpus").glob("*.ngc"))


def test_corpus_is_big_enough_and_has_every_dialect():
    names = [p.stem for p in CORPUS]
    assert len(names) >= 40
    for dialect in ("freecad", "fusion", "grbl", "lcnc"):
        assert sum(n.startswith(dialect) for n in names) >= 10


def _advise(program: Path, tmp_path: Path, *extra: str):
    out_csv, out_ngc = tmp_path / "advice.csv", tmp_path / (program.stem + "_advised.ngc")
    assert main(["advise", str(program), "-o", str(out_csv), "--gcode", str(out_ngc), *extra]) == 0
    return out_csv, out_ngc


@pytest.mark.parametrize("program", CORPUS, ids=lambda p: p.stem)
def test_rs274_round_trip(program, tmp_path, capsys):
    out_csv, out_ngc = _advise(program, tmp_path, "--feed-step-mm-min", "20")
    original = canon(program, tmp_path)
    rewritten = canon(out_ngc, tmp_path)
    result = compare(original, rewritten)
    assert result.feed_moves > 0
    # the advice is applied: somewhere the program now runs at half its F or less
    assert result.min_ratio <= 0.5, f"lowest feed ratio {result.min_ratio}"
    # every original line is still there, in order, only F words changed or inserted
    old = program.read_text().splitlines()
    new = out_ngc.read_text().splitlines()
    it = iter(new)
    for line in old:
        for candidate in it:
            if _same_line(line, candidate):
                break
        else:
            pytest.fail(f"line {line!r} of {program.name} not found in order in the output")
    with open(out_csv, newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert {"cut", "source_line", "feed_pct", "feed_mm_min", "programmed_feed_mm_min"} <= set(rows[0])
    feed = np.array([float(r["feed_mm_min"]) for r in rows])
    ceiling = np.array([float(r["programmed_feed_mm_min"]) for r in rows])
    assert np.all(feed > 0) and np.all(feed <= ceiling + 1e-9)
    lines = np.array([int(r["source_line"]) for r in rows])
    assert lines.min() >= 1 and lines.max() <= len(old)


def test_comparison_catches_a_faster_feed_and_a_moved_point(tmp_path):
    """The check above can fail: a feed above the programmed one, a point moved by 5 µm, a
    dropped line are each caught."""
    program = CORPUS[0]
    _, out_ngc = _advise(program, tmp_path)
    original = canon(program, tmp_path)
    text = out_ngc.read_text()
    faster = re.sub(r"F(\d+\.\d)", lambda m: f"F{float(m.group(1)) * 40:.1f}", text, count=3)
    moved = re.sub(r"X(\d+\.\d+)", lambda m: f"X{float(m.group(1)) + 0.005:.4f}", text, count=8)
    lines = text.splitlines()
    dropped = "\n".join(ln for ln in lines if not ln.startswith("M3")) + "\n"
    for name, bad in (("faster", faster), ("moved", moved), ("dropped", dropped)):
        path = tmp_path / f"{name}.ngc"
        path.write_text(bad)
        with pytest.raises(AssertionError):
            compare(original, canon(path, tmp_path))
