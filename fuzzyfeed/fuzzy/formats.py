"""The exchange formats' one entry point: export a rule table as FCL, FLL or ``.fis`` text, and
import such a file (or a fuzzyfeed ``.toml``) as a validated table. Each format lives in its own
module (:mod:`~fuzzyfeed.fuzzy.fcl`, :mod:`~fuzzyfeed.fuzzy.fll`, :mod:`~fuzzyfeed.fuzzy.fis`) on the
shared pieces of :mod:`~fuzzyfeed.fuzzy.exchange`; this dispatcher sits above them, so nothing
imports in a circle.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from fuzzyfeed.errors import RuleTableError
from fuzzyfeed.fuzzy.exchange import EXPORT_FORMATS, IMPORT_SUFFIXES, Spec, spec_to_table
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.fuzzy.rules import RuleTable


def export_table(t: RuleTable, fmt: str) -> str:
    """The table as text in ``fmt`` (a key of :data:`EXPORT_FORMATS`)."""
    if fmt == "fcl":
        from fuzzyfeed.fuzzy.fcl import table_to_fcl
        return table_to_fcl(t, dialect="iec")
    if fmt == "fcl-fuzzylite":
        from fuzzyfeed.fuzzy.fcl import table_to_fcl
        return table_to_fcl(t, dialect="fuzzylite")
    if fmt == "fll":
        from fuzzyfeed.fuzzy.fll import table_to_fll
        return table_to_fll(t)
    if fmt == "fis":
        from fuzzyfeed.fuzzy.fis import table_to_fis
        return table_to_fis(t)
    raise RuleTableError(f"format {fmt!r}: unknown; formats are {', '.join(EXPORT_FORMATS)}")


def parse_text(text: str, fmt: str, path: str | Path = "<rules>") -> Spec:
    """Parse exchange-format text (``fcl`` — either dialect —, ``fll`` or ``fis``)."""
    if fmt == "fcl":
        from fuzzyfeed.fuzzy.fcl import parse_fcl
        return parse_fcl(text, str(path))
    if fmt == "fll":
        from fuzzyfeed.fuzzy.fll import parse_fll
        return parse_fll(text, str(path))
    if fmt == "fis":
        from fuzzyfeed.fuzzy.fis import parse_fis
        return parse_fis(text, str(path))
    raise RuleTableError(f"{path}: format {fmt!r}: unknown; fuzzyfeed imports fcl, fll and fis")


def import_table(path: str | Path, fmt: str | None = None,
                 settings_from: RuleTable | None = None) -> RuleTable:
    """Read a FCL, FLL, ``.fis`` (or fuzzyfeed ``.toml``) file as a validated :class:`RuleTable`."""
    from fuzzyfeed.base.files import read_text

    path = Path(path)
    if fmt is None:
        fmt = IMPORT_SUFFIXES.get(path.suffix.lower())
        if fmt is None:
            raise RuleTableError(f"{path}: unknown file type {path.suffix!r}; rules import reads "
                                 ".fcl, .fll, .fis and .toml (or give --format)")
    if fmt == "toml":
        return load_rule_table(path)
    text = read_text(path, "rule table", RuleTableError)
    table = spec_to_table(parse_text(text, fmt, path), settings_from)
    return replace(table, path=path)
