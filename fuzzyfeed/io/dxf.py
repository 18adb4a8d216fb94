"""DXF import with ezdxf: the contours of a drawing as paths.

Curves (model space, and block references ``INSERT``/``MINSERT`` exploded with their transforms
through ezdxf's ``virtual_entities``, nested blocks included):

- ``LINE``; ``ARC``, ``CIRCLE``, ``ELLIPSE`` as exact rational quadratic NURBS (ezdxf's
  ``rational_bspline_from_ellipse``; a non-uniformly scaled block turns arcs into ellipses);
- ``SPLINE`` with control points as stored (weights 1 if not rational); fit points only: ezdxf's
  construction tool (AutoCAD's global interpolation); unclamped (closed/periodic) knots clamped to
  [u_p, u_n] by knot insertion (The NURBS Book §5.3); piecewise-Bézier splines (interior knots of
  multiplicity p + 1) joined where the pieces meet, split where they do not;
- ``LWPOLYLINE`` and 2-D/3-D ``POLYLINE``: the vertices; bulge segments flattened into points on
  the exact arc; spline-fit and curve-fit POLYLINEs as the fitted vertices ezdxf stores (frame
  points skipped). Polyface/mesh POLYLINEs, texts, hatches, dimensions are not paths.

They are chained into contours by :mod:`fuzzyfeed.io.contours` (end points within 1 µm, per
layer). A contour of one SPLINE/ARC/CIRCLE/ELLIPSE is that exact NURBS; a chain of several pieces,
or a polyline, is a point sequence on the exact pieces.

Units: ``$INSUNITS`` is honoured only where the header sets it (0 unitless and 4 read as mm; 1 inch,
2 feet, 5 cm, 6 m converted; other codes refused); a file without it is read as mm with a notice.
``units=`` ("mm", "inch", "m") overrides both. (``ezdxf.new()`` writes ``$INSUNITS = 6``, metres.)

Damaged files that ``ezdxf.readfile`` refuses are read through ``ezdxf.recover`` with a notice;
any ezdxf failure becomes one line naming the file. Notices are :class:`FuzzyfeedNotice` warnings.

Choosing one contour (:func:`load_dxf`): ``FILE#HANDLE``/``FILE#handle=H`` the contour holding
that entity (an INSERT's handle for its exploded pieces), ``FILE#layer=NAME`` the only contour of
a layer, ``FILE#path=N`` the N-th contour (1-based, file order of its first piece). Without a
selector a drawing of several contours is an error for one path; :func:`load_dxf_shapes` returns
every contour.
"""

from __future__ import annotations

import contextlib
import contextvars
import logging
import os
import warnings
from pathlib import Path

import numpy as np

from fuzzyfeed.errors import FuzzyfeedNotice, NurbsError, PathFormatError
from fuzzyfeed.io.contours import FLATTEN_ANGLE_RAD, Contour, Piece, chain
from fuzzyfeed.io.dxf_splines import spline_curves
from fuzzyfeed.io.points import pick_by_index, polyline_shape
from fuzzyfeed.io.shape import Shape
from fuzzyfeed.geometry.nurbs import MIN_EXTENT_MM, Nurbs

#: A bulge whose sagitta is below this (mm) is a straight segment (a bulge of 1e-300 has no arc).
STRAIGHT_SAGITTA_MM = 1e-9
#: $INSUNITS code → factor to mm (0 = unitless, read as mm).
INSUNITS_TO_MM = {0: 1.0, 1: 25.4, 2: 304.8, 4: 1.0, 5: 10.0, 6: 1000.0}
_INSUNITS_NAMES = {0: "unitless (read as mm)", 1: "inch", 2: "feet", 4: "mm", 5: "cm", 6: "m"}
#: ``--units`` choices → factor to mm.
UNITS_TO_MM = {"mm": 1.0, "inch": 25.4, "m": 1000.0}
#: Units forced by the caller (the CLI's ``--units``); None: the file's header decides.
UNITS_OVERRIDE: contextvars.ContextVar[str | None] = contextvars.ContextVar("dxf_units", default=None)
CURVE_TYPES = ("LINE", "ARC", "CIRCLE", "ELLIPSE", "SPLINE", "LWPOLYLINE", "POLYLINE")
#: Deepest block nesting followed through INSERTs (guards against a block that inserts itself).
MAX_BLOCK_DEPTH = 16
#: How many items a message lists before "… and N more".
LIST_LIMIT = 5


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def _notice(message: str) -> None:
    warnings.warn(message, FuzzyfeedNotice, stacklevel=3)


