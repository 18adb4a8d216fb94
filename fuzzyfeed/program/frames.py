"""Positions that depend on the point before them, followed line by line as LinuxCNC's interpreter
follows them (``interp_find.cc`` find_ends, ``interp_convert.cc`` convert_axis_offsets and
convert_coordinate_system, ``interp_cycles.cc`` convert_cycle_xy). The reader
(:mod:`fuzzyfeed.program.read`) computes positions with array sums; it calls
:func:`sequential_positions` only for a program with polar words, G52/G92.x/G10 L2 or drilling
cycles.

Every coordinate is a value plus an integer combination of the offsets the machine holds when the
program starts (its parameter file): U, the G92/G52 axis offset, and S1…S9, the G54…G59.3
offsets. A coordinate whose combination is zero is known (epoch 0); one with another combination
is known up to that constant (an epoch of its own, so that moves within it keep their lengths);
anything else (the machine's start point, a probe, a homing move) is unknown from the line that
made it so (epoch −(line + 1)), as in :func:`fuzzyfeed.program.read._axis_positions`.

- Polar words: about the origin of the frame in force, in G90 ``@`` is the radius and ``^`` the
  angle (degrees; the one not given is the current point's), in G91 ``@`` adds to the radius and
  ``^`` to the angle. From a point not known, the end is not known.
- ``G92 X a``: the point becomes a, the axis offset o the point before + o − a; ``G52 X b``: o = b;
  G92.1/G92.2: o = 0; G92.3: o = the offsets G92, G52 or G92.1 saved last (parameters 5211-5213);
  the point becomes p + o_before − o_after.
- G54…G59.3: the point becomes p + o_old − o_new; ``G10 L2 P`` sets a system's offsets.
- A G17 drilling cycle ends at Z = R (G99; LinuxCNC's retract mode starts as R_PLANE) or at the
  higher of R and the initial level (G98: the Z before the first cycle of a run), R in G91 from
  that level.
"""

from __future__ import annotations

import numpy as np

from fuzzyfeed.program.modal import CYCLES

#: Epoch of every axis at the start of a program (see fuzzyfeed.program.read).
START_EPOCH = -(2 ** 62)
#: Epochs of points known up to a combination of the start offsets: SYMBOLIC_EPOCH − index.
SYMBOLIC_EPOCH = -(2 ** 61)
_N_SYMBOLS = 10                                   # U, S1 … S9
_ZERO = (0,) * _N_SYMBOLS


def _unit(i: int) -> tuple:
    return tuple(1 if j == i else 0 for j in range(_N_SYMBOLS))


def _combine(a, b, sign=1):
    if a is None or b is None:
        return None
    return tuple(x + sign * y for x, y in zip(a, b))


