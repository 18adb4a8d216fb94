"""MATLAB Fuzzy Logic Toolbox ``.fis`` files (Mamdani): export and import.

Layout (MathWorks' ``writeFIS`` text format): ``[System]`` (Name, Type='mamdani', AndMethod='min',
ImpMethod='min', AggMethod='max', DefuzzMethod='centroid'), ``[Input1]``, ``[Input2]``,
``[Output1]`` (Name, Range=[lo hi], NumMFs, ``MFk='label':'trimf',[a b c]`` or ``'trapmf'``) and
``[Rules]``, one line per rule: the input terms' 1-based indices, a comma, the output term's index,
the weight in parentheses and the connective after a colon (1 = AND): ``1 1, 8 (1) : 1``.
A ``.fis`` carries neither fuzzyfeed's settings nor a default output; see
:mod:`fuzzyfeed.fuzzy.exchange`.
"""

from __future__ import annotations

import re

from fuzzyfeed.errors import RuleTableError
from fuzzyfeed.fuzzy.exchange import Spec, num, numbered_rules, shape_params
from fuzzyfeed.fuzzy.rules import RuleTable, Term, Variable


def _quote(s: str) -> str:
    return "'" + s.replace("'", "") + "'"


def table_to_fis(t: RuleTable) -> str:
    """The table as a Mamdani ``.fis`` (rules in seed 002's order)."""
    out = ["[System]", f"Name={_quote(t.name)}", "Type='mamdani'", "Version=2.0", "NumInputs=2",
           "NumOutputs=1", f"NumRules={len(t.rules)}", "AndMethod='min'", "OrMethod='max'",
           "ImpMethod='min'", "AggMethod='max'", "DefuzzMethod='centroid'"]
    for section, var in (("Input1", t.curvature), ("Input2", t.curvature_variation), ("Output1", t.feed)):
        out += ["", f"[{section}]", f"Name={_quote(var.name)}",
                f"Range=[{num(var.universe[0])} {num(var.universe[1])}]", f"NumMFs={len(var.terms)}"]
        for m, term in enumerate(var.terms, start=1):
            kind, params = shape_params(term.points)
            mf = "trimf" if kind == "triangle" else "trapmf"
            out.append(f"MF{m}={_quote(term.label)}:'{mf}',[" + " ".join(num(x) for x in params) + "]")
    out += ["", "[Rules]"]
    k, d, f = t.curvature, t.curvature_variation, t.feed
    for _, kl, dl, fl in numbered_rules(t):
        out.append(f"{k.index(kl) + 1} {d.index(dl) + 1}, {f.index(fl) + 1} (1) : 1")
    return "\n".join(out) + "\n"


_MF = re.compile(r"MF(\d+)\s*=\s*'([^']*)'\s*:\s*'(\w+)'\s*,\s*\[([^\]]*)\]")
_RULE = re.compile(r"([-\d.\s]+),([-\d.\s]+)\(\s*([-\d.eE+]+)\s*\)\s*:\s*(\d+)")


def _numbers(text: str, where: str) -> list[float]:
    try:
        return [float(x) for x in text.replace(",", " ").split()]
    except ValueError:
        raise RuleTableError(f"{where}: {text!r}; expected numbers") from None


