"""The exact geometry of the G-code moves that need more than their end point: G2/G3 arcs (centre
from I/J/K or R in the plane in force, turns, LinuxCNC's radius rule), G5.2 … G5.3 NURBS
blocks (LinuxCNC's uniform clamped knot vector) and G5/G5.1 splines (Bézier curves). Used by :mod:`fuzzyfeed.program.read`; errors
go through its ``fail(line_index, message)``."""

from __future__ import annotations

import numpy as np

from fuzzyfeed.errors import NurbsError
from fuzzyfeed.program.g52 import linuxcnc_knots
from fuzzyfeed.program.model import ARC, PLANE_AXES
from fuzzyfeed.geometry.nurbs import Nurbs

#: LinuxCNC's CENTER_ARC_RADIUS_TOLERANCE (mm, inch): an arc whose end radius differs from its
#: start radius by more than this *and* by more than ARC_RELATIVE_TOLERANCE is an error.
ARC_RADIUS_TOLERANCE = {False: 0.02, True: 0.002}
ARC_RELATIVE_TOLERANCE = 0.001
#: An R arc whose radius is shorter than half the chord by more than this (program units) is an
#: error: LinuxCNC's RADIUS_TOLERANCE_MM / _INCH (0.00005 inch; rs274 takes R 1.4988 for a chord of
#: 3 mm and refuses R 1.4987 — a Fusion post's R 1.508 on a chord of 3.0169 mm is an arc).
R_TOLERANCE = {False: 0.00127, True: 0.00005}


def arc_centres(fail, kind, move_rows, motion, plane, start, endp, col, inch, scale, ij_absolute,
                words_only=None):
    """Centre (M, 3; NaN off the plane and for non-arcs), signed turns, plane code and a
    multi-turn flag of every ARC move; refuses arcs that do not fit. Moves of ``words_only``
    (arcs from a point not known) have their words checked only."""
    centre = np.full((move_rows.size, 3), np.nan)
    turns = np.zeros(move_rows.size, dtype=np.int64)
    arc_plane = np.zeros(move_rows.size, dtype=np.int64)
    multi = np.zeros(move_rows.size, bool)
    p_col, r_col = col("P"), col("R")
    ijk = [col(ch) for ch in "IJK"]
    words_only = np.zeros(kind.size, bool) if words_only is None else words_only
    for m in np.flatnonzero((kind == ARC) | words_only):
        i = int(move_rows[m])
        clockwise = motion[i] == 20
        name = "G2" if clockwise else "G3"
        pl = int(plane[i])
        a, b, nrm = PLANE_AXES[pl]
        letters_ab = "IJK"[a] + "/" + "IJK"[b]
        s, e = start[m], endp[m]
        has_c = [not np.isnan(ijk[a][i]), not np.isnan(ijk[b][i])]
        if not np.isnan(ijk[nrm][i]):
            fail(i, f"{'IJK'[nrm]}{ijk[nrm][i]:g} with {name} in the G{pl} plane: "
                    f"the centre words of this plane are {letters_ab}")
        has_r = not np.isnan(r_col[i])
        if (has_c[0] or has_c[1]) and has_r:
            fail(i, f"{name} with both R and {letters_ab}")
        if not (has_c[0] or has_c[1] or has_r):
            fail(i, f"{name} needs {letters_ab} (centre) or R (radius)")
        if words_only[m]:
            continue
        tol = ARC_RADIUS_TOLERANCE[bool(inch[i])] * scale[i]
        if has_c[0] or has_c[1]:
            ci = np.nan_to_num(np.array([ijk[a][i], ijk[b][i]])) * scale[i]
            if ij_absolute[i]:
                ci = np.array([ci[0] if has_c[0] else s[a], ci[1] if has_c[1] else s[b]])
                c2 = ci
            else:
                c2 = np.array([s[a], s[b]]) + ci
        elif has_r:
            r = r_col[i] * scale[i]
            chord = np.array([e[a] - s[a], e[b] - s[b]])
            d = float(np.hypot(*chord))
            if d == 0:
                fail(i, f"{name} R{r_col[i]:g}: a full circle needs {letters_ab}, not R")
            if abs(r) < d / 2 - R_TOLERANCE[bool(inch[i])] * scale[i]:
                fail(i, f"{name} R{r_col[i]:g}: radius {abs(r) / scale[i]:g} is shorter than half "
                        f"the chord ({d / 2 / scale[i]:g}); the arc does not fit")
            h = np.sqrt(max(r * r - d * d / 4, 0.0))
            right = np.array([chord[1], -chord[0]]) / d
            side = 1.0 if clockwise == (r > 0) else -1.0
            c2 = 0.5 * np.array([s[a] + e[a], s[b] + e[b]]) + side * h * right
        else:
            fail(i, f"{name} needs {letters_ab} (centre) or R (radius)")
        r0 = float(np.hypot(s[a] - c2[0], s[b] - c2[1]))
        r1 = float(np.hypot(e[a] - c2[0], e[b] - c2[1]))
        if r0 == 0:
            fail(i, f"{name}: the centre is the start point (radius 0)")
        err = abs(r1 - r0)
        if err > tol and err > ARC_RELATIVE_TOLERANCE * r0:
            fail(i, f"{name}: radius to the end {r1 / scale[i]:.6g} differs from radius to the "
                    f"start {r0 / scale[i]:.6g} by {err / scale[i]:.4g} (LinuxCNC allows "
                    f"{tol / scale[i]:g} or 0.1 %); the arc does not fit")
        p = p_col[i]
        t = 1 if np.isnan(p) else p
        if t < 1 or t != int(t):
            fail(i, f"{name} P{t:g}: the number of turns must be an integer >= 1")
        c3 = np.full(3, np.nan)
        c3[a], c3[b] = c2
        centre[m] = c3
        turns[m] = -int(t) if clockwise else int(t)
        arc_plane[m] = pl
        if t > 1:
            multi[m] = True
    return centre, turns, arc_plane, multi


