"""rs274's check of a program advised in windows (issue 36; :mod:`fuzzyfeed.program.window_advice`):
the same verdict, kept lines and text as :func:`fuzzyfeed.program.verify.verified_rewrite` on the
whole read, memory bounded by a window.

While the windows are advised, each window's pieces (move, end, feed: its own move numbers) and
its changed lines (the file's lines of its pieces) go to a scratch folder (:class:`PieceSpill`;
a few tens of bytes a move on disk, nothing in memory). rs274 then reads the program as written
and as rewritten side by side, its calls compared as they come
(:func:`~fuzzyfeed.program.verify_stream.check_rewrites`). Where it refuses or the moves differ,
each rewrite of a part of the changed lines is made by reading the windows again (the same windows:
the read is deterministic) and rewriting each with the pieces of the chosen lines, the F in force
carried from window to window as in the first pass (:func:`rewrite_windows`).
"""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import numpy as np

from fuzzyfeed.program.verify_stream import Ranges, check_rewrites, selected


class PieceSpill:
    """Each window's pieces and changed lines, in ``folder`` (module docstring); ``counts`` the
    changed lines of each window (their indices in the program's sorted changed lines follow on)."""

    def __init__(self, folder: Path):
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.counts: list[int] = []

    def __call__(self, win, pm: np.ndarray, pe: np.ndarray, pf: np.ndarray) -> None:
        line_of = win.program.move_line[pm]
        changed = np.unique(line_of[line_of >= 0]) + win.line0
        np.savez(self.folder / f"w{len(self.counts)}.npz", pm=pm, pe=pe, pf=pf, changed=changed)
        self.counts.append(int(changed.size))

    def load(self, k: int):
        with np.load(self.folder / f"w{k}.npz") as z:
            return z["pm"], z["pe"], z["pf"], z["changed"]

    @property
    def n_changed(self) -> int:
        return sum(self.counts)

    def offsets(self) -> np.ndarray:
        return np.concatenate([[0], np.cumsum(self.counts)]).astype(np.int64)

    def kept_lines(self, sel: Ranges) -> tuple[int, ...]:
        """The changed lines (1-based) not in ``sel``, in order."""
        keep = selected(sel, self.n_changed)
        off = self.offsets()
        out = []
        for k in range(len(self.counts)):
            changed = self.load(k)[3]
            out.extend(int(v) + 1 for v in changed[~keep[off[k]:off[k + 1]]])
        return tuple(out)


def rewrite_windows(path: Path, tools, window_lines: int, spill: PieceSpill, sel: Ranges, write) -> None:
    """The program rewritten with the pieces of the changed lines in ``sel`` only, window by window
    (as :func:`~fuzzyfeed.program.window_advice.advise_in_windows` writes it), to ``write``."""
    from fuzzyfeed.program.rewrite import rewrite_chunks
    from fuzzyfeed.program.windows import read_windows

    keep_all = selected(sel, spill.n_changed)
    off = spill.offsets()
    carry = {"f": None}
    rest: list = []
    newline, k = None, -1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")             # the reader's notices were given by the first pass
        for k, win in enumerate(read_windows(path, tools=tools, window_lines=window_lines, rest=rest)):
            wp = win.program
            newline = wp.newline
            pm, pe, pf, changed = spill.load(k)
            line_of = wp.move_line[pm] + win.line0
            keep = np.isin(line_of, changed[keep_all[off[k]:off[k + 1]]])
            for chunk in rewrite_chunks(wp, pm[keep], pe[keep], pf[keep], carry=carry):
                write(chunk)
    if len(spill.counts) != k + 1:
        raise RuntimeError(f"{path}: read again in {k + 1} windows, advised in {len(spill.counts)}")
    for block in rest:
        if block:
            write(newline.join(block) + newline)


def verify_windows(path: Path, first: Path, spill: PieceSpill, tools, window_lines: int, scratch: Path,
                   out, max_runs: int = 40):
    """rs274's verdict on the rewrite ``first`` (written by the windows' first pass) and the text
    it accepts written to the binary handle ``out``: a :class:`~fuzzyfeed.program.verify.Verification`,
    the whole read's (module docstring)."""
    from fuzzyfeed.program.verify import Verification

    def write_subset(sel: Ranges, target: Path) -> None:
        with open(target, "w", newline="") as handle:
            rewrite_windows(path, tools, window_lines, spill, sel, handle.write)

    status, said, accepted, runs = check_rewrites(Path(path).resolve(), first, write_subset, spill.n_changed,
                                                  tools, scratch, max_runs)
    if status != "kept":
        with open(first, "rb") as handle:
            shutil.copyfileobj(handle, out)
        return Verification(status, said, (), runs)
    final = scratch / "final"
    write_subset(accepted, final)       # no accepted line: every piece dropped, as the whole read writes it
    with open(final, "rb") as handle:
        shutil.copyfileobj(handle, out)
    return Verification("kept", said, spill.kept_lines(accepted), runs)
