"""Point lists as paths: CSV import, and the polyline :class:`Shape` every point-sequence importer
(CSV, G-code G1 chains, DXF polylines) builds.

CSV: a header row, then one point per row. The coordinate columns are ``x_mm, y_mm[, z_mm]`` or
``x, y[, z]`` (case and surrounding spaces ignored); other columns are ignored, so a CSV that
fuzzyfeed wrote loads back as a path. Values are parsed with Python's ``float`` (exact for the
``repr`` text fuzzyfeed writes). An empty, non-numeric, NaN or infinite value is an error naming
the file, the row (the file's line number) and the column; a row that repeats the previous point
is dropped (a note says how many).

A polyline shape keeps the points (``Shape.polyline``) — the planners sample it at its vertices
with the curvature of :mod:`fuzzyfeed.geometry.polyline` (the path within the coordinates' rounding,
corners as the controller's blend) — and carries as ``Shape.curve`` the degree-1
NURBS through the points with chord-length knots, for plotting and arc length.
"""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path

import numpy as np

from fuzzyfeed.base.files import read_text as read_file_text
from fuzzyfeed.errors import NurbsError, PathFormatError
from fuzzyfeed.io.shape import Shape
from fuzzyfeed.geometry.nurbs import Nurbs

_COLUMN_SETS = (("x_mm", "y_mm", "z_mm"), ("x", "y", "z"))
#: Two consecutive points closer than this (mm) are one point (a repeat is dropped with a note).
REPEAT_MM = 1e-9


def read_text(path: str | os.PathLike, kind: str) -> str:
    """The text of a path file (CSV or G-code); see :func:`fuzzyfeed.base.files.read_text`. G-code may
    be Latin-1 (comments in old controllers' files often are)."""
    return read_file_text(path, kind, PathFormatError, latin1=kind == "G-code")


def chord_knots(points: np.ndarray) -> np.ndarray:
    """Knot vector of the degree-1 NURBS through ``points``: cumulative chord length on [0, 1],
    clamped (first and last knot doubled)."""
    chords = np.linalg.norm(np.diff(points, axis=0), axis=1)
    t = np.concatenate([[0.0], np.cumsum(chords)])
    t /= t[-1]
    t[-1] = 1.0
    return np.concatenate([[0.0], t, [1.0]])


def polyline_shape(points: np.ndarray, *, name: str, source: str = "", path: Path | None = None,
                   notes: str = "", where: str | None = None):
    """A polyline :class:`Shape` from (N, 2|3) points in mm (N ≥ 2, finite; a point that repeats
    the previous one is dropped with a note). With two points only the curve is kept (a straight
    line, sampled as a NURBS)."""
    where = where or str(path or name)
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise PathFormatError(f"{where}: points have shape {pts.shape}; need N rows of 2 or 3 coordinates")
    if pts.shape[0] < 2:
        raise PathFormatError(f"{where}: {pts.shape[0]} point(s); a path needs at least 2")
    if not np.isfinite(pts).all():
        i = int(np.argwhere(~np.isfinite(pts))[0, 0])
        raise PathFormatError(f"{where}: point {i} = {pts[i].tolist()}; coordinates must be finite")
    from fuzzyfeed.geometry.nurbs import MAX_COORDINATE_MM, MIN_EXTENT_MM

    big = np.abs(pts) > MAX_COORDINATE_MM
    if big.any():
        i = int(np.argwhere(big)[0, 0])
        raise PathFormatError(f"{where}: point {i} = {pts[i].tolist()}; coordinates must lie within "
                              f"±{MAX_COORDINATE_MM:g} mm (1 km)")
    extent = float(np.ptp(pts, axis=0).max())
    if extent == 0:
        raise PathFormatError(f"{where}: every point repeats the first; a path needs at least 2 "
                              "distinct points")
    if extent < MIN_EXTENT_MM:
        raise PathFormatError(f"{where}: all points within {extent:g} mm of each other; a path needs "
                              f"points more than {MIN_EXTENT_MM:g} mm apart")
    # a point within REPEAT_MM (or 1e-12 of the extent) of the previous one is no move: dropped
    gap = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    same = gap <= max(REPEAT_MM, 1e-12 * extent)
    if same.any():
        keep = np.concatenate([[True], ~same])
        pts = pts[keep]
        notes = (notes + "; " if notes else "") + f"{int(same.sum())} repeated point(s) dropped"
        if pts.shape[0] < 2:
            raise PathFormatError(f"{where}: every point repeats the first; a path needs at least 2 "
                                  "distinct points")
    try:
        curve = Nurbs(1, chord_knots(pts), pts)
    except NurbsError as exc:
        raise PathFormatError(f"{where}: {exc}") from None
    polyline = pts.copy() if pts.shape[0] >= 3 else None
    if polyline is not None:
        polyline.flags.writeable = False
    return Shape(name=name, curve=curve, source=source, notes=notes, path=path, polyline=polyline)


