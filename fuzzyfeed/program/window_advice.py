"""The plain advice of a long program window by window (:mod:`fuzzyfeed.program.windows`): read a
window, advise its cuts in pieces (:func:`fuzzyfeed.program.stream.stream_program_advice`), hand
their CSV rows on, write its lines back (:func:`fuzzyfeed.program.rewrite.rewrite_chunks`, the F in
force carried from window to window), drop it. Every cut lies in one window, so its advice is the
whole read's, bit for bit; the rows get the file's line and cut numbers. A cut split between
windows is advised from the file in pieces (:func:`~fuzzyfeed.program.long_cut.advise_long_cut`,
bit for bit the stream's) and each window takes the pieces of its own moves (:class:`_LongCut`). What the summary needs
is kept as sums (no per-sample or per-move array of the program): the advised fraction's min, max,
sum and count, the times at the programmed and advised F, the split points and the coverage.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fuzzyfeed.fuzzy.rules import RuleTable
from fuzzyfeed.program.coverage import Coverage, NotJudged, FIRST_LINES, REASONS, program_coverage
from fuzzyfeed.program.feeds import DEFAULT_MIN_PIECE_MM, pieces_times
from fuzzyfeed.program.rewrite import rewrite_chunks
from fuzzyfeed.program.cuts import cut_moves
from fuzzyfeed.program.stream import concat_pieces, stream_program_advice
from fuzzyfeed.program.windows import WINDOW_LINES, Fallback, read_windows


@dataclass
class WindowTotals:
    """What the summary of a program advised in windows says, summed window by window."""

    lines: int = 0
    moves: int = 0
    cuts: int = 0
    windows: int = 0
    pct_min: float = np.inf
    pct_max: float = -np.inf
    pct_sum: float = 0.0
    pct_count: int = 0
    splits: int = 0
    time_written_s: float = 0.0
    time_advised_s: float = 0.0
    coverages: list = field(default_factory=list)   # (line0, Coverage) of every window

    def coverage(self) -> Coverage:
        """The windows' coverages as one (counts and sums added, first lines in file order)."""
        cov = [c for _, c in self.coverages]
        groups = []
        for key, text in REASONS:
            parts = [(line0, g) for line0, c in self.coverages for g in c.not_judged if g.key == key]
            if not parts:
                continue
            lines = list(dict.fromkeys(v + line0 for line0, g in parts for v in g.first_lines))[:FIRST_LINES]
            groups.append(NotJudged(key=key, text=text, moves=sum(g.moves for _, g in parts),
                                    length_mm=sum(g.length_mm for _, g in parts), first_lines=tuple(lines)))
        return Coverage(moves=sum(c.moves for c in cov), judged_moves=sum(c.judged_moves for c in cov),
                        length_mm=sum(c.length_mm for c in cov),
                        judged_length_mm=sum(c.judged_length_mm for c in cov),
                        unknown_length_moves=sum(c.unknown_length_moves for c in cov),
                        time_s=sum(c.time_s for c in cov), judged_time_s=sum(c.judged_time_s for c in cov),
                        unknown_time_moves=sum(c.unknown_time_moves for c in cov), not_judged=tuple(groups))


def advise_in_windows(path, table: RuleTable, *, step_mm: float, cap_mm_min: float | None,
                      feed_step_mm_min: float, min_piece_mm: float = DEFAULT_MIN_PIECE_MM, tools=None,
                      sink=None, write=None, window_lines: int = WINDOW_LINES,
                      piece_points: int | None = None, on_window=None) -> WindowTotals:
    """Advise the program at ``path`` window by window: ``sink(columns)`` takes every piece's CSV
    rows (as :func:`~fuzzyfeed.program.stream.stream_program_advice` makes them, with the file's cut
    and line numbers), ``write(text)`` the rewritten program in chunks, ``on_window(window, move,
    end, feed)`` each window's pieces (its own move numbers). Raises
    :class:`~fuzzyfeed.program.windows.Fallback` where the windows cannot give the whole read's
    result (see there; also a program with no cut, or any error: the whole read names it)."""
    from fuzzyfeed.errors import FuzzyfeedError

    from fuzzyfeed.program import stream

    piece_points = stream.DEFAULT_PIECE_POINTS if piece_points is None else piece_points
    totals = WindowTotals()
    carry = {"f": None}
    rest: list = []
    newline = None
    cuts = WindowCuts()  # the cut going on from window to window
    kw = dict(step_mm=step_mm, cap_mm_min=cap_mm_min, feed_step_mm_min=feed_step_mm_min, min_piece_mm=min_piece_mm)

    def taken(cols, offset: bool, win):
        if offset:
            cols = file_columns(cols, win)
        if sink is not None:
            sink(cols)
        pct = cols["feed_pct"]
        if pct.size:
            totals.pct_min = min(totals.pct_min, float(pct.min()))
            totals.pct_max = max(totals.pct_max, float(pct.max()))
            totals.pct_sum += float(np.sum(pct))
            totals.pct_count += pct.size

    def advise(win, regular):
        return stream_program_advice(win.program, table, cuts=regular, **kw)

    def advise_long(win, k):
        from fuzzyfeed.program.long_cut import advise_long_cut

        return advise_long_cut(path, win, k, table, tools=tools, window_lines=window_lines,
                               piece_points=piece_points, **kw)

    try:
        for win in read_windows(path, tools=tools, window_lines=window_lines, rest=rest):
            wp = win.program
            newline = wp.newline
            totals.windows += 1
            totals.lines += len(wp.lines)
            totals.moves += wp.kind.size
            pm, pe, pf = cuts.pieces(win, advise, advise_long, taken)
            if pm.size:
                t_prog, t_adv = pieces_times(wp, pm, pe, pf)
                totals.time_written_s += t_prog
                totals.time_advised_s += t_adv
                totals.splits += int(np.sum(np.diff(pm) == 0))
            if on_window is not None:
                on_window(win, pm, pe, pf)
            totals.cuts += wp.n_cuts - int(win.continued)
            totals.coverages.append((win.line0, program_coverage(wp)))
            if write is not None:
                for chunk in rewrite_chunks(wp, pm, pe, pf, carry=carry):
                    write(chunk)
        for block in rest:
            totals.lines += len(block)
            if write is not None and block:
                write(newline.join(block) + newline)
    except FuzzyfeedError as exc:
        raise Fallback(str(exc)) from None
    finally:
        cuts.close()                    # a long cut left unfinished: its scratch folder goes now
    cuts.ended()
    if totals.cuts == 0:
        raise Fallback("no cut: the whole read says so")
    return totals


