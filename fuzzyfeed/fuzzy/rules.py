"""Rule tables of the fuzzy feedrate advisor (seed 002, section 2.7.1, rules R1-R30 / Table 6).

A rule table is a TOML file (one per table, in ``rules/``): the feature settings (WS, the Dκ clip,
the average-filter size, a feed floor), three fuzzy variables — ``curvature`` (κ, 1/mm),
``curvature_variation`` (normalised Dκ) and ``feed`` (% of the maximum feed) — each with a
universe and named terms (triangles ``[a, b, c]`` or trapezoids ``[a, b, c, d]``), and the grid
``[rules]``: one row per κ term, the Dκ column labels given once. ``rules/paper.toml`` is the
documented example and the default.

Files are read with :mod:`tomllib`; :func:`set_cell` edits them with :mod:`tomlkit` so comments and
layout survive. Every error is a :class:`~fuzzyfeed.errors.RuleTableError` whose one-line message
names the file and line (or the field of an in-memory table), the bad value and the rule broken.
"""

from __future__ import annotations

import math
import os
import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from fuzzyfeed.base.files import read_text, resolve_file, shipped_dir, shipped_names
from fuzzyfeed.base.toml_lines import HEADER as _HEADER
from fuzzyfeed.base.toml_lines import KEY as _KEY
from fuzzyfeed.base.toml_lines import KeyLines as _Lines
from fuzzyfeed.base.toml_lines import Locator
from fuzzyfeed.base.toml_lines import file_locator as _file_locator
from fuzzyfeed.errors import RuleTableError
from fuzzyfeed.fuzzy.filters import DEFAULT_FILTER, FILTER_KINDS

#: Section names of the three fuzzy variables of a paper table, in the order inputs, output.
KAPPA, DK, FEED = "curvature", "curvature_variation", "feed"
VARIABLES = (KAPPA, DK, FEED)
#: The inputs a table says it uses (top-level key ``inputs``): seed 002's curvature and windowed
#: variation, or the machine's terms (issue 32): the feed that holds the contour tolerance at a
#: point over the programmed feed, and the lowest such ratio within the servo's settling distance.
PAPER, MACHINE = "paper", "machine"
SAFE, SAFE_NEAR = "safe_feed_ratio", "safe_feed_ratio_near"
INPUT_NAMES = {PAPER: (KAPPA, DK), MACHINE: (SAFE, SAFE_NEAR)}
#: Keys of a variable section that are not terms.
RESERVED_KEYS = ("universe", "unit")
UNITS = {KAPPA: "1/mm", DK: "", FEED: "%", SAFE: "", SAFE_NEAR: ""}
DEFAULT_TABLE = "paper"
#: The table a machine makes the default (``--machine`` or any machine flag).
DEFAULT_MACHINE_TABLE = "machine"
#: Settings of the [features] section (a machine table needs only feed_floor_pct).
FEATURE_KEYS = ("window_points", "dk_clip_1_mm", "filter_points", "feed_floor_pct")
MACHINE_FEATURE_KEYS = ("feed_floor_pct",)


def kind_of_inputs(names: Sequence[str]) -> str | None:
    """The input kind whose two variable names are ``names`` (in order), or None."""
    for kind, pair in INPUT_NAMES.items():
        if tuple(names) == pair:
            return kind
    return None
#: Optional settings of [features]: the filter kind, and WS / M as lengths along the path (mm).
OPTIONAL_FEATURE_KEYS = ("filter", "window_mm", "filter_mm")



@dataclass(frozen=True)
class Term:
    """A fuzzy term: a triangle (a, b, c) or a trapezoid (a, b, c, d), a <= b <= c <= d, a < d."""

    label: str
    points: tuple[float, ...]

    @property
    def trapezoid(self) -> tuple[float, float, float, float]:
        """The term as a trapezoid (a, b, c, d); a triangle has b = c."""
        p = self.points
        return (p[0], p[1], p[1], p[2]) if len(p) == 3 else (p[0], p[1], p[2], p[3])


@dataclass(frozen=True)
class Variable:
    """A fuzzy variable: its universe [lo, hi] and its terms in file order."""

    name: str
    universe: tuple[float, float]
    terms: tuple[Term, ...]

    @property
    def labels(self) -> tuple[str, ...]:
        return tuple(t.label for t in self.terms)

    def index(self, label: str) -> int:
        return self.labels.index(label)

    def term(self, label: str) -> Term:
        return self.terms[self.index(label)]


