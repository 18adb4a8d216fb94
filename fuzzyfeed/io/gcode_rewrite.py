"""Write a program back with new feeds: every original line in order, only F words changed or
inserted, a move split only where its feed changes inside it.

Input: a :class:`~fuzzyfeed.io.program.Program` and its pieces — for some moves, the end
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
the program's units, rounded down (never above the feed wanted).
"""

from __future__ import annotations

import math
import re

import numpy as np

from fuzzyfeed.io.program import ARC, HOME, RAPID, Program, arc_geometry, arc_points

_WORD = re.compile(r"([A-Za-z])(\s*)([-+]?\s*(?:\d+\.?\d*|\.\d+))")
_AXES = "XYZ"


def _words(raw: str) -> tuple[list[tuple[str, int, int, int, str]], int]:
    """Words of a line outside comments: (letter, start of word, start of number, end, number
    text), and where new words go (after the last word)."""
    out = []
    if "(" not in raw and ";" not in raw:
        for m in _WORD.finditer(raw):
            out.append((m.group(1).upper(), m.start(), m.start(3), m.end(), m.group(3)))
    else:
        i, n = 0, len(raw)
        while i < n:
            ch = raw[i]
            if ch == "(":
                j = raw.find(")", i)
                i = n if j < 0 else j + 1
                continue
            if ch == ";":
                break
            m = _WORD.match(raw, i)
            if m:
                out.append((m.group(1).upper(), m.start(), m.start(3), m.end(), m.group(3)))
                i = m.end()
            else:
                i += 1
    insert_at = out[-1][3] if out else len(raw.rstrip())
    return out, insert_at


def edit_line(raw: str, sets: list[tuple[str, str]], remove: tuple[str, ...] = ()) -> str:
    """``raw`` with the numbers of the words in ``sets`` replaced (or the words appended after the
    last word, in order) and the words in ``remove`` deleted; comments and spacing kept."""
    words, insert_at = _words(raw)
    pos = {w[0]: w for w in words}
    edits = []                                  # (start, end, text)
    appended = []
    for letter, text in sets:
        w = pos.get(letter)
        if w is not None:
            edits.append((w[2], w[3], text))
        else:
            appended.append(letter + text)
    for letter in remove:
        w = pos.get(letter)
        if w is not None:
            start = w[1]
            while start > 0 and raw[start - 1] in " \t":
                start -= 1
            edits.append((start, w[3], ""))
    if appended:
        edits.append((insert_at, insert_at, " " + " ".join(appended)))
    out = raw
    for start, end, text in sorted(edits, key=lambda e: (e[0], e[1]), reverse=True):
        out = out[:start] + text + out[end:]
    return out


def _decimals_of(text: str) -> int:
    text = text.replace(" ", "")
    return len(text) - text.index(".") - 1 if "." in text else 0


def format_fixed(value_int: int, decimals: int) -> str:
    """An integer count of 10^-decimals units as exact fixed-point text."""
    sign = "-" if value_int < 0 else ""
    q, r = divmod(abs(int(value_int)), 10 ** decimals)
    return f"{sign}{q}.{r:0{decimals}d}" if decimals else f"{sign}{q}"


def format_feed_down(value: float, inch: bool) -> str:
    """F text rounded down (1 decimal in mm/min, 2 in inch/min; more if that would give 0)."""
    d = 2 if inch else 1
    while True:
        q = math.floor(value * 10 ** d + 1e-9)
        if q > 0 or d >= 6:
            return format_fixed(max(q, 1), d)
        d += 1


def format_feed_exact(value: float) -> str:
    text = f"{value:.6f}".rstrip("0").rstrip(".")
    return text or "0"


