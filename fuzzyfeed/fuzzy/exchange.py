"""Rule tables in and out of other fuzzy tools: IEC 61131-7 FCL (and fuzzylite's FCL dialect),
fuzzylite FLL and MATLAB ``.fis`` (Mamdani). One format per module (:mod:`~fuzzyfeed.fuzzy.fcl`,
:mod:`~fuzzyfeed.fuzzy.fll`, :mod:`~fuzzyfeed.fuzzy.fis`); this module holds what they share: the
neutral description a parser returns, its checks (two inputs — ``curvature`` and
``curvature_variation``, or a machine table's ``safe_feed_ratio`` and ``safe_feed_ratio_near`` —
one output ``feed``; AND = min, implication = min, aggregation = max,
centroid — the only controller fuzzyfeed computes), the rule numbering and the settings comment.

Rules are numbered as seed 002 numbers them, κ running fastest: rule (κ term i, Dκ term j) is
R(1 + i + n_κ·j), so on the paper's 6 × 5 grid R1 = (ZO, ZO), R2 = (VS, ZO) … R30 = (VB, VH).

fuzzyfeed's own settings (WS, the Dκ clip, the filter, the feed floor, name and source) have no
place in these formats; FCL and FLL carry them in one comment line ``fuzzyfeed-settings {json}``
that the importer reads back, so an export imports to the same table. A ``.fis`` has no comments
MATLAB is sure to accept, so its import takes them from a table (``--settings-from``, default the
paper's); the feed floor is the FCL/FLL ``DEFAULT``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from fuzzyfeed.errors import RuleTableError
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.fuzzy.rules import (DEFAULT_MACHINE_TABLE, FEED, INPUT_NAMES, MACHINE, VARIABLES, RuleTable, Term,
                                   Variable, kind_of_inputs)

#: Export formats of ``fuzzyfeed rules show --format``: name -> (suffix, description).
EXPORT_FORMATS = {
    "fcl": (".fcl", "IEC 61131-7 FCL"),
    "fcl-fuzzylite": (".fcl", "FCL in fuzzylite's dialect (QtFuzzyLite, fuzzylite 6)"),
    "fll": (".fll", "fuzzylite language (FLL)"),
    "fis": (".fis", "MATLAB Fuzzy Logic Toolbox .fis (Mamdani)"),
}
#: Suffixes ``rules import`` recognises.
IMPORT_SUFFIXES = {".fcl": "fcl", ".fll": "fll", ".fis": "fis", ".toml": "toml"}
SETTINGS_TAG = "fuzzyfeed-settings"
#: Centroid resolution written to FLL: fuzzylite 6 integrates the output by the midpoint rule on
#: this many cells. Its default, 100, is off by up to 0.017 % on the paper's table; 10**5 cells
#: (0.001 % of the feed universe each) agree with fuzzyfeed's exact centroid to 2e-8 % over a
#: grid of (κ, Dκ) (the error falls as the square of the cell), at ~5 ms per point in fuzzylite.
FLL_RESOLUTION = 100_000


def rule_number(i: int, j: int, n_kappa: int) -> int:
    """Seed 002's number of the rule (κ term i, Dκ term j): κ runs fastest, R1 = (0, 0)."""
    return 1 + i + n_kappa * j


def numbered_rules(t: RuleTable) -> list[tuple[int, str, str, str]]:
    """(number, κ label, Dκ label, feed label) in seed 002's order R1, R2, …"""
    nk = len(t.curvature.terms)
    out = [(rule_number(i, j, nk), k.label, d.label, t.grid[i][j])
           for i, k in enumerate(t.curvature.terms)
           for j, d in enumerate(t.curvature_variation.terms)]
    return sorted(out)


def num(x: float) -> str:
    """A float as the shortest text that reads back to the same float64."""
    return repr(float(x))


def settings_json(t: RuleTable) -> str:
    """fuzzyfeed's settings of ``t`` as one line of JSON (floats exact)."""
    d = {"name": t.name, "source": t.source, "window_points": t.window_points,
         "dk_clip_1_mm": t.dk_clip_1_mm, "filter": t.filter, "filter_points": t.filter_points,
         "feed_floor_pct": t.feed_floor_pct, "window_mm": t.window_mm, "filter_mm": t.filter_mm}
    return json.dumps(d, ensure_ascii=True).replace("*)", "*\\u0029")