def shorten(items: list[str], limit: int = LIST_LIMIT) -> str:
    """``a, b, c`` — or the first ``limit`` and "… and N more"."""
    if len(items) <= limit:
        return ", ".join(items)
    return ", ".join(items[:limit]) + f", … and {len(items) - limit} more"


@contextlib.contextmanager
def _quiet_ezdxf():
    """ezdxf logs every value it repairs; the user gets one notice instead."""
    logger = logging.getLogger("ezdxf")
    level = logger.level
    logger.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        logger.setLevel(level)


def header_sets_insunits(path: Path) -> bool:
    """Whether the file's own HEADER section has ``$INSUNITS`` (ezdxf fills a missing header with
    its defaults, $INSUNITS = 6 metres among them, so the loaded document cannot tell)."""
    data = path.read_bytes()
    start = data.find(b"HEADER")
    if start < 0:
        return False
    end = data.find(b"ENDSEC", start)
    return b"$INSUNITS" in data[start:end if end > 0 else len(data)]


def _read(path: Path):
    import ezdxf
    from ezdxf import recover

    if not path.is_file():
        raise PathFormatError(f"{path}: no such file")
    head = path.read_bytes()[:32]
    if b"\x00" in head and not head.startswith(b"AutoCAD Binary DXF"):
        raise PathFormatError(f"{path}: binary file that is not a DXF; expected a DXF drawing")
    try:
        with _quiet_ezdxf():
            return ezdxf.readfile(str(path))
    except OSError as exc:
        if exc.errno is not None:
            raise PathFormatError(f"{path}: cannot read ({exc.strerror})") from None
        first = exc
    except Exception as exc:  # noqa: BLE001 — ezdxf raises many types on damaged files
        first = exc
    try:
        with _quiet_ezdxf():
            doc, auditor = recover.readfile(str(path))
    except Exception as exc:  # noqa: BLE001
        raise PathFormatError(f"{path}: not a DXF that ezdxf can read or recover "
                              f"({type(first).__name__}: {_one_line(first)}; recover: "
                              f"{_one_line(exc)})") from None
    reported = len(getattr(auditor, "fixes", [])) + len(getattr(auditor, "errors", []))
    _notice(f"{path}: damaged DXF ({_one_line(first)[:80]}) read through ezdxf.recover "
            f"({reported} problem(s) reported and repaired or skipped)")
    return doc


def _units_factor(doc, path: Path) -> tuple[float, str]:
    override = UNITS_OVERRIDE.get()
    if override is not None:
        if override not in UNITS_TO_MM:
            raise PathFormatError(f"--units = {override!r}; use one of {', '.join(UNITS_TO_MM)}")
        return UNITS_TO_MM[override], f"{override} (--units)"
    if "$INSUNITS" not in doc.header or not header_sets_insunits(path):
        _notice(f"{path}: the header does not set $INSUNITS; coordinates read as mm "
                "(use --units inch|m if they are not)")
        return 1.0, "mm (no $INSUNITS in the header)"
    try:
        code = int(doc.header.get("$INSUNITS", 0) or 0)
    except (TypeError, ValueError):
        raise PathFormatError(f"{path}: $INSUNITS = {doc.header.get('$INSUNITS')!r} is not a "
                              "units code; use --units mm|inch|m") from None
    if code not in INSUNITS_TO_MM:
        raise PathFormatError(f"{path}: $INSUNITS = {code} is not supported; use 0 (unitless = mm), "
                              "1 (inch), 2 (feet), 4 (mm), 5 (cm) or 6 (m), or --units mm|inch|m")
    return INSUNITS_TO_MM[code], _INSUNITS_NAMES[code]


