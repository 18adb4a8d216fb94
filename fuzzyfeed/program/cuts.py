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


def cut_moves(program: Program, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The moves of cut ``k`` that are sampled (a line that does not move is left out), their
    kinds and their chords."""
    moves = program.cut_moves(k)
    start, end = program.start, program.end
    kinds = program.kind[moves]
    chord = np.linalg.norm(end[moves] - start[moves], axis=1)
    keep = (chord > 0) | (kinds != LINE)
    return moves[keep], kinds[keep], chord[keep]


def move_lengths(program: Program, moves: np.ndarray, kinds: np.ndarray, chord: np.ndarray) -> np.ndarray:
    """Path length of every move (lines: the chord, arcs: the helix, G5.2: the NURBS)."""
    out = chord.astype(float, copy=True)
    for i in np.flatnonzero(kinds != LINE):
        m = int(moves[i])
        out[i] = arc_geometry(program, m)["length"] if kinds[i] == ARC else program.nurbs[m].length
    return out


def move_sample_counts(program: Program, moves: np.ndarray, kinds: np.ndarray, chord: np.ndarray,
                       step_mm: float) -> np.ndarray:
    """Samples every move adds (its end included, its start not): what :func:`sample_cut` takes."""
    counts = segment_pieces(chord, step_mm).astype(np.int64)
    for i in np.flatnonzero(kinds != LINE):
        m = int(moves[i])
        if kinds[i] == ARC:
            g = arc_geometry(program, m)
            counts[i] = max(2, int(np.ceil(g["length"] / step_mm)), int(np.ceil(abs(g["sweep"]) / ARC_STEP_RAD)))
        else:
            curve = program.nurbs[m]
            counts[i] = max(8 * max(1, curve.span_breaks.size - 1), int(np.ceil(curve.length / step_mm)))
    return counts


@dataclass(frozen=True, eq=False)
class RunGeometry:
    """The curvature of the cut's runs of G1 moves, per vertex (the cut start and every move end)
    and per move: what the vertices describe within their own rounding (see
    :func:`_line_runs_curvature`). NaN where a value does not apply (not in a run of lines)."""

    vertex_kappa: np.ndarray     # (n+1,) κ a vertex takes (NaN: keeps its three-point estimate)
    vertex_corner: np.ndarray    # (n+1,) bool: a true corner of a run
    inner_kappa: np.ndarray      # (n,) κ of the samples inside a line move of a run (NaN: none)


def vertex_points(program: Program, moves: np.ndarray, kinds: np.ndarray) -> np.ndarray:
    """The cut start and every move end, as the samples put them (an arc's end on its circle)."""
    pts = np.vstack([program.start[moves[0]][None, :], program.end[moves]])
    for i in np.flatnonzero(kinds == ARC):
        pts[i + 1] = arc_points(program, int(moves[i]), np.array([1.0]))[-1]
    return pts


def run_geometry(program: Program, moves: np.ndarray, kinds: np.ndarray) -> RunGeometry:
    """:class:`RunGeometry` of a cut's moves: every run of at least two G1 moves fitted once, on
    its vertices alone (per-move arrays: no sample of the cut is needed)."""
    from fuzzyfeed.geometry.polyline import polyline_curvature

    n = moves.size
    vk = np.full(n + 1, np.nan)
    vc = np.zeros(n + 1, bool)
    inner = np.full(n, np.nan)
    is_line = kinds == LINE
    if is_line.sum() < 2:
        return RunGeometry(vk, vc, inner)
    pts = vertex_points(program, moves, kinds)
    # runs of consecutive line moves j..k (k > j): moves[j] starts at vertex j, ends at vertex j + 1
    edge = np.diff(np.concatenate([[0], is_line.astype(np.int8), [0]]))
    for j, k1 in zip(np.flatnonzero(edge == 1), np.flatnonzero(edge == -1)):
        k = k1 - 1
        if k <= j:
            continue
        fit = polyline_curvature(pts[j:k + 2])
        est = fit.curvature
        own = np.where(fit.corner, np.inf, est)
        first = 0 if j == 0 else 1              # an arc/NURBS end keeps the junction estimate
        last = est.size if k == n - 1 else est.size - 1
        vk[j + first:j + last] = est[first:last]
        vc[j + 1:k + 1] |= fit.corner[1:-1]
        mn = np.minimum(own[:-1], own[1:])
        inner[j:k + 1] = np.where(np.isfinite(mn), mn, 0.0)    # between two corners: 0
    return RunGeometry(vk, vc, inner)


@dataclass(frozen=True, eq=False)
class MoveSamples:
    """Samples of consecutive moves ``lo..hi-1`` of a cut (see :func:`sample_moves`)."""

    xyz: np.ndarray
    curvature: np.ndarray
    corner: np.ndarray
    turn_angle: np.ndarray
    seg_move: np.ndarray     # program move index per segment
    seg_f0: np.ndarray
    seg_f1: np.ndarray
    vertex_sample: np.ndarray   # (hi-lo+1,) the sample at vertex lo .. hi (move starts/ends)


def sample_cut(program: Program, k: int, step_mm: float = DEFAULT_STEP_MM) -> CutSamples:
    """Samples of cut ``k`` (see the module docstring)."""
    moves, kinds, chord = cut_moves(program, k)
    budget = f"{program.path}: cut {k + 1}: samples every {step_mm:g} mm (--step-mm)"
    point_budget(float(move_sample_counts(program, moves, kinds, chord, step_mm).sum()) + 1, budget)
    ms = sample_moves(program, moves, kinds, chord, step_mm, 0, moves.size,
                      run_geometry(program, moves, kinds))
    pts = ms.xyz
    s = path_length(pts, 0, 0.0)
    total = s[-1] if s[-1] > 0 else 1.0
    samples = PathSamples(u=s / total, xyz=pts, s=s, tangent=sample_tangents(pts), curvature=ms.curvature,
                          d1=np.full_like(pts, np.nan), d2=np.full_like(pts, np.nan), dim=3, curve=None)
    sample_move = np.concatenate([[ms.seg_move[0]], ms.seg_move])
    return CutSamples(cut=k, samples=samples, seg_move=ms.seg_move, seg_f0=ms.seg_f0, seg_f1=ms.seg_f1,
                      sample_move=sample_move, turn_angle=ms.turn_angle, corner=ms.corner,
                      entry_direction=_entry_direction(program, int(moves[0])))


def path_length(pts: np.ndarray, anchor: int, s_anchor: float) -> np.ndarray:
    """Arc length at every sample, ``s_anchor`` at sample ``anchor``: summed forward one segment
    at a time from the anchor (so the same samples give the same s, bit for bit, wherever the
    summing starts on them), backward before it."""
    ds = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    s = np.empty(pts.shape[0])
    s[anchor:] = np.cumsum(np.concatenate([[s_anchor], ds[anchor:]]))
    if anchor:
        s[:anchor] = s_anchor - np.cumsum(ds[:anchor][::-1])[::-1]
    return s


def sample_tangents(pts: np.ndarray) -> np.ndarray:
    """Unit direction of the segment leaving each sample (the last sample: of the one arriving)."""
    ds = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    tangent = np.zeros_like(pts)
    d = np.diff(pts, axis=0)
    nz = ds > 0
    d[nz] /= ds[nz, None]
    tangent[:-1] = d
    tangent[-1] = d[-1]
    return tangent


def sample_moves(program: Program, moves: np.ndarray, kinds: np.ndarray, chord: np.ndarray, step_mm: float,
                 lo: int, hi: int, geo: RunGeometry) -> MoveSamples:
    """Samples of the cut's moves ``lo..hi-1`` (``moves``, ``kinds``, ``chord``: the whole cut's,
    :func:`cut_moves`), from the start of move ``lo``; ``geo`` the cut's :func:`run_geometry`.
    Every sample at least two moves away from ``lo`` and ``hi`` (one for the cut's own ends) is the
    sample :func:`sample_cut` makes there, bit for bit."""
    start, end = program.start, program.end
    g_moves = moves
    moves, kinds, chord = moves[lo:hi], kinds[lo:hi], chord[lo:hi]
    if np.all(kinds == LINE):
        counts = segment_pieces(chord, step_mm)
        total = int(counts.sum())
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
                lo_u, hi_u = curve.domain
                f = np.arange(1, n + 1) / n
                u = lo_u + (hi_u - lo_u) * f
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
    ends_at = np.concatenate([[0], np.flatnonzero(np.isnan(exact)) + 1])   # cut start + move ends
    corner = np.zeros(pts.shape[0], bool)
    # runs of G1 moves: their vertices' and inner samples' curvature from the run's fit
    vk = geo.vertex_kappa[lo:hi + 1]
    set_v = ~np.isnan(vk)
    kappa[ends_at[set_v]] = vk[set_v]
    corner[ends_at] |= geo.vertex_corner[lo:hi + 1]
    inner_idx = np.flatnonzero(~np.isnan(exact)) + 1      # samples strictly inside a move
    if inner_idx.size:
        local = np.searchsorted(g_moves[lo:hi], seg_move[inner_idx - 1])
        ik = geo.inner_kappa[lo:hi][local]
        has = ~np.isnan(ik)
        kappa[inner_idx[has]] = ik[has]
    kappa = np.where(np.isnan(kappa), 0.0, kappa)
    turn = _junction_angles(program, moves, ends_at, pts.shape[0])
    # a junction where an arc or a G5.2 block meets another move at an angle is a corner too
    if moves.size > 1:
        beside = (kinds[:-1] != LINE) | (kinds[1:] != LINE)
        inner = ends_at[1:-1]
        corner[inner[beside & (turn[inner] > CORNER_MIN_RAD)]] = True
    return MoveSamples(xyz=pts, curvature=kappa, corner=corner, turn_angle=turn, seg_move=seg_move,
                       seg_f0=f0, seg_f1=f1, vertex_sample=ends_at)


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


def _ffill_nan(values: np.ndarray) -> np.ndarray:
    ok = ~np.isnan(values)
    if ok.all():
        return values
    idx = np.where(ok, np.arange(values.size), 0)
    np.maximum.accumulate(idx, out=idx)
    return values[idx]