def pick_by_index(path: Path, selector: str | None, described: list[str]) -> int:
    """Index (0-based) chosen by ``selector`` ``N`` or ``path=N`` (1-based) among ``described``.
    Without a selector the file must hold exactly one path."""
    if selector is None:
        if len(described) == 1:
            return 0
        raise PathFormatError(f"{path}: {len(described)} paths ({', '.join(described)}); pick one "
                              f"with {path}#path=N")
    text = selector.strip()
    if text.lower().startswith("path="):
        text = text[5:]
    try:
        number = int(text)
    except ValueError:
        raise PathFormatError(f"{path}#{selector}: selector must be N or path=N (1-based path "
                              "number)") from None
    if not 1 <= number <= len(described):
        raise PathFormatError(f"{path}#{selector}: path {number} does not exist; the file has "
                              f"{len(described)} path(s): {', '.join(described)}")
    return number - 1


#: Most point rows a CSV may hold: the sampling budget (MAX_POINTS); a longer file is refused
#: after reading only as far as that many rows.
MAX_CSV_POINTS = 1_000_000


def _check_row_count(path: Path) -> None:
    """Refuse a CSV with more than MAX_CSV_POINTS rows, reading no further than that."""
    rows = 0
    try:
        with open(path, "rb") as handle:
            while True:
                chunk = handle.read(1 << 23)
                if not chunk:
                    return
                rows += chunk.count(b"\n")
                if rows > MAX_CSV_POINTS + 1:
                    raise PathFormatError(f"{path}: more than {MAX_CSV_POINTS:,} point rows; at most "
                                          f"{MAX_CSV_POINTS:,} points (the sampling budget): thin the "
                                          "list or split the path")
    except OSError:
        return           # read_text gives the one-line reason


def _fast_points(text: str, names: list[str], columns: list[int]) -> np.ndarray | None:
    """The points parsed by Arrow's CSV reader (exact float parsing), or None when any cell is
    not a finite number (the row-by-row reader then names it)."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    try:
        table = pacsv.read_csv(pa.py_buffer(text.encode()),
                               read_options=pacsv.ReadOptions(column_names=[f"c{k}" for k in range(len(names))],
                                                              skip_rows=1),
                               convert_options=pacsv.ConvertOptions(
                                   include_columns=[f"c{k}" for k in columns],
                                   column_types={f"c{k}": pa.float64() for k in columns}))
    except (pa.ArrowInvalid, pa.ArrowTypeError, ValueError):
        return None
    cols = []
    for k in columns:
        col = table.column(f"c{k}")
        if col.null_count:
            return None
        cols.append(col.to_numpy())
    pts = np.column_stack(cols) if cols else np.zeros((0, len(columns)))
    if not np.isfinite(pts).all():
        return None
    return pts


def read_points_csv(path: str | os.PathLike) -> np.ndarray:
    """The (N, 2|3) points of a point-list CSV (see the module docstring), float64 exact."""
    path = Path(path)
    _check_row_count(path)
    text = read_text(path, "CSV")
    rows = csv.reader(io.StringIO(text))
    try:
        header = next(rows)
    except StopIteration:
        raise PathFormatError(f"{path}: empty file; expected a header row with x_mm,y_mm[,z_mm] "
                              "or x,y[,z]") from None
    names = [h.strip().lower() for h in header]
    columns = None
    for candidates in _COLUMN_SETS:
        if candidates[0] in names and candidates[1] in names:
            columns = [names.index(c) for c in candidates if c in names]
            labels = [header[i].strip() for i in columns]
            break
    if columns is None:
        raise PathFormatError(f"{path}:1: header {header!r} has no x_mm,y_mm or x,y columns")
    if text.count("\n") > 1000 and "\"" not in text:      # long plain lists: Arrow's parser
        fast = _fast_points(text, names, columns)
        if fast is not None and fast.shape[0] >= 2:
            return fast
    points = []
    for line_no, row in enumerate(rows, start=2):
        if not row or all(not cell.strip() for cell in row):
            continue
        values = []
        for col, label in zip(columns, labels):
            cell = row[col].strip() if col < len(row) else ""
            try:
                value = float(cell)
            except ValueError:
                raise PathFormatError(f"{path}:{line_no}: column {label} = {cell!r} is not a number") from None
            if not np.isfinite(value):
                raise PathFormatError(f"{path}:{line_no}: column {label} = {cell}; coordinates must "
                                      "be finite")
            values.append(value)
        points.append(values)
    if len(points) < 2:
        raise PathFormatError(f"{path}: {len(points)} point row(s); a path needs at least 2")
    return np.array(points, dtype=float)


def load_points_csv(path: str | os.PathLike, selector: str | None = None):
    """A point-list CSV as a polyline :class:`Shape` (one path per file)."""
    path = Path(path)
    if selector is not None:
        pick_by_index(path, selector, ["1"])
    pts = read_points_csv(path)
    return polyline_shape(pts, name=path.stem, source=f"{path} (CSV point list)", path=path,
                          notes=f"{len(pts)} points from CSV")