# ---------------------------------------------------------------------------------- polylines
def bulge_points(p0: np.ndarray, p1: np.ndarray, bulge: float,
                 max_turn_rad: float = FLATTEN_ANGLE_RAD) -> np.ndarray:
    """Points after ``p0`` up to and including ``p1`` on the exact arc of a polyline segment with
    ``bulge`` = tan(θ/4) (θ the signed included angle, counter-clockwise positive), each chord
    turning by at most ``max_turn_rad``. 2-D (the polyline's OCS)."""
    chord = p1 - p0
    d = float(np.hypot(*chord))
    if bulge == 0 or d == 0 or abs(bulge) * d / 2 <= STRAIGHT_SAGITTA_MM:  # no arc to speak of
        return p1[None, :]
    normal = np.array([-chord[1], chord[0]]) / d                  # left of the chord
    center = 0.5 * (p0 + p1) + normal * (d / 2) * (1 - bulge * bulge) / (2 * bulge)
    radius = float(np.hypot(*(p0 - center)))
    sweep = 4.0 * np.arctan(bulge)
    m = max(2, int(np.ceil(abs(sweep) / max_turn_rad)))
    a = np.arctan2(*(p0 - center)[::-1]) + sweep * np.arange(1, m + 1) / m
    pts = center + radius * np.column_stack([np.cos(a), np.sin(a)])
    pts[-1] = p1
    return pts


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
        vertices = [v for v in entity.vertices if not (int(v.dxf.get("flags", 0) or 0) & 16)]
        xyz = np.asarray([tuple(v.dxf.location) for v in vertices], dtype=float).reshape(-1, 3)
        bulges = np.asarray([float(v.dxf.get("bulge", 0) or 0) for v in vertices])
        xyb = np.column_stack([xyz[:, :2], bulges])
        elevation = float(xyz[0, 2]) if planar and len(xyz) else 0.0
    if len(xyb) == 0:
        raise PathFormatError(f"{where}: polyline without vertices")
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
            xy = np.vstack([xy, xy[:1]])      # the last vertex's bulge is the closing segment's
        out = [xy[:1]]
        for i in range(len(xy) - 1):
            out.append(bulge_points(xy[i], xy[i + 1], bulge[i]))
        xy = np.vstack(out)
        ocs = entity.ocs()
        pts = np.asarray([tuple(ocs.to_wcs((x, y, elevation))) for x, y in xy], dtype=float).reshape(-1, 3)
    if not np.isfinite(pts).all():
        i = int(np.argwhere(~np.isfinite(pts))[0, 0])
        raise PathFormatError(f"{where}: vertex {i} = {pts[i].tolist()}; coordinates must be finite")
    keep = np.concatenate([[True], np.any(pts[1:] != pts[:-1], axis=1)])  # drop repeated vertices
    return pts[keep] * scale


# ----------------------------------------------------------------------------------- entities
def _conic_curve(entity, scale: float, where: str):
    """ARC, CIRCLE or ELLIPSE as ezdxf's exact rational quadratic B-spline, in WCS, scaled."""
    from ezdxf.math import ConstructionEllipse, rational_bspline_from_ellipse


    kind = entity.dxftype()
    if kind == "ELLIPSE":
        ellipse = entity.construction_tool()
    else:
        d = entity.dxf
        start, end = (0.0, 360.0) if kind == "CIRCLE" else (float(d.start_angle), float(d.end_angle))
        if not float(d.radius) > 0:
            raise PathFormatError(f"{where}: radius = {float(d.radius):g}; must be > 0")
        ellipse = ConstructionEllipse.from_arc(center=d.center, radius=float(d.radius),
                                               extrusion=d.extrusion, start_angle=start, end_angle=end)
    spline = rational_bspline_from_ellipse(ellipse)
    pts = np.asarray([tuple(p) for p in spline.control_points], dtype=float) * scale
    w = np.asarray(spline.weights(), dtype=float) if spline.is_rational else None
    try:
        return Nurbs(int(spline.degree), np.asarray(spline.knots(), dtype=float), pts, w)
    except NurbsError as exc:
        raise PathFormatError(f"{where}: {exc}") from None


