"""What an advice is asked for, as one frozen value: :class:`AdviceOptions`.

Every field is one flag of ``fuzzyfeed advise`` (its Python name: ``--feed-step-mm-min`` is
``feed_step_mm_min``; ``--no-reference`` is ``reference=False``), checked when the value is made,
with the one-line errors the command gives. The rule table and the machine are read then too (a
shipped name, a file, or the value itself), so a bad one is refused before any work and the value
can be pickled to a worker as it is.
"""

from __future__ import annotations

import contextlib
import math
import numbers
import os
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

from fuzzyfeed.errors import InputError, MachineLimitsError

#: Values the choice fields take.
FILTERS = ("corner-mean", "min-mean", "mean", "none")
UNITS = ("mm", "inch", "m")
TOOL_UNITS = ("mm", "inch")

#: Fields that apply to drawings and shapes only (a program refuses them when not at their default).
DRAWING_ONLY = ("units", "points", "rule_strengths")
#: Fields that apply to programs only, and the G-code export of a shape: a drawing's batch run drops them.
PROGRAM_ONLY = ("step_mm", "reference", "tool_table", "tool_units", "safe_z_mm", "plunge_feed_mm_min",
                "feed_step_mm_min", "line_numbers", "gcode_decimals", "g52_whole", "verify_rs274")


def _flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def _number(name: str, value):
    """A finite number > 0 (at most MAX_LIMIT), as ``--NAME`` accepts it; one line otherwise."""
    given = value
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise InputError(f"{_flag(name)}: {value!r} is not a number") from None
    value = float(value)
    if not math.isfinite(value) or value <= 0:
        raise InputError(f"{_flag(name)}: {given!r} must be a finite number > 0")
    from fuzzyfeed.machine.limits import MAX_LIMIT

    if value > MAX_LIMIT:
        raise InputError(f"{_flag(name)}: {given!r} is too large; at most {MAX_LIMIT:g}")
    return value


def _count(name: str, value, minimum: int, maximum: int, unit: str) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        else:
            raise InputError(f"{_flag(name)}: {value!r} is not an integer")
    if value < minimum:
        raise InputError(f"{_flag(name)}: {value} is too few; use at least {minimum} {unit}")
    if value > maximum:
        raise InputError(f"{_flag(name)}: {value} is too many; use at most {maximum:,} {unit}")
    return int(value)


def _choice(name: str, value, choices: tuple[str, ...]):
    if value not in choices:
        raise InputError(f"{_flag(name)}: invalid choice: {value!r} (choose from "
                         f"{', '.join(repr(c) for c in choices)})")
    return value


