"""Write a program back with new feeds: every original line in order, only F words changed or
inserted, a move split only where its feed changes inside it.

Input: a :class:`~fuzzyfeed.program.model.Program` and its pieces — for some moves, the end
fractions (0, 1] and feeds (mm/min) of consecutive pieces. Every other feed move keeps the feed it
was programmed with. The F in force is tracked as LinuxCNC does (an F word stays in force until
the next one; a change of feed mode G93/G94/G95 resets it), so an F word is written exactly where
the feed in force would otherwise differ from the feed wanted.

A split move: its own line becomes the first piece (so every other word of the line acts as
before, in LinuxCNC's order of execution), with its end point (and, for an R arc, the centre as
I/J/K) rewritten; the other pieces follow as new lines ``G1``/``G2``/``G3`` with the axes of the
mode in force (G90/G91, G20/G21, G90.1/G91.1, the arc's plane). Arcs stay arcs with the same
centre; the pieces' end points are rounded to the line's decimals (at least 4 in mm, 5 in inch)
on an integer grid, so incremental programs keep their exact positions. F words are written in
the program's units, rounded down (never above the feed wanted): on the move's own line in the units
in force before it (LinuxCNC reads F before the line's G20/G21), on the pieces' new lines in the
line's units.
"""

from __future__ import annotations

import re

import numpy as np

from fuzzyfeed.program.lines import (edit_line, feed_units_inch, format_feed_down, format_feed_exact,
                                     piece_layout, split_lines)
from fuzzyfeed.program.model import NO_F_KINDS, Program

_F_WORD = re.compile(r"[Ff]\s*[-+]?(?:\d+\.?\d*|\.\d+)")
#: A comment, parameter or expression on a line: its F is placed by :func:`~fuzzyfeed.program.lines.edit_line`.
_SPECIAL = re.compile(r"[(;#\[]")


def rewrite_program(program: Program, piece_move: np.ndarray, piece_end: np.ndarray,
                    piece_feed_mm_min: np.ndarray) -> str:
    """The program text with the pieces' feeds (see the module docstring)."""
    return "".join(rewrite_chunks(program, piece_move, piece_end, piece_feed_mm_min))


#: Lines per chunk of :func:`rewrite_chunks`.
CHUNK_LINES = 1 << 14


def rewrite_chunks(program: Program, piece_move: np.ndarray, piece_end: np.ndarray,
                   piece_feed_mm_min: np.ndarray, carry: dict | None = None):
    """:func:`rewrite_program`'s text in chunks of about :data:`CHUNK_LINES` lines, to be written as
    they come (the text of a 10⁶-line program is never held whole). ``carry``: for a window of a
    program's lines (:mod:`fuzzyfeed.program.windows`), ``carry["f"]`` the F in force (mm/min, None:
    none yet) before its first line, set to the F in force after its last."""
    if program.rows is not None:
        from fuzzyfeed.program.rewrite_rows import rewrite_rows

        yield rewrite_rows(program, piece_move, piece_end, piece_feed_mm_min)
        return
    nl = program.newline
    for part in _rewrite_parts(program, piece_move, piece_end, piece_feed_mm_min, carry):
        if part:
            yield nl.join(part) + nl