def _describe(e, parent: str = "") -> str:
    handle = e.dxf.get("handle", None)
    own = f"{e.dxftype()} {handle}" if handle else e.dxftype()
    return f"{parent}{own} (layer {e.dxf.get('layer', '0')})"


def _degenerate(e, scale: float) -> str | None:
    """Why entity ``e`` has no length to follow (a point drawn as a curve), or None."""
    kind = e.dxftype()
    d = e.dxf
    if kind == "LINE":
        a, b = np.asarray(tuple(d.start), dtype=float), np.asarray(tuple(d.end), dtype=float)
        if np.isfinite(a).all() and np.isfinite(b).all() and np.linalg.norm(b - a) * scale < MIN_EXTENT_MM:
            return "LINE of zero length"
    elif kind in ("ARC", "CIRCLE"):
        radius = float(d.get("radius", 0) or 0)
        if not radius * scale >= MIN_EXTENT_MM and not np.isnan(radius):
            return f"{kind} of radius {radius:g}"
        if kind == "ARC" and float(d.start_angle) % 360.0 == float(d.end_angle) % 360.0:
            return "ARC of zero sweep"
    elif kind == "ELLIPSE":
        major = np.asarray(tuple(d.major_axis), dtype=float)
        if np.linalg.norm(major) * scale < MIN_EXTENT_MM or not float(d.get("ratio", 1) or 0) > 0:
            return "ELLIPSE of zero size"
    elif kind == "SPLINE":
        pts = [tuple(p) for p in (e.control_points if len(e.control_points) else e.fit_points)]
        arr = np.asarray(pts, dtype=float).reshape(-1, 3)
        if arr.shape[0] and np.isfinite(arr).all() and float(np.ptp(arr, axis=0).max()) * scale < MIN_EXTENT_MM:
            return "SPLINE of no length"
    return None


def _pieces_of(e, scale: float, path: Path, where: str, handle: str, layer: str) -> list[Piece]:

    kind = e.dxftype()
    full = f"{path}: {where}"
    if kind == "LINE":
        a = np.asarray(tuple(e.dxf.start), dtype=float) * scale
        b = np.asarray(tuple(e.dxf.end), dtype=float) * scale
        if not (np.isfinite(a).all() and np.isfinite(b).all()):
            raise PathFormatError(f"{full}: end points {a.tolist()}, {b.tolist()}; must be finite")
        return [Piece(where, layer, handle, curve=Nurbs(1, [0, 0, 1, 1], np.vstack([a, b])))]
    if kind in ("ARC", "CIRCLE", "ELLIPSE"):
        return [Piece(where, layer, handle, curve=_conic_curve(e, scale, full))]
    if kind == "SPLINE":
        curves, how = spline_curves(e, scale, full)
        return [Piece(where, layer, handle, how=how, curve=c if c.dim == 3 else
                      Nurbs(c.degree, c.knots, np.column_stack([c.control_points, np.zeros(c.n_control_points)]),
                            c.weights)) for c in curves]
    pts = _polyline_points(e, scale, full)
    if len(pts) < 2 or float(np.ptp(pts, axis=0).max()) < MIN_EXTENT_MM:
        return []
    return [Piece(where, layer, handle, points=pts)]


