"""Rule tables of the fuzzy feedrate advisor (seed 002, section 2.7.1, rules R1-R30 / Table 6).

A rule table is a TOML file (one per table, in ``rules/``): the feature settings (WS, the Dκ clip,
the average-filter size, a feed floor), three fuzzy variables — ``curvature`` (κ, 1/mm),
``curvature_variation`` (normalised Dκ) and ``feed`` (% of the maximum feed) — each with a
universe and named terms (triangles ``[a, b, c]`` or trapezoids ``[a, b, c, d]``), and the grid
``[rules]``: one row per κ term, the Dκ column labels given once. ``rules/paper.toml`` is the
documented example and the default.

This module is the table itself: its variables and terms, the grid, and the validation shared by
the in-memory constructor and the file reader (:func:`uncovered`: where no term's μ > 0). Files are
read by :mod:`fuzzyfeed.fuzzy.rule_reader` (:mod:`tomllib`) and written or edited by
:mod:`fuzzyfeed.fuzzy.rule_writer` (:mod:`tomlkit`, so comments and layout survive). Every error is
a :class:`~fuzzyfeed.errors.RuleTableError` whose one-line message names the file and line (or the
field of an in-memory table), the bad value and the rule broken.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from fuzzyfeed.base.toml_lines import Locator
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
#: Optional settings of [features]: the filter kind, and WS / M as lengths along the path (mm).
OPTIONAL_FEATURE_KEYS = ("filter", "window_mm", "filter_mm")


def kind_of_inputs(names: Sequence[str]) -> str | None:
    """The input kind whose two variable names are ``names`` (in order), or None."""
    for kind, pair in INPUT_NAMES.items():
        if tuple(names) == pair:
            return kind
    return None


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
        _validate(self, field_locator(self.name))

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
        i = term_index(self.curvature, row, f"rule table {self.name!r}: row")
        j = term_index(self.curvature_variation, column, f"rule table {self.name!r}: column")
        grid = [list(r) for r in self.grid]
        grid[i][j] = label
        return replace(self, grid=tuple(tuple(r) for r in grid))


def term_index(var: Variable, label: str, where: str) -> int:
    if label not in var.labels:
        raise RuleTableError(f"{where} {label!r}: unknown {var.name} label; "
                             f"{var.name} terms are {', '.join(var.labels)}")
    return var.index(label)


def field_locator(name: str) -> Locator:
    def where(section: str, key: str | None = None) -> str:
        return f"rule table {name!r}: {section}" + (f".{key}" if key else "")
    return where


def _fmt(x: float) -> str:
    return f"{x:g}"


def validate_features(values: Mapping[str, object], where: Locator) -> None:
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


def validate_optional_features(values: Mapping[str, object], where: Locator) -> None:
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
    validate_features({k: getattr(t, k) for k in FEATURE_KEYS}, where)
    validate_optional_features({k: getattr(t, k) for k in OPTIONAL_FEATURE_KEYS}, where)
    for var in t.variables:
        validate_variable(var, where, require_cover=var.name != FEED)
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


def validate_variable(var: Variable, where: Locator, require_cover: bool) -> None:
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
