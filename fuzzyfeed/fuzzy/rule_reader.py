"""Rule tables read from TOML (:mod:`fuzzyfeed.fuzzy.rules`): the shipped tables in ``rules/``, a
``--rules`` argument resolved to a file, and the text parsed with :mod:`tomllib` into a validated
:class:`~fuzzyfeed.fuzzy.rules.RuleTable` — duplicate keys, missing sections, unknown settings, rows
and cells each one :class:`~fuzzyfeed.errors.RuleTableError` naming the file and line.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from fuzzyfeed.base.files import read_text, resolve_file, shipped_dir, shipped_names
from fuzzyfeed.base.toml_lines import KeyLines as _Lines
from fuzzyfeed.base.toml_lines import Locator, load_toml
from fuzzyfeed.base.toml_lines import file_locator as _file_locator
from fuzzyfeed.errors import RuleTableError
from fuzzyfeed.fuzzy.filters import DEFAULT_FILTER
from fuzzyfeed.fuzzy.rules import (DEFAULT_TABLE, FEATURE_KEYS, FEED, INPUT_NAMES, MACHINE, MACHINE_FEATURE_KEYS,
                                   OPTIONAL_FEATURE_KEYS, PAPER, RESERVED_KEYS, SAFE, SAFE_NEAR, VARIABLES, RuleTable,
                                   Term, Variable, field_locator, validate_features, validate_optional_features,
                                   validate_variable)


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


def read_rule_text(path: Path) -> str:
    return read_text(path, "rule table", RuleTableError)


def load_rule_table(spec: str | Path | None = None) -> RuleTable:
    """Load and validate a rule table (None = ``rules/paper.toml``, a shipped name, or a path)."""
    path = resolve_rules_path(spec)
    return parse_rule_table(read_rule_text(path), path)


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
    data = load_toml(text, path, RuleTableError, "a rule table")
    return table_from_mapping(data, _file_locator(path, lines), path)


def table_from_mapping(data: Mapping, where: Locator | None = None, path: Path | None = None) -> RuleTable:
    """Build a :class:`RuleTable` from parsed TOML; ``where`` turns (section, key) into a location."""
    where = where or field_locator(str(data.get("name", "rules")))
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
        validate_variable(var, where, require_cover=var.name != FEED)
    grid = _grid_from_mapping(data["rules"], variables[k_name], variables[d_name], variables[FEED], where)
    validate_features(feats, where)
    validate_optional_features(feats, where)
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
