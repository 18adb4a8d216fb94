"""Write back a program whose lines run more than once or out of order (loops, subroutine calls:
:class:`~fuzzyfeed.program.model.Rows`), with new feeds.

A line that runs several times carries one F for all its runs: the slowest of its moves' advised
feeds (its moves are never split). A line that runs once is written as :mod:`fuzzyfeed.program.rewrite`
writes it (split where its feed changes). Every advised line carries its own F word. The F in
force is then followed in execution order, as LinuxCNC follows it: every move that is not advised
must run at the F it had (an F word is added to its line where that F would otherwise differ);
when one F word cannot serve every run of a line (a subroutine line called at different feeds,
a line of another file), the advice of the lines that changed the F in force before it is
dropped and the program is checked again.
"""

from __future__ import annotations

import numpy as np

from fuzzyfeed.program.model import NO_F_KINDS, Program
from fuzzyfeed.program.lines import edit_line, piece_layout, format_feed_exact, split_lines

#: Two feeds equal within this (program units per minute).
_SAME = 1e-9


def rewrite_rows(program: Program, piece_move: np.ndarray, piece_end: np.ndarray,
                 piece_feed_mm_min: np.ndarray) -> str:
    """The program text with the pieces' feeds (see the module docstring)."""
    rows = program.rows
    lines = program.lines
    kind = program.kind
    move_line = program.move_line
    n_moves = kind.size
    piece_lo, piece_hi, p_text = piece_layout(program, piece_move, piece_feed_mm_min)
    p_val = [float(t) for t in p_text]
    row_move = np.full(rows.line.size, -1)
    row_move[rows.move_row] = np.arange(n_moves)
    feed_move = ~np.isin(kind, NO_F_KINDS)
    advised = {int(m) for m in np.flatnonzero(piece_lo >= 0)}
    while True:
        first, last, split = _advised_lines(advised, move_line, piece_lo, piece_hi, p_val, p_text)
        added, drop = _follow_feeds(rows, row_move, feed_move, first, last)
        if not drop:
            break
        advised -= {m for m in advised if int(move_line[m]) in drop}
    out = []
    for li, raw in enumerate(lines):
        if li in split:
            m = split[li]
            lo, hi = piece_lo[m], piece_hi[m]
            out.extend(split_lines(program, m, raw, piece_end[lo:hi], p_text[lo:hi]))
        elif li in first:
            out.append(edit_line(raw, [("F", first[li][1])]))
        elif li in added:
            out.append(edit_line(raw, [("F", format_feed_exact(added[li]))]))
        else:
            out.append(raw)
    text = program.newline.join(out)
    return text + program.newline if out else text


def _advised_lines(advised, move_line, piece_lo, piece_hi, p_val, p_text):
    """Per advised line: (value, text) of the F on the line, the value in force after it, and
    the lines split into pieces (line -> move)."""
    first: dict = {}
    last: dict = {}
    split: dict = {}
    for m in sorted(advised):
        li = int(move_line[m])
        lo, hi = int(piece_lo[m]), int(piece_hi[m])
        if hi - lo > 1:
            split[li] = m
            first[li] = (p_val[lo], p_text[lo])
            last[li] = p_val[hi - 1]
            continue
        if li not in first or p_val[lo] < first[li][0]:
            first[li] = (p_val[lo], p_text[lo])
            last[li] = p_val[lo]
    return first, last, split


def _follow_feeds(rows, row_move, feed_move, first, last):
    """F words to add (line -> value) so that every move that is not advised runs at its own F,
    or the advised lines to give up (a set) when one F word cannot serve every run of a line."""
    added: dict = {}
    cause: dict = {}                         # added line -> the advised lines that made it needed
    line_of = rows.line.tolist()
    mode = rows.feed_mode.tolist()
    reset = rows.feed_reset.tolist()
    has_f = rows.has_f.tolist()
    value = rows.feed_value.tolist()
    moves = row_move.tolist()
    while True:
        f = 0.0
        restart = False
        touched: list[int] = []              # advised lines run since the original F was set
        for r in range(len(line_of)):
            li = line_of[r]
            if reset[r]:
                f, touched = 0.0, []
            if li in first:
                f = last[li]
                touched.append(li)
                continue
            if li in added:
                f = added[li]
            elif has_f[r]:
                f = value[r]
                touched = []
            m = moves[r]
            if m < 0 or not feed_move[m] or mode[r] == 93:
                continue
            want = value[r]
            if abs(f - want) <= _SAME:
                continue
            if li >= 0 and li not in added:
                added[li] = want
                cause[li] = set(touched)
                restart = True
                break
            culprits = set(touched) | cause.get(li, set())
            return added, culprits or set(first)
        if not restart:
            return added, set()
