"""Shape files: one editable text file per NURBS tool path (TOML, or JSON in geomdl's style).

Fields: ``name``, ``units`` ("mm" or "inch"; inches are converted to mm on load), ``source``,
``notes`` (optional), ``degree``, ``knotvector`` (alias ``knots``), ``control_points`` and
``weights`` (optional, default 1). geomdl's JSON exchange layout
``{"shape": {"data": [{"degree", "knotvector", "control_points": {"points", "weights"}}]}}`` loads
as well. A SHAPE argument is a shipped shape's name (see :func:`shape_names`) or a file path; DXF
(:mod:`fuzzyfeed.io.dxf`), G-code (:mod:`fuzzyfeed.io.gcode`) and CSV point lists
(:mod:`fuzzyfeed.io.points`) load as paths too, with ``FILE#SELECTOR`` to pick one of several.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from fuzzyfeed.base.files import read_text, resolve_file, shipped_dir, shipped_names
from fuzzyfeed.base.toml_lines import load_toml
from fuzzyfeed.errors import NurbsError, ShapeFileError
from fuzzyfeed.program.model import GCODE_SUFFIXES
from fuzzyfeed.io.shape import Shape
from fuzzyfeed.geometry.nurbs import Nurbs, non_number
from fuzzyfeed.geometry.sampling import DEFAULT_POINTS, PathSamples, sample_uniform_u, samples_from_points

#: Units a shape file may declare, with the factor that converts them to mm.
UNIT_TO_MM = {"mm": 1.0, "inch": 25.4, "in": 25.4}


def shapes_dir() -> Path:
    """Folder of the shipped shapes: inside the installed package, or the repository's shapes/."""
    return shipped_dir("shapes", ShapeFileError)


def shape_names() -> list[str]:
    """Names of the shipped shapes, sorted."""
    return shipped_names("shapes", ShapeFileError)


def sample_shape(shape: Shape, points: int = DEFAULT_POINTS, max_step_mm: float | None = None) -> PathSamples:
    """The planners' samples of a shape: ``points`` uniform in u for a NURBS (seed 002); for a
    polyline the vertices themselves with the curvature of the path they describe
    (:func:`fuzzyfeed.geometry.sampling.samples_from_points`), with samples added inside segments longer
    than ``max_step_mm`` if given."""
    if not isinstance(shape, Shape):
        raise ShapeFileError(f"shape: {type(shape).__name__} {shape!r:.40}; expected a Shape (load_shape)")
    if shape.polyline is not None:
        return samples_from_points(shape.polyline, shape.curve, max_step_mm=max_step_mm,
                                   where=shape.name if shape.path is None else f"{shape.path} ({shape.name})")
    return sample_uniform_u(shape.curve, points)


def resolve_shape_path(spec: str | Path) -> Path:
    """Turn a SHAPE argument (shipped name or path) into an existing file path."""
    return resolve_file(spec, "shapes", "shape", ShapeFileError)


def split_selector(spec: str | Path) -> tuple[str | Path, str | None]:
    """Split ``FILE#SELECTOR`` (see :data:`SELECTOR_HELP`); an existing path is never split."""
    if isinstance(spec, Path) or Path(spec).exists() or "#" not in str(spec):
        return spec, None
    base, selector = str(spec).rsplit("#", 1)
    return base, selector


def load_shape(spec: str | Path) -> Shape:
    """Load a SHAPE: a shipped name, a .toml/.json shape file, or a DXF, G-code or CSV point file,
    optionally followed by ``#SELECTOR`` to pick one path of a file that holds several."""
    if not isinstance(spec, (str, os.PathLike)):
        raise ShapeFileError(f"shape: {type(spec).__name__} {spec!r:.40}; expected a name or a file path")
    base, selector = split_selector(spec)
    path = resolve_shape_path(base)
    loader = _LOADERS.get(path.suffix.lower())
    if loader is None:
        raise ShapeFileError(f"{path}: unsupported file type {path.suffix!r}; "
                             f"shape files are {', '.join(sorted(_LOADERS))}")
    if selector is not None:
        if path.suffix.lower() in (".toml", ".json"):
            raise ShapeFileError(f"{spec}: a shape file holds one curve; '#{selector}' selects a "
                                 "path only in DXF, G-code and CSV files")
        return loader(path, selector)
    return loader(path)


def load_shapes(spec: str | Path) -> list[Shape]:
    """Every path in a file (DXF entities, G-code chains), or the one shape of any other SHAPE."""
    base, selector = split_selector(spec)
    if selector is None:
        path = resolve_shape_path(base)
        many = _MULTI_LOADERS.get(path.suffix.lower())
        if many is not None:
            return many(path)
    return [load_shape(spec)]


def _read_text(path: Path) -> str:
    return read_text(path, "shape", ShapeFileError)


def _load_toml(path: Path) -> Shape:
    return shape_from_mapping(load_toml(_read_text(path), path, ShapeFileError, "a shape file"), path)