def nurbs_blocks(fail, blocks, move_of_line, known, col, any_xyz, xyz_has, pos_before, pos_after):
    """The NURBS of every G5.2 block (move index -> curve in mm) and its (first, last) lines."""
    nurbs, nurbs_lines = {}, {}
    p_col, l_col = col("P"), col("L")
    for a, b in blocks:
        m = move_of_line[a]
        if not known[a:b + 1].all():
            fail(a, "G5.2 block after a change of offsets: its start point is unknown; "
                    "give a G0/G1 to a known point first")
        order = 3
        l_here = l_col[a:b]
        if np.any(~np.isnan(l_here)):
            lv = l_here[~np.isnan(l_here)]
            if np.any(lv != np.rint(lv)):
                fail(a, f"L{lv[0]:g}: the NURBS order must be an integer")
            order = max(3, int(lv.max()))
        pts = [pos_before[a]]
        w = [1.0]
        if not any_xyz[a] and not np.isnan(p_col[a]) and p_col[a] > 0:
            w[0] = p_col[a]
        for i in range(a, b):
            if xyz_has[2][i]:
                fail(i, "Z in a G5.2 block: G5.2 is planar (X, Y only)")
            if xyz_has[0][i] != xyz_has[1][i]:
                fail(i, "a G5.2 control point needs both X and Y")
            if xyz_has[0][i]:
                wt = 0.0 if np.isnan(p_col[i]) else p_col[i]
                if wt <= 0:
                    fail(i, f"G5.2 control point weight P = {wt:g}; every control point needs a "
                            "positive weight P")
                pts.append(pos_after[i])
                w.append(wt)
            elif i != a and not np.isnan(p_col[i]):
                fail(i, "P without X and Y is allowed only on the first G5.2 line")
        pts_arr = np.array(pts)
        if len(pts_arr) < order:
            fail(b, f"G5.2 block from line {a + 1}: {len(pts_arr)} control points (with the start "
                    f"point) but order L = {order} needs at least {order}")
        try:
            curve = Nurbs(order - 1, linuxcnc_knots(len(pts_arr), order), pts_arr, w)
        except NurbsError as exc:
            fail(b, f"G5.2 block from line {a + 1}: {exc}")
        nurbs[m] = curve
        nurbs_lines[m] = (a, b)

    return nurbs, nurbs_lines


def spline_moves(fail, kind, move_rows, motion, plane, start, endp, col, scale, known) -> dict:
    """The Bézier curve of every G5 (cubic) and G5.1 (quadratic) move from a known point, in mm,
    as LinuxCNC draws them in the XY plane: G5.1 X Y I J has its control point at start + (I, J);
    G5 X Y I J P Q at start + (I, J) and end + (P, Q), and I, J left out continue the previous G5
    smoothly (−P, −Q of it)."""
    out = {}
    ijpq = [col(ch) for ch in "IJPQ"]
    previous_pq = None
    for m in np.flatnonzero(np.isin(motion[move_rows], [50, 51])):
        i = int(move_rows[m])
        code = int(motion[i])
        if plane[i] != 17:
            fail(i, f"G{code / 10:g} in the G{int(plane[i])} plane: G5 and G5.1 work in G17 only")
        if start[m, 2] != endp[m, 2]:
            fail(i, f"Z with G{code / 10:g}: G5 and G5.1 are planar (X and Y only)")
        ii, jj, pp, qq = (v[i] * scale[i] if not np.isnan(v[i]) else np.nan for v in ijpq)
        s, e = start[m], endp[m]
        if code == 51:
            if np.isnan(ii) and np.isnan(jj):
                fail(i, "G5.1 needs I and J (the control point from the start point)")
            ctrl = [s, s + np.array([np.nan_to_num(ii), np.nan_to_num(jj), 0.0]), e]
            previous_pq = None
        else:
            if np.isnan(pp) or np.isnan(qq):
                fail(i, "G5 needs P and Q (the second control point from the end point)")
            if np.isnan(ii) and np.isnan(jj):
                if previous_pq is None or m == 0 or int(motion[move_rows[m - 1]]) != 50:
                    fail(i, "G5 without I and J must follow a G5 (it continues that spline)")
                ii, jj = -previous_pq[0], -previous_pq[1]
            elif np.isnan(ii) or np.isnan(jj):
                fail(i, "G5 needs both I and J, or neither")
            ctrl = [s, s + np.array([ii, jj, 0.0]), e + np.array([pp, qq, 0.0]), e]
            previous_pq = (pp, qq)
        if not known[i]:
            continue
        degree = len(ctrl) - 1
        try:
            out[int(m)] = Nurbs(degree, [0.0] * (degree + 1) + [1.0] * (degree + 1), np.array(ctrl))
        except NurbsError as exc:
            fail(i, f"G{code / 10:g}: {exc}")
    return out
