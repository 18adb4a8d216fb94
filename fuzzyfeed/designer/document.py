"""A rule table being edited: its TOML text (comments kept), undo/redo, validation by field, the
difference to the file on disk, export, and a save that never overwrites a file changed on disk.

Every edit is a new TOML text made with :mod:`tomlkit` from the last one, so the file's comments
and layout survive (grid cells through :func:`fuzzyfeed.fuzzy.rule_writer.set_cell_text`, which keeps
the grid aligned). The text is validated by :func:`fuzzyfeed.fuzzy.rule_reader.table_from_mapping`, the
validator of ``fuzzyfeed rules check``, with a locator that marks which field a message is about,
so the designer can show it next to that field. An invalid draft stays editable and is never
saved.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

from fuzzyfeed.errors import FileConflictError, RuleTableError
from fuzzyfeed.fuzzy.rules import RuleTable, Term, Variable

_MARK = re.compile("\x02([^\x03]*)\x03([^\x02]*)\x02")


@dataclass(frozen=True)
class FieldError:
    """A validation message and the field it is about: ``section`` (a variable's name,
    ``features`` or ``rules``) and ``key`` (a term label, ``universe``, a setting; None for the
    whole section)."""

    section: str
    key: str | None
    message: str


def validate_text(text: str, path: Path | None) -> RuleTable | FieldError:
    """The table the TOML text describes, or the first rule it breaks (the messages of
    ``fuzzyfeed rules check``, without the location, and the field they are about)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        return FieldError("", None, f"invalid TOML: {exc}")
    return validate_data(data, path)


def validate_data(data: dict, path: Path | None) -> RuleTable | FieldError:
    """:func:`validate_text` on the parsed TOML."""
    from fuzzyfeed.fuzzy.rule_reader import table_from_mapping

    def where(section: str, key: str | None = None) -> str:
        return f"\x02{section}\x03{key or ''}\x02"

    try:
        return table_from_mapping(data, where, path)
    except RuleTableError as exc:
        message = str(exc)
        m = _MARK.search(message)
        if m is None:
            return FieldError("", None, message)
        section, key = m.group(1), m.group(2) or None
        shown = f"{section}.{key}" if key else f"[{section}]"
        message = message[m.end() + 2:] if m.start() == 0 and message[m.end():].startswith(": ") else \
            _MARK.sub(lambda g: shown, message, count=1)
        return FieldError(section, key, message)


_HEADER = re.compile(r"^\s*\[\s*([A-Za-z0-9_.\-]+)\s*\]\s*(#.*)?$")
_LIST_KEY = re.compile(r"^(\s*([A-Za-z0-9_\-]+)\s*=\s*)\[([^\[\]#]*)\](.*)$", re.DOTALL)


def set_list_item(text: str, section: str, key: str, index: int, literal: str) -> str | None:
    """The text with item ``index`` of the one-line list ``key = [...]`` in ``[section]`` written
    as ``literal``, the spaces after it adjusted so aligned columns stay aligned; None when the
    list is not on one line of its own (the caller then edits with tomlkit)."""
    lines = text.splitlines(keepends=True)
    current = ""
    for n, line in enumerate(lines):
        m = _HEADER.match(line)
        if m:
            current = m.group(1)
            continue
        if current != section:
            continue
        m = _LIST_KEY.match(line)
        if not m or m.group(2) != key:
            continue
        items = m.group(3).split(",")
        if not 0 <= index < len(items) or any(not x.strip() for x in items):
            return None
        old = items[index]
        lead = old[:len(old) - len(old.lstrip())]
        trail = old[len(old.rstrip()):]
        items[index] = lead + literal + trail
        grow = len(literal) - len(old.strip())
        if index + 1 < len(items) and grow:
            nxt = items[index + 1]
            spaces = len(nxt) - len(nxt.lstrip(" "))
            items[index + 1] = " " * max(1, spaces - grow) + nxt.lstrip(" ")
        lines[n] = f"{m.group(1)}[{','.join(items)}]{m.group(4)}"
        return "".join(lines)
    return None


def _round_to_universe(value: float, universe: tuple[float, float]) -> float:
    """``value`` rounded to 1/1000 of the universe's width (a dragged breakpoint)."""
    import math

    width = universe[1] - universe[0]
    digits = max(0, 3 - math.floor(math.log10(width))) if width > 0 else 6
    return round(float(value), digits)