@dataclass(frozen=True, eq=False)
class RuleTable:
    """A validated Mamdani rule table (seed 002 Table 6 layout).

    ``grid[i][j]`` is the feed label of the rule "IF κ is curvature.terms[i] AND Dκ is
    curvature_variation.terms[j]"; every cell is filled. ``window_points`` is WS (seed 002
    eq. 10), ``dk_clip_1_mm`` the clip applied to Dκ before normalisation, ``filter_points`` the
    size M of the centred average filter and ``feed_floor_pct`` the lowest feed advised.
    """

    name: str
    curvature: Variable
    curvature_variation: Variable
    feed: Variable
    grid: tuple[tuple[str, ...], ...]
    window_points: int = 30
    dk_clip_1_mm: float = 3.0
    filter_points: int = 21
    feed_floor_pct: float = 5.0
    source: str = ""
    filter: str = DEFAULT_FILTER
    window_mm: float | None = None
    filter_mm: float | None = None
    path: Path | None = field(default=None, compare=False)
    inputs: str = PAPER

    def __post_init__(self) -> None:
        _validate(self, _field_locator(self.name))

    @property
    def variables(self) -> tuple[Variable, Variable, Variable]:
        return (self.curvature, self.curvature_variation, self.feed)

    @property
    def row_input(self) -> Variable:
        """The first input (the grid's rows): κ, or the safe-feed ratio here."""
        return self.curvature

    @property
    def column_input(self) -> Variable:
        """The second input (the grid's columns): Dκ, or the safe-feed ratio near."""
        return self.curvature_variation

    @property
    def input_names(self) -> tuple[str, str]:
        return INPUT_NAMES[self.inputs]

    @property
    def rules(self) -> list[tuple[str, str, str]]:
        """The rules as (κ label, Dκ label, feed label), row by row (R1 = first row, first column)."""
        return [(k.label, d.label, self.grid[i][j])
                for i, k in enumerate(self.curvature.terms)
                for j, d in enumerate(self.curvature_variation.terms)]

    def rule_names(self) -> list[str]:
        """Readable rule names, e.g. ``"k=VS & Dk=M -> VHF"``, in the order of :attr:`rules`."""
        return [f"k={k} & Dk={d} -> {f}" for k, d, f in self.rules]

    def with_cell(self, row: str, column: str, label: str) -> "RuleTable":
        """A copy with one grid cell changed (validated)."""
        i = _lookup(self.curvature, row, f"rule table {self.name!r}: row")
        j = _lookup(self.curvature_variation, column, f"rule table {self.name!r}: column")
        grid = [list(r) for r in self.grid]
        grid[i][j] = label
        return replace(self, grid=tuple(tuple(r) for r in grid))


def _lookup(var: Variable, label: str, where: str) -> int:
    if label not in var.labels:
        raise RuleTableError(f"{where} {label!r}: unknown {var.name} label; "
                             f"{var.name} terms are {', '.join(var.labels)}")
    return var.index(label)


# --------------------------------------------------------------------------------------------
# validation (shared by the in-memory constructor and the file loader)

def _field_locator(name: str) -> Locator:
    def where(section: str, key: str | None = None) -> str:
        return f"rule table {name!r}: {section}" + (f".{key}" if key else "")
    return where


def _fmt(x: float) -> str:
    return f"{x:g}"


def _validate_features(values: Mapping[str, object], where: Locator) -> None:
    for key in ("window_points", "filter_points"):
        v = values[key]
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            raise RuleTableError(f"{where('features', key)}: {key} = {v!r}; must be an integer >= 1")
    m = values["filter_points"]
    if m % 2 == 0:  # a centred average has 2h + 1 points; an even size would silently be M - 1
        raise RuleTableError(f"{where('features', 'filter_points')}: filter_points = {m}; a centred "
                             f"moving average needs an odd number of points (use {m - 1} or {m + 1})")
    clip = values["dk_clip_1_mm"]
    if not _is_number(clip) or not math.isfinite(clip) or clip <= 0:
        raise RuleTableError(f"{where('features', 'dk_clip_1_mm')}: dk_clip_1_mm = {clip!r}; "
                             "must be a finite number > 0 (1/mm)")
    floor = values["feed_floor_pct"]
    if not _is_number(floor) or not math.isfinite(floor) or not 0 < floor <= 100:
        raise RuleTableError(f"{where('features', 'feed_floor_pct')}: feed_floor_pct = "
                             f"{floor!r}; must be in (0, 100] (a feed is never 0)")


