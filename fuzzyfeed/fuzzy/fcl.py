"""FCL (IEC 61131-7 Fuzzy Control Language): export in the standard's form or in fuzzylite's
dialect, and import of either.

The standard's form: ``(* *)`` comments, upper-case keywords, terms as point lists
``(x, μ) (x, μ) …``, ``ACCU`` in the RULEBLOCK. fuzzylite 6 (QtFuzzyLite) reads FCL differently
and silently: it skips only ``//`` and ``#`` comments (a ``(*`` line is an error), takes ``ACCU``
only in DEFUZZIFY, and parses rules with lower-case ``if/is/and/then`` — an upper-case rule fails
to load without a message and the engine returns DEFAULT everywhere. Its dialect therefore writes
``//`` comments, ``ACCU`` in DEFUZZIFY, lower-case rules and ``Triangle``/``Trapezoid`` terms.
Neither can state the centroid's resolution: fuzzylite's FCL importer uses its default (100 cells).
"""

from __future__ import annotations

import re

from fuzzyfeed.errors import RuleTableError
from fuzzyfeed.fuzzy.exchange import (SETTINGS_TAG, Spec, num, numbered_rules, points_to_trapezoid,
                                      read_settings, rule_cells, settings_json, shape_params,
                                      trapezoid_points)
from fuzzyfeed.fuzzy.rules import DK, FEED, KAPPA, SAFE, SAFE_NEAR, RuleTable, Term, Variable

_UNITS = {KAPPA: "1/mm, clipped to the universe", DK: "normalised curvature variation",
          SAFE: "feed that holds the contour tolerance / programmed feed",
          SAFE_NEAR: "lowest such ratio within the servo's settling distance",
          FEED: "% of the maximum feed"}


def table_to_fcl(t: RuleTable, dialect: str = "iec") -> str:
    """The table as FCL: AND/ACT MIN, ACCU MAX, METHOD COG, DEFAULT = the feed floor (fuzzyfeed's
    output where no rule fires); rules numbered as seed 002 (R1–R30 on the paper's grid).

    fuzzyfeed clips its inputs to the universes and normalises Dκ before the controller; an FCL
    engine gets the same numbers only if it is fed the same features.
    """
    if dialect not in ("iec", "fuzzylite"):
        raise RuleTableError(f"FCL dialect {dialect!r}: must be 'iec' or 'fuzzylite'")
    iec = dialect == "iec"

    def comment(text: str) -> str:
        return f"(* {text.replace('*)', '* )')} *)" if iec else f"// {text}"

    def term_text(term: Term, lo: float, hi: float) -> str:
        if iec:
            return " ".join(f"({num(x)}, {num(y)})" for x, y in trapezoid_points(term, lo, hi))
        kind, params = shape_params(term.points)
        return ("Triangle " if kind == "triangle" else "Trapezoid ") + " ".join(num(x) for x in params)

    name = re.sub(r"\W", "_", t.name) or "rules"
    head = f"fuzzyfeed rule table {t.name!r}" + (f": {t.source}" if t.source else "")
    out = [comment(head), comment(f"{SETTINGS_TAG} {settings_json(t)}"), f"FUNCTION_BLOCK {name}", ""]
    out += ["VAR_INPUT"]
    k_name, d_name = t.input_names
    for var in (k_name, d_name):
        out.append(f"    {var} : REAL;" + (f" {comment(_UNITS[var])}" if iec else ""))
    out += ["END_VAR", "", "VAR_OUTPUT", f"    {FEED} : REAL;" + (f" {comment(_UNITS[FEED])}" if iec else ""),
            "END_VAR", ""]
    for var, block in ((t.curvature, "FUZZIFY"), (t.curvature_variation, "FUZZIFY"), (t.feed, "DEFUZZIFY")):
        lo, hi = var.universe
        out += [f"{block} {var.name}", f"    RANGE := ({num(lo)} .. {num(hi)});"]
        out += [f"    TERM {term.label} := {term_text(term, lo, hi)};" for term in var.terms]
        if block == "DEFUZZIFY":
            out += ["    METHOD : COG;"] + ([] if iec else ["    ACCU : MAX;"])
            out += [f"    DEFAULT := {num(t.feed_floor_pct)};"]
        out += [f"END_{block}", ""]
    out += ["RULEBLOCK rules", "    AND : MIN;", "    ACT : MIN;"] + (["    ACCU : MAX;"] if iec else [])
    kw = ("IF", "IS", "AND", "THEN") if iec else ("if", "is", "and", "then")
    for n, k, d, f in numbered_rules(t):
        out.append(f"    RULE {n} : {kw[0]} {k_name} {kw[1]} {k} {kw[2]} {d_name} {kw[1]} {d} "
                   f"{kw[3]} {FEED} {kw[1]} {f};")
    out += ["END_RULEBLOCK", "", "END_FUNCTION_BLOCK"]
    return "\n".join(out) + "\n"