def _load_json(path: Path) -> Shape:
    try:
        data = json.loads(_read_text(path))
    except json.JSONDecodeError as exc:
        raise ShapeFileError(f"{path}:{exc.lineno}: invalid JSON: {exc.msg}") from None
    except RecursionError:
        raise ShapeFileError(f"{path}: nested too deeply to be a shape file") from None
    if isinstance(data, dict) and isinstance(data.get("shape"), dict):  # geomdl exchange layout
        items = data["shape"].get("data") or []
        if len(items) != 1 or not isinstance(items[0], dict):
            raise ShapeFileError(f"{path}: shape.data must hold exactly one curve, found {len(items)}")
        item = dict(items[0])
        cp = item.get("control_points")
        if isinstance(cp, dict):
            item["control_points"] = cp.get("points")
            if "weights" in cp:
                item["weights"] = cp["weights"]
        item.setdefault("name", item.get("name") or path.stem)
        data = item
    return shape_from_mapping(data, path)


def shape_from_mapping(data: object, path: Path | None = None) -> Shape:
    """Build a :class:`Shape` from parsed file contents; errors name the file and the field."""
    where = str(path) if path is not None else "shape"
    if not isinstance(data, dict):
        raise ShapeFileError(f"{where}: expected a table of fields, found {type(data).__name__}")
    knots = data.get("knotvector", data.get("knots"))
    for key, value in (("degree", data.get("degree")), ("knotvector", knots),
                       ("control_points", data.get("control_points"))):
        if value is None:
            raise ShapeFileError(f"{where}: field '{key}' is missing")
    units = data.get("units", "mm")
    for key in ("name", "units", "source", "notes"):
        if key in data and not isinstance(data[key], str):
            raise ShapeFileError(f"{where}: {key} = {data[key]!r:.40}; must be a string")
    for key in ("degree", "knotvector", "control_points", "weights"):
        bad = non_number(knots if key == "knotvector" else data.get(key))
        if bad is not None:
            if key == "control_points":
                raise ShapeFileError(f"{where}: control_points must be a list of [x, y] or [x, y, z] "
                                     f"numbers; found {bad!r}")
            raise ShapeFileError(f"{where}: {key}: {bad!r} is not a number")
    if units not in UNIT_TO_MM:
        raise ShapeFileError(f"{where}: units = {units!r}; use one of {', '.join(UNIT_TO_MM)}")
    try:
        points = np.array(data["control_points"], dtype=float) * UNIT_TO_MM[units]
    except (TypeError, ValueError):
        raise ShapeFileError(f"{where}: control_points must be a list of [x, y] or [x, y, z] numbers") from None
    try:
        curve = Nurbs(data["degree"], knots, points, data.get("weights"))
    except NurbsError as exc:
        raise ShapeFileError(f"{where}: {exc}") from None
    name = data.get("name") or (path.stem if path is not None else "shape")
    return Shape(name=str(name), curve=curve, source=str(data.get("source", "")),
                 notes=str(data.get("notes", "")), path=path)


def shape_to_toml(shape: Shape) -> str:
    """TOML text of a shape in the shipped layout (full float precision)."""
    c = shape.curve

    def num(v: float) -> str:
        return repr(float(v))

    lines = [f"name = {json.dumps(shape.name)}", 'units = "mm"', f"source = {json.dumps(shape.source)}"]
    if shape.notes:
        lines.append(f"notes = {json.dumps(shape.notes)}")
    lines += [f"degree = {c.degree}",
              "knotvector = [" + ", ".join(num(k) for k in c.knots) + "]",
              "weights = [" + ", ".join(num(w) for w in c.weights) + "]",
              "control_points = ["]
    lines += ["  [" + ", ".join(num(x) for x in p) + "]," for p in c.control_points]
    lines.append("]")
    return "\n".join(lines) + "\n"


#: How to pick one path of a file that holds several (shown in the CLI's SHAPE help).
SELECTOR_HELP = ("FILE#SELECTOR picks one path of a file with several: DXF FILE#HANDLE, "
                 "FILE#handle=H, FILE#layer=NAME or FILE#path=N; G-code (one path per chain of "
                 "G1/G5.2 moves between G0 rapids) FILE#N or FILE#path=N")


def _load_gcode(path: Path, selector: str | None = None) -> Shape:
    from fuzzyfeed.io.gcode_paths import load_gcode
    return load_gcode(path, selector)


def _load_gcode_all(path: Path) -> list[Shape]:
    from fuzzyfeed.io.gcode_paths import load_gcode_shapes
    return load_gcode_shapes(path)


def _load_dxf(path: Path, selector: str | None = None) -> Shape:
    from fuzzyfeed.io.dxf import load_dxf
    return load_dxf(path, selector)


def _load_dxf_all(path: Path) -> list[Shape]:
    from fuzzyfeed.io.dxf import load_dxf_shapes
    return load_dxf_shapes(path)


def _load_csv(path: Path, selector: str | None = None) -> Shape:
    from fuzzyfeed.io.points import load_points_csv
    return load_points_csv(path, selector)


_LOADERS = {".toml": _load_toml, ".json": _load_json, ".dxf": _load_dxf, ".csv": _load_csv,
            **{suffix: _load_gcode for suffix in GCODE_SUFFIXES}}
_MULTI_LOADERS = {".dxf": _load_dxf_all, **{suffix: _load_gcode_all for suffix in GCODE_SUFFIXES}}