class Document:
    """A rule-table file opened for editing. ``table`` is the last valid table (what the plots
    show), ``error`` the first rule the current text breaks (None when valid)."""

    def __init__(self, spec: str | Path | None = None):
        from fuzzyfeed.fuzzy.rule_reader import parse_rule_table, resolve_rules_path, rules_dir
        from fuzzyfeed.base.files import read_text

        path = resolve_rules_path(spec)
        text = read_text(path, "rule table", RuleTableError)
        table = parse_rule_table(text, path)    # an invalid file is refused in one line
        shipped = path.resolve().parent == rules_dir().resolve()
        #: where Save writes: the file opened, or for a shipped table a new file of its name here
        self.save_path = Path.cwd() / path.name if shipped else path
        self.path = path
        self.disk_text = text                   # the file as read (or last saved)
        self.disk_table = table
        self._on_disk = None if shipped else path
        self.text = text
        self._data = tomllib.loads(text)
        self.table = table
        self.error: FieldError | None = None
        self._undo: list[str] = []
        self._redo: list[str] = []

    # -- state --------------------------------------------------------------------------------
    @property
    def variables(self) -> tuple[Variable, Variable, Variable]:
        """The two inputs and the output as the current text gives them (drawn even when the
        draft is invalid); labels and order are those of the table opened."""
        out = []
        for var in self.table.variables:
            sec = self._data[var.name]
            terms = tuple(Term(t.label, tuple(float(x) for x in sec[t.label])) for t in var.terms)
            out.append(Variable(var.name, tuple(float(x) for x in sec["universe"]), terms))
        return tuple(out)  # type: ignore[return-value]

    @property
    def grid(self) -> tuple[tuple[str, ...], ...]:
        """The rule grid of the current text (rows: first input's terms, columns: second's)."""
        rules = self._data["rules"]
        rows, cols = self.table.curvature.labels, list(rules["columns"])
        return tuple(tuple(rules[r][cols.index(c)] for c in self.table.curvature_variation.labels)
                     for r in rows)

    def settings(self) -> dict:
        """The [features] settings of the current text."""
        return dict(self._data["features"])

    @property
    def can_undo(self) -> bool:
        return bool(self._undo)

    @property
    def can_redo(self) -> bool:
        return bool(self._redo)

    @property
    def valid(self) -> bool:
        return self.error is None

    # -- edits --------------------------------------------------------------------------------
    def _commit(self, text: str) -> None:
        if text == self.text:
            return
        self._undo.append(self.text)
        self._redo.clear()
        self._set_text(text)

    def _set_text(self, text: str) -> None:
        self.text = text
        self._data = tomllib.loads(text)
        result = validate_data(self._data, self.path)
        if isinstance(result, FieldError):
            self.error = result
        else:
            self.error, self.table = None, result

    @staticmethod
    def _with_items(text: str, section: str, key: str, items: list[tuple[int, str, object]]) -> str:
        """``text`` with items (index, TOML literal, value) of the list ``key`` in ``[section]``
        changed: in the line itself, else through tomlkit (comments are kept either way)."""
        new: str | None = text
        for index, literal, _ in items:
            new = set_list_item(new, section, key, index, literal) if new is not None else None
        if new is None:
            import tomlkit

            doc = tomlkit.parse(text)
            for index, _, value in items:
                doc[section][key][index] = value
            new = tomlkit.dumps(doc)
        return new

    def set_point(self, variable: str, label: str, index: int, value: float,
                  dragged: bool = False) -> None:
        """Breakpoint ``index`` of term ``label`` of ``variable`` set to ``value``."""
        self.set_points(variable, [(label, index, value)], dragged)

    def set_points(self, variable: str, moves: list[tuple[str, int, float]],
                   dragged: bool = False) -> None:
        """Several breakpoints of ``variable`` at once (one undo step): (term, index, value);
        dragged ones are rounded to 1/1000 of the universe's width."""
        var = self._variable(variable)
        if dragged:
            moves = [(label, k, _round_to_universe(x, var.universe)) for label, k, x in moves]
        for label, k, x in moves:
            self._check_index(var, label, k)
        text = self.text
        for label in dict.fromkeys(m[0] for m in moves):
            text = self._with_items(text, variable, label,
                                    [(k, repr(float(x)), float(x)) for t, k, x in moves if t == label])
        self._commit(text)

    def _check_index(self, var: Variable, label: str, index: int) -> None:
        if label not in var.labels or not 0 <= index < len(var.term(label).points):
            raise RuleTableError(f"{var.name}.{label}[{index}]: no such breakpoint")

    def set_universe(self, variable: str, index: int, value: float) -> None:
        """The universe's lower (``index`` 0) or upper (1) end of ``variable``."""
        self._variable(variable)
        self._commit(self._with_items(self.text, variable, "universe",
                                      [(index, repr(float(value)), float(value))]))

    def set_feature(self, key: str, value: object) -> None:
        """A [features] setting (window_points, dk_clip_1_mm, filter, ...)."""
        import tomlkit

        doc = tomlkit.parse(self.text)
        doc["features"][key] = value
        self._commit(tomlkit.dumps(doc))

    def set_cell(self, row: str, column: str, label: str) -> None:
        """The rule (row term, column term) -> output term ``label``."""
        rows, cols, out = self.table.variables
        for var, x in ((rows, row), (cols, column), (out, label)):
            if x not in var.labels:
                raise RuleTableError(f"{var.name} {x!r}: unknown term; terms are {', '.join(var.labels)}")
        j = list(self._data["rules"]["columns"]).index(column)
        self._commit(self._with_items(self.text, "rules", row, [(j, f'"{label}"', label)]))

    def _variable(self, name: str) -> Variable:
        for var in self.variables:
            if var.name == name:
                return var
        raise RuleTableError(f"variable {name!r}: not in table {self.table.name!r}; its variables "
                             f"are {', '.join(v.name for v in self.table.variables)}")

    def undo(self) -> None:
        if self._undo:
            self._redo.append(self.text)
            self._set_text(self._undo.pop())

    def redo(self) -> None:
        if self._redo:
            self._undo.append(self.text)
            self._set_text(self._redo.pop())

    # -- files --------------------------------------------------------------------------------
    def differences(self) -> list[str]:
        """``fuzzyfeed rules diff`` of the file as read (or last saved) against the draft."""
        from fuzzyfeed.fuzzy.diff import table_differences

        return table_differences(self.disk_table, self.table)

    def conflict(self, target: str | Path | None = None) -> str | None:
        """Why saving to ``target`` (default :attr:`save_path`) needs asking, or None: the file
        opened changed on disk since it was read, or another file exists there."""
        target = Path(target) if target is not None else self.save_path
        if not target.exists():
            return None
        try:
            now = target.read_text(encoding="utf-8-sig")
        except (OSError, UnicodeDecodeError):
            now = None
        if self._on_disk is not None and _same_file(target, self._on_disk):
            if now == self.disk_text:
                return None
            return f"{target}: changed on disk since it was opened; save over it anyway?"
        if now == self.text:
            return None
        return f"{target}: exists and is not the file opened; replace it?"

    def save(self, target: str | Path | None = None, overwrite: bool = False) -> Path:
        """Write the draft to ``target`` (default :attr:`save_path`) atomically. An invalid draft
        is a :class:`RuleTableError`; a conflict (:meth:`conflict`) a :class:`FileConflictError`
        unless ``overwrite``."""
        from fuzzyfeed.base.atomic import atomic_write

        target = Path(target) if target is not None else self.save_path
        if self.error is not None:
            raise RuleTableError(f"{target}: not saved; {self.error.message}")
        if target.suffix.lower() != ".toml":
            raise RuleTableError(f"{target}: a rule table is saved as .toml (export the other formats)")
        why = self.conflict(target)
        if why is not None and not overwrite:
            raise FileConflictError(why)
        with atomic_write(target, "w") as handle:
            handle.write(self.text)
        self.save_path = self.path = target
        self._on_disk = target
        self.disk_text = self.text
        self.disk_table = self.table
        return target

    def reload(self) -> None:
        """Take the file on disk (after it changed there) as the draft; undoable."""
        from fuzzyfeed.base.files import read_text

        target = self._on_disk or self.path
        text = read_text(target, "rule table", RuleTableError)
        self.disk_text = text
        result = validate_text(text, target)
        if isinstance(result, RuleTable):
            self.disk_table = result
        self._commit(text)

    def export(self, fmt: str) -> str:
        """The draft in an exchange format (``fcl``, ``fcl-fuzzylite``, ``fll``, ``fis``)."""
        from fuzzyfeed.fuzzy.formats import export_table

        if self.error is not None:
            raise RuleTableError(f"not exported; {self.error.message}")
        return export_table(self.table, fmt)


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve() or a.samefile(b)
    except OSError:
        return False