_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_RULE = re.compile(r"RULE\s+\w+\s*:\s*IF\s+(\w+)\s+IS\s+(\w+)\s+AND\s+(\w+)\s+IS\s+(\w+)\s+THEN\s+"
                   rf"(\w+)\s+IS\s+(\w+)(?:\s+WITH\s+({_NUMBER}))?\s*$", re.IGNORECASE)


def _strip_comments(text: str) -> list[tuple[int, str]]:
    """(line number, text) with ``(* *)`` (possibly multi-line), ``//`` and ``#`` comments removed."""
    text = re.sub(r"\(\*.*?\*\)", lambda m: "\n" * m.group(0).count("\n"), text, flags=re.DOTALL)
    out = []
    for n, line in enumerate(text.splitlines(), start=1):
        line = re.split(r"//|#", line, maxsplit=1)[0].strip()
        for stmt in line.split(";"):
            if stmt.strip():
                out.append((n, stmt.strip()))
    return out


def _range(stmt: str, where: str) -> tuple[float, float]:
    m = re.fullmatch(rf"RANGE\s*:=\s*\(\s*({_NUMBER})\s*\.\.\s*({_NUMBER})\s*\)", stmt, re.IGNORECASE)
    if not m:
        raise RuleTableError(f"{where}: {stmt!r}; expected RANGE := (min .. max)")
    return float(m.group(1)), float(m.group(2))


def _term(stmt: str, where: str) -> tuple[str, str, list]:
    m = re.fullmatch(r"TERM\s+(\w+)\s*:=\s*(.+)", stmt, re.IGNORECASE | re.DOTALL)
    if not m:
        raise RuleTableError(f"{where}: {stmt!r}; expected TERM name := points")
    label, body = m.group(1), m.group(2).strip()
    pts = re.findall(rf"\(\s*({_NUMBER})\s*,\s*({_NUMBER})\s*\)", body)
    if pts and re.fullmatch(rf"(?:\(\s*{_NUMBER}\s*,\s*{_NUMBER}\s*\)\s*)+", body):
        return label, "points", [(float(x), float(y)) for x, y in pts]
    m = re.fullmatch(rf"(Triangle|Trapezoid)((?:\s+{_NUMBER})+)", body, re.IGNORECASE)
    if m:
        params = [float(x) for x in m.group(2).split()]
        if len(params) != (3 if m.group(1).lower() == "triangle" else 4):
            raise RuleTableError(f"{where}: {stmt!r}; a Triangle has 3 vertices, a Trapezoid 4")
        return label, "shape", params
    raise RuleTableError(f"{where}: term {label} := {body!r}; fuzzyfeed reads point lists "
                         "(x, y) … and Triangle/Trapezoid terms")


