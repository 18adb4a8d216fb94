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
the program's units, rounded down (never above the feed wanted).
"""

from __future__ import annotations

import math
import re

import numpy as np

from fuzzyfeed.program.model import ARC, HOME, RAPID, Program, arc_geometry, arc_points

_NUMBER = re.compile(r"[-+]?\s*(?:\d+\.?\d*|\.\d+)")
_AXES = "XYZ"


def _skip_space(raw: str, i: int) -> int:
    while i < len(raw) and raw[i] in " \t":
        i += 1
    return i


def _bracket_end(raw: str, i: int) -> int:
    """Index after the ``]`` that closes the ``[`` at ``i`` (the line's end if none)."""
    depth = 0
    for j in range(i, len(raw)):
        if raw[j] == "[":
            depth += 1
        elif raw[j] == "]":
            depth -= 1
            if depth == 0:
                return j + 1
    return len(raw)


def _value_end(raw: str, i: int) -> int:
    """Index after the value written at ``i`` (spaces allowed, as LinuxCNC reads them): a
    number, ``#n``/``#<name>``/``##n``/``#[...]``, ``[...]``, a function ``sin[...]`` (``atan[..]/[..]``),
    or a sign before one of those."""
    i = _skip_space(raw, i)
    if i >= len(raw):
        return i
    c = raw[i]
    if c == "[":
        return _bracket_end(raw, i)
    if c == "#":
        j = _skip_space(raw, i + 1)
        if j < len(raw) and raw[j] == "<":
            k = raw.find(">", j)
            return len(raw) if k < 0 else k + 1
        return _value_end(raw, j)
    if c in "+-":
        j = _skip_space(raw, i + 1)
        if j < len(raw) and not (raw[j].isdigit() or raw[j] == "."):
            return _value_end(raw, j)
    if c.isalpha():
        j = i
        while j < len(raw) and raw[j].isalpha():
            j += 1
        name = raw[i:j].lower()
        j = _skip_space(raw, j)
        if j < len(raw) and raw[j] == "[":
            end = _bracket_end(raw, j)
            if name == "atan":
                k = _skip_space(raw, end)
                if k < len(raw) and raw[k] == "/":
                    k = _skip_space(raw, k + 1)
                    if k < len(raw) and raw[k] == "[":
                        end = _bracket_end(raw, k)
            return end
        return i
    m = _NUMBER.match(raw, i)
    return m.end() if m else i


def _words(raw: str) -> tuple[list[tuple[str, int, int, int, str]], int]:
    """Words of a line outside comments: (letter, start of word, start of value, end, value
    text), and where new words go (after the last word). Parameter settings (``#1 = 5``) are
    skipped; an O-word line has no words. A value may be an expression (``X[#1 * 2]``)."""
    out = []
    i, n = 0, len(raw)
    first = True
    while i < n:
        ch = raw[i]
        if ch in " \t":
            i += 1
            continue
        if ch == "(":
            j = raw.find(")", i)
            i = n if j < 0 else j + 1
            continue
        if ch == ";":
            break
        if first and ch in "Oo":
            return [], len(raw.rstrip())
        if ch == "#":                       # a parameter setting: #... = value
            j = _value_end(raw, i)
            j = _skip_space(raw, j)
            i = _value_end(raw, j + 1) if j < n and raw[j] == "=" else j + 1
            continue
        if ch.isalpha():
            start = _skip_space(raw, i + 1)
            end = _value_end(raw, start)
            if end > start:
                out.append((ch.upper(), i, start, end, raw[start:end]))
                if ch not in "Nn/":
                    first = False
                i = end
                continue
        if ch != "/":
            first = False
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
    """Decimals of a number as written (0 for an expression: its value is not written)."""
    text = text.replace(" ", "")
    if not _NUMBER.fullmatch(text):
        return 0
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


def feed_texts_down(values: np.ndarray, inch: np.ndarray) -> list[str]:
    """:func:`format_feed_down` for many values at once."""
    values = np.asarray(values, dtype=float)
    d = np.where(inch, 2, 1)
    q = np.floor(values * 10.0 ** d + 1e-9)
    mm = (d == 1) & (q > 0)
    out = np.empty(values.size, dtype=object)
    if mm.any():
        out[mm] = np.char.mod("%.1f", q[mm] / 10.0).tolist()
    for i in np.flatnonzero(~mm):
        out[i] = format_feed_down(float(values[i]), bool(inch[i]))
    return out.tolist()


_F_WORD = re.compile(r"[Ff]\s*[-+]?(?:\d+\.?\d*|\.\d+)")


def rewrite_program(program: Program, piece_move: np.ndarray, piece_end: np.ndarray,
                    piece_feed_mm_min: np.ndarray) -> str:
    """The program text with the pieces' feeds (see the module docstring)."""
    if program.rows is not None:
        from fuzzyfeed.program.rewrite_rows import rewrite_rows

        return rewrite_rows(program, piece_move, piece_end, piece_feed_mm_min)
    lines = program.lines
    n_lines = len(lines)
    kind = program.kind
    move_line = program.move_line
    feed_value = program.feed_value
    has_f = program.has_f
    inch = program.inch
    # pieces per move
    n_moves = kind.size
    piece_lo = np.full(n_moves, -1)
    piece_hi = np.full(n_moves, -1)
    if piece_move.size:
        bounds = np.flatnonzero(np.diff(piece_move)) + 1
        starts = np.concatenate([[0], bounds])
        stops = np.concatenate([bounds, [piece_move.size]])
        piece_lo[piece_move[starts]] = starts
        piece_hi[piece_move[starts]] = stops
    p_inch = inch[move_line[piece_move]] if piece_move.size else np.zeros(0, bool)
    p_text = feed_texts_down(piece_feed_mm_min / np.where(p_inch, 25.4, 1.0), p_inch)
    # per feed move: the F text wanted on its line (first piece) and in force after it (last)
    want_first = {}
    want_last = {}
    feed_kind = ~np.isin(kind, [RAPID, HOME])
    advised = piece_lo >= 0
    for m in np.flatnonzero(feed_kind & advised).tolist():
        li = int(move_line[m])
        if li in want_first:   # several moves on one line (a corner arc of cutter compensation):
            slowest = min(want_first[li][1], p_text[piece_lo[m]], key=float)    # one F, the slowest
            want_first[li] = (want_first[li][0], slowest)
            want_last[li] = slowest
            continue
        want_first[li] = (m, p_text[piece_lo[m]])
        want_last[li] = p_text[piece_hi[m] - 1]
    for m in np.flatnonzero(feed_kind & ~advised).tolist():
        li = int(move_line[m])
        if program.feed_mode[li] == 93 and has_f[li]:
            continue  # inverse time: its own F, already on the line
        text = format_feed_exact(float(feed_value[li]))
        want_first[li] = (m, text)
        want_last[li] = text
    mode_change = program.feed_reset
    out_lines = []
    f_in_force = None   # value in program units
    end = min(program.end_line + 1, n_lines)
    change_lines = set(np.flatnonzero(mode_change[:end]).tolist())
    f_lines = has_f.tolist()
    for li in range(end):
        raw = lines[li]
        if li in change_lines:
            f_in_force = 0.0
        hit = want_first.get(li)
        if hit is None:
            if f_lines[li]:
                f_in_force = float(feed_value[li])
            out_lines.append(raw)
            continue
        m, want = hit
        if piece_lo[m] >= 0 and piece_hi[m] - piece_lo[m] > 1:
            lo, hi = piece_lo[m], piece_hi[m]
            out_lines.extend(_split_lines(program, m, raw, piece_end[lo:hi], p_text[lo:hi]))
        else:
            want_v = float(want)
            if f_lines[li]:
                if abs(float(feed_value[li]) - want_v) > 1e-9:
                    if any(c in raw for c in "(;#["):
                        raw = edit_line(raw, [("F", want)])
                    else:
                        raw = _F_WORD.sub("F" + want, raw, count=1)
            elif f_in_force is None or abs(f_in_force - want_v) > 1e-9:
                if any(c in raw for c in "(;#["):
                    raw = edit_line(raw, [("F", want)])
                else:
                    raw = raw.rstrip() + " F" + want
            out_lines.append(raw)
        f_in_force = float(want_last[li])
    out_lines.extend(lines[end:])
    text = program.newline.join(out_lines)
    return text + program.newline if out_lines else text


def _split_lines(program: Program, m: int, raw: str, fractions, feeds: list[str]) -> list[str]:
    """The move's own line as the first piece plus one new line per further piece."""
    li = int(program.move_line[m])
    inch = bool(program.inch[li])
    scale = 25.4 if inch else 1.0
    absolute = bool(program.absolute[li])
    ij_abs = bool(program.ij_absolute[li])
    words, _ = _words(raw)
    given = {w[0]: w[4] for w in words}
    d = max([5 if inch else 4] + [_decimals_of(given[c]) for c in "XYZIJKR" if c in given])
    unit = 10 ** d
    fr = np.asarray(fractions, dtype=float)
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