def _validate_optional_features(values: Mapping[str, object], where: Locator) -> None:
    kind = values.get("filter", DEFAULT_FILTER)
    if kind not in FILTER_KINDS:
        raise RuleTableError(f"{where('features', 'filter')}: filter = {kind!r}; must be one of "
                             f"{', '.join(repr(k) for k in FILTER_KINDS)}")
    for key in ("window_mm", "filter_mm"):
        v = values.get(key)
        if v is not None and (not _is_number(v) or not math.isfinite(v) or v <= 0):
            raise RuleTableError(f"{where('features', key)}: {key} = {v!r}; must be a finite "
                                 "number > 0 (mm along the path)")


def _validate(t: RuleTable, where: Locator) -> None:
    if t.inputs not in INPUT_NAMES:
        raise RuleTableError(f"{where('inputs')}: inputs = {t.inputs!r}; must be one of "
                             f"{', '.join(repr(k) for k in INPUT_NAMES)}")
    names = (t.curvature.name, t.curvature_variation.name, t.feed.name)
    if names != (*INPUT_NAMES[t.inputs], FEED):
        raise RuleTableError(f"{where('inputs')}: variables {list(names)} for inputs = {t.inputs!r}; "
                             f"that kind has {', '.join(INPUT_NAMES[t.inputs])} and {FEED}")
    _validate_features({k: getattr(t, k) for k in FEATURE_KEYS}, where)
    _validate_optional_features({k: getattr(t, k) for k in OPTIONAL_FEATURE_KEYS}, where)
    for var in t.variables:
        _validate_variable(var, where, require_cover=var.name != FEED)
    k, d, f = t.curvature, t.curvature_variation, t.feed
    if len(t.grid) != len(k.terms):
        raise RuleTableError(f"{where('rules')}: {len(t.grid)} rows; expected one per {k.name} term "
                             f"({len(k.terms)}: {', '.join(k.labels)})")
    for i, row in enumerate(t.grid):
        if len(row) != len(d.terms):
            raise RuleTableError(f"{where('rules', k.labels[i])}: row {k.labels[i]} has {len(row)} cells; "
                                 f"expected {len(d.terms)}, one per {d.name} term "
                                 f"({', '.join(d.labels)})")
        for j, label in enumerate(row):
            if label not in f.labels:
                raise RuleTableError(f"{where('rules', k.labels[i])}: row {k.labels[i]}, column "
                                     f"{d.labels[j]} (cell {j + 1}): unknown feed label {label!r}; "
                                     f"feed terms are {', '.join(f.labels)}")


def _is_number(x: object) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _validate_variable(var: Variable, where: Locator, require_cover: bool) -> None:
    unit = UNITS.get(var.name, "")
    lo_hi = var.universe
    if (len(lo_hi) != 2 or not all(_is_number(x) and math.isfinite(x) for x in lo_hi)
            or not lo_hi[0] < lo_hi[1]):
        raise RuleTableError(f"{where(var.name, 'universe')}: universe = {list(lo_hi)!r}; must be "
                             "[lo, hi], two finite numbers with lo < hi")
    lo, hi = lo_hi
    if not var.terms:
        raise RuleTableError(f"{where(var.name)}: no terms; give at least one term = [a, b, c]")
    seen: set[str] = set()
    for term in var.terms:
        w = where(var.name, term.label)
        if term.label in seen:
            raise RuleTableError(f"{w}: term {term.label!r} given twice in {var.name}")
        seen.add(term.label)
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", term.label):
            raise RuleTableError(f"{w}: term label {term.label!r}; use letters, digits and _ only")
        p = term.points
        if len(p) not in (3, 4) or not all(_is_number(x) for x in p):
            raise RuleTableError(f"{w}: {var.name}.{term.label} = {list(p)!r}; a term is 3 numbers "
                                 "[a, b, c] (triangle) or 4 [a, b, c, d] (trapezoid)")
        if not all(math.isfinite(x) for x in p):
            raise RuleTableError(f"{w}: {var.name}.{term.label} = {list(p)!r}; breakpoints must be finite")
        for m in range(len(p) - 1):
            if p[m + 1] < p[m]:
                raise RuleTableError(
                    f"{w}: {var.name}.{term.label} = {list(p)!r}; breakpoints must be non-decreasing "
                    f"({_fmt(p[m + 1])} follows {_fmt(p[m])})")
        if not p[0] < p[-1]:
            raise RuleTableError(f"{w}: {var.name}.{term.label} = {list(p)!r}; a term needs a "
                                 "width, first breakpoint < last")
        if p[0] < lo or p[-1] > hi:
            raise RuleTableError(f"{w}: {var.name}.{term.label} = {list(p)!r} leaves the universe "
                                 f"[{_fmt(lo)}, {_fmt(hi)}] {unit}".rstrip())
    if require_cover:
        gap = uncovered(var)
        if gap is not None:
            a, b = gap
            span = f"{_fmt(a)}" if a == b else f"{_fmt(a)} to {_fmt(b)}"
            raise RuleTableError(
                f"{where(var.name)}: no {var.name} term covers {span} {unit}".rstrip()
                + f"; no rule can fire for {var.name} = {span}; widen or add a term")