def sequential_positions(fail, n, sets, incs, pre, post, polar=None, absolute=None, radius=None,
                         angle=None, offsets=None, cycles=None):
    """Positions (n, 3) mm and epochs (n, 3) after every line (see the module docstring).

    ``sets``: per axis (values, is_set); ``incs``: per axis increments; ``pre``/``post``: per axis
    frame resets before/after the line's motion; ``polar`` lines and their ``radius`` (mm) and
    ``angle`` (degrees) words with ``absolute`` (G90) per line; ``offsets`` = (per line 1 G92,
    2 G52, 3 G92.1, 4 G92.2, 5 G92.3; per axis the words in mm; (system selected on the line or 0,
    system a G10 L2 sets or 0)); ``cycles`` = (cycle line, R in mm, G99, line ending a run of
    cycles)."""
    polar_l = polar.tolist() if polar is not None else [False] * n
    absolute_l = absolute.tolist() if absolute is not None else [True] * n
    r_l = radius.tolist() if radius is not None else None
    a_l = angle.tolist() if angle is not None else None
    if offsets is not None:
        off_code, off_words = offsets[0].tolist(), [w.tolist() for w in offsets[1]]
        sys_active, sys_target = offsets[2]
    else:
        off_code = sys_active = sys_target = [0] * n
    cyc, cyc_r, cyc_99, cyc_end = cycles if cycles is not None else ([False] * n, None, None, None)
    cols = [(s[0].tolist(), s[1].tolist(), inc.tolist(), p.tolist(), q.tolist())
            for s, inc, p, q in zip(sets, incs, pre, post)]

    ids: dict = {}
    pos = [0.0, 0.0, 0.0]
    coef = [None, None, None]                     # the machine's start point: unknown
    epoch = [START_EPOCH] * 3
    o92 = [(0.0, _unit(0))] * 3                   # (value, combination)
    saved = [(0.0, _unit(0))] * 3                 # at the start LinuxCNC restores the saved ones
    same = [True] * 3                             # o92 is the saved one
    g5x: dict = {}                                # (system, axis) -> (value, combination)
    system = 1
    level = None
    pos_after = np.empty((n, 3))
    epoch_after = np.empty((n, 3), dtype=np.int64)

    def g5x_of(s, k):
        return g5x.get((s, k), (0.0, _unit(s)))

    def reset(k, i):
        pos[k], coef[k], epoch[k] = 0.0, None, -(i + 1)

    def known(k, value):
        pos[k], coef[k], epoch[k] = value, _ZERO, 0

    def shift(k, i, dv, dc):
        """The point moves by dv + dc (the frame changed under it)."""
        if dc is None or (coef[k] is None and dc != _ZERO):
            reset(k, i)
            return
        pos[k] += dv
        if dc == _ZERO:
            return
        coef[k] = _combine(coef[k], dc)
        epoch[k] = 0 if coef[k] == _ZERO else ids.setdefault(coef[k], SYMBOLIC_EPOCH - len(ids))

    for i in range(n):
        new_system, target = sys_active[i], sys_target[i]
        if new_system and new_system != system:            # G54…: p + o_old − o_new
            for k in range(3):
                (ov, oc), (nv, nc) = g5x_of(system, k), g5x_of(new_system, k)
                shift(k, i, ov - nv, _combine(oc, nc, -1))
            system = new_system
        for k in range(3 if target else 0):                 # G10 L2 P: a system's offsets
            word = off_words[k][i]
            if word != word:
                continue
            if target == system:
                ov, oc = g5x_of(system, k)
                shift(k, i, ov - word, oc)
            g5x[(target, k)] = (word, _ZERO)
        code = off_code[i]
        for k in range(3 if code else 0):
            word = off_words[k][i]
            if code == 1:                                   # G92: the point becomes the word
                if word == word:
                    ov, oc = o92[k]
                    o92[k] = (pos[k] + ov - word, _combine(coef[k], oc))
                    known(k, word)
                saved[k], same[k] = o92[k], True
                continue
            new = (0.0, _ZERO) if code in (3, 4) else (word, _ZERO) if code == 2 else saved[k]
            if new[0] != new[0]:                            # G52 without this axis: only saved
                saved[k], same[k] = o92[k], True
                continue
            if not (code == 5 and same[k]):                 # G92.3 of the offset in force: no change
                shift(k, i, o92[k][0] - new[0], _combine(o92[k][1], new[1], -1))
            o92[k] = new
            if code == 3:
                saved[k] = (0.0, _ZERO)
            if code == 2:                                   # G52 saves the offsets as G92 does
                saved[k] = o92[k]
            same[k] = code in (2, 3, 5) or (o92[k][1] == saved[k][1] and o92[k][0] == saved[k][0])
        if cyc[i] and level is None:
            level = (pos[2], coef[2], epoch[2])
        elif cycles is not None and cyc_end[i]:
            level = None
        for k in range(3):
            setv, is_set, inc, p, _ = (c[i] for c in cols[k])
            if p:
                reset(k, i)
            if is_set:
                known(k, setv)
            else:
                pos[k] += inc
        if polar_l[i]:
            r_word, a_word = r_l[i], a_l[i]
            has_r, has_a = r_word == r_word, a_word == a_word
            placed = coef[0] == _ZERO and coef[1] == _ZERO
            x, y = pos[0], pos[1]
            if placed and x == 0 and y == 0 and not (absolute_l[i] and has_r and has_a):
                fail(i, "polar word (@ or ^) at the origin: the angle or radius it keeps is "
                        "indeterminate (LinuxCNC refuses it)")
            if absolute_l[i]:
                r = r_word if has_r else float(np.hypot(x, y))
                t = np.radians(a_word) if has_a else float(np.arctan2(y, x))
                placed = placed or (has_r and has_a)
            else:
                r = float(np.hypot(x, y)) + (r_word if has_r else 0.0)
                t = float(np.arctan2(y, x)) + (np.radians(a_word) if has_a else 0.0)
            for k, v in ((0, r * np.cos(t)), (1, r * np.sin(t))):
                if placed:
                    known(k, float(v))
                else:
                    reset(k, i)
                    pos[k] = float(v)
        if cyc[i]:
            r = cyc_r[i]
            if r != r:
                reset(2, i)
            elif absolute_l[i]:
                if cyc_99[i]:
                    known(2, r)
                elif level[1] == _ZERO:
                    known(2, max(level[0], r))
                else:
                    reset(2, i)
            else:
                pos[2], coef[2], epoch[2] = level[0] + (r if cyc_99[i] else max(r, 0.0)), level[1], level[2]
        for k in range(3):
            if cols[k][4][i]:
                reset(k, i)
        pos_after[i], epoch_after[i] = pos, epoch
    return pos_after, epoch_after


_SYSTEMS = (540, 550, 560, 570, 580, 590, 591, 592, 593)


def system_events(frame_lines, coord, g10_l2, p_col):
    """Per line for :func:`sequential_positions`: (the coordinate system in force, 1-9, or 0 where
    the line changes nothing, the system a G10 L2 sets (0 none))."""
    system = np.searchsorted(np.array(_SYSTEMS), coord) + 1
    active = np.where(frame_lines, system, 0)
    p = np.nan_to_num(p_col).astype(np.int64)
    target = np.where(g10_l2, np.where(p == 0, system, p), 0)
    return active.tolist(), target.tolist()


def cycle_info(cycle_line, motion, r_mm, retract):
    """Per line for :func:`sequential_positions`: a G17 drilling cycle runs on it, the cycle's R
    (mm; LinuxCNC keeps the last R), G99 in force (LinuxCNC's retract mode starts as R_PLANE,
    zero-initialised: G99 until the program says G98), and a line that ends a run of cycles (a motion
    mode that is not a cycle: the next cycle takes its initial level anew)."""
    has_r = cycle_line & ~np.isnan(r_mm)
    idx = np.where(has_r, np.arange(has_r.size), -1)
    np.maximum.accumulate(idx, out=idx)
    r = np.where(idx >= 0, r_mm[np.maximum(idx, 0)], np.nan)
    ends_run = ~np.isin(motion, list(CYCLES))
    return cycle_line.tolist(), r.tolist(), (retract == 990).tolist(), ends_run.tolist()
