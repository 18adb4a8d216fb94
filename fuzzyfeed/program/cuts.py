"""Sample a cut of a program on its exact geometry, for the advisor.

A cut's moves are sampled at most ``step_mm`` apart (arcs also every :data:`ARC_STEP_RAD`):
lines at evenly spaced points on the line, arcs on the exact circle (helical too), G5.2 blocks
uniformly in their parameter. The curvature of every sample is exact where the path is smooth —
0 inside a line, r / (r² + c²) inside an arc of radius r and rise c per radian (1/r when planar),
the NURBS's own κ inside a G5.2 block — and the three-point estimate of seed 002 (eq. 4–9,
:func:`fuzzyfeed.geometry.sampling.three_point_curvature`) at the points where moves meet, taken over the
sequence of move ends and arc/NURBS points (so a corner between two lines is seen at its own
scale, not at the sampling step). Each segment between consecutive samples belongs to one move,
between two fractions of it (``seg_move``, ``seg_f0``, ``seg_f1``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.program.model import (ARC, HOME, LINE, RAPID, Program, arc_geometry, arc_points,
                                     move_end_tangents)
from fuzzyfeed.geometry.sampling import (POINT_STEP_MM, PathSamples, point_budget, segment_pieces,
                                         three_point_curvature)

#: Default largest distance between samples along a cut (mm).
DEFAULT_STEP_MM = POINT_STEP_MM
#: Largest angle between samples on an arc (rad): 10°.
ARC_STEP_RAD = np.pi / 18
#: A junction of an arc or a G5.2 block with another move that turns more than this is a corner.
CORNER_MIN_RAD = np.radians(1.0)


@dataclass(frozen=True, eq=False)
class CutSamples:
    """The samples of one cut and, per segment between samples, the move it lies on."""

    cut: int
    samples: PathSamples
    seg_move: np.ndarray     # (N-1,) move index
    seg_f0: np.ndarray       # (N-1,) fraction of the move where the segment starts
    seg_f1: np.ndarray       # (N-1,) ... and ends
    sample_move: np.ndarray  # (N,) the move each sample lies on (a move end: the arriving move)
    turn_angle: np.ndarray   # (N,) rad: the angle the path turns at a junction of two moves (0 elsewhere)
    corner: np.ndarray       # (N,) bool: a true corner (not a chord of a curve, not tangent)
    entry_direction: tuple = (float("nan"),) * 3   # unit direction of the rapid that leads into the cut (NaN: none)


def sample_cut(program: Program, k: int, step_mm: float = DEFAULT_STEP_MM) -> CutSamples:
    """Samples of cut ``k`` (see the module docstring)."""
    moves = program.cut_moves(k)
    start, end = program.start, program.end
    kinds = program.kind[moves]
    chord = np.linalg.norm(end[moves] - start[moves], axis=1)
    keep = (chord > 0) | (kinds != LINE)
    moves, kinds, chord = moves[keep], kinds[keep], chord[keep]
    budget = f"{program.path}: cut {k + 1}: samples every {step_mm:g} mm (--step-mm)"
    if np.all(kinds == LINE):
        counts = segment_pieces(chord, step_mm)
        total = point_budget(float(counts.sum()) + 1, budget) - 1
        seg_move = np.repeat(moves, counts)
        first = np.repeat(np.cumsum(counts) - counts, counts)
        idx = np.arange(total) - first + 1
        cnt = np.repeat(counts, counts)
        f1 = idx / cnt
        f0 = (idx - 1) / cnt
        s0 = start[seg_move]
        pts = s0 + (end[seg_move] - s0) * f1[:, None]
        pts[idx == cnt] = end[seg_move[idx == cnt]]
        pts = np.vstack([start[moves[0]][None, :], pts])
        exact = np.where(idx == cnt, np.nan, 0.0)      # κ inside a line is 0
        key = np.concatenate([[True], idx == cnt])
    else:
        parts, f0s, f1s, segm, exacts, keys = [start[moves[0]][None, :]], [], [], [], [], [True]
        lengths = np.array([arc_geometry(program, m)["length"] if kd == ARC else
                            (program.nurbs[int(m)].length if kd != LINE else c)
                            for m, kd, c in zip(moves, kinds, chord)])
        point_budget(float(segment_pieces(lengths, step_mm).sum()) + 1, budget)
        for m, kind, c in zip(moves, kinds, chord):
            if kind == LINE:
                n = int(segment_pieces(np.array([c]), step_mm)[0])
                f = np.arange(1, n + 1) / n
                p = start[m] + (end[m] - start[m]) * f[:, None]
                p[-1] = end[m]
                ex = np.zeros(n)
                key = np.zeros(n, bool)
            elif kind == ARC:
                g = arc_geometry(program, m)
                n = max(2, int(np.ceil(g["length"] / step_mm)), int(np.ceil(abs(g["sweep"]) / ARC_STEP_RAD)))
                f = np.arange(1, n + 1) / n
                p = arc_points(program, m, f)
                ex = np.full(n, g["curvature"])
                key = np.ones(n, bool)
            else:  # NURBS
                curve = program.nurbs[int(m)]
                spans = max(1, curve.span_breaks.size - 1)
                n = max(8 * spans, int(np.ceil(curve.length / step_mm)))
                lo, hi = curve.domain
                f = np.arange(1, n + 1) / n
                u = lo + (hi - lo) * f
                c3 = curve(u)
                p = np.column_stack([c3[:, 0], c3[:, 1], np.full(n, start[m, 2])])
                p[-1] = end[m]
                ex = np.asarray(curve.curvature(u), dtype=float)
                key = np.ones(n, bool)
            ex = ex.copy()
            ex[-1] = np.nan          # a move end: estimated where the moves meet
            key[-1] = True
            parts.append(p)
            f0s.append(np.concatenate([[0.0], f[:-1]]))
            f1s.append(f)
            segm.append(np.full(f.size, m))
            exacts.append(ex)
            keys.append(key)
        pts = np.vstack(parts)
        f0, f1 = np.concatenate(f0s), np.concatenate(f1s)
        seg_move = np.concatenate(segm)
        exact = np.concatenate(exacts)
        key = np.concatenate([np.asarray(kk, bool) for kk in keys[1:]])
        key = np.concatenate([[True], key])
    # curvature: exact inside moves, three-point estimate over the key points at move ends
    kappa = np.concatenate([[np.nan], exact])
    key_idx = np.flatnonzero(key)
    if key_idx.size >= 3:
        kp = pts[key_idx]
        distinct = np.concatenate([[True], np.any(kp[1:] != kp[:-1], axis=1)])
        kk = three_point_curvature(kp[distinct])
        est = np.empty(key_idx.size)
        est[distinct] = kk
        est[~distinct] = np.nan
        est = _ffill_nan(est)
        at = np.isnan(kappa[key_idx])
        kappa[key_idx[at]] = est[at]
    corner = np.zeros(pts.shape[0], bool)
    _line_runs_curvature(kappa, pts, moves, kinds, seg_move, exact, corner)
    kappa = np.where(np.isnan(kappa), 0.0, kappa)
    ends_at = np.concatenate([[0], np.flatnonzero(np.isnan(exact)) + 1])   # cut start + move ends
    turn = _junction_angles(program, moves, ends_at, pts.shape[0])
    # a junction where an arc or a G5.2 block meets another move at an angle is a corner too
    if moves.size > 1:
        beside = (kinds[:-1] != LINE) | (kinds[1:] != LINE)
        inner = ends_at[1:-1]
        corner[inner[beside & (turn[inner] > CORNER_MIN_RAD)]] = True
    ds = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(ds)])
    total = s[-1] if s[-1] > 0 else 1.0
    tangent = np.zeros_like(pts)
    d = np.diff(pts, axis=0)
    nz = ds > 0
    d[nz] /= ds[nz, None]
    tangent[:-1] = d
    tangent[-1] = d[-1]
    nan = np.full_like(pts, np.nan)
    samples = PathSamples(u=s / total, xyz=pts, s=s, tangent=tangent, curvature=kappa,
                          d1=nan, d2=nan, dim=3, curve=None)
    sample_move = np.concatenate([[seg_move[0]], seg_move])
    return CutSamples(cut=k, samples=samples, seg_move=seg_move, seg_f0=f0, seg_f1=f1,
                      sample_move=sample_move, turn_angle=turn, corner=corner,
                      entry_direction=_entry_direction(program, int(moves[0])))


def _entry_direction(program: Program, first: int) -> tuple:
    """The unit direction of the rapid that ends where move ``first`` starts (moves that do not
    move, a repeated G0 Z or a G1 to where the tool is, are transparent), or NaNs when no rapid
    leads into it."""
    none = (float("nan"),) * 3
    prev = first - 1
    while prev >= 0 and int(program.kind[prev]) in (RAPID, HOME, LINE) and \
            np.array_equal(program.end[prev], program.start[prev]):
        prev -= 1
    if prev < 0 or int(program.kind[prev]) not in (RAPID, HOME):
        return none
    if not np.array_equal(program.end[prev], program.start[first]):
        return none
    d = program.end[prev] - program.start[prev]
    return tuple(float(x) for x in d / np.linalg.norm(d))


def _junction_angles(program: Program, moves: np.ndarray, move_end_samples: np.ndarray, n: int) -> np.ndarray:
    """Per sample: the angle (rad) between the arriving move's end tangent and the leaving move's
    start tangent at every junction of two moves (exact tangents), 0 elsewhere."""
    turn = np.zeros(n)
    if moves.size < 2:
        return turn
    # a line's tangent is its direction (vectorised); arcs and splines need their exact end tangents
    d = program.end[moves] - program.start[moves]
    norm = np.linalg.norm(d, axis=1)
    first = np.divide(d, norm[:, None], out=np.zeros_like(d), where=norm[:, None] > 0)
    last = first.copy()
    for i in np.flatnonzero(program.kind[moves] != LINE):
        first[i], last[i] = move_end_tangents(program, int(moves[i]))
    t_end, t_start = last[:-1], first[1:]
    cos = np.clip(np.einsum("ij,ij->i", t_end, t_start), -1.0, 1.0)
    turn[move_end_samples[1:-1]] = np.arccos(cos)
    return turn


def _line_runs_curvature(kappa: np.ndarray, pts: np.ndarray, moves: np.ndarray, kinds: np.ndarray,
                         seg_move: np.ndarray, exact: np.ndarray, corner: np.ndarray) -> None:
    """Curvature along runs of consecutive G1 moves, in place: the path the vertices describe within
    their own rounding (:func:`fuzzyfeed.geometry.polyline.polyline_curvature`: straight runs κ = 0, a circle
    written as rounded G1 chords its one κ = 1/R, a corner the LinuxCNC G64 P blend), not the
    three-point estimate of rounded coordinates. The run's vertices get that κ (the ends too, unless
    an arc or a G5.2 block meets them there); a sample inside a line move gets the smaller κ of the
    move's two ends that are not corners (0 between two corners) — a chord of a circle run has the
    circle's κ, a side of a polygon has 0."""
    from fuzzyfeed.geometry.polyline import polyline_curvature

    is_line = kinds == LINE
    if is_line.sum() < 2:
        return
    vertex_sample = np.flatnonzero(np.concatenate([[True], np.isnan(exact)]))  # cut start + move ends
    # moves[j] ends at sample vertex_sample[j + 1] and starts at vertex_sample[j]
    j = 0
    while j < moves.size:
        if not is_line[j]:
            j += 1
            continue
        k = j
        while k + 1 < moves.size and is_line[k + 1]:
            k += 1
        if k > j:                                   # moves j..k: at least two lines in a row
            at = vertex_sample[j:k + 2]
            fit = polyline_curvature(pts[at])
            est = fit.curvature
            # inside a move: a corner end is the blend, not the move's own curvature
            own = np.where(fit.corner, np.inf, est)
            first = 0 if j == 0 else 1              # an arc/NURBS end keeps the junction estimate
            last = est.size if k == moves.size - 1 else est.size - 1
            kappa[at[first:last]] = est[first:last]
            corner[at[1:-1]] |= fit.corner[1:-1]
            inside = np.isin(seg_move, moves[j:k + 1])
            idx = np.flatnonzero(inside)[:-1] + 1   # samples strictly inside a move (not its end)
            idx = idx[~np.isnan(exact[idx - 1])]
            if idx.size:
                move_of = np.searchsorted(moves[j:k + 1], seg_move[idx - 1])
                inner = np.minimum(own[move_of], own[move_of + 1])
                kappa[idx] = np.where(np.isfinite(inner), inner, 0.0)    # between two corners: 0
        j = k + 1


def _ffill_nan(values: np.ndarray) -> np.ndarray:
    ok = ~np.isnan(values)
    if ok.all():
        return values
    idx = np.where(ok, np.arange(values.size), 0)
    np.maximum.accumulate(idx, out=idx)
    return values[idx]