def file_columns(cols: dict, win) -> dict:
    """A piece's CSV columns of window ``win``'s own cut and line numbers with the file's."""
    if not (win.line0 or win.cut0):
        return cols
    return dict(cols, cut=cols["cut"] + win.cut0, source_line=cols["source_line"] + win.line0)


class WindowCuts:
    """The advice of each window's cuts as the pieces its moves are written as, a cut split between
    windows (:attr:`~fuzzyfeed.program.windows.Window.continues`) advised from its file in pieces
    (:class:`_LongCut`) and handed to each window for its own moves."""

    def __init__(self):
        self._long = None          # the cut going on from window to window

    def pieces(self, win, advise, advise_long, taken):
        """(move, end, feed) of window ``win``'s cuts in move order: ``advise(cuts)`` the pieces of
        its cuts that lie in it (window-local cut and move numbers), ``advise_long(k)`` the pieces
        of a cut that starts as its cut ``k`` and goes on (the file's cut and lines, moves as the
        cut's ordinals); every piece's rows go to ``taken(columns, offset, win)`` (``offset``: the
        window's numbers, to be made the file's)."""
        wp = win.program
        parts = []
        regular = list(range(wp.n_cuts))
        if win.continued:             # cut 0 goes on from the window before
            if self._long is None:
                raise Fallback("a cut split between windows without its start")
            last = not (win.continues and wp.n_cuts == 1)
            parts.append(self._long.take(win, 0, taken, last=last))
            regular.remove(0)
            if last:
                self._long = None
        starts_long = win.continues and not (win.continued and wp.n_cuts == 1)
        if starts_long:
            regular.remove(wp.n_cuts - 1)
        if regular:
            pieces = []
            for piece in advise(win, regular):
                taken(piece.columns, True, win)
                pieces.append(piece)
            parts.append(concat_pieces(pieces))
            del pieces
        if starts_long:
            self._long = _LongCut(advise_long(win, wp.n_cuts - 1))
            parts.append(self._long.take(win, wp.n_cuts - 1, taken, last=False))
        return tuple(np.concatenate(c) for c in zip(*parts)) if parts else concat_pieces([])

    def close(self) -> None:
        """Stop a long cut's advice left unfinished (its scratch folder is removed)."""
        if self._long is not None:
            self._long.close()

    def ended(self) -> None:
        """Raise :class:`~fuzzyfeed.program.windows.Fallback` if a cut split between windows did not end."""
        if self._long is not None:
            raise Fallback("a cut split between windows without its end")


class _LongCut:
    """A cut split between windows: its pieces (:func:`~fuzzyfeed.program.long_cut.advise_long_cut`)
    handed to each window for its moves; a piece over a window's end is split there."""

    def __init__(self, pieces):
        self._pieces = pieces
        self._ordinal = 0                 # the cut's sampled moves before the window
        self._pending = None              # (move, end, feed) of a piece beyond the window before

    def close(self) -> None:
        """Stop the cut's advice (its scratch folder is removed)."""
        self._pieces.close()

    def take(self, win, k: int, taken, last: bool):
        """The pieces of the cut's moves in window ``win`` (its cut ``k``), window-local moves;
        every piece's rows go to ``taken(columns, offset, win)`` when first met."""
        moves = cut_moves(win.program, k)[0]
        lo, hi = self._ordinal, self._ordinal + moves.size
        got = []

        def keep(pm, pe, pf):
            i = int(np.searchsorted(pm, hi)) if not last else pm.size
            got.append((pm[:i], pe[:i], pf[:i]))
            self._pending = (pm[i:], pe[i:], pf[i:]) if i < pm.size else None

        if self._pending is not None:
            keep(*self._pending)
        while self._pending is None:
            try:
                piece = next(self._pieces)
            except StopIteration:
                break
            taken(piece.columns, False, win)
            keep(piece.piece_move, piece.piece_end, piece.piece_feed_mm_min)
        if last and (self._pending is not None or next(self._pieces, None) is not None):
            raise Fallback("a cut split between windows ends before its pieces")
        pm = np.concatenate([g[0] for g in got]) if got else np.zeros(0, int)
        if pm.size and (pm.min() < lo or pm.max() >= hi):
            raise Fallback("a piece outside the cut's moves in the window")
        self._ordinal = hi
        return (moves[pm - lo], np.concatenate([g[1] for g in got]) if got else np.zeros(0),
                np.concatenate([g[2] for g in got]) if got else np.zeros(0))
