"""Contours of a drawing: DXF entities as exact pieces, chained end to end.

Every curve entity becomes one or more **pieces**: a NURBS (LINE degree 1; ARC, CIRCLE, ELLIPSE
and polyline bulge segments exact rational quadratic NURBS from ezdxf's
``rational_bspline_from_ellipse``; SPLINE as stored) or a run of straight segments (polylines).
Pieces are chained into contours by matching end points within :data:`CHAIN_TOLERANCE_MM`
(nearest free end first, a piece is reversed where needed), per layer.

A contour of one NURBS piece stays that NURBS. A contour of several pieces is a polyline whose
points lie exactly on the pieces (chord turning ≤ :data:`FLATTEN_ANGLE_RAD`, so its length is
within 2·10⁻⁷ of the exact one; straight segments cut into steps ≤ :data:`STRAIGHT_STEP_MM`),
sampled at its own vertices with the curvature of
:mod:`fuzzyfeed.geometry.polyline` (arcs fitted back to their exact κ = 1/R, corners blended as the
controller blends them).

ezdxf is imported inside the functions.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


#: End points closer than this (mm) are one joint of a contour.
CHAIN_TOLERANCE_MM = 1e-3
#: The comparison's reach: the tolerance plus float noise, so a gap of exactly the tolerance (the
#: butterfly's ends, 0.001 mm apart) joins whatever the last bits of the evaluation.
_JOIN_MM = CHAIN_TOLERANCE_MM * (1 + 1e-9)
#: An open contour whose end is this close (mm) to another free end is a contour that does not
#: close: an error naming the gap (a drawing error, not a path).
GAP_REPORT_MM = 0.1
#: Largest turning of one chord when a curved piece of a chain is flattened (rad).
FLATTEN_ANGLE_RAD = 2e-3
#: Straight segments of a chain are cut into steps of at most this length (mm), so the planners,
#: which sample a point sequence at its points, see the straight stretch between two corners.
STRAIGHT_STEP_MM = 1.0


@dataclass(eq=False)
class Piece:
    """One curve of a drawing, in mm (3-D): a NURBS or an (N, 3) run of straight segments."""

    where: str                  # "LINE 2F (layer CUT)" or "INSERT 3A > ARC #2 (layer 0)"
    layer: str
    handle: str
    curve: object = None        # fuzzyfeed.geometry.nurbs.Nurbs (3-D control points) or None
    points: np.ndarray | None = None
    reversed: bool = False
    how: str = ""               # how the curve was read (for notes)
    ends: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        if self.curve is not None:
            lo, hi = self.curve.domain
            c = self.curve(np.array([lo, hi]))
            self.ends = np.array([c[0], c[-1]])
        else:
            self.ends = np.array([self.points[0], self.points[-1]])

    @property
    def closed(self) -> bool:
        return bool(np.linalg.norm(self.ends[0] - self.ends[1]) <= _JOIN_MM)

    def flatten(self) -> np.ndarray:
        """Points on the piece from start to end (in its chain direction)."""
        if self.curve is None:
            pts = densify(self.points)
        elif self.curve.degree == 1:
            pts = densify(self.curve.control_points)
        else:
            pts = _flatten_nurbs(self.curve)
        return pts[::-1] if self.reversed else pts


def densify(points: np.ndarray, step_mm: float = STRAIGHT_STEP_MM) -> np.ndarray:
    """The points with every segment longer than ``step_mm`` cut into equal steps (the given
    points are kept exactly)."""
    pts = np.asarray(points, dtype=float)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    counts = np.maximum(1, np.ceil(seg / step_mm).astype(int))
    if np.all(counts == 1):
        return pts
    out = [pts[:1]]
    for a, b, n in zip(pts[:-1], pts[1:], counts):
        t = np.arange(1, n + 1)[:, None] / n
        step = a + (b - a) * t
        step[-1] = b
        out.append(step)
    return np.vstack(out)


def _flatten_nurbs(curve) -> np.ndarray:
    """Points on ``curve``, uniform in u per knot span, so that no chord turns by more than
    :data:`FLATTEN_ANGLE_RAD` (turning estimated from 64 points per span)."""
    lo, hi = curve.domain
    breaks = np.unique(np.concatenate([[lo], curve.knots[(curve.knots > lo) & (curve.knots < hi)], [hi]]))
    out = [curve(breaks[:1])]
    for a, b in zip(breaks[:-1], breaks[1:]):
        probe = curve(np.linspace(a, b, 65))
        d = np.diff(probe, axis=0)
        n = np.linalg.norm(d, axis=1)
        d = d[n > 0] / n[n > 0][:, None]
        turning = float(np.sum(np.arccos(np.clip(np.einsum("ij,ij->i", d[:-1], d[1:]), -1, 1)))) if len(d) > 1 else 0.0
        count = max(2, int(np.ceil(turning / FLATTEN_ANGLE_RAD)) + 1)
        out.append(curve(np.linspace(a, b, count + 1)[1:]))
    pts = np.vstack(out)
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    return pts


@dataclass(eq=False)
class Contour:
    pieces: list[Piece]
    closed: bool
    #: Why the contour cannot be followed (an end that nearly meets a free end: a gap in the
    #: drawing), or None. Only the contour a user picks must be whole.
    problem: str | None = None

    @property
    def layer(self) -> str:
        return self.pieces[0].layer

    @property
    def handles(self) -> list[str]:
        return [p.handle for p in self.pieces]

    def describe(self) -> str:
        first = self.pieces[0].where
        more = f" + {len(self.pieces) - 1} more" if len(self.pieces) > 1 else ""
        return f"{'closed' if self.closed else 'open'} contour of {first}{more}"

    def points(self) -> np.ndarray:
        """The chained points (joints within the chain tolerance are merged; exact repeats dropped)."""
        parts = [self.pieces[0].flatten()]
        for piece in self.pieces[1:]:
            pts = piece.flatten()
            parts.append(pts[1:])       # its start is the previous end (within the tolerance)
        pts = np.vstack(parts)
        if self.closed:
            pts[-1] = pts[0]
        keep = np.concatenate([[True], np.any(pts[1:] != pts[:-1], axis=1)])
        return pts[keep]


def _start(p: Piece) -> np.ndarray:
    return p.ends[1 if p.reversed else 0]


def _end(p: Piece) -> np.ndarray:
    return p.ends[0 if p.reversed else 1]


def chain(pieces: list[Piece], where: str) -> list[Contour]:
    """Pieces chained into contours per layer, in file order of their first piece: from each
    unused piece, grow at its end, then at its start, by the nearest unused piece that has an end
    within :data:`CHAIN_TOLERANCE_MM` of the tip, until the contour closes or nothing fits."""
    from scipy.spatial import cKDTree

    contours: list[Contour] = []
    order = {id(p): k for k, p in enumerate(pieces)}
    layers: dict[str, list[Piece]] = {}
    for p in pieces:
        layers.setdefault(p.layer.lower(), []).append(p)
    for group in layers.values():
        tree = cKDTree(np.vstack([p.ends for p in group]))   # row 2k: start of k, 2k+1: end of k
        used = np.zeros(len(group), dtype=bool)

        def take(tip: np.ndarray) -> tuple[Piece, bool] | None:
            hits = [i for i in tree.query_ball_point(tip, _JOIN_MM) if not used[i // 2]]
            if not hits:
                return None
            best = min(hits, key=lambda i: (np.linalg.norm(tree.data[i] - tip), i))
            used[best // 2] = True
            return group[best // 2], best % 2 == 1

        for k0, first in enumerate(group):
            if used[k0]:
                continue
            used[k0] = True
            first.reversed = False
            items = [first]
            closed = first.closed
            while not closed:                       # grow at the end
                hit = take(_end(items[-1]))
                if hit is None:
                    break
                piece, at_its_end = hit
                piece.reversed = at_its_end         # it must start at the tip
                items.append(piece)
                closed = bool(np.linalg.norm(_end(piece) - _start(items[0])) <= _JOIN_MM)
            while not closed:                       # grow at the start
                hit = take(_start(items[0]))
                if hit is None:
                    break
                piece, at_its_end = hit
                piece.reversed = not at_its_end     # it must end at the tip
                items.insert(0, piece)
                closed = bool(np.linalg.norm(_end(items[-1]) - _start(piece)) <= _JOIN_MM)
            contours.append(Contour(items, closed))
    contours.sort(key=lambda c: min(order[id(p)] for p in c.pieces))
    _check_gaps(contours, where)
    return contours


def _fmt_point(p: np.ndarray) -> str:
    xyz = p if abs(p[2]) > 0 else p[:2]
    return "(" + ", ".join(f"{v:.6g}" for v in xyz) + ")"


def _check_gaps(contours: list[Contour], where: str) -> None:
    """An open contour whose end nearly meets a free end (beyond the chain tolerance, within
    :data:`GAP_REPORT_MM`) gets a :attr:`Contour.problem` naming the gap: a drawing error, not a
    path (both contours of a gap get it)."""
    from scipy.spatial import cKDTree

    free = []
    for n, c in enumerate(contours):
        if not c.closed:
            free += [(_start(c.pieces[0]), n, c.pieces[0]), (_end(c.pieces[-1]), n, c.pieces[-1])]
    if len(free) < 2:
        return
    tree = cKDTree(np.vstack([f[0] for f in free]))
    for a, b in sorted(tree.query_pairs(GAP_REPORT_MM)):
        (pa, na, piece_a), (pb, nb, piece_b) = free[a], free[b]
        gap = float(np.linalg.norm(pa - pb))
        if gap <= _JOIN_MM:
            continue
        what = (f"{contours[na].describe()} does not close" if na == nb else
                f"{piece_a.where} and {piece_b.where} do not meet")
        problem = (f"{where}: {what}: gap of {gap:.6g} mm between {_fmt_point(pa)} and "
                   f"{_fmt_point(pb)} (chain tolerance {CHAIN_TOLERANCE_MM:g} mm)")
        for n in (na, nb):
            if contours[n].problem is None:
                contours[n].problem = problem