def rewrite_program(program: Program, piece_move: np.ndarray, piece_end: np.ndarray,
                    piece_feed_mm_min: np.ndarray) -> str:
    """The program text with the pieces' feeds (see the module docstring)."""
    lines = list(program.lines)
    n_lines = len(lines)
    scale = program.scale
    kind = program.kind
    move_line = program.move_line
    feed_value = program.feed_value
    has_f = program.has_f
    n_moves = kind.size
    # wanted feed per piece in program units, first/last piece per move
    pieces_of = {}
    if piece_move.size:
        bounds = np.flatnonzero(np.diff(piece_move)) + 1
        starts = np.concatenate([[0], bounds])
        stops = np.concatenate([bounds, [piece_move.size]])
        for a, b in zip(starts.tolist(), stops.tolist()):
            pieces_of[int(piece_move[a])] = (a, b)
    # per move: the F text wanted on its line (first piece) and in force after it (last piece)
    first_f = [None] * n_moves
    last_f = [None] * n_moves
    for m in range(n_moves):
        if kind[m] in (RAPID, HOME):
            continue
        li = int(move_line[m])
        inch = bool(program.inch[li])
        if m in pieces_of:
            a, b = pieces_of[m]
            texts = [format_feed_down(v / scale[li], inch) for v in piece_feed_mm_min[a:b]]
            first_f[m], last_f[m] = texts[0], texts[-1]
        else:
            if program.feed_mode[li] == 93 and has_f[li]:
                continue  # inverse time: its own F, already on the line
            text = format_feed_exact(float(feed_value[li]))
            first_f[m] = last_f[m] = text
    # F in force in the output, line by line
    out_lines = []
    feed_move_at = {}
    for m in range(n_moves):
        if first_f[m] is not None:
            feed_move_at[int(move_line[m])] = m
    f_in_force = None   # float value in program units
    prev_mode = 94
    end = min(program.end_line + 1, n_lines)
    for li in range(n_lines):
        raw = lines[li]
        if li >= end:
            out_lines.append(raw)
            continue
        mode = int(program.feed_mode[li])
        if mode != prev_mode:
            f_in_force = 0.0
            prev_mode = mode
        m = feed_move_at.get(li)
        if m is None:
            if has_f[li]:
                f_in_force = float(feed_value[li])
            out_lines.append(raw)
            continue
        want = first_f[m]
        want_v = float(want)
        split = m in pieces_of and pieces_of[m][1] - pieces_of[m][0] > 1
        if not split:
            if has_f[li]:
                if abs(float(feed_value[li]) - want_v) > 1e-9:
                    raw = edit_line(raw, [("F", want)])
            elif f_in_force is None or abs(f_in_force - want_v) > 1e-9:
                raw = edit_line(raw, [("F", want)])
            out_lines.append(raw)
            f_in_force = float(last_f[m])
            continue
        new_lines = _split_lines(program, m, raw, piece_end, piece_feed_mm_min, pieces_of[m])
        out_lines.extend(new_lines)
        f_in_force = float(last_f[m])
    text = program.newline.join(out_lines)
    return text + program.newline if out_lines else text


def _split_lines(program: Program, m: int, raw: str, piece_end, piece_feed, span) -> list[str]:
    """The move's own line as the first piece plus one new line per further piece."""
    li = int(program.move_line[m])
    inch = bool(program.inch[li])
    scale = float(program.scale[li])
    absolute = bool(program.absolute[li])
    ij_abs = bool(program.ij_absolute[li])
    words, _ = _words(raw)
    given = {w[0]: w[4] for w in words}
    d = max([5 if inch else 4] + [_decimals_of(given[c]) for c in "XYZIJKR" if c in given])
    unit = 10 ** d
    a, b = span
    fr = np.asarray(piece_end[a:b], dtype=float)
    feeds = [format_feed_down(v / scale, inch) for v in piece_feed[a:b]]
    start_mm, end_mm = program.start[m], program.end[m]
    is_arc = program.kind[m] == ARC
    if is_arc:
        pts = arc_points(program, m, fr)
    else:
        pts = start_mm + (end_mm - start_mm) * fr[:, None]
    # integer grid in program units; the start and end are exact on it (d >= the line's decimals)
    q = np.rint(pts / scale * unit).astype(np.int64)
    q0 = np.rint(start_mm / scale * unit).astype(np.int64)
    q[-1] = np.rint(end_mm / scale * unit).astype(np.int64)
    prev = np.vstack([q0[None, :], q[:-1]])
    out = []
    if is_arc:
        g = arc_geometry(program, m)
        ax_a, ax_b, ax_n = g["axes"]
        centre = np.rint(np.array(g["centre"]) / scale * unit).astype(np.int64)
        motion = "G2" if program.turns[m] < 0 else "G3"
        rise = g["rise"] != 0
    for k in range(fr.size):
        target, before = q[k], prev[k]
        sets = []
        if is_arc:
            axes = [ax_a, ax_b] + ([ax_n] if rise or _AXES[ax_n] in given else [])
        else:
            axes = [i for i in range(3) if target[i] != before[i] or (k == 0 and _AXES[i] in given)]
            if not axes:
                axes = [int(np.argmax(np.abs(target - before)))]
        for i in sorted(axes):
            value = target[i] if absolute else target[i] - before[i]
            sets.append((_AXES[i], format_fixed(int(value), d)))
        if is_arc and (k > 0 or "R" in given):
            for i, c in ((ax_a, centre[0]), (ax_b, centre[1])):
                value = c if ij_abs else c - before[i]
                sets.append(("IJK"[i], format_fixed(int(value), d)))
        sets.append(("F", feeds[k]))
        if k == 0:
            out.append(edit_line(raw, sets, remove=("R",) if is_arc and "R" in given else ()))
        else:
            head = motion if is_arc else "G1"
            out.append(head + " " + " ".join(letter + text for letter, text in sets))
    return out
