"""Rule tables written and edited (:mod:`fuzzyfeed.fuzzy.rules`): the TOML text in the shipped layout
(aligned grid, full float precision), one rule cell changed in place with :mod:`tomlkit` (comments
and layout kept, the result validated), and the grid as text for a terminal or a spreadsheet.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

from fuzzyfeed.base.toml_lines import HEADER as _HEADER
from fuzzyfeed.base.toml_lines import KEY as _KEY
from fuzzyfeed.errors import RuleTableError
from fuzzyfeed.fuzzy.rule_reader import parse_rule_table, read_rule_text
from fuzzyfeed.fuzzy.rules import PAPER, RuleTable, term_index


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
    term_index(table.curvature, row, f"{path}: row")
    term_index(table.curvature_variation, column, f"{path}: column")
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
    new_text = set_cell_text(read_rule_text(path), row, column, label, path)
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
