"""A rewritten program checked by the controller's own interpreter (issue 40 item 5): LinuxCNC's
stand-alone ``rs274`` reads the program as written and as rewritten, with the same tool table, and
must accept the rewrite and give the same canonical moves apart from the feeds (a split move's
pieces on its line or arc, within 1 µm, covering it exactly; every other call identical). Where it
refuses or the moves differ, the lines whose rewrite is to blame keep their text: the rewrite is
tried on halves of the changed lines (a bisection, at most ``max_runs`` runs of rs274) and only
the lines it accepts are rewritten. rs274's calls are read from a pipe and compared as they come
(:mod:`fuzzyfeed.program.verify_stream`; a long program read in windows:
:mod:`fuzzyfeed.program.verify_windows`, the same verdicts).

Tool table: the one the advice used (diameters in mm, written for rs274 in inches, as the
stand-alone rs274 reads them); without one, tools 1–999 of diameter 0 so that tool changes are
accepted (compensation then has no radius, as in fuzzyfeed's reading).
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fuzzyfeed.program.model import Program
from fuzzyfeed.program.verify_stream import TIMEOUT_S, TOL, rs274_path  # noqa: F401  (named here too)


@dataclass(frozen=True)
class Rs274Run:
    """rs274 on one program: accepted, its first error line (and the line it names), its calls."""

    ok: bool
    message: str
    calls: tuple[tuple[str, str], ...]


def run_rs274(program: Path, tools_mm: dict[int, float] | None, workdir: Path) -> Rs274Run:
    """``rs274 -t TABLE -g program`` in ``workdir`` (its own HOME and parameter file), its calls
    held (small programs; the check itself streams them: :mod:`fuzzyfeed.program.verify_stream`)."""
    from fuzzyfeed.program.verify_stream import Rs274Process

    run = Rs274Process(program, tools_mm, workdir)
    try:
        calls = tuple(run.calls())
        ok, message = run.finish()
    finally:
        run.close()
    return Rs274Run(ok, message, calls if ok or not run.timed_out else ())


def compare_moves(original, rewritten) -> str | None:
    """None when ``rewritten``'s calls are ``original``'s apart from SET_FEED_RATE values and feed
    moves split into pieces along the same line or arc (module docstring); else what differs
    (:func:`~fuzzyfeed.program.verify_stream.compare_call_streams` on the two lists)."""
    from fuzzyfeed.program.verify_stream import compare_call_streams

    return compare_call_streams(original, rewritten)


@dataclass(frozen=True)
class Verification:
    """What rs274 said: ``status`` is ``accepted`` (the whole rewrite), ``kept`` (``kept_lines``,
    1-based, keep their text; ``message`` is what rs274 said of the full rewrite) or ``unchecked``
    (rs274 refuses the program as written: ``message``)."""

    status: str
    message: str
    kept_lines: tuple[int, ...]
    runs: int

    def __post_init__(self):
        if self.status not in ("accepted", "kept", "unchecked"):
            raise ValueError(f"status = {self.status!r}; must be accepted, kept or unchecked")

    def figures(self) -> dict[str, object]:
        """The columns a CSV row or a batch summary carries."""
        return {"rs274": self.status, "rs274_kept_lines": " ".join(str(v) for v in self.kept_lines)}

    def summary(self) -> str:
        if self.status == "accepted":
            return (f"rs274 accepts the rewritten program and gives the same moves apart from the feeds "
                    f"({self.runs} run(s))")
        if self.status == "unchecked":
            return f"not checked with rs274: it refuses the program as written ({self.message})"
        shown = ", ".join(str(v) for v in self.kept_lines[:12]) + (", ..." if len(self.kept_lines) > 12 else "")
        return (f"rs274: {len(self.kept_lines)} line(s) keep their text ({shown}): rewritten, {self.message}; "
                f"the rest is accepted with the same moves ({self.runs} run(s))")


def verified_rewrite(program: Program, piece_move: np.ndarray, piece_end: np.ndarray,
                     piece_feed_mm_min: np.ndarray, rewrite: Callable, tools_mm: dict[int, float] | None,
                     max_runs: int = 40) -> tuple[str, Verification]:
    """The rewritten text (``rewrite(program, move, end, feed)``) that rs274 accepts with the same
    moves, and what it said (module docstring). rs274's calls are compared as they come
    (:func:`~fuzzyfeed.program.verify_stream.check_rewrites`), never held."""
    from fuzzyfeed.program.verify_stream import check_rewrites, selected

    line_of = program.move_line[piece_move]
    changed = np.unique(line_of[line_of >= 0])

    def subset(sel) -> str:
        keep = np.isin(line_of, changed[selected(sel, changed.size)])
        return rewrite(program, piece_move[keep], piece_end[keep], piece_feed_mm_min[keep])

    def write_subset(sel, path: Path) -> None:
        path.write_text(subset(sel), newline="")

    with tempfile.TemporaryDirectory(prefix="fuzzyfeed-rs274-") as tmp:
        scratch = Path(tmp)
        text = rewrite(program, piece_move, piece_end, piece_feed_mm_min)
        first = scratch / "first" / program.path.name
        first.parent.mkdir()
        first.write_text(text, newline="")
        status, said, accepted, runs = check_rewrites(program.path.resolve(), first, write_subset, changed.size,
                                                      tools_mm, scratch, max_runs)
    if status != "kept":
        return text, Verification(status, said, (), runs)
    del text
    keep = selected(accepted, changed.size)
    kept = tuple(int(v) + 1 for v in changed[~keep])
    final = subset(accepted) if keep.any() else rewrite(program, piece_move[:0], piece_end[:0], piece_feed_mm_min[:0])
    return final, Verification("kept", said, kept, runs)