def uncovered(var: Variable) -> tuple[float, float] | None:
    """The first stretch of the universe where every term's membership is 0, or None.

    μ > 0 on the open support (a, d), and also at a when a = b and at d when c = d (a shoulder).
    Returns (start, end) of the gap; a single uncovered point gives start = end.
    """
    lo, hi = var.universe
    pieces = sorted(((a, a == b, d, c == d) for a, b, c, d in (t.trapezoid for t in var.terms)),
                    key=lambda q: (q[0], not q[1]))
    reach, reach_closed = lo, False          # covered so far: [lo, reach), plus reach if closed
    for start, start_closed, end, end_closed in pieces:
        if reach > hi or (reach == hi and reach_closed):
            return None
        if start > reach or (start == reach and not reach_closed and not start_closed):
            return (reach, start)
        if end > reach:
            reach, reach_closed = end, end_closed
        elif end == reach:
            reach_closed = reach_closed or end_closed
    if reach < hi or not reach_closed:
        return (reach, hi)
    return None


# --------------------------------------------------------------------------------------------
# files

def rules_dir() -> Path:
    """Folder of the shipped rule tables: inside the installed package, or the repository's rules/."""
    return shipped_dir("rules", RuleTableError)


def table_names() -> list[str]:
    """Names of the shipped rule tables, sorted."""
    return shipped_names("rules", RuleTableError)


def resolve_rules_path(spec: str | Path | None) -> Path:
    """A --rules argument (None = the default table, a shipped name, or a path) as an existing file."""
    if spec is not None and not isinstance(spec, (str, os.PathLike)):
        raise RuleTableError(f"rule table: {type(spec).__name__} {spec!r:.40}; expected a name or a file path")
    return resolve_file(DEFAULT_TABLE if spec is None else spec, "rules", "rule table", RuleTableError)


def _read_text(path: Path) -> str:
    return read_text(path, "rule table", RuleTableError)


def load_rule_table(spec: str | Path | None = None) -> RuleTable:
    """Load and validate a rule table (None = ``rules/paper.toml``, a shipped name, or a path)."""
    path = resolve_rules_path(spec)
    return parse_rule_table(_read_text(path), path)


def parse_rule_table(text: str, path: Path | str = "<rules>") -> RuleTable:
    """Parse and validate rule-table TOML text; messages name ``path`` and the line."""
    if not isinstance(text, str):
        raise RuleTableError(f"{path}: {type(text).__name__}; expected the TOML text as str")
    path = Path(path)
    lines = _Lines(text)
    for section, key, first, again in lines.duplicates:
        what = (f"row {key!r}" if section == "rules" else
                f"term {key!r}" if section in (*VARIABLES, SAFE, SAFE_NEAR) else f"key {key!r}")
        raise RuleTableError(f"{path}:{again}: duplicate {what} in [{section}] (first at line {first}); "
                             "give each once")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise RuleTableError(f"{path}: invalid TOML: {exc}") from None
    except RecursionError:
        raise RuleTableError(f"{path}: nested too deeply to be a rule table") from None
    where = _file_locator(path, lines)
    return table_from_mapping(data, where, path)