SETTING_KEYS = ("window_points", "dk_clip_1_mm", "filter", "filter_points", "feed_floor_pct",
                "window_mm", "filter_mm")


def read_settings(line: str, where: str) -> dict:
    """The settings dict from a ``fuzzyfeed-settings {json}`` comment line."""
    text = line[line.index(SETTINGS_TAG) + len(SETTINGS_TAG):].strip()
    end = text.rfind("}")
    try:
        d = json.loads(text[:end + 1])
    except (json.JSONDecodeError, ValueError):
        raise RuleTableError(f"{where}: {SETTINGS_TAG} comment is not valid JSON: {text[:60]!r}") from None
    if not isinstance(d, dict):
        raise RuleTableError(f"{where}: {SETTINGS_TAG} must be a JSON object")
    return d


def points_to_trapezoid(pts: Sequence[tuple[float, float]], lo: float, hi: float,
                        where: str) -> tuple[float, ...]:
    """An FCL point list (IEC 61131-7: linear between points, constant beyond the first and last)
    as a triangle (a, b, c) or trapezoid (a, b, c, d) on the universe [lo, hi].

    Only 0 … 1 … 0 shapes are terms fuzzyfeed computes: an optional (a, 0), one or two points at 1,
    an optional (d, 0). A list starting (ending) at 1 is a shoulder reaching the universe's end.
    """
    if not pts or any(y not in (0.0, 1.0) for _, y in pts):
        raise RuleTableError(f"{where}: points {list(pts)!r}; fuzzyfeed reads terms whose points "
                             "rise from 0 to 1 and fall back to 0 (triangles, trapezoids, shoulders)")
    xs = [x for x, _ in pts]
    if any(b < a for a, b in zip(xs, xs[1:])):
        raise RuleTableError(f"{where}: points {list(pts)!r}; x must be non-decreasing")
    rest = list(pts)
    a = d = None
    if rest[0][1] == 0.0:
        a = rest.pop(0)[0]
    if rest and rest[-1][1] == 0.0:
        d = rest.pop()[0]
    if not 1 <= len(rest) <= 2 or any(y != 1.0 for _, y in rest):
        raise RuleTableError(f"{where}: points {list(pts)!r}; expected (a, 0), one or two points "
                             "at 1, (d, 0)")
    b, c = rest[0][0], rest[-1][0]
    if a is None:
        a = b = lo
    if d is None:
        c = d = hi
    return (a, b, d) if b == c else (a, b, c, d)


def trapezoid_points(term: Term, lo: float, hi: float) -> list[tuple[float, float]]:
    """The inverse of :func:`points_to_trapezoid`: the term as an FCL point list."""
    a, b, c, d = term.trapezoid
    pts = []
    if a < b or a > lo:           # a = b > lo: a vertical rising edge, (a, 0) then (a, 1)
        pts.append((a, 0.0))
    pts.append((b, 1.0))
    if c > b:
        pts.append((c, 1.0))
    if d > c or d < hi:           # c = d < hi: a vertical falling edge
        pts.append((d, 0.0))
    return pts


def shape_params(points: tuple[float, ...]) -> tuple[str, tuple[float, ...]]:
    """("triangle", (a, b, c)) or ("trapezoid", (a, b, c, d))."""
    return ("triangle" if len(points) == 3 else "trapezoid", tuple(float(x) for x in points))


@dataclass
class Spec:
    """What a parser read: variables in file order, rules, operators and fuzzyfeed's settings."""

    path: str
    name: str = ""
    inputs: list[Variable] = field(default_factory=list)
    outputs: list[Variable] = field(default_factory=list)
    rules: list[tuple[dict, str]] = field(default_factory=list)       # ({input: label}, feed label)
    operators: dict[str, str] = field(default_factory=dict)           # role -> name as written
    default: float | None = None
    settings: dict = field(default_factory=dict)


#: Operator names each format may use for fuzzyfeed's controller, lower-case.
ACCEPTED = {"and": {"min", "minimum"}, "implication": {"min", "minimum"},
            "aggregation": {"max", "maximum"}, "defuzzifier": {"cog", "centroid"}}


