"""The cuts of a G-code program as shapes (for plot, compare, schedule and ``advise FILE#N``).

A cut (:mod:`fuzzyfeed.program.model`) becomes a polyline :class:`~fuzzyfeed.io.shape.Shape`: its
line end points, its arcs (any plane, helical) flattened into points on the exact arc within
:data:`ARC_TOLERANCE_MM`, and its G5.2 blocks sampled at :data:`NURBS_IMPORT_POINTS_PER_SPAN`
points per knot span. A cut that is one G5.2 block becomes that NURBS exactly (degree L−1,
LinuxCNC's knot vector on [0, 1]). Zero-length moves are skipped.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

import numpy as np

from fuzzyfeed.errors import PathFormatError
from fuzzyfeed.program.read import read_program
from fuzzyfeed.io.points import pick_by_index, polyline_shape
from fuzzyfeed.program.model import ARC, NURBS, Program, arc_geometry, arc_points
from fuzzyfeed.io.shape import Shape
from fuzzyfeed.geometry.nurbs import Nurbs

#: Largest distance between a G2/G3 arc and the chords it is read as (mm).
ARC_TOLERANCE_MM = 1e-4
#: Points per knot span when a G5.2 block is sampled into a polyline.
NURBS_IMPORT_POINTS_PER_SPAN = 32


def cut_points(program: Program, k: int, arc_tolerance_mm: float = ARC_TOLERANCE_MM) -> np.ndarray:
    """The (N, 3) points of cut ``k``: move ends, arcs within ``arc_tolerance_mm`` of the exact
    arc, G5.2 blocks sampled per knot span; consecutive repeats dropped."""
    return _cut_points(program, k, arc_tolerance_mm)[0]


def _cut_points(program: Program, k: int, arc_tolerance_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`cut_points` and, per point, the move that ends there (the first point: the first
    move)."""
    moves = program.cut_moves(k)
    parts = [program.start[moves[0]][None, :]]
    owner = [moves[:1]]
    kinds = program.kind[moves]
    if not np.isin(kinds, [ARC, NURBS]).any():
        parts.append(program.end[moves])
        owner.append(moves)
    else:
        for m in moves:
            if program.kind[m] == ARC:
                g = arc_geometry(program, m)
                r = max(g["r0"], g["r1"])
                step = 2.0 * np.arccos(1.0 - arc_tolerance_mm / r) if arc_tolerance_mm < r else np.pi / 2
                count = max(2, int(np.ceil(abs(g["sweep"]) / step)))
                parts.append(arc_points(program, m, np.arange(1, count + 1) / count))
            elif program.kind[m] == NURBS:
                curve = program.nurbs[m]
                spans = max(1, curve.span_breaks.size - 1)
                u = np.linspace(*curve.domain, spans * NURBS_IMPORT_POINTS_PER_SPAN + 1)[1:]
                c = curve(u)
                block = np.column_stack([c[:, :2], np.full(u.size, program.start[m, 2])])
                block[-1] = program.end[m]
                parts.append(block)
            else:
                parts.append(program.end[m][None, :])
            owner.append(np.full(len(parts[-1]), m))
    pts = np.concatenate(parts)
    move = np.concatenate(owner)
    keep = np.concatenate([[True], np.any(pts[1:] != pts[:-1], axis=1)])
    return pts[keep], move[keep]


def programmed_feed(program: Program, moves: np.ndarray, length_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The F in force along a cut (see :attr:`Shape.programmed_feed`): ``moves`` in order with
    their lengths along the path (mm); a step where the F changes between two moves."""
    feed = program.feed_mm_min[moves]
    ends = np.cumsum(length_mm)
    change = np.flatnonzero(feed[1:] != feed[:-1])
    s = np.concatenate([[0.0], np.repeat(ends[change], 2), [ends[-1]]])
    f = np.concatenate([[feed[0]], np.column_stack([feed[change], feed[change + 1]]).ravel(), [feed[-1]]])
    return s, f


def cut_shape(program: Program, k: int) -> Shape:
    """Cut ``k`` (0-based) of a program as a :class:`Shape` (see the module docstring)."""
    path = program.path
    total = program.n_cuts
    moves = program.cut_moves(k)
    first = int(program.move_line[moves[0]]) + 1
    name = path.stem if total == 1 else f"{path.stem}#{k + 1}"
    source = f"{path} (G-code, cut {k + 1} of {total}, from line {first})"
    planar = not program.has_z_words and bool(np.all(program.end[moves, 2] == 0))
    dim = 2 if planar else 3
    kinds = program.kind[moves]
    if np.all(kinds == NURBS) and moves.size == 1:
        curve = program.nurbs[int(moves[0])]
        if dim == 2 and curve.dim == 3:
            curve = Nurbs(curve.degree, curve.knots, curve.control_points[:, :2], curve.weights)
        return Shape(name=name, curve=curve, source=source, path=path,
                     notes="one G5.2 block, LinuxCNC's uniform clamped knot vector on [0, 1]",
                     programmed_feed=programmed_feed(program, moves, np.array([curve.length])))
    pts, owner = _cut_points(program, k, ARC_TOLERANCE_MM)
    # each move's length along the polyline: the chords of the points it ends
    chord = np.linalg.norm(np.diff(pts[:, :dim], axis=0), axis=1)
    along = np.zeros(moves.size)
    np.add.at(along, np.searchsorted(moves, owner[1:]), chord)
    notes = "G1 polyline"
    if (kinds == ARC).any():
        notes += f" with G2/G3 arcs flattened within {ARC_TOLERANCE_MM} mm"
    if (kinds == NURBS).any():
        notes += f"; G5.2 block(s) sampled at {NURBS_IMPORT_POINTS_PER_SPAN} points per knot span"
    shape = polyline_shape(pts[:, :dim], name=name, source=source, path=path, notes=notes)
    return replace(shape, programmed_feed=programmed_feed(program, moves, along))


def _checked(path: str | os.PathLike) -> Program:
    program = read_program(Path(path))
    if program.n_cuts == 0:
        raise PathFormatError(f"{program.path}: no feed move (G1, G2/G3 or G5.2) found; nothing to import")
    return program


def load_gcode_shapes(path: str | os.PathLike) -> list[Shape]:
    """All cuts of a G-code file, one :class:`Shape` per cut."""
    program = _checked(path)
    return [cut_shape(program, k) for k in range(program.n_cuts)]


def load_gcode(path: str | os.PathLike, selector: str | None = None) -> Shape:
    """One cut of a G-code file: the only one, or ``selector`` = ``N`` / ``path=N`` (1-based)."""
    program = _checked(path)
    described = [f"{k + 1} (line {int(program.move_line[program.cut_moves(k)[0]]) + 1})"
                 for k in range(program.n_cuts)]
    index = pick_by_index(program.path, selector, described)
    return cut_shape(program, index)
