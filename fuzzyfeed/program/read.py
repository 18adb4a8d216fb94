"""Read a whole G-code program (LinuxCNC dialect) into a :class:`~fuzzyfeed.program.model.Program`.

The reader tokenises the program once and works on arrays: the words of every line become one
column per letter (NaN where absent), the modal groups are forward-filled per line
(:mod:`fuzzyfeed.program.read_words`), and the positions come from cumulative sums (G91)
restarted at every absolute coordinate (G90) or at a change of frame. Only arcs, G5.2 blocks and the few lines that change the frame are visited one
by one.

Carried through unchanged (they do not change the programmed path): G43/G43.1/G43.2/G49 H,
G54–G59.3, G10 L1/L2/L10/L11/L20, G20/G21, G90/G91 (.1), G93/G94/G95, G96/G97, G61/G61.1/G64,
G40, G80, G98/G99, G4, G28/G30/G53 moves (rapids that end a cut), G28.1/G30.1, G92 family and
G52 (offsets, followed by :mod:`fuzzyfeed.program.frames`), G17/G18/G19, M0–M9, M30, M48–M53, M60–M66, M70–M73, M100–M199, T, S, H, D, N, E,
``%``, ``/``, comments ``( )`` and ``;``. Canned cycles G73, G74, G81–G89 are moves of their
own kind, kept as written. Arcs in any plane (I/J/K or R, helical, P turns) are exact.

A program with parameters, expressions or O-words (``#``, ``[``, ``<``, ``O``, M98/M99) is first
executed line by line (:mod:`fuzzyfeed.program.flow`, LinuxCNC's semantics) into the words with
plain values of every executed line; when each line runs at most once, in file order (parameters,
expressions, ``if``), the rows are the file's lines and everything below is unchanged. With loops
and calls a line may run many times: the arrays are per executed row, mapped back to their lines
(``Program.rows``).

Modal groups as LinuxCNC's reader checks them (``interp_read.cc`` read_g, ``enhance_block``): two
codes of one group on a line are an error, except G80 beside another motion code (the other
wins: ``G0 G80`` is G0); a motion code beside G10/G28/G30/G52/G92 is an error (both use the
axis words), and so are axis words with G80 or with G80 in force.

Refused with ``file:line``: cutter compensation G41/G42 (.1) unless :mod:`fuzzyfeed.program.compensation`
is given the tool (see there), G5/G5.1 splines, threading G33/G76, probing G38.x, lathe diameter
mode G7, the UVW planes, polar words outside G17 or beside X/Y, and arcs whose end radius does not fit the start radius
(LinuxCNC's rule: more than 0.02 mm / 0.002 in *and* 0.1 %); coordinates beyond ±1 km (also a
thousand-digit number).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from fuzzyfeed.errors import PathFormatError
from fuzzyfeed.geometry.nurbs import MAX_COORDINATE_MM
from fuzzyfeed.program.compensation import compensate
from fuzzyfeed.program.flow import execute, needs_execution
from fuzzyfeed.program.frames import START_EPOCH, cycle_info, sequential_positions, system_events
from fuzzyfeed.program.lexer import clean_lines, fail_at, tokenise
from fuzzyfeed.program.line_store import LineStore
from fuzzyfeed.program.read_words import line_words
from fuzzyfeed.program.modal import CYCLES, modal_checks
from fuzzyfeed.program.motion import arc_centres, nurbs_blocks, spline_moves
from fuzzyfeed.program.model import (ARC, CYCLE, HOME, KEPT, LINE, NURBS, RAPID, SYNCED, Program,
                                    Rows, lines_of_rows)

#: Epoch of an axis at the start of a program: the machine is wherever it is (not at 0), so a
#: move that sets some axes from there starts from an unknown point (see _axis_positions).
_START_EPOCH = START_EPOCH


def _axis_positions(n: int, setv: np.ndarray, is_set: np.ndarray, inc: np.ndarray,
                    pre: np.ndarray, post: np.ndarray, line0: int = 0, pos0: float = 0.0,
                    epoch0: int = _START_EPOCH):
    """Position of one axis after every line, and its epoch (0 = known; −(i+1) = unknown
    constant since line i), from absolute sets, increments and frame resets (see module docs);
    a window of lines from line ``line0`` starts at ``pos0`` with epoch ``epoch0``."""
    inc = np.where(post, 0.0, inc)
    has = is_set | pre | post
    base = np.where(is_set, setv, 0.0)
    epoch_evt = np.where(is_set, 0, -(np.arange(n) + 1 + line0))
    c = np.cumsum(inc)
    d = c - inc
    last = np.where(has, np.arange(n), -1)
    np.maximum.accumulate(last, out=last)
    known = last >= 0
    li = np.maximum(last, 0)
    pos = np.where(known, base[li] + c - d[li], c if epoch0 == _START_EPOCH and pos0 == 0.0 else pos0 + c)
    epoch = np.where(known, epoch_evt[li], epoch0)
    return pos, epoch


def read_program(path: str | os.PathLike, text: str | None = None, tools: dict | None = None) -> Program:
    """Read a G-code program (see the module docstring); ``text`` if already read; ``tools`` the
    tool diameters (mm) by tool number, for cutter compensation
    (:func:`fuzzyfeed.program.tools.read_tool_table`)."""
    path = Path(path)
    if text is None:
        from fuzzyfeed.base.files import read_text
        # G-code may be Latin-1 (comments in old controllers' files often are)
        return parse_program(read_text(path, "G-code", PathFormatError, latin1=True), path, tools)
    return parse_program(text, path, tools)


def parse_program(text: str, path: str | os.PathLike = "<gcode>", tools: dict | None = None) -> Program:
    """A program from its text (see :func:`read_program`)."""
    path = Path(path)
    newline = "\r\n" if "\r\n" in text else "\n"
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    if newline == "\r\n" or "\r" in text:
        lines = [ln.rstrip("\r") for ln in lines]
    clean = clean_lines(lines, text, path)
    del text                  # the caller's copy only, from here (a 10⁶-line program: 24 MB)
    body, end_line, n = program_body(clean, len(lines))
    del clean
    if needs_execution(body):
        return _parse_executed(path, lines, newline, tools)
    if n == 0 or not body.strip():
        raise PathFormatError(f"{path}: the program has no words (empty or only comments); "
                              "nothing to advise")
    tokens = list(tokenise(body, path, lines))
    del body
    return _interpret(path, lines, newline, end_line, n, tokens, tools=tools)


#: The program's end: the first M2/M30 (nothing after its line is read).
PROGRAM_END = re.compile(r"(?m)M0*(?:2|30)(?![0-9.])")


def program_body(clean: list[str], n_all: int) -> tuple[str, int, int]:
    """The words of the cleaned lines as one upper-case text without blanks or block-delete marks,
    up to the line of the first M2/M30: (body, the end's line, the lines read); (body, ``n_all``,
    ``n_all``) for a program without an end."""
    body = "\n".join(clean).upper().replace(" ", "").replace("\t", "")
    if "/" in body:
        body = re.sub(r"(?m)^/", "", body)
    end = PROGRAM_END.search(body)
    if end is None:
        return body, n_all, n_all
    end_line = body.count("\n", 0, end.start())
    cut_at = body.find("\n", end.start())
    return (body if cut_at < 0 else body[:cut_at]), end_line, end_line + 1


def _parse_executed(path: Path, lines: list[str], newline: str, tools: dict | None) -> Program:
    """A program with parameters, expressions or O-words: executed first (see the module docs)."""
    ex = execute(path, lines)
    if ex.n_rows == 0 or ex.tl.size == 0:
        raise PathFormatError(f"{path}: the program has no words (empty or only comments); "
                              "nothing to advise")
    if ex.in_order:   # every row is its own line: the file's lines, some of them empty
        last = int(ex.row_line[-1])
        end_line = last if ex.ended else len(lines)
        n = last + 1 if ex.ended else len(lines)
        return _interpret(path, lines, newline, end_line, n, [ex.row_line[ex.tl], ex.tc, ex.tv], tools=tools)
    return _interpret(path, lines, newline, len(lines), ex.n_rows, [ex.tl, ex.tc, ex.tv], rows=ex, tools=tools)


def _interpret(path, lines, newline, end_line, n, tokens, rows=None, tools=None, read_state=None,
               capture=None) -> Program:
    """The program from its tokens ``[line, letter, value]`` (the list is emptied: the words go once
    their columns are made, ~24 B a word): per line (or, with ``rows``, per executed row) the words.
    A window of a program's lines (:mod:`fuzzyfeed.program.windows`): ``read_state`` the state in force
    before its first line (a ``ReadState``: its lines are the program's from ``read_state.line``),
    ``capture`` a dict given the per-line state the next window starts from and what the window's
    joins are checked with."""
    line0 = 0 if read_state is None else int(read_state.line)

    def fail(i: int, message: str):
        if rows is None:
            fail_at(path, int(i) + 1 + line0, message)
        where, number = rows.where(int(i))
        raise PathFormatError(f"{where}:{number}: {message}")

    def text_of(i: int) -> str:
        if rows is None:
            return lines[int(i)].strip()
        where, number = rows.where(int(i))
        return lines[number - 1].strip() if where == path else f"line {number} of {Path(where).name}"

    w = line_words(tokens, n, end_line, len(lines), fail, text_of, tools, read_state)
    if capture is not None:
        capture.update(codes=w.codes, motion=w.motion, feed_value=w.feed_value, feed_scale=w.feed_scale,
                       scale=w.scale, tool=w.tool, loaded=w.loaded, comp_side=w.comp_side,
                       units_given=(w.gcol["units"] >= 0) if w.gcol["units"] is not None else np.zeros(n, bool))
    # the words as columns and the modal state per line (fuzzyfeed.program.read_words)
    (absolute, blocks, col, cols, comp_code, comp_radius, comp_side, coord, f_col, feed_mode,
     feed_scale, feed_value, fm_change, gany, gcol, gline, has, has_f, ij_absolute, inch, length_mode,
     loaded, m_break, m_int, m_line, m_stop, m_val, modal, motion, nurbs_open, plane, polar, scale,
     scale_before, t_col, tool, units) = \
        (w.absolute, w.blocks, w.col, w.cols, w.comp_code, w.comp_radius, w.comp_side, w.coord, w.f_col,
         w.feed_mode, w.feed_scale, w.feed_value, w.fm_change, w.gany, w.gcol, w.gline, w.has, w.has_f,
         w.ij_absolute, w.inch, w.length_mode, w.loaded, w.m_break, w.m_int, w.m_line, w.m_stop,
         w.m_val, w.modal, w.motion, w.nurbs_open, w.plane, w.polar, w.scale, w.scale_before, w.t_col,
         w.tool, w.units)
    release_words = w.release
    del w

    # --- which lines move, and how ---
    xyz_has = [has(ch) for ch in "XYZ"]
    any_xyz = xyz_has[0] | xyz_has[1] | xyz_has[2]
    abc_has = np.zeros(n, bool)
    for ch in "ABCUVW":
        abc_has |= has(ch)
    # polar words (@ radius, ^ angle): the XY they reach depends on where the tool is; the move is
    # kept as written and X, Y are unknown after it (LinuxCNC: G17 only, never beside X or Y)
    bad_polar = polar & (xyz_has[0] | xyz_has[1] | (plane != 17))
    if bad_polar.any():
        i = int(np.argmax(bad_polar))
        fail(i, "polar words (@, ^) beside X or Y, or outside G17 (LinuxCNC refuses them)")
    nonmodal = gcol["nonmodal"]
    nm = (lambda code: gline("nonmodal", code)) if nonmodal is not None else (lambda code: np.zeros(n, bool))
    g10_l, g28, g30, g53 = nm(100), nm(280), nm(300), nm(530)
    g92_set = nm(920)             # G92 with axis words: those axes take the given values
    g92 = np.zeros(n, bool)       # G92.1/.2/.3: offsets cancelled or restored
    g92_zero = np.zeros(n, bool)  # G92.1/.2: the axis offsets become 0
    g92_keep = np.zeros(n, bool)  # G92.1: ... and so do the saved ones
    g92_restore = np.zeros(n, bool)  # G92.3: the saved offsets come back
    if gcol["g92_offsets"] is not None:
        g92 = gcol["g92_offsets"] >= 0
        g92_zero = np.isin(gcol["g92_offsets"], [921, 922])
        g92_keep = gcol["g92_offsets"] == 922
        g92_restore = gcol["g92_offsets"] == 923
    g52_local = nm(520)
    covets = g10_l | g92_set | g52_local | g28 | g30   # LinuxCNC's mode_zero_covets_axes
    takes_axes = covets                                # axis words are not a target
    motion_here = gcol["motion"] >= 0 if gcol["motion"] is not None else np.zeros(n, bool)
    both = covets & motion_here & (gcol["motion"] != 800 if gcol["motion"] is not None else False)
    if both.any():
        i = int(np.argmax(both))
        fail(i, f"G{gcol['motion'][i] / 10:g} with G{int(gcol['nonmodal'][i]) / 10:g}: two G codes that "
                "both use the axis words (LinuxCNC refuses it)")
    arcs_words = has("I") | has("J") | has("K") | has("R")
    is_arc_mode = (motion == 20) | (motion == 30)
    full_circle = is_arc_mode & ~any_xyz & (has("I") | has("J") | has("K")) & ~takes_axes
    moving = (any_xyz | abc_has | full_circle | polar) & ~takes_axes & ~nurbs_open
    no_motion = moving & (motion < 0) & ~g53
    if no_motion.any():
        fail(int(np.argmax(no_motion)), "axis words with no motion mode (G0, G1, G2, G3) in force")
    modal_checks(fail, n, gcol, motion, motion_here, moving, any_xyz | abc_has, has, g53, absolute,
                  nm(920) | g52_local, feed_value)
    after_g80 = moving & (motion == 800)
    if after_g80.any():
        fail(int(np.argmax(after_g80)), "axis words with G80 in force (G80 cancels the motion "
                                        "mode; LinuxCNC refuses them)")
    bad_arcwords = arcs_words & ((motion == 0) | (motion == 10)) & moving
    if bad_arcwords.any():
        i = int(np.argmax(bad_arcwords))
        which = "/".join(ch for ch in "IJKR" if has(ch)[i])
        fail(i, f"{which} with G{motion[i] / 10:g}: arc words belong to G2/G3")
    cycle_line = moving & np.isin(motion, list(CYCLES))
    probe_line = moving & np.isin(motion, [382, 383, 384, 385])   # ends where the probe trips
    tap_line = moving & (motion == 331)                           # rigid tapping: back where it began
    control_point = nurbs_open & any_xyz
    # frame resets: before the motion of their line (offsets), after it (homing, G53, cycles)
    coord_change = np.zeros(n, bool)
    coord_change[1:] = coord[1:] != coord[:-1]
    coord_change[0] = coord[0] != 540
    length_line = gany("length")
    l_col = col("L")
    tool_table = g10_l & np.isin(l_col, [1, 10, 11])
    # G52 and G92.1/.2 set the axis offsets (shared with G92) to known values: followed line by
    # line (a shift of the frame when the offsets before are known too, see sequential_positions)
    offset_lines = g52_local | g92_zero | g92_restore
    # G10 L2 sets a coordinate system's offsets to known values: systems followed line by line too
    g10_l2 = g10_l & (l_col == 2) & ~has("R")
    frame_lines = coord_change | g10_l2
    follow_offsets = bool(offset_lines.any() or frame_lines.any())
    pre_all = (coord_change & ~frame_lines) | (g10_l & ~tool_table & ~g10_l2) | (g92 & ~offset_lines) | (gline("length", 431) if gcol["length"] is not None else np.zeros(n, bool))
    pre_z = length_line | tool_table
    home_line = g28 | g30
    post_named = g53 & moving
    follow_cycles = bool((cycle_line & (plane == 17)).any()) and not (cycle_line & (plane != 17)).any()
    post = []
    pre = []
    for k in range(3):
        p = pre_all | (pre_z if k == 2 else False)
        # a probe stops somewhere on its line: the axes it moves are unknown after it
        q = (home_line & (xyz_has[k] | ~any_xyz)) | (post_named & xyz_has[k]) | (probe_line & xyz_has[k])
        if k == 2:
            q = q | (cycle_line & ~follow_cycles)
        else:
            q = q | (cycle_line & ~absolute)
        pre.append(p)
        post.append(q)

    # --- positions ---
    updates = (moving | control_point) & ~g53 & ~tap_line
    pos_after = np.empty((n, 3))
    epoch_after = np.empty((n, 3), dtype=np.int64)
    sets, incs = [], []
    for k, ch in enumerate("XYZ"):
        v = col(ch) * scale
        given = xyz_has[k] & updates
        if k == 2:
            given &= ~cycle_line
        # G92 X…: the current point becomes the given value, whatever the mode and the offsets
        is_set = (given & absolute) | (g92_set & xyz_has[k] & ~follow_offsets)
        inc = np.where(given & ~absolute, v, 0.0)
        sets.append((np.where(is_set, v, 0.0), is_set))
        incs.append(inc)
        if read_state is None:
            pos_after[:, k], epoch_after[:, k] = _axis_positions(n, sets[k][0], is_set, inc, pre[k], post[k])
        else:
            pos_after[:, k], epoch_after[:, k] = _axis_positions(n, sets[k][0], is_set, inc, pre[k], post[k],
                                                                 line0, float(read_state.pos[k]), int(read_state.epoch[k]))
        if capture is not None:
            capture["increments"] = capture.get("increments", False) or bool(np.any(inc != 0))
    polar_moves = polar & updates & ~cycle_line
    if capture is not None:
        capture["sequential"] = bool(polar_moves.any() or follow_offsets or follow_cycles or blocks
                                     or (gcol["motion"] is not None and np.isin(gcol["motion"], [50, 51]).any()))
    if polar_moves.any() or follow_offsets or follow_cycles:   # these depend on the point before
        offsets = None
        if follow_offsets:
            code = (np.where(g92_set, 1, 0) + np.where(g52_local, 2, 0) + np.where(g92_zero & ~g92_keep, 3, 0)
                    + np.where(g92_keep, 4, 0) + np.where(g92_restore, 5, 0))
            offsets = (code, [col(ch) * scale for ch in "XYZ"],
                       system_events(frame_lines, coord, g10_l2, col("P")))
        pos_after, epoch_after = sequential_positions(fail, n, sets, incs, pre, post, polar_moves,
                                                       absolute, col("@") * scale, col("^"), offsets,
                                                       cycle_info(cycle_line, motion, col("R") * scale,
                                                                   modal("retract", 990))
                                                       if follow_cycles else None)
    far = np.abs(pos_after) > MAX_COORDINATE_MM
    if far.any():
        i, k = (int(v) for v in np.argwhere(far)[0])
        fail(i, f"{'XYZ'[k]} reaches {pos_after[i, k]:.6g} mm; coordinates must lie within "
                f"±{MAX_COORDINATE_MM:g} mm (1 km)")
    if read_state is None:
        pos_before = np.vstack([np.zeros((1, 3)), pos_after[:-1]])
        epoch_before = np.vstack([np.full((1, 3), _START_EPOCH, dtype=np.int64), epoch_after[:-1]])
    else:
        pos_before = np.vstack([np.asarray(read_state.pos, float)[None], pos_after[:-1]])
        epoch_before = np.vstack([np.asarray(read_state.epoch, np.int64)[None], epoch_after[:-1]])
    if capture is not None:
        capture.update(pos_after=pos_after, epoch_after=epoch_after.copy())
    for k in range(3):
        epoch_before[:, k] = np.where(pre[k], -(np.arange(n) + 1 + line0), epoch_before[:, k])
    known = np.all(epoch_before == epoch_after, axis=1)
    del epoch_before, epoch_after, sets, incs, v, inc, is_set, given   # a 10⁶-line program: ~100 MB

    # --- moves ---
    nurbs_first = np.zeros(n, bool)
    for a, _ in blocks:
        nurbs_first[a] = True
    move_rows = np.flatnonzero(moving | home_line | nurbs_first)
    units_col = gcol["units"]
    if move_rows.size and (units_col is None or not (units_col[:move_rows[0] + 1] >= 0).any()) and (
            read_state is None or not (read_state.units_given or read_state.moved)):
        i = int(move_rows[0])
        _notice(f"{path}:{int(rows.where(i)[1]) if rows is not None else i + 1 + line0}: no G20/G21 before the "
                "first move: read in mm, as GRBL and a metric LinuxCNC start (a machine that starts in "
                "inches reads it 25.4 x larger); put G21 or G20 at the top to say which")
    kind = np.full(move_rows.size, KEPT, dtype=np.int8)
    mo = motion[move_rows]
    kind[mo == 0] = RAPID
    kind[mo == 10] = LINE
    kind[(mo == 20) | (mo == 30)] = ARC
    kind[np.isin(mo, list(CYCLES))] = CYCLE
    kind[np.isin(mo, [330, 331])] = SYNCED
    hl = home_line[move_rows] | g53[move_rows]
    kind[hl & ((mo == 0) | home_line[move_rows])] = HOME
    kind[g53[move_rows] & (mo != 0)] = KEPT
    kind[nurbs_first[move_rows]] = NURBS
    start = pos_before[move_rows].copy()
    endp = pos_after[move_rows].copy()
    fmode = feed_mode[move_rows]
    kept = np.isin(kind, [LINE, ARC]) & (~known[move_rows] | abc_has[move_rows] | (fmode != 94))
    unplaced_arcs = kept & (kind == ARC) & ~known[move_rows]
    kind[unplaced_arcs] = KEPT
    feed_mm = np.where(np.isin(kind, [RAPID, HOME, SYNCED]), np.nan, feed_value[move_rows] * feed_scale[move_rows])
    no_split = m_stop[move_rows] | polar[move_rows]     # a polar line takes no X or Y word
    stops = m_stop[move_rows].copy()
    # LinuxCNC's task waits for the motion queue to empty before a spindle, coolant or tool-change
    # command (M3-M9, an S word) and a dwell (emctaskmain.cc, emcTaskCheckPreconditions:
    # WAITING_FOR_MOTION), executed before the motion of their line: the tool stops after the
    # move before them (issue 37). GRBL 1.1 syncs its buffer the same way (protocol_buffer_synchronize
    # for M3-M5, M7-M9, G4), but on an S word only when the speed changes with the spindle on
    m_drain = np.zeros(n, bool)
    m_drain[m_line[np.isin(m_int, [3, 4, 5, 6, 7, 8, 9])]] = True
    drain = m_drain | has("S") | nm(40)
    if move_rows.size > 1:
        dcum = np.concatenate([[0], np.cumsum(drain)])       # dcum[i] = drains on rows < i
        stops[:-1] |= (dcum[move_rows[1:] + 1] - dcum[move_rows[:-1] + 1]) > 0
    centre, turns, arc_plane, multi_turn = arc_centres(fail, kind, move_rows, motion, plane, start,
                                                       endp, col, inch, scale, ij_absolute, unplaced_arcs)
    no_split |= multi_turn
    row_of = {int(r): k for k, r in enumerate(move_rows)} if blocks else {}   # only G5.2 blocks ask
    nurbs, nurbs_lines = nurbs_blocks(fail, blocks, row_of, known, col, any_xyz, xyz_has,
                                      pos_before, pos_after)
    del pos_before, pos_after
    for m in nurbs:
        endp[m] = nurbs[m].control_points[-1]
    splines = spline_moves(fail, kind, move_rows, motion, plane, start, endp, col, scale, known)
    kind[list(splines)] = NURBS
    nurbs.update(splines)
    kind[np.isin(mo, [50, 51]) & (kind != NURBS)] = KEPT        # from an unknown point

    # --- cutter compensation: the tool centre's path, where the tool's radius is known ---
    side_m = comp_side[move_rows]
    unknown_r = (side_m != 0) & np.isnan(comp_radius[move_rows])
    # on the programmed contour, not the tool centre's path: moves under G41/G42 with no diameter
    # and the move after them (it starts from the compensated point); see Program.comp_unknown
    comp_unknown = unknown_r | ((side_m == 0) & np.concatenate([[False], unknown_r[:-1]]))
    if unknown_r.any():
        i = int(move_rows[np.argmax(unknown_r)])
        i = int(np.flatnonzero(gany("comp")[:i + 1])[-1])        # the G41/G42 line
        _notice(f"{path}:{int(rows.where(i)[1]) if rows is not None else i + 1}: cutter compensation "
                "with no tool diameter (give --tool-table FILE, or G41.1/G42.1 D<diameter>): the "
                "programmed contour is advised, not the tool centre's path")
        side_m = np.where(unknown_r, 0, side_m)
    if (side_m != 0).any():
        moved_kinds = np.isin(kind, [RAPID, LINE, ARC])
        bad = (side_m != 0) & ~moved_kinds
        if bad.any():
            fail(move_rows[np.argmax(bad)], "only G0, G1, G2 and G3 moves can run under cutter "
                                            "compensation (LinuxCNC refuses the others)")
        resets = np.zeros((move_rows.size, 3), bool)     # a frame change since the move before
        for k in range(3):
            before = np.concatenate([[0], np.cumsum(pre[k])])     # resets on lines < i
            prev_row = np.concatenate([[-1], move_rows[:-1]])
            resets[:, k] = before[move_rows + 1] - before[prev_row + 1] > 0
        comp = compensate(kind, start, endp, centre, turns, side_m, comp_radius[move_rows] * 1.0,
                          plane[move_rows], bool(inch[move_rows[0]]), lambda m, msg: fail(move_rows[m], msg),
                          resets)
        src = comp.src
        remap = {int(old): k for k, old in enumerate(src) if int(old) in nurbs}
        nurbs = {remap[m]: c for m, c in nurbs.items()}
        nurbs_lines = {remap[m]: v for m, v in nurbs_lines.items()}
        in_comp = side_m[src] != 0
        move_rows, kind, start, endp = move_rows[src], comp.kind, comp.start, comp.end
        centre = np.where((kind == ARC)[:, None] & in_comp[:, None], comp.centre, centre[src])
        turns = np.where(in_comp, comp.turns, turns[src])
        arc_plane = np.where(kind == ARC, np.where(in_comp, plane[move_rows], arc_plane[src]), 0)
        feed_mm, no_split = feed_mm[src], no_split[src] | in_comp
        stops = stops[src] & (np.append(src[1:] != src[:-1], True))   # after the line's last move
        fmode = fmode[src]
        comp_unknown = comp_unknown[src]

    # the letters' and groups' columns and the per-line modal arrays the model does not keep go
    # before the cuts and the model's own arrays are made (a 10⁶-line program: ~0.2 GB)
    cols.clear()
    gcol.clear()
    del motion, comp_side, comp_radius, loaded, feed_scale, units, scale, comp_code, f_col, t_col, mo
    release_words()
    m_val = m_int = drain = m_drain = dcum = None

    # --- cuts ---
    moved = np.any(endp != start, axis=1) | (turns != 0) | (kind == NURBS)
    advisable = np.isin(kind, [LINE, ARC, NURBS]) & (feed_mode[move_rows] == 94)
    advisable &= known[move_rows] | (kind == NURBS)
    advisable &= ~abc_has[move_rows]
    if rows is not None:         # moves of another file's lines (a called NAME.ngc) are kept
        advisable &= rows.row_line[move_rows] >= 0
    breaker_line = m_break | pre_all | pre_z | home_line | g53 | g92_set
    bcum = np.concatenate([[0], np.cumsum(breaker_line)])   # bcum[i] = breakers on lines < i
    # a chain is broken by a move that is not advised (a rapid that moves, home, cycle, kept) and
    # by a line where the tool stops or the frame changes; rapids that do not move are transparent
    stopper = ~advisable & (moved | (kind != RAPID))
    idx = np.where(advisable | stopper, np.arange(move_rows.size), -1)
    np.maximum.accumulate(idx, out=idx)
    prev_idx = np.concatenate([[-1], idx])[:-1].astype(np.int64)
    if move_rows.size:
        prev_is_adv = (prev_idx >= 0) & advisable[np.maximum(prev_idx, 0)]
        prev_line = np.where(prev_idx >= 0, move_rows[np.maximum(prev_idx, 0)], 0)
    else:
        prev_is_adv = prev_line = prev_idx
    brk = (bcum[move_rows + 1] - bcum[prev_line]) > 0
    chain_start = advisable & (~prev_is_adv | brk)
    cut = np.where(advisable, np.cumsum(chain_start) - 1, -1)
    if capture is not None:     # where a window may end: a move whose chain does not reach back
        capture.update(restart=chain_start | stopper, move_rows=move_rows)
    # a cut that does not move at all is no cut
    if cut.size and cut.max() >= 0:
        lengths = np.zeros(cut.max() + 1)
        np.add.at(lengths, cut[cut >= 0], moved[cut >= 0].astype(float))
        empty = lengths == 0
        if empty.any():
            remap = np.cumsum(~empty) - 1
            cut = np.where(cut >= 0, np.where(empty[np.maximum(cut, 0)], -1, remap[np.maximum(cut, 0)]), -1)
    # small codes in small integers (17-19, 93-95: ~13 MB of the 10⁶-line raster's model)
    state = dict(inch=inch, absolute=absolute, ij_absolute=ij_absolute, plane=plane.astype(np.int8),
                 feed_mode=feed_mode.astype(np.int8),
                 feed_value=feed_value, tool=tool, work_offset=coord / 10.0, length_offset=length_mode / 10.0)
    if rows is None:
        per_line = {k: _pad(v, len(lines)) for k, v in state.items()}
        per_line["has_f"] = _pad(has_f, len(lines), False)
        per_line["feed_reset"] = _pad(fm_change, len(lines), False)
        move_line, row_info = move_rows, None
    else:
        per_line = {k: lines_of_rows(v, rows.row_line, len(lines)) for k, v in state.items()}
        per_line["has_f"] = lines_of_rows(has_f, rows.row_line, len(lines), False)
        per_line["feed_reset"] = lines_of_rows(fm_change, rows.row_line, len(lines), False)
        move_line = rows.row_line[move_rows]
        row_info = Rows(line=rows.row_line, feed_mode=feed_mode, has_f=has_f, feed_value=feed_value,
                        feed_reset=fm_change, move_row=move_rows, feed_inch=scale_before != 1.0,
                        call_line=rows.row_call)
        runs = np.bincount(rows.row_line[rows.row_line >= 0], minlength=len(lines))
        no_split |= (move_line < 0) | (runs[np.maximum(move_line, 0)] > 1)
    return Program(path=path, lines=LineStore(lines), newline=newline, end_line=end_line, **per_line,
                   move_line=move_line, kind=kind, start=start, end=endp, feed_mm_min=feed_mm,
                   cut=_narrow(cut, np.int32), centre=centre, turns=_narrow(turns, np.int32),
                   arc_plane=arc_plane.astype(np.int8), no_split=no_split,
                   has_z_words=bool(xyz_has[2].any()), nurbs=nurbs, nurbs_lines=nurbs_lines,
                   rows=row_info, rotary=abc_has[move_rows], known=known[move_rows], stops=stops,
                   comp_unknown=comp_unknown,
                   inch_before=read_state is not None and read_state.codes["units"] == 200)


def _notice(message: str) -> None:
    import warnings

    from fuzzyfeed.errors import FuzzyfeedNotice

    warnings.warn(message, FuzzyfeedNotice, stacklevel=4)


def _narrow(arr: np.ndarray, dtype) -> np.ndarray:
    """``arr`` as ``dtype`` where every value fits (cut numbers, P turns), else as it is."""
    info = np.iinfo(dtype)
    if arr.size and (arr.min() < info.min or arr.max() > info.max):
        return arr
    return arr.astype(dtype)


def _pad(arr: np.ndarray, total: int, value=None) -> np.ndarray:
    """Per-line array extended to every line of the file (lines after the end keep the last state)."""
    if arr.size >= total:
        return arr[:total]
    fill = arr[-1] if (value is None and arr.size) else (value if value is not None else 0)
    return np.concatenate([arr, np.full(total - arr.size, fill, dtype=arr.dtype)])