def _collect(doc, path: Path, scale: float) -> tuple[list[Piece], dict[str, int]]:
    """Pieces of the model space (INSERTs exploded) and the count of non-path entities by type."""
    pieces: list[Piece] = []
    other: dict[str, int] = {}

    def visit(e, parent: str, handle: str | None, depth: int) -> None:
        kind = e.dxftype()
        if kind == "INSERT":
            if depth >= MAX_BLOCK_DEPTH:
                raise PathFormatError(f"{path}: {parent}INSERT nested deeper than {MAX_BLOCK_DEPTH} "
                                      "blocks (a block that inserts itself?)")
            name = e.dxf.get("name", "?")
            here = f"{parent}INSERT {e.dxf.get('handle', None) or ''} (block {name}) > ".replace("  ", " ")
            try:
                inserts = list(e.multi_insert()) if e.mcount > 1 else [e]
                children = [c for ins in inserts for c in ins.virtual_entities()]
            except PathFormatError:
                raise
            except Exception as exc:  # noqa: BLE001 — a broken block reference
                raise PathFormatError(f"{path}: {here.rstrip(' >')}: cannot explode the block "
                                      f"({type(exc).__name__}: {_one_line(exc)})") from None
            for child in children:
                visit(child, here, handle or e.dxf.get("handle", None), depth + 1)
            return
        if kind == "POLYLINE" and not (e.is_2d_polyline or e.is_3d_polyline):
            other["POLYLINE (mesh/polyface)"] = other.get("POLYLINE (mesh/polyface)", 0) + 1
            return
        if kind not in CURVE_TYPES:
            other[kind] = other.get(kind, 0) + 1
            return
        why = _degenerate(e, scale)
        if why is not None:
            skipped[why] = skipped.get(why, 0) + 1
            first.setdefault(why, _describe(e, parent))
            return
        own = handle or e.dxf.get("handle", None) or "?"
        found = _pieces_of(e, scale, path, _describe(e, parent), own, e.dxf.get("layer", "0"))
        if not found:
            why = f"{kind} of one point"
            skipped[why] = skipped.get(why, 0) + 1
            first.setdefault(why, _describe(e, parent))
        pieces.extend(found)

    skipped: dict[str, int] = {}
    first: dict[str, str] = {}
    for entity in doc.modelspace():
        visit(entity, "", None, 0)
    if skipped:
        total = sum(skipped.values())
        _notice(f"{path}: {total} degenerate entit{'y' if total == 1 else 'ies'} skipped (no length to "
                f"follow): " + shorten([f"{n} {why} (first: {first[why]})" for why, n in skipped.items()]))
        for why, n in skipped.items():
            other[why] = other.get(why, 0) + n
    return pieces, other


def _contours(path: Path) -> tuple[list[Contour], str]:
    doc = _read(path)
    scale, units = _units_factor(doc, path)
    try:
        pieces, other = _collect(doc, path, scale)
    except PathFormatError as exc:
        if "must lie within" in str(exc) and "--units" not in units:   # the stated units may be wrong
            raise PathFormatError(f"{exc} (the drawing's units: {units}; --units mm|inch reads its "
                                  "numbers in other units)") from None
        raise
    except Exception as exc:  # noqa: BLE001 — any ezdxf failure on a strange file is one line
        raise PathFormatError(f"{path}: ezdxf could not read the drawing's entities "
                              f"({type(exc).__name__}: {_one_line(exc)})") from None
    if not pieces:
        found = ", ".join(f"{k} x{n}" for k, n in sorted(other.items())) or "nothing"
        raise PathFormatError(f"{path}: no curve to follow (LINE, ARC, CIRCLE, ELLIPSE, SPLINE, "
                              f"LWPOLYLINE, POLYLINE) in the model space or its blocks; found {found}")
    return chain(pieces, str(path)), units


def _contour_shape(contour: Contour, path: Path, units: str, name: str):

    first = contour.pieces[0]
    source = f"{path} ({contour.describe()}, units {units})"
    if len(contour.pieces) == 1 and first.curve is not None and first.curve.degree > 1:
        c = first.curve
        pts = c.control_points[::-1] if first.reversed else c.control_points
        w = c.weights[::-1] if first.reversed else c.weights
        knots = (c.knots[0] + c.knots[-1] - c.knots[::-1]) if first.reversed else c.knots
        if np.all(pts[:, 2] == 0):
            pts = pts[:, :2]
        curve = Nurbs(c.degree, knots, pts, w)
        kind = first.where.split(" (")[0].split("> ")[-1].split(" ")[0]
        return Shape(name=name, curve=curve, source=source, path=path,
                     notes=f"DXF {kind} as an exact NURBS of degree {curve.degree}"
                           + (f" from {first.how}" if first.how else ""))
    pts = contour.points()
    if np.all(pts[:, 2] == 0):
        pts = pts[:, :2]
    return polyline_shape(pts, name=name, source=source, path=path, where=f"{path}: {contour.describe()}",
                          notes=f"DXF {contour.describe()}: {len(pts)} points on the exact pieces")