def table_from_mapping(data: Mapping, where: Locator | None = None, path: Path | None = None) -> RuleTable:
    """Build a :class:`RuleTable` from parsed TOML; ``where`` turns (section, key) into a location."""
    where = where or _field_locator(str(data.get("name", "rules")))
    top = str(path) if path is not None else "rule table"
    kind = data.get("inputs", PAPER)
    if kind not in INPUT_NAMES:
        raise RuleTableError(f"{where('', 'inputs')}: inputs = {kind!r}; must be one of "
                             f"{', '.join(repr(k) for k in INPUT_NAMES)} (which inputs the table uses)")
    k_name, d_name = INPUT_NAMES[kind]
    sections = ("features", k_name, d_name, FEED, "rules")
    for section in sections:
        if not isinstance(data.get(section), Mapping):
            raise RuleTableError(f"{top}: section [{section}] is missing; a rule table with inputs = "
                                 f"{kind!r} has " + ", ".join(f"[{s}]" for s in sections[:-1])
                                 + " and [rules]")
    for other_kind, pair in INPUT_NAMES.items():
        stray = [s for s in pair if s not in (k_name, d_name) and isinstance(data.get(s), Mapping)]
        if stray:
            raise RuleTableError(f"{where(stray[0])}: section [{stray[0]}] belongs to inputs = "
                                 f"{other_kind!r}; this table says inputs = {kind!r}")
    feats = data["features"]
    known = set(FEATURE_KEYS) | set(OPTIONAL_FEATURE_KEYS)
    for key in feats:
        if key not in known:
            raise RuleTableError(f"{where('features', key)}: unknown setting {key!r}; "
                                 f"[features] takes {', '.join(sorted(known))}")
    required = FEATURE_KEYS if kind == PAPER else MACHINE_FEATURE_KEYS
    for key in required:
        if key not in feats:
            raise RuleTableError(f"{where('features')}: setting {key!r} is missing from [features]")
    defaults = {"window_points": 30, "dk_clip_1_mm": 3.0, "filter_points": 21}
    feats = {**defaults, **feats} if kind == MACHINE else feats
    variables = {}
    for name in (k_name, d_name, FEED):
        sec = data[name]
        if "universe" not in sec:
            raise RuleTableError(f"{where(name)}: [{name}] has no universe = [lo, hi]")
        uni = sec["universe"]
        if not isinstance(uni, list):
            raise RuleTableError(f"{where(name, 'universe')}: universe = {uni!r}; must be [lo, hi]")
        terms = []
        for key, value in sec.items():
            if key in RESERVED_KEYS:
                continue
            if not isinstance(value, list):
                raise RuleTableError(f"{where(name, key)}: {name}.{key} = {value!r}; a term is a list "
                                     "of 3 or 4 breakpoints")
            terms.append(Term(key, tuple(value)))
        variables[name] = Variable(name, tuple(uni), tuple(terms))
    for var in variables.values():
        _validate_variable(var, where, require_cover=var.name != FEED)
    grid = _grid_from_mapping(data["rules"], variables[k_name], variables[d_name], variables[FEED], where)
    _validate_features(feats, where)
    _validate_optional_features(feats, where)
    return RuleTable(name=str(data.get("name", path.stem if path else "rules")),
                     curvature=variables[k_name], curvature_variation=variables[d_name], inputs=kind,
                     feed=variables[FEED], grid=grid,
                     window_points=feats["window_points"], dk_clip_1_mm=feats["dk_clip_1_mm"],
                     filter_points=feats["filter_points"], feed_floor_pct=feats["feed_floor_pct"],
                     source=str(data.get("source", "")), path=path,
                     filter=feats.get("filter", DEFAULT_FILTER),
                     window_mm=_opt_float(feats.get("window_mm")),
                     filter_mm=_opt_float(feats.get("filter_mm")))


def _opt_float(v: object) -> float | None:
    return None if v is None else float(v)  # type: ignore[arg-type]