def _rewrite_parts(program: Program, piece_move: np.ndarray, piece_end: np.ndarray,
                   piece_feed_mm_min: np.ndarray, carry: dict | None = None):
    """Lists of output lines, in order."""
    lines = program.lines
    n_lines = len(lines)
    kind = program.kind
    move_line = program.move_line
    feed_value = program.feed_value
    has_f = program.has_f
    piece_lo, piece_hi, p_text = piece_layout(program, piece_move, piece_feed_mm_min)
    # mm per unit of an F word on each line (read before the line's G20/G21), and after it
    f_inch = feed_units_inch(program)
    f_scale = np.where(f_inch, 25.4, 1.0)
    scale = program.scale
    # per line with a feed move: that move, the F text wanted on the line (first piece) and in force
    # after it (last); arrays over the lines, not dicts (a 10⁶-line program: ~0.2 GB of entries)
    want_move = np.full(n_lines, -1, dtype=np.int64)
    want_text = np.empty(n_lines, dtype=object)
    want_last = np.empty(n_lines, dtype=object)
    feed_kind = ~np.isin(kind, NO_F_KINDS)
    advised = piece_lo >= 0
    for m in np.flatnonzero(feed_kind & advised).tolist():
        li = int(move_line[m])
        if want_move[li] >= 0:   # several moves on one line (a corner arc of cutter compensation):
            slowest = min(want_text[li], p_text[piece_lo[m]], key=float)    # one F, the slowest
            want_text[li] = slowest
            want_last[li] = slowest
            continue
        want_move[li] = m
        want_text[li] = p_text[piece_lo[m]]
        want_last[li] = p_text[piece_hi[m] - 1]
    for m in np.flatnonzero(feed_kind & ~advised).tolist():
        li = int(move_line[m])
        if program.feed_mode[li] == 93 and has_f[li]:
            continue  # inverse time: its own F, already on the line
        text = format_feed_exact(float(feed_value[li]))
        mm = float(program.feed_mm_min[m])
        if np.isfinite(mm) and abs(float(feed_value[li]) * f_scale[li] - mm) > 1e-9 * max(mm, 1.0):
            text = format_feed_down(mm / f_scale[li], bool(f_inch[li]))   # F in force read in other units
        want_move[li] = m
        want_text[li] = text
        want_last[li] = text
    mode_change = program.feed_reset
    out_lines = []
    f_in_force = None if carry is None else carry["f"]   # mm/min
    end = min(program.end_line + 1, n_lines)
    # the loop reads Python lists, a block of lines at a time (a numpy scalar per line and field
    # cost ~half its time on a 10⁶-line program); the same IEEE doubles, so the same decisions and
    # F texts
    number: dict = {}                       # float() of each F text met
    special = _SPECIAL.search
    source = iter(lines)                    # in order: a LineStore decodes a block at a time
    for b0 in range(0, end, CHUNK_LINES):
        b1 = min(b0 + CHUNK_LINES, end)
        moves_of = want_move[b0:b1]
        some = np.maximum(moves_of, 0)
        plo = np.where(moves_of >= 0, piece_lo[some], -1).tolist() if piece_lo.size else [-1] * (b1 - b0)
        phi = np.where(moves_of >= 0, piece_hi[some], -1).tolist() if piece_hi.size else [-1] * (b1 - b0)
        moves_of = moves_of.tolist()
        change_lines, f_lines = mode_change[b0:b1].tolist(), has_f[b0:b1].tolist()
        fv, fs, sc = feed_value[b0:b1].tolist(), f_scale[b0:b1].tolist(), scale[b0:b1].tolist()
        for i, raw in zip(range(b1 - b0), source):
            li = b0 + i
            if change_lines[i]:
                f_in_force = 0.0
            m = moves_of[i]
            if m < 0:
                if f_lines[i]:
                    f_in_force = fv[i] * fs[i]
                out_lines.append(raw)
                continue
            want = want_text[li]
            split = plo[i] >= 0 and phi[i] - plo[i] > 1
            if split:
                lo, hi = plo[i], phi[i]
                out_lines.extend(split_lines(program, m, raw, piece_end[lo:hi], p_text[lo:hi]))
            else:
                want_v = number.get(want)
                if want_v is None:
                    want_v = number[want] = float(want)
                if f_lines[i]:
                    if abs(fv[i] - want_v) > 1e-9:
                        if special(raw):
                            raw = edit_line(raw, [("F", want)])
                        else:
                            raw = _F_WORD.sub("F" + want, raw, count=1)
                elif f_in_force is None or abs(f_in_force - want_v * fs[i]) > 1e-9 * max(f_in_force, 1.0):
                    if special(raw):
                        raw = edit_line(raw, [("F", want)])
                    else:
                        raw = raw.rstrip() + " F" + want
                out_lines.append(raw)
            last = want_last[li]
            last_v = number.get(last)
            if last_v is None:
                last_v = number[last] = float(last)
            f_in_force = last_v * (sc[i] if split else fs[i])
        if len(out_lines) >= CHUNK_LINES:
            yield out_lines
            out_lines = []
    if carry is not None:
        carry["f"] = f_in_force
    yield out_lines
    yield lines[end:]