def spec_to_table(spec: Spec, settings_from: RuleTable | None = None) -> RuleTable:
    """Check a parsed file against fuzzyfeed's controller and build the :class:`RuleTable`."""
    where = spec.path
    for role, name in spec.operators.items():
        if role in ACCEPTED and name.lower() not in ACCEPTED[role]:
            raise RuleTableError(f"{where}: {role} = {name}; fuzzyfeed computes AND = min, "
                                 "implication = min, aggregation = max, centroid only")
    names_in = [v.name for v in spec.inputs]
    names_out = [v.name for v in spec.outputs]
    kind = kind_of_inputs(names_in)
    if kind is None or names_out != [FEED]:
        kinds = " or ".join(f"[{a!r}, {b!r}]" for a, b in INPUT_NAMES.values())
        raise RuleTableError(f"{where}: inputs {names_in} and outputs {names_out}; a fuzzyfeed table "
                             f"has inputs {kinds} and one output {FEED!r} (rename them)")
    k, d, f = spec.inputs[0], spec.inputs[1], spec.outputs[0]
    kn, dn = k.name, d.name
    cells: dict[tuple[str, str], str] = {}
    for pairs, fl in spec.rules:
        if set(pairs) != {kn, dn}:
            raise RuleTableError(f"{where}: rule on {sorted(pairs)}; a rule reads IF {kn} IS … AND {dn} "
                                 f"IS … THEN {FEED} IS …")
        kl, dl = pairs[kn], pairs[dn]
        for var, label in ((k, kl), (d, dl), (f, fl)):
            if label not in var.labels:
                raise RuleTableError(f"{where}: rule IF {kn} IS {kl} AND {dn} IS {dl} THEN {FEED} "
                                     f"IS {fl}: unknown {var.name} term {label!r}")
        if (kl, dl) in cells:
            raise RuleTableError(f"{where}: two rules for {kn} IS {kl} AND {dn} IS {dl} "
                                 f"({cells[(kl, dl)]} and {fl}); give each cell once")
        cells[(kl, dl)] = fl
    missing = [f"({a}, {b})" for a in k.labels for b in d.labels if (a, b) not in cells]
    if missing:
        raise RuleTableError(f"{where}: no rule for ({kn}, {dn}) = {', '.join(missing[:6])}"
                             + (" …" if len(missing) > 6 else "") + "; fuzzyfeed's grid needs "
                             "one rule per pair of input terms")
    base = settings_from if settings_from is not None else load_rule_table(
        DEFAULT_MACHINE_TABLE if kind == MACHINE else None)
    s = dict(spec.settings)
    unknown = set(s) - set(SETTING_KEYS) - {"name", "source"}
    if unknown:
        raise RuleTableError(f"{where}: unknown {SETTINGS_TAG} key(s) {sorted(unknown)}")
    values = {key: s.get(key, getattr(base, key)) for key in SETTING_KEYS}
    if spec.default is not None and math.isfinite(spec.default):
        values["feed_floor_pct"] = spec.default if "feed_floor_pct" not in s else s["feed_floor_pct"]
    name = str(s.get("name") or spec.name or Path(spec.path).stem)
    source = str(s.get("source", f"imported from {Path(spec.path).name}"))
    grid = tuple(tuple(cells[(a, b)] for b in d.labels) for a in k.labels)
    try:
        return RuleTable(name=name, curvature=k, curvature_variation=d, feed=f, grid=grid,
                         source=source, inputs=kind, **values)
    except TypeError as exc:        # a settings value of the wrong type
        raise RuleTableError(f"{where}: {SETTINGS_TAG}: {exc}") from None


def rule_cells(m, where: str, shown: str, weight_word: str, form: str) -> tuple[dict, str]:
    """({input: term}, feed term) of a parsed rule, shared by the FCL and FLL readers: ``m`` is
    their rule pattern's match (groups: variable/term pairs 1–4, output 5/6, weight 7); ``shown``,
    ``weight_word`` and ``form`` word the one-line errors in the format's own keywords. Which
    inputs a rule names is checked against the declared ones by :func:`spec_to_table`."""
    if m.group(7) is not None and float(m.group(7)) != 1.0:
        raise RuleTableError(f"{where}: {weight_word} {m.group(7)}; fuzzyfeed's rules all weigh 1")
    pairs = {m.group(1): m.group(2), m.group(3): m.group(4)}
    if len(pairs) != 2 or m.group(5) != FEED:
        raise RuleTableError(f"{where}: {shown}; {form}")
    return pairs, m.group(6)


__all__ = ["EXPORT_FORMATS", "IMPORT_SUFFIXES", "Spec", "numbered_rules", "rule_number",
           "spec_to_table", "VARIABLES"]
