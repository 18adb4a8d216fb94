"""``advise --machine`` in windows of lines when the uniform slowdown sets a place apart (issue 36):
places set apart are measured on the whole read (program/uniform.py ``_Search.set_apart`` on a
stored path raises Fallback), so the windowed path falls back for that reason and writes the whole
read's CSV, sidecar, program and summary, byte for byte; the scratch directory is gone."""

from __future__ import annotations

import tempfile
from pathlib import Path

from test_machine_windows import _compare
from test_uniform_apart import PLUNGE_FROM_RAPIDS, PLUNGE_FROM_REST


def _spy_fallbacks(monkeypatch):
    import fuzzyfeed.program.uniform as uniform
    from fuzzyfeed.program.windows import Fallback

    said = []
    real = uniform._Search.set_apart

    def spy(self, hot):
        try:
            return real(self, hot)
        except Fallback as exc:
            said.append(str(exc))
            raise
    monkeypatch.setattr(uniform._Search, "set_apart", spy)
    return said


def test_a_place_set_apart_falls_back_to_the_whole_read(tmp_path, monkeypatch, capsys):
    said = _spy_fallbacks(monkeypatch)
    before = set(Path(tempfile.gettempdir()).iterdir())
    prog = tmp_path / "p.ngc"
    prog.write_text(PLUNGE_FROM_RAPIDS)
    out = _compare(tmp_path, prog, monkeypatch, capsys, 400, "--machine", "reference", windowed=False)
    assert said and "set apart" in said[0]
    assert "1 place(s) set apart" in out, out
    assert set(Path(tempfile.gettempdir()).iterdir()) <= before


def test_without_a_place_set_apart_the_windows_give_the_result(tmp_path, monkeypatch, capsys):
    """The same program with the plunge started at rest: nothing set apart, no fallback (so the
    test above checks the fallback's reason, not another)."""
    said = _spy_fallbacks(monkeypatch)
    prog = tmp_path / "p.ngc"
    prog.write_text(PLUNGE_FROM_REST)
    _compare(tmp_path, prog, monkeypatch, capsys, 400, "--machine", "reference", windowed=True)
    assert not said