def _grid_from_mapping(rules: Mapping, k: Variable, d: Variable, f: Variable,
                       where: Locator) -> tuple[tuple[str, ...], ...]:
    if "columns" not in rules:
        raise RuleTableError(f"{where('rules')}: [rules] has no columns = [...] (the "
                             f"{d.name} labels: {', '.join(d.labels)})")
    cols = rules["columns"]
    if not isinstance(cols, list) or not all(isinstance(c, str) for c in cols):
        raise RuleTableError(f"{where('rules', 'columns')}: columns = {cols!r}; must be a list of "
                             "curvature_variation labels")
    seen: dict[str, int] = {}
    for j, c in enumerate(cols):
        if c not in d.labels:
            raise RuleTableError(f"{where('rules', 'columns')}: column {j + 1} {c!r}: unknown "
                                 f"{d.name} label; terms are {', '.join(d.labels)}")
        if c in seen:
            raise RuleTableError(f"{where('rules', 'columns')}: column {c!r} given twice (columns "
                                 f"{seen[c] + 1} and {j + 1}); each cell must be given once")
        seen[c] = j
    missing = [c for c in d.labels if c not in seen]
    if missing:
        raise RuleTableError(f"{where('rules', 'columns')}: no column for {d.name} "
                             f"{', '.join(missing)}; missing cells for every row")
    rows: dict[str, list[str]] = {}
    for key, row in rules.items():
        if key == "columns":
            continue
        if key not in k.labels:
            raise RuleTableError(f"{where('rules', key)}: row {key!r}: unknown {k.name} label; "
                                 f"{k.name} terms are {', '.join(k.labels)}")
        if not isinstance(row, list):
            raise RuleTableError(f"{where('rules', key)}: row {key} = {row!r}; must be a list of "
                                 "feed labels, one per column")
        if len(row) != len(cols):
            what = "missing cell" if len(row) < len(cols) else "extra cell"
            raise RuleTableError(f"{where('rules', key)}: row {key} has {len(row)} cells for "
                                 f"{len(cols)} columns ({what}); give one feed label per column")
        for j, cell in enumerate(row):
            if not isinstance(cell, str) or cell == "":
                raise RuleTableError(f"{where('rules', key)}: row {key}, column {cols[j]} (cell "
                                     f"{j + 1}): {cell!r}; missing cell, give a feed label "
                                     f"({', '.join(f.labels)})")
            if cell not in f.labels:
                raise RuleTableError(f"{where('rules', key)}: row {key}, column {cols[j]} (cell "
                                     f"{j + 1}): unknown feed label {cell!r}; feed terms are "
                                     f"{', '.join(f.labels)}")
        rows[key] = row
    missing_rows = [r for r in k.labels if r not in rows]
    if missing_rows:
        raise RuleTableError(f"{where('rules')}: no row for {k.name} {', '.join(missing_rows)}; "
                             "missing cells (every curvature term needs a row)")
    return tuple(tuple(rows[r][seen[c]] for c in d.labels) for r in k.labels)


# --------------------------------------------------------------------------------------------
# writing and editing

def _num(x: float) -> str:
    return repr(float(x))


def table_to_toml(t: RuleTable, with_name: bool = True) -> str:
    """TOML text of a table in the shipped layout (aligned grid, full float precision).
    ``with_name=False`` leaves the name out, so the file's own name becomes the table's."""
    out = [f"name = {_quote(t.name)}"] if with_name else []
    if t.inputs != PAPER:
        out.append(f"inputs = {_quote(t.inputs)}")
    if t.source:
        out.append(f"source = {_quote(t.source)}")
    out += ["", "[features]", f"window_points = {t.window_points}",
            f"dk_clip_1_mm = {_num(t.dk_clip_1_mm)}", f"filter_points = {t.filter_points}",
            f"feed_floor_pct = {_num(t.feed_floor_pct)}", f"filter = {_quote(t.filter)}"]
    out += [f"{key} = {_num(getattr(t, key))}" for key in ("window_mm", "filter_mm")
            if getattr(t, key) is not None]
    for var in t.variables:
        width = max(len(x) for x in var.labels)
        out += ["", f"[{var.name}]", f"universe = [{_num(var.universe[0])}, {_num(var.universe[1])}]"]
        out += [f"{term.label:<{width}} = [" + ", ".join(_num(x) for x in term.points) + "]"
                for term in var.terms]
    cells = [list(t.curvature_variation.labels)] + [list(r) for r in t.grid]
    cw = max(len(c) for row in cells for c in row) + 3
    kw = max(len("columns"), *(len(x) for x in t.curvature.labels))

    def row_text(key: str, row: Sequence[str]) -> str:
        parts = [f'"{c}",'.ljust(cw) for c in row[:-1]] + [f'"{row[-1]}"']
        return f"{key:<{kw}} = [" + " ".join(parts) + "]"

    out += ["", "[rules]", row_text("columns", t.curvature_variation.labels)]
    out += [row_text(label, t.grid[i]) for i, label in enumerate(t.curvature.labels)]
    return "\n".join(out) + "\n"


