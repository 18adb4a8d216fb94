"""Where each key of a TOML file sits, for one-line messages that name ``file:line``.

:mod:`tomllib` returns values without positions; :class:`KeyLines` reads the text once more and
records the line of every ``[section]`` and ``key =`` (first occurrence), plus keys given twice;
:func:`load_toml` parses the text, a parse error one message naming the file. Rule tables and
machine files use them.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Callable
from pathlib import Path

#: where(section, key=None) -> "file:line" (or a field path for an in-memory value)
Locator = Callable[..., str]

HEADER = re.compile(r"^\s*\[\s*([A-Za-z0-9_.\-\"' ]+?)\s*\]\s*(#.*)?$")
KEY = re.compile(r"^\s*([A-Za-z0-9_\-]+|\"[^\"]*\")\s*=")


class KeyLines:
    """Where each (section, key) sits in the file text, for messages (first occurrence); the
    top level is section ""."""

    def __init__(self, text: str):
        self.first: dict[tuple[str, str], int] = {}
        self.sections: dict[str, int] = {}
        self.duplicates: list[tuple[str, str, int, int]] = []
        section = ""
        for n, line in enumerate(text.splitlines(), start=1):
            m = HEADER.match(line)
            if m:
                section = m.group(1).strip().strip("\"'")
                self.sections.setdefault(section, n)
                continue
            m = KEY.match(line)
            if m:
                key = m.group(1).strip('"')
                if (section, key) in self.first:
                    self.duplicates.append((section, key, self.first[(section, key)], n))
                else:
                    self.first[(section, key)] = n

    def line(self, section: str, key: str | None = None) -> int | None:
        if key is not None and (section, key) in self.first:
            return self.first[(section, key)]
        return self.sections.get(section)


def file_locator(path: Path, lines: KeyLines) -> Locator:
    """A locator naming ``path:line`` of a key (or its section), else ``path: [section]``."""
    def where(section: str, key: str | None = None) -> str:
        n = lines.line(section, key)
        return f"{path}:{n}" if n else f"{path}: [{section}]"
    return where


def load_toml(text: str, path: Path | str, error: type[Exception], what: str) -> dict:
    """``text`` parsed by :mod:`tomllib`; invalid TOML, or nesting too deep for the parser, is one
    ``error`` naming ``path`` (``what`` is the kind of file: "a rule table")."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{path}: invalid TOML: {exc}") from None
    except RecursionError:
        raise error(f"{path}: nested too deeply to be {what}") from None
