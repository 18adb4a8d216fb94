"""The lines of a program as written: their words (values as numbers or LinuxCNC expressions,
comments and parameter settings skipped), a line with words replaced or added, F texts rounded
down, and a move written as consecutive pieces with the mode in force (G90/G91, G20/G21,
G90.1/G91.1, the arc's plane). Used by :mod:`fuzzyfeed.program.rewrite` and
:mod:`fuzzyfeed.program.rewrite_rows`."""

from __future__ import annotations

import math
import re

import numpy as np

from fuzzyfeed.program.model import ARC, Program, arc_geometry, arc_points

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
    """:func:`format_feed_down` for many values at once (one string per distinct value, shared:
    a 10⁶-piece advice has a few hundred feeds)."""
    values = np.asarray(values, dtype=float)
    d = np.where(inch, 2, 1)
    q = np.floor(values * 10.0 ** d + 1e-9)
    mm = (d == 1) & (q > 0)
    out = np.empty(values.size, dtype=object)
    if mm.any():
        distinct, which = np.unique(q[mm], return_inverse=True)
        out[mm] = np.array(np.char.mod("%.1f", distinct / 10.0).tolist(), dtype=object)[which]
    for i in np.flatnonzero(~mm):
        out[i] = format_feed_down(float(values[i]), bool(inch[i]))
    return out.tolist()



def piece_layout(program: Program, piece_move: np.ndarray,
                 piece_feed_mm_min: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Per move the range [lo, hi) of its pieces (-1 for a move with none; pieces are in move
    order), and every piece's F text in the units of its line (rounded down)."""
    n_moves = program.kind.size
    piece_lo = np.full(n_moves, -1)
    piece_hi = np.full(n_moves, -1)
    if piece_move.size:
        bounds = np.flatnonzero(np.diff(piece_move)) + 1
        starts = np.concatenate([[0], bounds])
        stops = np.concatenate([bounds, [piece_move.size]])
        piece_lo[piece_move[starts]] = starts
        piece_hi[piece_move[starts]] = stops
    if not piece_move.size:
        return piece_lo, piece_hi, []
    line = program.move_line[piece_move]
    p_inch = program.inch[line].copy()
    # a move's first piece is its own line: its F is read in the units before the line's G20/G21
    first = np.zeros(piece_move.size, bool)
    first[np.concatenate([[0], np.flatnonzero(np.diff(piece_move)) + 1])] = True
    p_inch[first] = feed_units_inch(program)[line[first]]
    return piece_lo, piece_hi, feed_texts_down(piece_feed_mm_min / np.where(p_inch, 25.4, 1.0), p_inch)


def feed_units_inch(program: Program) -> np.ndarray:
    """Per line, True where an F word on the line is read in inches: LinuxCNC sets the feed
    (order of execution step 4) before it changes units (step 14), so an F is in the units in
    force *before* its line (the reader's rule, :func:`fuzzyfeed.program.read.parse_program`).
    A program whose lines run out of order (loops, calls) is written back with one unit for every
    F (:mod:`fuzzyfeed.program.rewrite_rows` follows the F in force as numbers); if it changes
    units once a feed is set, no F word could be placed safely: refused."""
    inch = np.asarray(program.inch, bool)
    rows = program.rows
    if rows is not None and rows.feed_inch is not None:
        feeds = rows.has_f.copy()
        feeds[rows.move_row] = True
        seen = rows.feed_inch[np.argmax(feeds):] if feeds.any() else rows.feed_inch[:0]
        if seen.size and seen.any() != seen.all():
            from fuzzyfeed.errors import ExportError

            r = int(np.argmax(feeds)) + int(np.flatnonzero(seen != seen[0])[0])
            li = int(rows.line[r - 1]) if r else -1
            where = f"line {li + 1}" if li >= 0 else "a line of another file"
            raise ExportError(f"{program.path.name}: {where} changes units (G20/G21) after a feed is set, "
                              "in a program with loops or subroutine calls; fuzzyfeed cannot write F words "
                              "into it safely (each run of a line may read its F in other units)")
        return np.full(inch.size, bool(seen[0]) if seen.size else False)
    return np.concatenate([[bool(program.inch_before)], inch[:-1]])


def split_lines(program: Program, m: int, raw: str, fractions, feeds: list[str]) -> list[str]:
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