def check_feed_mm_min(value: float) -> float:
    """The --feed-mm-min value, or a one-line MachineLimitsError (the command's own words)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise MachineLimitsError(f"--feed-mm-min = {value!r}; the maximum feed must be a number in mm/min")
    value = float(value)
    if not math.isfinite(value) or value <= 0:
        raise MachineLimitsError(f"--feed-mm-min = {value:g}; the maximum feed must be a finite "
                                 "number > 0 mm/min")
    from fuzzyfeed.machine.limits import MAX_LIMIT

    if value > MAX_LIMIT:
        raise MachineLimitsError(f"--feed-mm-min = {value:g}; the maximum feed must be at most "
                                 f"{MAX_LIMIT:g} mm/min")
    return value


def _default_points() -> int:
    from fuzzyfeed.geometry.sampling import DEFAULT_POINTS

    return DEFAULT_POINTS


@dataclass(frozen=True)
class AdviceOptions:
    """How to advise a program, a drawing or a shape (``fuzzyfeed advise``'s flags, output files
    apart). ``rules``: a shipped table's name, a .toml file or a :class:`~fuzzyfeed.fuzzy.rules.
    RuleTable` (default: the paper's; with a machine, the machine table). ``machine``: a shipped
    machine's name, a file or a :class:`~fuzzyfeed.machine.description.Machine` (read here; None:
    no machine). ``feed_mm_min``: a shape's F, a program's cap on its own F. ``reference=False``
    leaves the limit reference out of a program's value report. The others: see
    ``fuzzyfeed advise --help``."""

    rules: object = None
    machine: object = None
    feed_mm_min: float | None = None
    feed_step_mm_min: float | None = None
    step_mm: float | None = None
    points: int = field(default_factory=_default_points)
    filter: str | None = None
    window_mm: float | None = None
    filter_mm: float | None = None
    rule_strengths: bool = False
    reference: bool = True
    units: str | None = None
    point_tolerance: float | None = None
    path_tolerance: float | None = None
    tool_table: str | None = None
    tool_units: str = "mm"
    safe_z_mm: float | None = None
    plunge_feed_mm_min: float | None = None
    line_numbers: bool = False
    gcode_decimals: int = 4
    g52_whole: bool = False
    #: read the rewritten program with LinuxCNC's rs274 (on PATH) and the same tool table; lines it
    #: refuses or whose moves it changes keep their text (:mod:`fuzzyfeed.program.verify`)
    verify_rs274: bool = False
    #: the rule table with filter/window_mm/filter_mm applied (read at construction)
    table: object = field(init=False, repr=False, compare=False, default=None)

    def __post_init__(self):
        from fuzzyfeed.geometry.sampling import MAX_POINTS

        put = object.__setattr__
        for name in ("step_mm", "window_mm", "filter_mm", "point_tolerance", "path_tolerance",
                     "feed_step_mm_min", "plunge_feed_mm_min"):
            value = getattr(self, name)
            if value is not None:
                put(self, name, _number(name, value))
        if self.feed_mm_min is not None:
            put(self, "feed_mm_min", check_feed_mm_min(self.feed_mm_min))
        if self.safe_z_mm is not None:
            if isinstance(self.safe_z_mm, bool) or not isinstance(self.safe_z_mm, numbers.Real) \
                    or not math.isfinite(self.safe_z_mm):
                raise InputError(f"--safe-z-mm: {self.safe_z_mm!r} must be a finite number")
            put(self, "safe_z_mm", float(self.safe_z_mm))
        put(self, "points", _count("points", self.points, 3, MAX_POINTS, "points"))
        if isinstance(self.gcode_decimals, bool) or not isinstance(self.gcode_decimals, numbers.Integral) \
                or not 3 <= self.gcode_decimals <= 9:
            raise InputError(f"--gcode-decimals: {self.gcode_decimals!r}: use 3 to 9 decimals for mm coordinates")
        put(self, "gcode_decimals", int(self.gcode_decimals))
        if self.filter is not None:
            _choice("filter", self.filter, FILTERS)
        if self.units is not None:
            _choice("units", self.units, UNITS)
        _choice("tool_units", self.tool_units, TOOL_UNITS)
        for name in ("rule_strengths", "reference", "line_numbers", "g52_whole", "verify_rs274"):
            if not isinstance(getattr(self, name), bool):
                raise InputError(f"{name}: {getattr(self, name)!r}; give True or False")
        if self.tool_table is not None:
            put(self, "tool_table", os.fspath(self.tool_table))
        put(self, "machine", _machine(self.machine))
        put(self, "table", self._table())

    def _table(self):
        """The rule table of ``rules`` with ``filter``, ``window_mm`` and ``filter_mm`` applied.
        Without ``rules``: the machine table when a machine is given, else the paper's."""
        from fuzzyfeed.fuzzy.rule_reader import load_rule_table
        from fuzzyfeed.fuzzy.rules import DEFAULT_MACHINE_TABLE, MACHINE, RuleTable

        spec = self.rules
        if isinstance(spec, RuleTable):
            table = spec
        else:
            if spec is not None and not isinstance(spec, (str, os.PathLike)):
                raise InputError(f"--rules: {type(spec).__name__} {spec!r:.40}; give a table's name, "
                                 "a .toml file or a RuleTable")
            table = load_rule_table(DEFAULT_MACHINE_TABLE if spec is None and self.machine is not None
                                    else spec)
        if table.inputs == MACHINE and self.machine is None:
            shown = spec.name if isinstance(spec, RuleTable) else spec
            raise MachineLimitsError(f"--rules {shown}: table {table.name!r} reads the machine's terms "
                                     "(inputs = 'machine'); give a machine (--machine FILE, or a machine "
                                     "flag such as --contour-tol-um)")
        changes = {key: getattr(self, key) for key in ("filter", "window_mm", "filter_mm")
                   if getattr(self, key) is not None}
        return replace(table, **changes) if changes else table

    def replace(self, **overrides) -> AdviceOptions:
        """These options with some fields changed (checked again); an unknown name is one line."""
        known = option_names()
        unknown = sorted(set(overrides) - set(known))
        if unknown:
            raise InputError(f"{unknown[0]}: not an advice option; they are: {', '.join(known)}")
        if not overrides:
            return self
        values = {name: getattr(self, name) for name in known}
        return AdviceOptions(**{**values, **overrides})

    def changed(self) -> dict:
        """The fields not at their defaults (name -> value), in field order."""
        default = _defaults()
        return {name: getattr(self, name) for name in option_names()
                if _differs(getattr(self, name), getattr(default, name))}

    def for_kind(self, kind: str) -> AdviceOptions:
        """The options a ``"program"`` or a ``"drawing"`` takes: the other kind's fields back at
        their defaults (a library's batch gives each file what applies to it)."""
        drop = DRAWING_ONLY if kind == "program" else PROGRAM_ONLY
        default = _defaults()
        return self.replace(**{name: getattr(default, name) for name in drop
                               if _differs(getattr(self, name), getattr(default, name))})

    def key_words(self) -> list[str]:
        """The options as words for a digest: ``name=repr(value)`` of every field changed, and
        every file they name (so a batch's manifest sees an edited rule table or tool table)."""
        words = [f"{name}={value!r}" for name, value in self.changed().items()]
        for value in (self.rules, self.tool_table):
            if isinstance(value, (str, os.PathLike)):
                words.append(_file_of(value))
        return words


def _file_of(spec) -> str:
    """The file a rule-table or tool-table name stands for (as given when it is no file)."""
    from fuzzyfeed.fuzzy.rule_reader import resolve_rules_path

    if os.path.isfile(spec):
        return os.fspath(spec)
    with contextlib.suppress(Exception):
        return os.fspath(resolve_rules_path(spec))
    return os.fspath(spec)


def _differs(a, b) -> bool:
    try:
        return bool(a != b) or type(a) is not type(b)
    except Exception:  # arrays inside a value: compare their text
        return repr(a) != repr(b)


def _machine(spec):
    from fuzzyfeed.machine.description import Machine, load_machine

    if spec is None or isinstance(spec, Machine):
        return spec
    if isinstance(spec, Path):
        spec = os.fspath(spec)
    return load_machine(spec)


def option_names() -> tuple[str, ...]:
    return tuple(f.name for f in fields(AdviceOptions) if f.init)


_DEFAULTS: list[AdviceOptions] = []


def _defaults() -> AdviceOptions:
    if not _DEFAULTS:
        _DEFAULTS.append(AdviceOptions())
    return _DEFAULTS[0]


def make_options(options: AdviceOptions | None = None, **overrides) -> AdviceOptions:
    """``options`` (default: every field at its default) with ``overrides`` applied."""
    if options is None:
        options = _defaults()
    elif not isinstance(options, AdviceOptions):
        raise InputError(f"options: {type(options).__name__}; give an AdviceOptions (or the fields "
                         "as keywords)")
    return options.replace(**overrides)


@contextlib.contextmanager
def shape_settings(spec: str, units: str | None, point_tolerance: float | None,
                   path_tolerance: float | None):
    """While a file is read and advised: ``units`` applied to a DXF drawing (refused for other
    files) and the point-sequence tolerances to curvature (:data:`~fuzzyfeed.geometry.polyline.
    TOLERANCES`)."""
    from fuzzyfeed.errors import ShapeFileError
    from fuzzyfeed.geometry.polyline import TOLERANCES

    token = None
    if units is not None:
        from fuzzyfeed.io.dxf import UNITS_OVERRIDE
        from fuzzyfeed.io.shapes import split_selector

        base, _ = split_selector(spec)
        if Path(str(base)).suffix.lower() != ".dxf":
            raise ShapeFileError(f"--units {units}: applies to DXF drawings only; {base} states its "
                                 "own units (G20/G21 in G-code, mm in CSV and shape files)")
        token = UNITS_OVERRIDE.set(units)
    tolerances = TOLERANCES.set((point_tolerance, path_tolerance))
    try:
        yield
    finally:
        TOLERANCES.reset(tolerances)
        if token is not None:
            UNITS_OVERRIDE.reset(token)
