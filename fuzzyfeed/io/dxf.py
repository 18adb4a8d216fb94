"""DXF import with ezdxf: SPLINE entities as NURBS, LWPOLYLINE/POLYLINE as point sequences.

Every usable entity of the modelspace becomes one path (:func:`load_dxf_shapes`):

- ``SPLINE`` with control points: degree, knots, control points and weights as stored (a
  non-rational spline has weights 1). A spline with fit points only is converted by ezdxf's own
  construction tool (``Spline.construction_tool()``, the global interpolation AutoCAD uses).
  A knot vector that is not clamped (closed/periodic splines) is clamped to its valid range
  [u_p, u_n] by knot insertion (The NURBS Book §5.3): the same curve, with clamped ends.
- ``LWPOLYLINE`` and 2-D/3-D ``POLYLINE``: the vertices as a polyline (closed ones repeat the first
  vertex at the end). Arc segments (bulge ≠ 0) are flattened into points on the exact
  arc with a sagitta of at most :data:`BULGE_TOLERANCE_MM`. Polyface and mesh POLYLINEs are not paths and are skipped.

Units: the header's ``$INSUNITS`` is honoured (0 unitless and 4 = mm are taken as mm; 1 inch,
2 feet, 5 cm, 6 m are converted to mm; other codes are refused). Note that ``ezdxf.new()`` sets
``$INSUNITS = 6`` (metres) unless told otherwise.

Choosing one path (:func:`load_dxf`): ``FILE#HANDLE`` or ``FILE#handle=H`` picks the entity by
handle, ``FILE#layer=NAME`` the only usable entity of a layer, ``FILE#path=N`` the N-th usable
entity (1-based, file order). A file with several usable entities and no selector is an error
listing them (type, handle, layer), so a path is never picked by accident.

ezdxf is imported inside the functions (it is slow to import and not needed by the core).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from fuzzyfeed.errors import NurbsError, PathFormatError
from fuzzyfeed.io.points import pick_by_index, polyline_shape
from fuzzyfeed.io.shape import Shape
from fuzzyfeed.nurbs import Nurbs, insert_knot

#: $INSUNITS code → factor to mm (0 = unitless, read as mm).
INSUNITS_TO_MM = {0: 1.0, 1: 25.4, 2: 304.8, 4: 1.0, 5: 10.0, 6: 1000.0}
#: Largest distance between an arc segment of a polyline and its flattened points (mm).
BULGE_TOLERANCE_MM = 1e-4
USABLE_TYPES = ("SPLINE", "LWPOLYLINE", "POLYLINE")


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split())


def _read(path: Path):
    import ezdxf

    if not path.is_file():
        raise PathFormatError(f"{path}: no such file")
    head = path.read_bytes()[:32]
    if b"\x00" in head and not head.startswith(b"AutoCAD Binary DXF"):
        raise PathFormatError(f"{path}: binary file that is not a DXF; expected a DXF drawing")
    try:
        return ezdxf.readfile(str(path))
    except (ezdxf.DXFStructureError, ezdxf.DXFError) as exc:
        raise PathFormatError(f"{path}: not a readable DXF ({_one_line(exc)})") from None
    except (UnicodeDecodeError, ValueError) as exc:
        raise PathFormatError(f"{path}: not a readable DXF ({type(exc).__name__}: {_one_line(exc)})") from None
    except OSError as exc:
        if exc.errno is None:  # ezdxf's "is not a DXF file"
            raise PathFormatError(f"{path}: not a readable DXF ({_one_line(exc)})") from None
        raise PathFormatError(f"{path}: cannot read ({exc.strerror})") from None


def _units_factor(doc, path: Path) -> tuple[float, str]:
    code = int(doc.header.get("$INSUNITS", 0) or 0)
    if code not in INSUNITS_TO_MM:
        raise PathFormatError(f"{path}: $INSUNITS = {code} is not supported; use 0 (unitless = mm), "
                              "1 (inch), 2 (feet), 4 (mm), 5 (cm) or 6 (m)")
    return INSUNITS_TO_MM[code], {0: "unitless (read as mm)", 1: "inch", 2: "feet", 4: "mm",
                                  5: "cm", 6: "m"}[code]


def _spline_curve(entity, scale: float, where: str):

    if len(entity.control_points) > 0:
        degree = int(entity.dxf.degree)
        knots = np.asarray(list(entity.knots), dtype=float)
        points = np.asarray([tuple(p) for p in entity.control_points], dtype=float)
        weights = np.asarray(list(entity.weights), dtype=float) if len(entity.weights) else None
        how = "control points"
    elif len(entity.fit_points) > 0:
        try:
            tool = entity.construction_tool()
        except Exception as exc:  # ezdxf raises several types for degenerate fit data
            raise PathFormatError(f"{where}: fit points could not be interpolated by ezdxf "
                                  f"({type(exc).__name__}: {_one_line(exc)})") from None
        degree = int(tool.degree)
        knots = np.asarray(tool.knots(), dtype=float)
        points = np.asarray([tuple(p) for p in tool.control_points], dtype=float)
        weights = np.asarray(tool.weights(), dtype=float) if tool.is_rational else None
        how = f"{len(entity.fit_points)} fit points (ezdxf construction tool)"
    else:
        raise PathFormatError(f"{where}: SPLINE has neither control points nor fit points")
    if not np.isfinite(points).all():
        i = int(np.argwhere(~np.isfinite(points))[0, 0])
        raise PathFormatError(f"{where}: control point {i} = {points[i].tolist()}; must be finite")
    points = points * scale
    weights = np.ones(len(points)) if weights is None or weights.size == 0 else weights
    if (degree >= 1 and knots.size == len(points) + degree + 1 and np.all(np.diff(knots) >= 0)
            and np.all(weights > 0) and (np.ptp(knots[:degree + 1]) > 0 or np.ptp(knots[-degree - 1:]) > 0)):
        knots, points, weights = clamp_knots(degree, knots, points, weights)
        how += ", unclamped knots clamped to [u_p, u_n]"
    if np.all(points[:, 2] == 0):
        points = points[:, :2]
    try:
        return Nurbs(degree, knots, points, weights), how
    except NurbsError as exc:
        raise PathFormatError(f"{where}: {exc}") from None


def bulge_points(p0: np.ndarray, p1: np.ndarray, bulge: float, tolerance: float) -> np.ndarray:
    """Points after ``p0`` up to and including ``p1`` along the arc of a polyline segment with
    ``bulge`` = tan(θ/4) (θ the signed included angle, counter-clockwise positive), spaced so the
    sagitta of each chord is at most ``tolerance``. 2-D (the polyline's OCS)."""
    chord = p1 - p0
    d = float(np.hypot(*chord))
    if bulge == 0 or d == 0:
        return p1[None, :]
    normal = np.array([-chord[1], chord[0]]) / d                  # left of the chord
    center = 0.5 * (p0 + p1) + normal * (d / 2) * (1 - bulge * bulge) / (2 * bulge)
    radius = float(np.hypot(*(p0 - center)))
    sweep = 4.0 * np.arctan(bulge)
    step = 2.0 * np.arccos(max(-1.0, 1.0 - tolerance / radius)) if tolerance < radius else np.pi / 2
    m = max(2, int(np.ceil(abs(sweep) / step)))
    a = np.arctan2(*(p0 - center)[::-1]) + sweep * np.arange(1, m + 1) / m
    pts = center + radius * np.column_stack([np.cos(a), np.sin(a)])
    pts[-1] = p1
    return pts


def _clamp_start(p: int, knots: np.ndarray, pw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = float(knots[p])
    while np.count_nonzero(knots == a) < p:
        knots, pw = insert_knot(p, knots, pw, a)
    j = int(np.argmax(knots == a))                   # first knot equal to a
    if j == 0:                                        # already p + 1 equal knots at the start
        return knots, pw
    m = int(np.count_nonzero(knots == a))
    start_cp = j + m - p - 1                          # C(a) = this control point
    return np.concatenate([[a] * (p + 1), knots[j + m:]]), pw[start_cp:]


def clamp_knots(p: int, knots: np.ndarray, points: np.ndarray, weights: np.ndarray):
    """The same curve on [u_p, u_n] with a clamped knot vector: insert u_p (and u_n) until each
    has multiplicity p, then drop the knots and control points outside the range (The NURBS Book
    §5.3, knot insertion; the curve is unchanged)."""
    pw = np.column_stack([points * weights[:, None], weights])
    knots, pw = _clamp_start(p, np.asarray(knots, dtype=float), pw)
    rk, rpw = _clamp_start(p, -knots[::-1], pw[::-1])
    knots, pw = -rk[::-1], rpw[::-1]
    return knots, pw[:, :-1] / pw[:, -1:], pw[:, -1]


def _polyline_points(entity, scale: float, where: str) -> np.ndarray:
    kind = entity.dxftype()
    if kind == "LWPOLYLINE":
        xyb = np.asarray([tuple(p) for p in entity.get_points("xyb")], dtype=float).reshape(-1, 3)
        closed = entity.closed
        elevation = float(entity.dxf.elevation)
        planar = True
    else:
        closed = entity.is_closed
        planar = entity.is_2d_polyline
        xyz = np.asarray([tuple(v.dxf.location) for v in entity.vertices], dtype=float).reshape(-1, 3)
        bulges = np.asarray([float(v.dxf.get("bulge", 0) or 0) for v in entity.vertices])
        xyb = np.column_stack([xyz[:, :2], bulges])
        elevation = float(xyz[0, 2]) if planar and len(xyz) else 0.0
    if not np.isfinite(xyb).all():
        i = int(np.argwhere(~np.isfinite(xyb))[0, 0])
        vertex = (xyb[i, :2].tolist() + [elevation]) if planar else xyz[i].tolist()
        raise PathFormatError(f"{where}: vertex {i} = {vertex}; coordinates must be finite")
    if not planar:  # 3-D polyline: straight segments in WCS
        pts = xyz
        if closed and len(pts) > 1 and not np.array_equal(pts[0], pts[-1]):
            pts = np.vstack([pts, pts[:1]])
    else:
        xy, bulge = xyb[:, :2], xyb[:, 2]
        if closed and len(xy) > 1 and not np.array_equal(xy[0], xy[-1]):
            xy = np.vstack([xy, xy[:1]])
            bulge = np.append(bulge, 0.0)
        out = [xy[:1]]
        for i in range(len(xy) - 1):
            out.append(bulge_points(xy[i], xy[i + 1], bulge[i], BULGE_TOLERANCE_MM / scale))
        xy = np.vstack(out)
        ocs = entity.ocs()
        pts = np.asarray([tuple(ocs.to_wcs((x, y, elevation))) for x, y in xy], dtype=float).reshape(-1, 3)
    if not np.isfinite(pts).all():
        i = int(np.argwhere(~np.isfinite(pts))[0, 0])
        raise PathFormatError(f"{where}: vertex {i} = {pts[i].tolist()}; coordinates must be finite")
    keep = np.concatenate([[True], np.any(pts[1:] != pts[:-1], axis=1)])  # drop repeated vertices
    pts = pts[keep] * scale
    if np.all(pts[:, 2] == 0):
        pts = pts[:, :2]
    return pts


def _usable(msp) -> tuple[list, dict]:
    usable, other = [], {}
    for e in msp:
        kind = e.dxftype()
        if kind == "POLYLINE" and not (e.is_2d_polyline or e.is_3d_polyline):
            other["POLYLINE (mesh/polyface)"] = other.get("POLYLINE (mesh/polyface)", 0) + 1
        elif kind in USABLE_TYPES:
            usable.append(e)
        else:
            other[kind] = other.get(kind, 0) + 1
    return usable, other


def _describe(e) -> str:
    return f"{e.dxftype()} {e.dxf.handle} (layer {e.dxf.layer})"


def _entity_shape(e, path: Path, scale: float, units: str):

    where = f"{path}: {_describe(e)}"
    name = f"{path.stem}#{e.dxf.handle}"
    source = f"{path} ({_describe(e)}, units {units})"
    if e.dxftype() == "SPLINE":
        curve, how = _spline_curve(e, scale, where)
        return Shape(name=name, curve=curve, source=source, path=path,
                     notes=f"DXF SPLINE from {how}, degree {curve.degree}")
    pts = _polyline_points(e, scale, where)
    return polyline_shape(pts, name=name, source=source, path=path, where=where,
                          notes=f"DXF {e.dxftype()} with {len(pts)} vertices")


def _open(path: str | os.PathLike):
    path = Path(path)
    doc = _read(path)
    scale, units = _units_factor(doc, path)
    usable, other = _usable(doc.modelspace())
    if not usable:
        found = ", ".join(f"{k} x{n}" for k, n in sorted(other.items())) or "nothing"
        raise PathFormatError(f"{path}: no usable entity (SPLINE, LWPOLYLINE, 2-D/3-D POLYLINE) in "
                              f"the modelspace; found {found}")
    return path, usable, scale, units


def load_dxf_shapes(path: str | os.PathLike) -> list:
    """Every usable entity of a DXF's modelspace as a :class:`Shape`, in file order."""
    path, usable, scale, units = _open(path)
    return [_entity_shape(e, path, scale, units) for e in usable]


def select_entity(path: Path, usable: list, selector: str | None):
    """The entity chosen by ``selector`` (see the module docstring)."""
    listing = ", ".join(_describe(e) for e in usable)
    if selector is None:
        if len(usable) == 1:
            return usable[0]
        raise PathFormatError(f"{path}: {len(usable)} usable entities ({listing}); pick one with "
                              f"{path}#HANDLE, #layer=NAME or #path=N")
    key, _, value = selector.partition("=")
    key = key.strip().lower() if value else "handle"
    value = (value if value else selector).strip()
    if key == "handle":
        hits = [e for e in usable if e.dxf.handle.upper() == value.upper()]
        if not hits:
            raise PathFormatError(f"{path}#{selector}: no usable entity with handle {value}; "
                                  f"usable: {listing}")
        return hits[0]
    if key == "layer":
        hits = [e for e in usable if e.dxf.layer.lower() == value.lower()]
        if len(hits) != 1:
            what = "no usable entity" if not hits else f"{len(hits)} usable entities ({', '.join(map(_describe, hits))})"
            raise PathFormatError(f"{path}#{selector}: {what} on layer {value!r}; "
                                  + ("pick one by handle" if hits else f"usable: {listing}"))
        return hits[0]
    if key == "path":
        return usable[pick_by_index(path, selector, [_describe(e) for e in usable])]
    raise PathFormatError(f"{path}#{selector}: unknown selector {key!r}; use HANDLE, handle=H, "
                          "layer=NAME or path=N")


def load_dxf(path: str | os.PathLike, selector: str | None = None):
    """One path of a DXF: the only usable entity, or the one ``selector`` names."""
    path, usable, scale, units = _open(path)
    return _entity_shape(select_entity(path, usable, selector), path, scale, units)
