"""The advised program's model made from the written one, without reading the advised text back.

:func:`~fuzzyfeed.program.rewrite.rewrite_program` writes every line in order, F words changed
or inserted, a move split where its feed changes inside it: its own line is the first piece, the
others follow as new ``G1`` lines whose end points are on the line's integer grid (10^-d program
units, d at least 4 in mm). Reading that text back gives the same moves as the written program
except that a split move becomes its pieces (end points q/10^d), an advised move runs at its F as
written (the text's F, rounded down), and the lines after a split move are shifted by the lines
inserted. :func:`advised_program` builds that model from the written program's arrays (a read of
a 10⁶-line text costs ~0.9 GB at its peak; this, a few arrays per move).

Where the text's numbers would come out otherwise than this construction reproduces exactly, it
returns None and the caller reads the text (:func:`~fuzzyfeed.program.read.parse_program`): a
program with executed rows (loops, calls), in inches anywhere, with several moves on one line (cutter
compensation's corner arcs), a split arc or G5.2 block, a split move in G91, or a split move whose
start or end is not on its line's grid (offsets in force). tests/test_program_advised.py holds the
result to the model read back from the text.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from fuzzyfeed.program.lines import _decimals_of, _words, piece_layout
from fuzzyfeed.program.model import LINE, NO_F_KINDS, Program

#: Per-line arrays of a Program (repeated for the lines a split inserts).
_PER_LINE = ("inch", "absolute", "ij_absolute", "plane", "feed_mode", "feed_value", "tool", "work_offset",
             "length_offset", "has_f", "feed_reset")


def advised_program(program: Program, piece_move: np.ndarray, piece_end: np.ndarray,
                    piece_feed_mm_min: np.ndarray) -> Program | None:
    """The program the rewrite with these pieces reads back as (module docstring), or None where
    that is not reproduced exactly (then read the text)."""
    if program.rows is not None or np.asarray(program.inch).any() or program.nurbs:
        return None
    piece_move = np.asarray(piece_move)
    piece_lo, piece_hi, p_text = piece_layout(program, piece_move, piece_feed_mm_min)
    kind = program.kind
    feed_kind = ~np.isin(kind, NO_F_KINDS)
    advised = np.flatnonzero((piece_lo >= 0) & feed_kind)
    line = program.move_line
    if advised.size and np.unique(line[advised]).size != advised.size:
        return None
    if advised.size and np.isin(line[advised], line[np.delete(np.arange(kind.size), advised)]).any():
        return None
    count = np.where(piece_lo >= 0, piece_hi - piece_lo, 1)
    count[~feed_kind] = 1
    split = np.flatnonzero(count > 1)
    n_lines = len(program.lines)
    if split.size == 0:
        src = np.arange(kind.size)
        new_line = line
        reps = None
    else:
        if not (kind[split] == LINE).all() or not np.asarray(program.absolute)[line[split]].all():
            return None
        src = np.repeat(np.arange(kind.size), count)
        extra = np.zeros(n_lines + 1, np.int64)
        np.add.at(extra, line[split] + 1, count[split] - 1)
        shift = np.cumsum(extra)                 # lines inserted before each line
        first = np.repeat(np.cumsum(count) - count, count)
        new_line = shift[line[src]] + line[src] + (np.arange(src.size) - first)
        reps = np.ones(n_lines, np.int64)
        reps[line[split]] += count[split] - 1
    start = program.start if split.size == 0 else program.start[src]
    end = program.end if split.size == 0 else program.end[src]
    feed = program.feed_mm_min[src]
    out_at = np.cumsum(count) - count            # the first new move of every old move
    # advised moves: their pieces' F as written (the text's value: rounded down in mm/min)
    for m in advised.tolist():
        lo, hi = int(piece_lo[m]), int(piece_hi[m])
        a = int(out_at[m])
        feed[a:a + hi - lo] = [float(t) for t in p_text[lo:hi]]
    for m in split.tolist():
        lo, hi = int(piece_lo[m]), int(piece_hi[m])
        raw = program.lines[int(line[m])]
        words, _ = _words(raw)
        given = {w[0]: w[4] for w in words}
        d = max([4] + [_decimals_of(given[c]) for c in "XYZIJKR" if c in given])
        unit = 10 ** d
        s0, s1 = program.start[m], program.end[m]
        if not (np.array_equal(np.rint(s0 * unit) / unit, s0) and np.array_equal(np.rint(s1 * unit) / unit, s1)):
            return None
        fr = np.asarray(piece_end[lo:hi], dtype=float)
        q = np.rint((s0 + (s1 - s0) * fr[:, None]) * unit).astype(np.int64)
        pts = q / unit
        pts[-1] = s1
        a = int(out_at[m])
        end[a:a + hi - lo] = pts
        start[a + 1:a + hi - lo] = pts[:-1]
    stops = None
    if program.stops is not None and split.size == 0:
        stops = program.stops
    elif program.stops is not None:
        last = np.ones(src.size, bool)
        last[:-1] = src[1:] != src[:-1]
        stops = program.stops[src] & last
    # the written program's own arrays where no move is split (a 10⁶-move program: ~0.1 GB of copies)
    pick = (lambda v: v) if split.size == 0 else (lambda v: v[src])
    per_move = {k: pick(getattr(program, k)) for k in ("kind", "cut", "centre", "turns", "arc_plane", "no_split")}
    for k in ("rotary", "known", "comp_unknown"):
        v = getattr(program, k)
        per_move[k] = None if v is None else pick(v)
    per_line = {} if reps is None else {k: np.repeat(getattr(program, k), reps) for k in _PER_LINE}
    end_line = program.end_line + (0 if reps is None else int(reps[:program.end_line].sum() - program.end_line))
    return replace(program, move_line=new_line, start=start, end=end, feed_mm_min=feed, stops=stops,
                   end_line=end_line, **per_move, **per_line)