def _names(path: Path, contours: list[Contour]) -> list[str]:
    """``stem#HANDLE`` where the first piece's handle names only that contour, else ``stem#path=N``
    (both are selectors that pick the contour again)."""
    owners: dict[str, int] = {}
    for c in contours:
        for h in set(h.upper() for h in c.handles):
            owners[h] = owners.get(h, 0) + 1
    names = []
    for n, c in enumerate(contours):
        handle = c.pieces[0].handle
        unique = owners.get(handle.upper()) == 1 and handle != "?"
        names.append(f"{path.stem}#{handle}" if unique else f"{path.stem}#path={n + 1}")
    return names


def _gap_notice(contour: Contour) -> Contour:
    """``contour``, with a notice naming its gap (an end that nearly meets another free end: the
    path stops there and a new contour starts), if it has one."""
    if contour.problem is not None:
        _notice(contour.problem + "; a new contour starts there")
    return contour


def load_dxf_shapes(path: str | os.PathLike) -> list:
    """Every contour of a drawing as a :class:`Shape`, in file order of their first pieces (a gap
    beyond the chain tolerance ends a contour, with a notice naming it)."""
    path = Path(path)
    contours, units = _contours(path)
    for c in contours:
        _gap_notice(c)
    return [_contour_shape(c, path, units, name) for c, name in zip(contours, _names(path, contours))]


def select_contour(path: Path, contours: list[Contour], selector: str | None) -> int:
    """Index of the contour ``selector`` names (see the module docstring)."""
    listing = shorten([f"{n + 1}: {c.describe()}" for n, c in enumerate(contours)])
    if selector is None:
        if len(contours) == 1:
            return 0
        raise PathFormatError(f"{path}: {len(contours)} contours ({listing}); pick one with "
                              f"{path}#HANDLE, #layer=NAME or #path=N")
    key, _, value = selector.partition("=")
    key = key.strip().lower() if value else "handle"
    value = (value if value else selector).strip()
    if key == "handle":
        hits = [n for n, c in enumerate(contours) if value.upper() in (h.upper() for h in c.handles)]
        if not hits:
            raise PathFormatError(f"{path}#{selector}: no contour holds an entity with handle {value}; "
                                  f"contours: {listing}")
    elif key == "layer":
        hits = [n for n, c in enumerate(contours) if c.layer.lower() == value.lower()]
        if not hits:
            raise PathFormatError(f"{path}#{selector}: no contour on layer {value!r}; contours: {listing}")
    elif key == "path":
        return pick_by_index(path, selector, [f"{n + 1}" for n in range(len(contours))])
    else:
        raise PathFormatError(f"{path}#{selector}: unknown selector {key!r}; use HANDLE, handle=H, "
                              "layer=NAME or path=N")
    if len(hits) > 1:
        raise PathFormatError(f"{path}#{selector}: {len(hits)} contours match "
                              f"({shorten([f'path={n + 1}' for n in hits])}); pick one with #path=N")
    return hits[0]


def load_dxf(path: str | os.PathLike, selector: str | None = None):
    """One contour of a drawing: the only one, or the one ``selector`` names."""
    path = Path(path)
    contours, units = _contours(path)
    try:
        index = select_contour(path, contours, selector)
    except PathFormatError as exc:                # a gap may be what splits the contour: say so
        gaps = [c.problem for c in contours if c.problem is not None]
        if gaps:
            raise PathFormatError(f"{exc}; {gaps[0]}") from None
        raise
    return _contour_shape(_gap_notice(contours[index]), path, units, _names(path, contours)[index])
