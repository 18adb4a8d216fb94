"""The words of a program's lines as columns, and the modal state in force after every line.

:func:`line_words` takes the tokens ``[line, letter, value]`` of the reader
(:func:`~fuzzyfeed.program.read.parse_program`; per executed row when the program is executed)
and makes one column per single-valued letter (NaN where absent), the G codes by modal group
(:func:`~fuzzyfeed.program.modal.g_columns`), the M codes checked against what is accepted,
and per line the modal state forward-filled: units, G90/G91 (.1), plane, feed mode, coordinate
system, tool length mode, motion mode, the G5.2 blocks, the F in force (reset to 0 where LinuxCNC
resets it, with the units it is read in), the tool selected and loaded and cutter compensation
(:func:`~fuzzyfeed.program.compensation.comp_per_line`). What the lines then do (positions,
moves, cuts) is :mod:`fuzzyfeed.program.read`'s.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from fuzzyfeed.program.compensation import comp_per_line
from fuzzyfeed.program.expr import POLAR_LETTERS
from fuzzyfeed.program.modal import M_ACCEPTED, M_BREAK, M_STOP, g_columns
from fuzzyfeed.program.model import MM_PER_INCH

#: Largest number a word may hold (mm or inch): beyond, a coordinate leaves the ±1 km of
#: MAX_COORDINATE_MM even in mm (checked again in mm on the positions).
_MAX_WORD = 1e6
_LENGTHLETTERS = [ord(ch) - 65 for ch in "XYZIJKRUVW"] + [POLAR_LETTERS["@"]]


def ffill(values: np.ndarray, has: np.ndarray, default):
    """Forward-fill ``values`` from the rows where ``has`` is true (``default`` before the first)."""
    idx = np.where(has, np.arange(has.size), -1)
    np.maximum.accumulate(idx, out=idx)
    out = np.where(idx >= 0, values[np.maximum(idx, 0)], default)
    return out


#: Modal groups whose code in force a window of lines starts from (fuzzyfeed.program.windows).
CARRIED_GROUPS = {"units": 210, "distance": 900, "arc_distance": 911, "plane": 170, "feed_mode": 940,
                  "coord": 540, "length": 490, "comp": 400, "retract": 990}


def line_words(tokens: list, n: int, end_line: int, n_lines: int, fail, text_of, tools,
               start=None) -> SimpleNamespace:
    """The columns and per-line modal state (module docstring) of ``n`` lines (rows) from
    ``tokens`` (emptied: the words go once their columns are made, ~24 B a word); ``fail(i, msg)``
    raises at line ``i``, ``text_of(i)`` is its text. ``release()`` of the result drops the G words
    (the columns ``cols`` and ``gcol`` are the caller's to clear). ``start``: the state in force
    before the first line (a :class:`fuzzyfeed.program.windows.ReadState`; None: a program's
    start), for a window of a program's lines."""
    tl, tc, tv = tokens
    tokens.clear()

    class _Letters:          # each letter's mask made when asked (28 masks of every word: 80 MB at 10⁶ lines)
        def __getitem__(self, ch):
            return tc == POLAR_LETTERS.get(ch, ord(ch) - 65)

    letter = _Letters()
    big = (np.abs(tv) > _MAX_WORD) & np.isin(tc, _LENGTHLETTERS)
    if big.any():
        k = int(np.argmax(big))
        text = f"{tv[k]:.6g}"
        fail(tl[k], f"{chr(65 + int(tc[k])) if tc[k] < 26 else '@'}{text}: a number beyond ±{_MAX_WORD:g} (no machine moves "
                    f"{_MAX_WORD:g} mm or inch; coordinates must lie within ±1 km)")
    # --- one column per letter (single-valued letters) ---
    cols = {}
    for ch in "XYZABCUVWIJKRPQLFSTHDE@^":
        mask = letter[ch]
        if not mask.any():
            cols[ch] = None
            continue
        li = tl[mask]
        dup = np.flatnonzero(np.diff(li) == 0)
        if dup.size:
            fail(li[dup[0]], f"{ch} given twice")
        col = np.full(n, np.nan)
        col[li] = tv[mask]
        cols[ch] = col
    li = dup = None

    def col(ch):
        c = cols[ch]
        return c if c is not None else np.full(n, np.nan)

    def has(ch):
        c = cols[ch]
        return ~np.isnan(c) if c is not None else np.zeros(n, bool)

    # --- G codes by group ---
    gmask = letter["G"]
    g_line, g10, gcol = g_columns(fail, n, tl[gmask], tv[gmask])

    def gany(name):
        c = gcol[name]
        return c >= 0 if c is not None else np.zeros(n, bool)

    def gline(name, code):
        """Lines that have G<code> (code × 10)."""
        sel = g10 == code
        out = np.zeros(n, bool)
        out[g_line[sel]] = True
        return out

    # --- M codes ---
    mmask = letter["M"]
    m_line, m_val = tl[mmask], tv[mmask]
    m_int = np.rint(m_val).astype(np.int64)
    for k in range(m_val.size):
        if m_val[k] != m_int[k] or int(m_int[k]) not in M_ACCEPTED:
            what = " (subroutine calls are not supported)" if m_int[k] in (98, 99) else ""
            fail(m_line[k], f"M{m_val[k]:g}: unsupported M code{what}")
    e_col = cols["E"]
    if e_col is not None:        # LinuxCNC's rule: an E word needs a code that uses it
        e_users = np.zeros(n, bool)
        e_users[m_line[np.isin(m_int, [66, 67, 68])]] = True
        stray = ~np.isnan(e_col) & ~e_users
        if stray.any():
            i = int(np.argmax(stray))
            fail(i, f"E word with no M66, M67 or M68 to use it in {text_of(i)!r} (LinuxCNC "
                    "refuses it; a number written as 1e6 reads as 1 E6)")
    polar = np.zeros(n, bool)     # polar words (@, ^), see below
    polar[tl[tc >= 26]] = True
    del tl, tc, tv, letter, gmask, mmask, big, mask   # the words: in columns from here
    m_stop = np.zeros(n, bool)
    m_stop[m_line[np.isin(m_int, list(M_STOP))]] = True
    m_break = np.zeros(n, bool)
    m_break[m_line[np.isin(m_int, list(M_BREAK))]] = True

    # --- modal state per line ---
    def modal(name, default):
        if start is not None and name in start.codes:
            default = start.codes[name]
        c = gcol[name]
        if c is None:
            return np.full(n, default, dtype=np.int64)
        return ffill(c, c >= 0, default).astype(np.int64, copy=False)

    units = modal("units", 210)
    inch = units == 200
    scale = np.where(inch, MM_PER_INCH, 1.0)
    absolute = modal("distance", 900) == 900
    ij_absolute = modal("arc_distance", 911) == 901
    plane = modal("plane", 170) // 10
    feed_mode = modal("feed_mode", 940) // 10
    coord = modal("coord", 540)
    length_mode = modal("length", 490)
    motion_col = gcol["motion"]
    motion_set = motion_col >= 0 if motion_col is not None else np.zeros(n, bool)
    motion0 = -1 if start is None else start.motion
    motion = ffill(motion_col, motion_set, motion0) if motion_col is not None else np.full(n, motion0)
    # G5.2 / G5.3 blocks: lines between them are control points
    nurbs_open = np.zeros(n, bool)
    g52_lines = np.flatnonzero(gline("motion", 52)) if motion_col is not None else np.zeros(0, int)
    g53_lines = np.flatnonzero(gline("motion", 53)) if motion_col is not None else np.zeros(0, int)
    blocks = []
    if g52_lines.size or g53_lines.size:
        opened = None
        marks = sorted([(int(i), 52) for i in g52_lines] + [(int(i), 53) for i in g53_lines])
        for i, code in marks:
            if code == 52:
                if opened is not None and opened != i:
                    fail(i, "G5.2 inside a G5.2 block (close it with G5.3 first)")
                opened = i
            else:
                if opened is None:
                    fail(i, "G5.3 without an open G5.2 block")
                blocks.append((opened, i))
                nurbs_open[opened:i + 1] = True
                opened = None
        if opened is not None:
            fail(n - 1 if end_line >= n_lines else end_line,
                 f"G5.2 block from line {opened + 1} is not closed by G5.3")
        for a, b in blocks:
            inner = motion_col[a + 1:b]
            bad = np.flatnonzero((inner >= 0) & (inner != 53))
            if bad.size:
                fail(a + 1 + bad[0], f"G{inner[bad[0]] / 10:g} inside a G5.2 block (close it with G5.3 first)")
            motion[b] = -1  # after G5.3 no motion mode is in force

    # feed: F in force, reset to 0 where the feed mode changes (LinuxCNC does)
    f_col = col("F")
    has_f = ~np.isnan(f_col)
    # LinuxCNC sets F to 0 at every G94/G95 (also when already in force) and at a change of mode
    fm_change = np.zeros(n, bool)
    fm_change[1:] = feed_mode[1:] != feed_mode[:-1]
    fm_change[0] = feed_mode[0] != (94 if start is None else start.codes["feed_mode"] // 10)
    if gcol["feed_mode"] is not None:
        fm_change |= np.isin(gcol["feed_mode"], [940, 950])
    feed_value = ffill(np.where(has_f, f_col, 0.0), has_f | fm_change, 0.0 if start is None else start.feed_value)
    # mm per unit of the F in force: LinuxCNC sets F (order of execution step 4) before it changes
    # units (step 14), and its canonical layer converts F with the units then in force, so
    # `G21` … `G20 F6` is 6 mm/min (issue 37): an F is read in the units of the line before
    scale_before = np.concatenate([[1.0 if start is None else start.scale], scale[:-1]])
    feed_scale = ffill(np.where(has_f, scale_before, 1.0), has_f | fm_change,
                       1.0 if start is None else start.feed_scale)
    if has_f.any() and (f_col[has_f] < 0).any():
        i = int(np.flatnonzero(has_f & (f_col < 0))[0])
        fail(i, f"F{f_col[i]:g}: a feed must be >= 0")
    t_col = col("T")
    tool = ffill(np.where(has("T"), t_col, -1), has("T"), -1 if start is None else start.tool).astype(np.int64)
    # the tool in the spindle: the T in force at an M6, or M61's Q
    m6 = np.zeros(n, bool)
    m6[m_line[m_int == 6]] = True
    m61 = np.zeros(n, bool)
    m61[m_line[m_int == 61]] = True
    loaded_set = m6 | (m61 & has("Q"))
    loaded = ffill(np.where(m6, tool, np.where(loaded_set, np.nan_to_num(col("Q")), 0)).astype(np.int64),
                    loaded_set, 0 if start is None else start.loaded)
    comp_code = modal("comp", 400)
    codes = None if start is None else {name: modal(name, code) for name, code in CARRIED_GROUPS.items()}
    comp_side, comp_radius = comp_per_line(comp_code, gany("comp"), col("D"), loaded, plane, scale, tools,
                                           fail)

    def release():
        nonlocal g10, g_line
        g10 = g_line = None

    return SimpleNamespace(release=release, codes=codes, absolute=absolute, blocks=blocks, col=col, cols=cols, comp_code=comp_code, comp_radius=comp_radius, comp_side=comp_side, coord=coord, f_col=f_col, feed_mode=feed_mode, feed_scale=feed_scale, feed_value=feed_value, fm_change=fm_change, gany=gany, gcol=gcol, gline=gline, has=has, has_f=has_f, ij_absolute=ij_absolute, inch=inch, length_mode=length_mode, loaded=loaded, m_break=m_break, m_int=m_int, m_line=m_line, m_stop=m_stop, m_val=m_val, modal=modal, motion=motion, nurbs_open=nurbs_open, plane=plane, polar=polar, scale=scale, scale_before=scale_before, t_col=t_col, tool=tool, units=units)
