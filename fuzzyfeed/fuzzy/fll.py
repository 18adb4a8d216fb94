"""FLL, the fuzzylite language (fuzzylite 6, QtFuzzyLite): export and import.

The centroid is written with an explicit resolution (:data:`~fuzzyfeed.fuzzy.exchange.FLL_RESOLUTION`
cells of the midpoint rule) so fuzzylite's discretised centroid agrees with fuzzyfeed's exact one;
conjunction Minimum, implication Minimum, aggregation Maximum, default = the feed floor.
"""

from __future__ import annotations

import re

from fuzzyfeed.errors import RuleTableError
from fuzzyfeed.fuzzy.exchange import (FLL_RESOLUTION, SETTINGS_TAG, Spec, num, numbered_rules,
                                      read_settings, rule_cells, settings_json, shape_params)
from fuzzyfeed.fuzzy.rules import FEED, RuleTable, Term, Variable


def _term_line(term: Term) -> str:
    kind, params = shape_params(term.points)
    return (f"  term: {term.label} {'Triangle' if kind == 'triangle' else 'Trapezoid'} "
            + " ".join(num(x) for x in params))


def table_to_fll(t: RuleTable, resolution: int = FLL_RESOLUTION) -> str:
    """The table as FLL; rules in seed 002's order, each followed by ``# R<n>``."""
    name = re.sub(r"\s", "_", t.name) or "rules"
    out = [f"# fuzzyfeed rule table {t.name!r}" + (f": {t.source}" if t.source else ""),
           f"# {SETTINGS_TAG} {settings_json(t)}", f"Engine: {name}"]
    for var in (t.curvature, t.curvature_variation):
        out += [f"InputVariable: {var.name}", "  enabled: true",
                f"  range: {num(var.universe[0])} {num(var.universe[1])}", "  lock-range: false"]
        out += [_term_line(term) for term in var.terms]
    f = t.feed
    out += [f"OutputVariable: {f.name}", "  enabled: true",
            f"  range: {num(f.universe[0])} {num(f.universe[1])}", "  lock-range: false",
            "  aggregation: Maximum", f"  defuzzifier: Centroid {int(resolution)}",
            f"  default: {num(t.feed_floor_pct)}", "  lock-previous: false"]
    out += [_term_line(term) for term in f.terms]
    out += ["RuleBlock: rules", "  enabled: true", "  conjunction: Minimum", "  disjunction: none",
            "  implication: Minimum", "  activation: General"]
    k_name, d_name = t.input_names
    out += [f"  rule: if {k_name} is {k} and {d_name} is {d} then {FEED} is {fl}  # R{n}"
            for n, k, d, fl in numbered_rules(t)]
    return "\n".join(out) + "\n"


_RULE = re.compile(r"if\s+(\w+)\s+is\s+(\w+)\s+and\s+(\w+)\s+is\s+(\w+)\s+then\s+(\w+)\s+is\s+(\w+)"
                   r"(?:\s+with\s+(\S+))?")


def parse_fll(text: str, path: str = "<fll>") -> Spec:
    """Read FLL into a :class:`Spec` (Triangle and Trapezoid terms; one rule block)."""
    spec = Spec(path=path)
    current: dict | None = None
    variables: list[dict] = []
    for n, raw in enumerate(text.splitlines(), start=1):
        where = f"{path}:{n}"
        if SETTINGS_TAG in raw:
            spec.settings = read_settings(raw, where)
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        if ":" not in line:
            raise RuleTableError(f"{where}: {line!r}; expected key: value")
        key, value = (x.strip() for x in line.split(":", 1))
        if key == "Engine":
            spec.name = value
        elif key in ("InputVariable", "OutputVariable"):
            current = {"kind": key, "name": value, "range": None, "terms": [], "where": where}
            variables.append(current)
        elif key == "RuleBlock":
            current = {"kind": key}
        elif key == "rule":
            spec.rules.append(_rule(value, where))
        elif key == "term":
            if current is None or current["kind"] == "RuleBlock":
                raise RuleTableError(f"{where}: term outside a variable")
            current["terms"].append(_term(value, where))
        elif key == "range":
            try:
                lo, hi = (float(x) for x in value.split())
            except ValueError:
                raise RuleTableError(f"{where}: range: {value!r}; expected two numbers") from None
            current["range"] = (lo, hi)
        elif key in ("conjunction", "implication", "aggregation", "defuzzifier", "disjunction",
                     "activation", "default"):
            role = {"conjunction": "and"}.get(key, key)
            if key == "defuzzifier":
                value = value.split()[0] if value else value
            if key == "default":
                try:
                    spec.default = float(value)
                except ValueError:
                    raise RuleTableError(f"{where}: default: {value!r}; expected a number") from None
            elif key in ("conjunction", "implication", "aggregation", "defuzzifier"):
                spec.operators[role] = value
            elif key == "activation" and value.lower() not in ("general", "none", ""):
                raise RuleTableError(f"{where}: activation: {value}; fuzzyfeed fires every rule (General)")
        elif key in ("enabled", "lock-range", "lock-previous", "description"):
            if key == "enabled" and value != "true":
                raise RuleTableError(f"{where}: enabled: {value}; a disabled part has no meaning here")
        else:
            raise RuleTableError(f"{where}: key {key!r} not understood")
    for v in variables:
        if v["range"] is None:
            raise RuleTableError(f"{v['where']}: {v['kind']} {v['name']} has no range")
        var = Variable(v["name"], v["range"], tuple(Term(label, pts) for label, pts in v["terms"]))
        (spec.inputs if v["kind"] == "InputVariable" else spec.outputs).append(var)
    return spec


def _term(value: str, where: str) -> tuple[str, tuple[float, ...]]:
    parts = value.split()
    if len(parts) < 2 or parts[1] not in ("Triangle", "Trapezoid"):
        raise RuleTableError(f"{where}: term {value!r}; fuzzyfeed reads Triangle and Trapezoid terms")
    try:
        params = tuple(float(x) for x in parts[2:])
    except ValueError:
        raise RuleTableError(f"{where}: term {value!r}; vertices must be numbers") from None
    want = 3 if parts[1] == "Triangle" else 4
    if len(params) not in (want, want + 1):         # fuzzylite allows a trailing height
        raise RuleTableError(f"{where}: term {value!r}; a {parts[1]} has {want} vertices")
    if len(params) == want + 1 and params[-1] != 1.0:
        raise RuleTableError(f"{where}: term {value!r}: height {params[-1]:g}; fuzzyfeed's terms reach 1")
    return parts[0], params[:want]


def _rule(value: str, where: str) -> tuple[dict, str]:
    m = _RULE.fullmatch(value.strip())
    if not m:
        raise RuleTableError(f"{where}: rule {value!r}; fuzzyfeed reads "
                             "'if a is x and b is y then c is z' (no or, not or hedges)")
    return rule_cells(m, where, f"rule {value!r}", "rule weight",
                      f"a rule reads if <input> is … and <input> is … then {FEED} is …")
