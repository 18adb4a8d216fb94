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

A subroutine called from a line of the program that runs once per call (pcb2gcode's
autolevelling ``o1 call [x] [y] [z]``, one call per point) is advised per call instead: an F line
is written just before the call (LinuxCNC takes no other word on an O-word line) with the slowest
feed wanted inside that call, when nothing inside the call sets F (no F word, no G93/G94/G95) and
every line the call moves on runs only inside such calls; the moves inside keep no F of their own.
"""

from __future__ import annotations

from dataclasses import dataclass

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
    calls = _call_blocks(rows, row_move, feed_move, move_line, advised, piece_lo, p_val, p_text, len(lines))
    while True:
        in_calls = {m for b in calls for m in b.moves}
        first, last, split = _advised_lines(advised - in_calls, move_line, piece_lo, piece_hi, p_val, p_text)
        added, drop, needed = _follow_feeds(rows, row_move, feed_move, first, last, calls)
        if not drop:
            break
        if any(key >= len(lines) for key in drop):
            calls = []                       # a call's F broke a feed after it: advise per line
            continue
        advised -= {m for m in advised if int(move_line[m]) in drop}
    before = {b.site: b.text for b, need in zip(calls, needed) if need}
    out = []
    for li, raw in enumerate(lines):
        if li in before:
            out.append(raw[:len(raw) - len(raw.lstrip())] + "F" + before[li])
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


def _follow_feeds(rows, row_move, feed_move, first, last, calls=()):
    """F words to add (line -> value) so that every move that is not advised runs at its own F,
    or the advised lines to give up (a set; a call's key is its site + the number of lines) when
    one F word cannot serve every run of a line; and per call block whether its F line changes the
    F in force."""
    start = {b.rows[0]: b for b in calls}
    inside = np.zeros(len(rows.line), bool)
    for b in calls:
        inside[b.rows[0]:b.rows[1]] = True
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
        needed = []
        for r in range(len(line_of)):
            li = line_of[r]
            if reset[r]:
                f, touched = 0.0, []
            b = start.get(r)
            if b is not None:
                needed.append(abs(f - b.value) > _SAME)
                f = b.value
                touched.append(b.key)
            if inside[r]:
                continue
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
            return added, culprits or set(first) | {b.key for b in calls}, []
        if not restart:
            return added, set(), needed


@dataclass(frozen=True)
class _CallBlock:
    """The rows [rows[0], rows[1]) of one call from ``site`` (a line run once per call), the feed
    moves in it, and the F (program units, and its text) written before the call."""

    site: int
    key: int
    rows: tuple[int, int]
    moves: tuple[int, ...]
    value: float
    text: str


def _call_blocks(rows, row_move, feed_move, move_line, advised, piece_lo, p_val, p_text, n_lines):
    """The calls advised per call (module docstring), in row order."""
    call = rows.call_line
    if call is None or not (call >= 0).any():
        return []
    edges = np.flatnonzero(np.diff(call)) + 1
    starts = np.concatenate([[0], edges])
    stops = np.concatenate([edges, [call.size]])
    keep = call[starts] >= 0
    starts, stops = starts[keep], stops[keep]
    sites = call[starts]
    once = np.bincount(sites, minlength=n_lines)[sites] == 1     # one block per site
    setting = rows.has_f | rows.feed_reset
    cum = np.concatenate([[0], np.cumsum(setting)])
    once &= cum[stops] == cum[starts]                           # nothing inside sets F
    line_of = rows.line
    block_of = np.full(line_of.size, -1)
    for k, (a, b) in enumerate(zip(starts, stops)):
        block_of[a:b] = k
    move_rows = [(int(r), int(row_move[r])) for r in np.flatnonzero(row_move >= 0) if feed_move[row_move[r]]]
    ok = once.copy()
    while True:                                                 # lines run only inside good blocks
        bad_lines = {int(line_of[r]) for r, _ in move_rows
                     if line_of[r] >= 0 and (block_of[r] < 0 or not ok[block_of[r]])}
        new = ok.copy()
        for r, m in move_rows:
            k = block_of[r]
            if k >= 0 and (int(line_of[r]) in bad_lines or rows.feed_mode[r] != 94):
                new[k] = False
        if (new == ok).all():
            break
        ok = new
    blocks = []
    feed_row = np.array([r for r, _ in move_rows], dtype=np.int64)    # ascending
    for k in np.flatnonzero(ok).tolist():
        a, b = int(starts[k]), int(stops[k])
        inner = move_rows[int(np.searchsorted(feed_row, a)):int(np.searchsorted(feed_row, b))]
        if not inner:
            continue
        wants = [(p_val[piece_lo[m]], p_text[piece_lo[m]]) if m in advised
                 else (float(rows.feed_value[r]), format_feed_exact(float(rows.feed_value[r]))) for r, m in inner]
        value, text = min(wants, key=lambda w: w[0])
        site = int(sites[k])
        blocks.append(_CallBlock(site, site + n_lines, (a, b), tuple(m for _, m in inner), value, text))
    # every call of a line is advised per call once one is (an F on the line would serve them all);
    # an F line is written only where it changes the F in force
    return blocks if any(m in advised for blk in blocks for m in blk.moves) else []
