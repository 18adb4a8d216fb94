"""``advise PROGRAM --machine ... -o OUT.csv``: the machine advice runs once, its CSV rows written
as the pieces come (to a temporary file beside OUT.csv, renamed at the end), the same bytes as the
rows made again from the evaluation afterwards (the way before: the advice run a second time for
the rows of a program over KEEP_ROWS samples); an error halfway changes nothing of the user's."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import pytest

import fuzzyfeed.program.advice_pieces as advice_pieces
import fuzzyfeed.program.stream_machine as stream_machine
from fuzzyfeed.advice.pipeline import advise_file
from fuzzyfeed.cli import main
from fuzzyfeed.errors import InputError

LIBRARY = Path(__file__).resolve().parents[1] / "benchmarks" / "library" / "programs"


def _counting(monkeypatch, fail_after: int | None = None) -> list[int]:
    """stream_machine_advice counted at each call (and made to fail after ``fail_after`` pieces)."""
    calls = []
    real = stream_machine.stream_machine_advice

    def counted(*args, **kwargs):
        calls.append(1)
        pieces = real(*args, **kwargs)

        def gen():
            for i, p in enumerate(pieces):
                if fail_after is not None and i >= fail_after:
                    raise InputError("test: the advice fails halfway")
                yield p
        return gen()
    monkeypatch.setattr(stream_machine, "stream_machine_advice", counted)
    return calls


def _zigzag(path: Path, rows: int = 40, length_mm: float = 50.0) -> Path:
    """A zig-zag of ``rows`` long lines with arcs between (a few hundred samples each at 0.25 mm)."""
    out = ["G21 G90 G94 G17", "G0 X0 Y0 Z1", "G1 Z-0.5 F600", "G1 F2400"]
    for r in range(rows):
        x = length_mm if r % 2 == 0 else 0.0
        out.append(f"G1 X{x:.4f} Y{r * 2.0:.4f}")
        out.append(f"G{3 if r % 2 == 0 else 2} X{x:.4f} Y{r * 2.0 + 2.0:.4f} R1.0")
    out += ["G0 Z5", "M30"]
    path.write_text("\n".join(out) + "\n")
    return path


def _reference_outputs(program: str, folder: Path, *flags) -> tuple[bytes, bytes]:
    """The CSV and G-code as written when the evaluation is made before the write (its rows made
    again piece by piece from the advice)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = advise_file(program, machine="reference", **dict(flags))
        result.evaluation                    # evaluated without a CSV: the rows are made again
        result.write(csv=folder / "ref.csv", gcode=folder / "ref.ngc")
    return (folder / "ref.csv").read_bytes(), (folder / "ref.ngc").read_bytes()


@pytest.mark.parametrize("name", ["linuxcnc/3D_Chips.ngc", "camotics/engrave.ngc"])
def test_advice_runs_once_and_writes_the_same_bytes(name, tmp_path, monkeypatch, capsys):
    program = LIBRARY / name
    if not program.exists():
        pytest.skip(f"{program} not in the library")
    monkeypatch.setattr(advice_pieces, "KEEP_ROWS", 0)       # as a program over KEEP_ROWS samples
    calls = _counting(monkeypatch)
    assert main(["advise", str(program), "--machine", "reference", "-o", str(tmp_path / "a.csv"),
                 "--gcode", str(tmp_path / "a.ngc")]) == 0
    assert len(calls) == 1
    csv, gcode = _reference_outputs(str(program), tmp_path)
    assert len(calls) == 3                   # the reference: once for the advice, once for its rows
    assert (tmp_path / "a.csv").read_bytes() == csv and (tmp_path / "a.ngc").read_bytes() == gcode
    assert csv.count(b"\n") > 100


def test_a_program_over_keep_rows_is_advised_once(tmp_path, monkeypatch, capsys):
    program = _zigzag(tmp_path / "zz.ngc")
    calls = _counting(monkeypatch)
    args = ["advise", str(program), "--machine", "reference", "--step-mm", "0.01", "-o",
            str(tmp_path / "a.csv"), "--gcode", str(tmp_path / "a.ngc")]
    assert main(args) == 0
    assert len(calls) == 1
    rows = (tmp_path / "a.csv").read_bytes().count(b"\n") - 1
    assert rows > advice_pieces.KEEP_ROWS
    csv, gcode = _reference_outputs(str(program), tmp_path, ("step_mm", 0.01))
    assert len(calls) == 3
    assert (tmp_path / "a.csv").read_bytes() == csv and (tmp_path / "a.ngc").read_bytes() == gcode


def test_an_error_halfway_changes_nothing(tmp_path, monkeypatch, capsys):
    program = _zigzag(tmp_path / "zz.ngc")
    out, code = tmp_path / "a.csv", tmp_path / "a.ngc"
    out.write_text("mine\n")
    _counting(monkeypatch, fail_after=1)            # after the first piece's rows were written
    assert main(["advise", str(program), "--machine", "reference", "--step-mm", "0.01", "-o", str(out),
                 "--gcode", str(code)]) == 2
    assert "the advice fails halfway" in capsys.readouterr().err
    assert out.read_text() == "mine\n" and not code.exists()
    assert sorted(os.listdir(tmp_path)) == ["a.csv", "zz.ngc"]