def _quote(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def save_rule_table(t: RuleTable, path: str | Path) -> None:
    """Write ``t`` to ``path`` atomically (comments are not kept; use :func:`set_cell` for edits)."""
    from fuzzyfeed.base.atomic import atomic_write

    with atomic_write(path, "w") as handle:
        handle.write(table_to_toml(t))


def set_cell_text(text: str, row: str, column: str, label: str, path: Path | str = "<rules>") -> str:
    """The TOML text with rule (row, column) set to ``label``; comments and layout are kept.

    The result is validated before it is returned (an unknown label or row is an error).
    """
    import tomlkit

    path = Path(path)
    table = parse_rule_table(text, path)
    _lookup(table.curvature, row, f"{path}: row")
    _lookup(table.curvature_variation, column, f"{path}: column")
    if label not in table.feed.labels:
        raise RuleTableError(f"{path}: label {label!r}: unknown feed label; feed terms are "
                             f"{', '.join(table.feed.labels)}")
    doc = tomlkit.parse(text)
    rules = doc["rules"]
    j = list(rules["columns"]).index(column)
    arr = rules[row]
    old = str(arr[j])
    # keep the aligned look: replace the quoted cell in the row's own line when possible
    new_text = _replace_cell_in_line(text, row, j, old, label)
    if new_text is None:
        arr[j] = label
        new_text = tomlkit.dumps(doc)
    parse_rule_table(new_text, path)
    return new_text


def _replace_cell_in_line(text: str, row: str, j: int, old: str, label: str) -> str | None:
    """Rewrite cell j of row ``row`` in [rules] in place, padding to keep the columns aligned."""
    lines = text.splitlines(keepends=True)
    section = ""
    for n, line in enumerate(lines):
        m = _HEADER.match(line)
        if m:
            section = m.group(1).strip()
            continue
        if section != "rules":
            continue
        m = _KEY.match(line)
        if not m or m.group(1).strip('"') != row:
            continue
        cells = list(re.finditer(r'"([^"]*)"', line[m.end():]))
        if j >= len(cells) or cells[j].group(1) != old:
            return None
        start, end = m.end() + cells[j].start(), m.end() + cells[j].end()
        rest = line[end:]
        new_cell = f'"{label}"'
        grow = len(new_cell) - (end - start)
        if grow < 0 and rest.startswith(","):
            rest = "," + " " * (-grow) + rest[1:]
        elif grow > 0 and rest.startswith(","):
            spaces = len(rest[1:]) - len(rest[1:].lstrip(" "))
            take = min(grow, max(spaces - 1, 0))
            rest = "," + rest[1 + take:]
        lines[n] = line[:start] + new_cell + rest
        return "".join(lines)
    return None


def set_cell(path: str | Path, row: str, column: str, label: str) -> RuleTable:
    """Change one rule of the file at ``path`` in place (atomically, comments kept); returns the table."""
    from fuzzyfeed.base.atomic import atomic_write

    path = Path(path)
    new_text = set_cell_text(_read_text(path), row, column, label, path)
    with atomic_write(path, "w") as handle:
        handle.write(new_text)
    return parse_rule_table(new_text, path)


def grid_text(t: RuleTable, sep: str | None = None) -> str:
    """The grid as text: aligned columns (``sep=None``) or separated by ``sep`` (tab/comma for
    spreadsheets); first row 'k \\ Dk' and the Dκ labels."""
    rows = [["k \\ Dk", *t.curvature_variation.labels]]
    rows += [[label, *t.grid[i]] for i, label in enumerate(t.curvature.labels)]
    if sep is not None:
        return "\n".join(sep.join(r) for r in rows) + "\n"
    width = max(len(c) for r in rows for c in r) + 2
    return "\n".join("".join(c.ljust(width) for c in r).rstrip() for r in rows) + "\n"
