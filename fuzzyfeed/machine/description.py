"""A machine description: one TOML file (``--machine FILE``) every command reads the same way.

It holds what decides whether slowing down is needed (DESIGN §3, "Advice on a machine"): the axis
limits, the axis servo, the controller's own corner handling and look-ahead, and the contour
tolerance the part must hold. Every key carries its unit in its name::

    name = "LinuxCNC mill"                    # optional; default: the file's stem
    source = "..."                            # optional: where the figures come from

    [axes]                                    # one value for all axes, or [x, y, z]
    max_velocity_mm_s = 250.0
    max_acceleration_mm_s2 = [1500.0, 1500.0, 800.0]
    max_jerk_mm_s3 = 20000.0                  # tangential jerk (SLW scheduler)
    path_acceleration_mm_s2 = 1000.0          # optional: the limit along the path (default: the
                                              # slowest axis's)

    [servo]                                   # first order: kv_1_s (or kv_m_min_mm);
    kv_1_s = 30.0                             # second order: natural_freq_hz (+ damping)
    feedforward = 0.0                         # velocity feed-forward fraction 0..1

    [controller]
    acceleration = "path"                     # "path": a limit along the path (LinuxCNC); "axes":
                                              # each axis within its own only (GRBL: a diagonal is faster)
    corner = "junction-deviation"             # GRBL ($11) or "path-tolerance" (LinuxCNC G64 P)
    junction_deviation_mm = 0.01              # the corner setting, whichever kind (also path_tolerance_mm)
    chord_tolerance_mm = 0.002                # arcs followed as chords within this (GRBL $12)
    lookahead_moves = 0                       # planner buffer in moves; 0 = unlimited (GRBL: 16)
    period_s = 0.001                          # interpolation (servo) period Ts

    [part]
    contour_tolerance_um = 50.0

Fields not given take the defaults of :class:`Machine` (the reference machine of issue 32).
Unknown keys, keys without a unit, values that are not finite and positive: one
:class:`~fuzzyfeed.errors.MachineLimitsError` line naming the file, the line, the key and the rule.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from fuzzyfeed.base.files import read_text, resolve_file, shipped_names
from fuzzyfeed.base.toml_lines import KeyLines, Locator, file_locator, load_toml
from fuzzyfeed.errors import MachineLimitsError
from fuzzyfeed.machine.limits import (AXES, DEFAULT_AXIS_ACC_MM_S2, DEFAULT_AXIS_VEL_MM_S, DEFAULT_JERK_MM_S3,
                                      DEFAULT_TS_S, MAX_LIMIT, MachineLimits)
from fuzzyfeed.machine.servo import ServoModel

CORNER_KINDS = ("junction-deviation", "path-tolerance")
ACCELERATION_KINDS = ("path", "axes")
DEFAULT_CORNER_MM = 0.01
DEFAULT_CHORD_TOLERANCE_MM = 0.002
DEFAULT_CONTOUR_TOLERANCE_UM = 50.0

#: section -> key -> (Machine field, kind); kind: "axes" (scalar or 3), "pos" (> 0), "frac" (0..1),
#: "int" (integer >= 0), "corner" (one of CORNER_KINDS), "text"
SCHEMA: dict[str, dict[str, tuple[str, str]]] = {
    "": {"name": ("name", "text"), "source": ("source", "text")},
    "axes": {"max_velocity_mm_s": ("axis_vel_mm_s", "axes"),
             "max_acceleration_mm_s2": ("axis_acc_mm_s2", "axes"),
             "max_jerk_mm_s3": ("jerk_mm_s3", "pos"),
             "path_acceleration_mm_s2": ("path_acc_mm_s2", "pos")},
    "servo": {"kv_1_s": ("servo", "servo"), "kv_m_min_mm": ("servo", "servo"),
              "natural_freq_hz": ("servo", "servo"), "damping": ("servo", "servo"),
              "feedforward": ("servo", "servo")},
    "controller": {"corner": ("corner", "corner"), "acceleration": ("acceleration", "acceleration"),
                   "junction_deviation_mm": ("corner_mm", "pos"),
                   "path_tolerance_mm": ("corner_mm", "pos"),
                   "chord_tolerance_mm": ("chord_tol_mm", "pos"),
                   "lookahead_moves": ("lookahead_moves", "int"),
                   "period_s": ("ts_s", "pos")},
    "part": {"contour_tolerance_um": ("contour_tol_um", "pos")},
}
#: Unit suffixes a key may end in; a known key given without its unit is named with it.
_UNITS = ("_mm_s2", "_mm_s3", "_mm_s", "_mm_min", "_mm", "_um", "_1_s", "_hz", "_s", "_m_min_mm")


def _positive(name: str, value: object, where: str = "") -> float:
    prefix = f"{where}: " if where else ""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise MachineLimitsError(f"{prefix}{name} = {value!r}; must be a finite number > 0")
    v = float(value)
    if not math.isfinite(v) or v <= 0.0:
        raise MachineLimitsError(f"{prefix}{name} = {value!r}; must be a finite number > 0")
    if v > MAX_LIMIT:
        raise MachineLimitsError(f"{prefix}{name} = {value!r}; must be at most {MAX_LIMIT:g}")
    return v


def _axes(name: str, value: object, where: str = "") -> tuple[float, float, float]:
    if isinstance(value, (list, tuple, np.ndarray)):
        items = list(value)
        if len(items) != 3:
            prefix = f"{where}: " if where else ""
            raise MachineLimitsError(f"{prefix}{name} = {items!r}; give one value for all axes or "
                                     "exactly 3 (x, y, z)")
        return tuple(_positive(f"{name}[{a}]", v, where) for a, v in zip(AXES, items))  # type: ignore[return-value]
    v = _positive(name, value, where)
    return (v, v, v)


@dataclass(frozen=True)
class Machine:
    """A machine and the tolerance its parts must hold, validated at construction.

    ``axis_vel_mm_s``, ``axis_acc_mm_s2`` per axis (x, y, z; a scalar applies to all);
    ``jerk_mm_s3`` tangential jerk (the SLW scheduler's); ``acceleration`` how the planner limits
    a move's acceleration: ``"path"`` at most ``path_acc_mm_s2`` along the path (None: the slowest
    axis's limit) and every axis within its own, or ``"axes"`` every axis within its own only
    (GRBL: a diagonal accelerates faster); ``servo`` the axis loops;
    ``corner`` how the controller takes a corner between two moves — ``"junction-deviation"``
    (GRBL ``$11``: v² = a·δ·sin(θ/2)/(1 − sin(θ/2))) or ``"path-tolerance"`` (LinuxCNC ``G64 P``:
    the same speed on a blend arc that leaves the corner by at most δ) — with δ = ``corner_mm``;
    ``chord_tol_mm`` arcs are followed as chords within it; ``lookahead_moves`` the planner's buffer
    (0: unlimited); ``ts_s`` the interpolation period; ``contour_tol_um`` the part's tolerance.
    """

    name: str = "reference"
    axis_vel_mm_s: tuple[float, float, float] = (DEFAULT_AXIS_VEL_MM_S,) * 3
    axis_acc_mm_s2: tuple[float, float, float] = (DEFAULT_AXIS_ACC_MM_S2,) * 3
    jerk_mm_s3: float = DEFAULT_JERK_MM_S3
    path_acc_mm_s2: float | None = None
    acceleration: str = "path"
    servo: ServoModel = field(default_factory=ServoModel)
    corner: str = "junction-deviation"
    corner_mm: float = DEFAULT_CORNER_MM
    chord_tol_mm: float = DEFAULT_CHORD_TOLERANCE_MM
    lookahead_moves: int = 0
    ts_s: float = DEFAULT_TS_S
    contour_tol_um: float = DEFAULT_CONTOUR_TOLERANCE_UM
    source: str = ""
    path: Path | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "axis_vel_mm_s", _axes("axis_vel_mm_s", self.axis_vel_mm_s))
        object.__setattr__(self, "axis_acc_mm_s2", _axes("axis_acc_mm_s2", self.axis_acc_mm_s2))
        for name in ("jerk_mm_s3", "corner_mm", "chord_tol_mm", "ts_s", "contour_tol_um"):
            object.__setattr__(self, name, _positive(name, getattr(self, name)))
        if self.path_acc_mm_s2 is not None:
            object.__setattr__(self, "path_acc_mm_s2", _positive("path_acc_mm_s2", self.path_acc_mm_s2))
        if self.acceleration not in ACCELERATION_KINDS:
            raise MachineLimitsError(f"acceleration = {self.acceleration!r}; must be one of "
                                     f"{', '.join(repr(k) for k in ACCELERATION_KINDS)}")
        if self.corner not in CORNER_KINDS:
            raise MachineLimitsError(f"corner = {self.corner!r}; must be one of "
                                     f"{', '.join(repr(k) for k in CORNER_KINDS)}")
        if not isinstance(self.servo, ServoModel):
            raise MachineLimitsError(f"servo = {self.servo!r}; expected a ServoModel")
        look = self.lookahead_moves
        if isinstance(look, bool) or not isinstance(look, (int, np.integer)) or look < 0 or look == 1:
            raise MachineLimitsError(f"lookahead_moves = {look!r}; must be an integer >= 2, or 0 "
                                     "for an unlimited look-ahead")
        if self.ts_s > 0.1:
            raise MachineLimitsError(f"ts_s = {self.ts_s!r} s; an interpolation period longer than "
                                     "0.1 s is not one (give seconds, e.g. 0.001)")
        if self.chord_tol_mm > 1.0:
            raise MachineLimitsError(f"chord_tol_mm = {self.chord_tol_mm!r}; arcs are followed as "
                                     "chords within at most 1 mm")

    # ---------------------------------------------------------------------------------------
    @property
    def contour_tol_mm(self) -> float:
        return self.contour_tol_um * 1e-3

    @property
    def path_limit_mm_s2(self) -> float | None:
        """The limit along the path (None when only the axes limit a move)."""
        if self.acceleration == "axes":
            return None
        return min(self.axis_acc_mm_s2) if self.path_acc_mm_s2 is None else self.path_acc_mm_s2

    @property
    def tangential_acc_mm_s2(self) -> float:
        """The acceleration the planner allows whatever the direction: the path limit and the
        slowest axis."""
        a = min(self.axis_acc_mm_s2)
        cap = self.path_limit_mm_s2
        return a if cap is None else min(a, cap)

    def move_acceleration(self, unit: np.ndarray) -> np.ndarray:
        """Largest tangential acceleration (mm/s²) along each unit direction (N, 3): every axis
        within its limit, |a·u_j| ≤ A_j (GRBL's ``limit_value_by_axis_maximum``), and the path
        limit unless ``acceleration = "axes"``."""
        return self._along(np.asarray(self.axis_acc_mm_s2), unit, self.path_limit_mm_s2)

    def move_velocity(self, unit: np.ndarray) -> np.ndarray:
        """Largest speed (mm/s) along each unit direction: every axis within its velocity limit."""
        return self._along(np.asarray(self.axis_vel_mm_s), unit, None)

    def speed_along(self, points: np.ndarray) -> np.ndarray:
        """Largest speed (mm/s) on each segment of a polyline ``points`` (N, 3): :meth:`move_velocity`
        along its direction (the slowest axis's on a segment of zero length)."""
        d = np.diff(np.asarray(points, dtype=float), axis=0)
        norm = np.linalg.norm(d, axis=1)
        unit = np.divide(d, norm[:, None], out=np.zeros_like(d), where=norm[:, None] > 0)
        return self.move_velocity(unit)

    @staticmethod
    def _along(per_axis: np.ndarray, unit: np.ndarray, cap: float | None) -> np.ndarray:
        """min_j A_j / |u_j| over the axes with |u_j| > 1e-12 (the slowest axis's A where none is)."""
        u = np.abs(np.asarray(unit, dtype=float))
        if u.ndim == 2 and u.shape[1] and per_axis.size == u.shape[1] and (per_axis == per_axis[0]).all():
            # every axis the same A: A / max_j |u_j|, the same floats (a correctly rounded A / x does
            # not grow with x); fmax skips a NaN as the test below does
            top = u[:, 0].copy()
            for j in range(1, u.shape[1]):
                np.fmax(top, u[:, j], out=top)
            a = per_axis[0]
            with np.errstate(divide="ignore", invalid="ignore"):
                out = np.where(top > 1e-12, a / top, a)
            return out if cap is None else np.minimum(out, cap)
        with np.errstate(divide="ignore"):
            each = np.where(u > 1e-12, per_axis[None, :] / u, np.inf)
        # the least of the columns (np.min over a 3-wide axis is ~5x slower; min is exact: the same floats)
        out = each[:, 0].copy() if each.shape[1] else np.full(each.shape[0], np.inf)
        for j in range(1, each.shape[1]):
            np.minimum(out, each[:, j], out=out)
        out = np.where(np.isfinite(out), out, per_axis.min())
        return out if cap is None else np.minimum(out, cap)

    def limits(self, feed_mm_s: float, chord_tol_mm: float | None = None) -> MachineLimits:
        """The scheduler's :class:`MachineLimits` at command feed ``feed_mm_s``."""
        return MachineLimits(feed_mm_s=feed_mm_s, axis_vel_mm_s=self.axis_vel_mm_s,
                             axis_acc_mm_s2=self.axis_acc_mm_s2, jerk_mm_s3=self.jerk_mm_s3,
                             chord_tol_mm=self.chord_tol_mm if chord_tol_mm is None else chord_tol_mm,
                             ts_s=self.ts_s)

    def describe(self) -> str:
        def axes(v):
            return f"{v[0]:g}" if len(set(v)) == 1 else ",".join(f"{x:g}" for x in v)
        corner = (f"junction deviation {self.corner_mm:g} mm" if self.corner == "junction-deviation"
                  else f"path tolerance (G64 P) {self.corner_mm:g} mm")
        cap = self.path_limit_mm_s2
        path_acc = " (each axis on its own)" if cap is None else f", path {cap:g} mm/s^2"
        look = "unlimited" if self.lookahead_moves == 0 else f"{self.lookahead_moves} moves"
        return (f"machine {self.name!r}: axes {axes(self.axis_vel_mm_s)} mm/s, "
                f"{axes(self.axis_acc_mm_s2)} mm/s^2{path_acc}; servo {self.servo.describe()}; "
                f"{corner}, arcs as chords within {self.chord_tol_mm * 1e3:g} um, look-ahead {look}, "
                f"Ts {self.ts_s * 1e3:g} ms; contour tolerance {self.contour_tol_um:g} um")

    def as_dict(self) -> dict[str, object]:
        servo = self.servo
        out: dict[str, object] = {
            "name": self.name, "axis_vel_mm_s": list(self.axis_vel_mm_s),
            "axis_acc_mm_s2": list(self.axis_acc_mm_s2), "jerk_mm_s3": self.jerk_mm_s3,
            "path_acc_mm_s2": self.path_limit_mm_s2, "acceleration": self.acceleration, "servo_kv_1_s": list(servo.kv_1_s),
            "servo_feedforward": list(servo.feedforward), "corner": self.corner,
            "corner_mm": self.corner_mm, "chord_tol_mm": self.chord_tol_mm,
            "lookahead_moves": self.lookahead_moves, "ts_s": self.ts_s,
            "contour_tol_um": self.contour_tol_um}
        if servo.order == 2:
            out["servo_natural_freq_hz"] = list(servo.natural_freq_hz)  # type: ignore[arg-type]
            out["servo_damping"] = list(servo.damping)
        return out


# -------------------------------------------------------------------------------------------
# files

def machine_names() -> list[str]:
    """Names of the shipped machine files (``machines/*.toml``), sorted."""
    return shipped_names("machines", MachineLimitsError)


def load_machine(spec: str | os.PathLike) -> Machine:
    """Load and validate a machine file: a shipped name (``fuzzyfeed machines``) or a path."""
    if not isinstance(spec, (str, os.PathLike)):
        raise MachineLimitsError(f"machine: {type(spec).__name__} {spec!r:.40}; expected a name or a file path")
    path = resolve_file(spec, "machines", "machine", MachineLimitsError)
    return parse_machine(read_text(path, "machine", MachineLimitsError), path)


def parse_machine(text: str, path: str | os.PathLike = "<machine>") -> Machine:
    """Parse and validate machine TOML text; messages name ``path``, the line and the key."""
    path = Path(path)
    lines = KeyLines(text)
    for section, key, first, again in lines.duplicates:
        raise MachineLimitsError(f"{path}:{again}: key {key!r} given twice in "
                                 f"[{section or 'top level'}] (first at line {first}); give it once")
    data = load_toml(text, path, MachineLimitsError, "a machine file")
    return machine_from_mapping(data, file_locator(path, lines), path)


def _unknown_key(section: str, key: str, where: Locator) -> MachineLimitsError:
    known = SCHEMA[section]
    stem_matches = [k for k in known if any(k == key + u for u in _UNITS)]
    at = where(section, key)
    if stem_matches:
        return MachineLimitsError(f"{at}: key {key!r} has no unit; write {stem_matches[0]!r} "
                                  "(every value carries its unit in its name)")
    label = f"[{section}]" if section else "the top level"
    return MachineLimitsError(f"{at}: unknown key {key!r} in {label}; it takes "
                              f"{', '.join(sorted(known))}")


def machine_from_mapping(data: Mapping, where: Locator | None = None, path: Path | None = None) -> Machine:
    """A :class:`Machine` from parsed TOML (see the module docstring)."""
    where = where or (lambda section, key=None: f"machine: [{section}]" + (f".{key}" if key else ""))
    fields: dict[str, object] = {}
    servo_keys: dict[str, object] = {}
    seen_corner_key: str | None = None
    for key, value in data.items():
        if isinstance(value, Mapping):
            if key not in SCHEMA or key == "":
                raise MachineLimitsError(f"{where(key)}: unknown section [{key}]; a machine file has "
                                         "[axes], [servo], [controller] and [part]")
            items = value.items()
            section = key
        else:
            items = [(key, value)]
            section = ""
        for k, v in items:
            if k not in SCHEMA[section]:
                raise _unknown_key(section, k, where)
            target, kind = SCHEMA[section][k]
            at = where(section, k)
            if kind == "text":
                if not isinstance(v, str):
                    raise MachineLimitsError(f"{at}: {k} = {v!r}; must be a string")
                fields[target] = v
            elif kind == "axes":
                fields[target] = _axes(k, v, at)
            elif kind == "pos":
                if target == "corner_mm":
                    if seen_corner_key is not None:
                        raise MachineLimitsError(f"{at}: {k} and {seen_corner_key} both given; the "
                                                 "controller takes corners one way, give one")
                    seen_corner_key = k
                fields[target] = _positive(k, v, at)
            elif kind == "int":
                if isinstance(v, bool) or not isinstance(v, int) or v < 0 or v == 1:
                    raise MachineLimitsError(f"{at}: {k} = {v!r}; must be an integer >= 2, or 0 for "
                                             "an unlimited look-ahead")
                fields[target] = v
            elif kind == "acceleration":
                if v not in ACCELERATION_KINDS:
                    raise MachineLimitsError(f"{at}: {k} = {v!r}; must be one of "
                                             f"{', '.join(repr(c) for c in ACCELERATION_KINDS)}")
                fields[target] = v
            elif kind == "corner":
                if v not in CORNER_KINDS:
                    raise MachineLimitsError(f"{at}: {k} = {v!r}; must be one of "
                                             f"{', '.join(repr(c) for c in CORNER_KINDS)}")
                fields[target] = v
            else:  # servo
                servo_keys[k] = (v, at)
    if seen_corner_key is not None and "corner" not in fields:
        fields["corner"] = "path-tolerance" if seen_corner_key == "path_tolerance_mm" else "junction-deviation"
    if "corner" in fields and seen_corner_key is not None:
        expected = "path_tolerance_mm" if fields["corner"] == "path-tolerance" else "junction_deviation_mm"
        if seen_corner_key != expected:
            raise MachineLimitsError(f"{where('controller', seen_corner_key)}: {seen_corner_key} with "
                                     f"corner = {fields['corner']!r}; that corner kind takes {expected}")
    if servo_keys:
        fields["servo"] = _servo_from_keys(servo_keys)
    if "name" not in fields:
        fields["name"] = path.stem if path is not None else "machine"
    try:
        return Machine(**fields, path=path)  # type: ignore[arg-type]
    except MachineLimitsError as exc:
        message = str(exc)
        for section, keys in SCHEMA.items():         # name the file's key, not the field
            for key, (target, _) in keys.items():
                if message.startswith(f"{target} ") and (section, key) in _given(data):
                    raise MachineLimitsError(f"{where(section, key)}: {key}{message[len(target):]}") from None
        raise MachineLimitsError(f"{path or 'machine'}: {message}") from None


def _given(data: Mapping) -> set[tuple[str, str]]:
    """(section, key) of every key the file gives."""
    out = set()
    for key, value in data.items():
        if isinstance(value, Mapping):
            out |= {(key, k) for k in value}
        else:
            out.add(("", key))
    return out


def _servo_from_keys(keys: dict[str, tuple[object, str]]) -> ServoModel:
    def value(k):
        v, at = keys[k]
        if isinstance(v, list):
            return v
        return v
    at_any = next(iter(keys.values()))[1]
    gains = [k for k in ("kv_1_s", "kv_m_min_mm", "natural_freq_hz") if k in keys]
    if len(gains) > 1:
        raise MachineLimitsError(f"{keys[gains[1]][1]}: {gains[0]} and {gains[1]} both given; give the "
                                 "loop's gain one way")
    kwargs: dict[str, object] = {}
    if "feedforward" in keys:
        kwargs["feedforward"] = value("feedforward")
    if "damping" in keys:
        if "natural_freq_hz" not in keys:
            raise MachineLimitsError(f"{keys['damping'][1]}: damping without natural_freq_hz; damping "
                                     "belongs to a second-order loop")
        kwargs["damping"] = value("damping")
    try:
        if "kv_m_min_mm" in keys:
            return ServoModel.from_kv_m_min_mm(value("kv_m_min_mm"), **kwargs)
        if "natural_freq_hz" in keys:
            return ServoModel(natural_freq_hz=value("natural_freq_hz"), **kwargs)
        return ServoModel(kv_1_s=value("kv_1_s") if "kv_1_s" in keys else None, **kwargs)
    except MachineLimitsError as exc:
        first = keys[gains[0]][1] if gains else at_any
        raise MachineLimitsError(f"{first.split(': [')[0]}: [servo] {exc}") from None


def with_overrides(machine: Machine, **changes) -> Machine:
    """``machine`` with the fields in ``changes`` that are not None replaced (validated)."""
    given = {k: v for k, v in changes.items() if v is not None}
    return replace(machine, **given) if given else machine