def parse_fcl(text: str, path: str = "<fcl>") -> Spec:
    """Read FCL (the standard's form, fuzzylite's dialect, or either mixed) into a :class:`Spec`."""
    spec = Spec(path=path)
    for line in text.splitlines():
        if SETTINGS_TAG in line:
            spec.settings = read_settings(line, path)
            break
    block, block_name = "", ""
    var_terms: dict[str, list] = {}
    var_range: dict[str, tuple[float, float]] = {}
    inputs: list[str] = []
    outputs: list[str] = []
    for n, stmt in _strip_comments(text):
        where = f"{path}:{n}"
        words = stmt.split()
        key = words[0].upper()
        if key == "FUNCTION_BLOCK":
            spec.name = " ".join(words[1:])
            continue
        if key == "END_FUNCTION_BLOCK":
            break
        if key in ("VAR_INPUT", "VAR_OUTPUT", "FUZZIFY", "DEFUZZIFY", "RULEBLOCK"):
            if block:
                raise RuleTableError(f"{where}: {key} inside {block}; close {block} first")
            block, block_name = key, (words[1] if len(words) > 1 else "")
            if key in ("FUZZIFY", "DEFUZZIFY"):
                if block_name not in inputs + outputs:
                    raise RuleTableError(f"{where}: {key} {block_name}: variable not declared in "
                                         "VAR_INPUT/VAR_OUTPUT")
                var_terms.setdefault(block_name, [])
            continue
        if key in ("END_VAR", "END_FUZZIFY", "END_DEFUZZIFY", "END_RULEBLOCK"):
            block = ""
            continue
        if block in ("VAR_INPUT", "VAR_OUTPUT"):
            m = re.fullmatch(r"(\w+)\s*:\s*REAL", stmt, re.IGNORECASE)
            if not m:
                raise RuleTableError(f"{where}: {stmt!r}; expected NAME : REAL")
            (inputs if block == "VAR_INPUT" else outputs).append(m.group(1))
        elif block in ("FUZZIFY", "DEFUZZIFY"):
            if key == "RANGE":
                var_range[block_name] = _range(stmt, where)
            elif key == "TERM":
                var_terms[block_name].append((where, *_term(stmt, where)))
            elif block == "DEFUZZIFY" and key in ("METHOD", "ACCU"):
                role = "defuzzifier" if key == "METHOD" else "aggregation"
                spec.operators[role] = stmt.split(":", 1)[-1].strip()
            elif block == "DEFUZZIFY" and key == "DEFAULT":
                value = stmt.split(":=", 1)[-1].split("|")[0].strip()
                try:
                    spec.default = float(value)
                except ValueError:
                    raise RuleTableError(f"{where}: DEFAULT := {value!r}; expected a number") from None
            else:
                raise RuleTableError(f"{where}: {stmt!r}: not understood in {block} {block_name}")
        elif block == "RULEBLOCK":
            if key in ("AND", "ACT", "ACCU", "OR"):
                role = {"AND": "and", "ACT": "implication", "ACCU": "aggregation", "OR": "or"}[key]
                spec.operators[role] = stmt.split(":", 1)[-1].strip()
            elif key == "RULE":
                spec.rules.append(_rule(stmt, where))
            else:
                raise RuleTableError(f"{where}: {stmt!r}: not understood in RULEBLOCK")
        else:
            raise RuleTableError(f"{where}: {stmt!r}: outside any block")
    spec.operators.setdefault("defuzzifier", "COG")
    for names, dest in ((inputs, spec.inputs), (outputs, spec.outputs)):
        for name in names:
            dest.append(_variable(name, var_terms.get(name, []), var_range.get(name), path))
    return spec


def _rule(stmt: str, where: str) -> tuple[dict, str]:
    m = _RULE.fullmatch(stmt.strip())
    if not m:
        raise RuleTableError(f"{where}: {stmt!r}; fuzzyfeed reads rules "
                             "RULE n : IF a IS x AND b IS y THEN c IS z (no OR, NOT or hedges)")
    return rule_cells(m, where, repr(stmt), "rule weight WITH",
                      f"a rule reads IF <input> IS … AND <input> IS … THEN {FEED} IS …")


def _variable(name: str, terms: list, rng: tuple[float, float] | None, path: str) -> Variable:
    if not terms:
        raise RuleTableError(f"{path}: variable {name} has no terms")
    if rng is None:                      # IEC allows no RANGE: the terms' extent
        xs = [p[0] for _, _, kind, pts in terms for p in (pts if kind == "points" else [(x,) for x in pts])]
        rng = (min(xs), max(xs))
    lo, hi = rng
    out = []
    for where, label, kind, pts in terms:
        points = (points_to_trapezoid(pts, lo, hi, f"{where}: {name}.{label}") if kind == "points"
                  else tuple(pts))
        out.append(Term(label, points))
    return Variable(name, (lo, hi), tuple(out))