def parse_fis(text: str, path: str = "<fis>") -> Spec:
    """Read a Mamdani ``.fis`` into a :class:`Spec` (trimf and trapmf terms, AND rules)."""
    spec = Spec(path=path)
    sections: list[tuple[str, int, dict, list]] = []
    for n, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith(("%", "#")):
            continue
        m = re.fullmatch(r"\[(\w+)\]", line)
        if m:
            sections.append((m.group(1), n, {}, []))
            continue
        if not sections:
            raise RuleTableError(f"{path}:{n}: {line!r} before the first [section]")
        name, _, keys, lines = sections[-1]
        if name == "Rules":
            lines.append((n, line))
        elif _MF.match(line):
            lines.append((n, line))
        elif "=" in line:
            key, value = (x.strip() for x in line.split("=", 1))
            keys[key] = (n, value.strip("'"))
        else:
            raise RuleTableError(f"{path}:{n}: {line!r}; expected Key=value")
    variables = {}
    for name, n, keys, lines in sections:
        if name == "System":
            spec.name = keys.get("Name", (n, ""))[1]
            kind = keys.get("Type", (n, "mamdani"))[1]
            if kind.lower() != "mamdani":
                raise RuleTableError(f"{path}:{keys['Type'][0]}: Type={kind}; fuzzyfeed reads Mamdani systems")
            for key, role in (("AndMethod", "and"), ("ImpMethod", "implication"),
                              ("AggMethod", "aggregation"), ("DefuzzMethod", "defuzzifier")):
                if key in keys:
                    spec.operators[role] = keys[key][1]
        elif re.fullmatch(r"(Input|Output)\d+", name):
            variables[name] = _variable(name, n, keys, lines, path)
        elif name != "Rules":
            raise RuleTableError(f"{path}:{n}: section [{name}] not understood")
    inputs = sorted((k for k in variables if k.startswith("Input")), key=lambda s: int(s[5:]))
    outputs = sorted((k for k in variables if k.startswith("Output")), key=lambda s: int(s[6:]))
    spec.inputs = [variables[k] for k in inputs]
    spec.outputs = [variables[k] for k in outputs]
    rules = [lines for name, _, _, lines in sections if name == "Rules"]
    for n, line in (rules[0] if rules else []):
        spec.rules.append(_rule(line, f"{path}:{n}", spec.inputs, spec.outputs))
    return spec


def _variable(section: str, n: int, keys: dict, lines: list, path: str) -> Variable:
    if "Name" not in keys or "Range" not in keys:
        raise RuleTableError(f"{path}:{n}: [{section}] needs Name= and Range=[lo hi]")
    rng = _numbers(keys["Range"][1].strip("[]"), f"{path}:{keys['Range'][0]}")
    if len(rng) != 2:
        raise RuleTableError(f"{path}:{keys['Range'][0]}: Range={keys['Range'][1]}; expected [lo hi]")
    terms = []
    for ln, line in lines:
        m = _MF.match(line)
        label, mf, params = m.group(2), m.group(3), _numbers(m.group(4), f"{path}:{ln}")
        want = {"trimf": 3, "trapmf": 4}.get(mf)
        if want is None:
            raise RuleTableError(f"{path}:{ln}: {mf} term {label!r}; fuzzyfeed reads trimf and trapmf")
        if len(params) != want:
            raise RuleTableError(f"{path}:{ln}: {mf} {label!r} has {len(params)} parameters; expected {want}")
        terms.append(Term(label, tuple(params)))
    return Variable(keys["Name"][1], (rng[0], rng[1]), tuple(terms))


def _rule(line: str, where: str, inputs: list[Variable], outputs: list[Variable]) -> tuple[dict, str]:
    m = _RULE.fullmatch(line.strip())
    if not m:
        raise RuleTableError(f"{where}: rule {line!r}; expected 'i j, o (w) : c'")
    ins, outs = _numbers(m.group(1), where), _numbers(m.group(2), where)
    if len(ins) != len(inputs) or len(outs) != len(outputs) or len(inputs) != 2 or len(outputs) != 1:
        raise RuleTableError(f"{where}: rule {line!r}; expected two input indices and one output index")
    if float(m.group(3)) != 1.0 or m.group(4) != "1":
        raise RuleTableError(f"{where}: rule {line!r}; fuzzyfeed's rules weigh 1 and join with AND (: 1)")
    labels = []
    for idx, var in zip(ins + outs, inputs + outputs):
        if idx != int(idx) or not 1 <= idx <= len(var.terms):
            raise RuleTableError(f"{where}: rule {line!r}: {var.name} index {idx:g}; must be 1 to "
                                 f"{len(var.terms)} (no 0 = any, no negative = NOT)")
        labels.append(var.terms[int(idx) - 1].label)
    return {inputs[0].name: labels[0], inputs[1].name: labels[1]}, labels[2]
