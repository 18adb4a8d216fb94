"""Shipped data and user text files: where the shipped shapes and rule tables live, how a
name-or-path argument resolves, and how a user's text file is read — one place for all of them.

Every function takes the error class to raise, so each caller keeps its own exception
(ShapeFileError, RuleTableError, PathFormatError) and its one-line messages.
"""

from __future__ import annotations

import os
from pathlib import Path

_PACKAGE = Path(__file__).resolve().parents[1]


def shipped_dir(kind: str, error: type[Exception]) -> Path:
    """Folder of shipped ``kind`` files ("shapes", "rules"): inside an installed wheel
    (fuzzyfeed/_data/KIND) or, for a source checkout, the repository's top-level KIND/."""
    candidates = (_PACKAGE / "_data" / kind, _PACKAGE.parent / kind)
    for candidate in candidates:
        if candidate.is_dir():
            return candidate
    raise error(f"shipped {kind} not found (looked in {candidates[0]} and {candidates[1]}); "
                "reinstall fuzzyfeed")


def shipped_names(kind: str, error: type[Exception]) -> list[str]:
    """Names (file stems) of the shipped ``kind`` TOML files, sorted."""
    return sorted(p.stem for p in shipped_dir(kind, error).glob("*.toml"))


def resolve_file(spec: str | os.PathLike, kind: str, noun: str, error: type[Exception]) -> Path:
    """A NAME-or-PATH argument as an existing file: an existing path wins, then a bare name is
    looked up among the shipped ``kind`` files. ``noun`` names the thing in messages
    ("shape", "rule table")."""
    candidate = Path(spec)
    if candidate.is_file():
        return candidate
    if candidate.suffix == "" and len(candidate.parts) == 1:
        shipped = shipped_dir(kind, error) / f"{spec}.toml"
        if shipped.is_file():
            return shipped
        raise error(f"{noun} {str(spec)!r}: no such shipped {noun.split()[-1]} or file; shipped "
                    f"{kind if noun == 'shape' else noun.split()[-1] + 's'} are: "
                    f"{', '.join(shipped_names(kind, error))}")
    if candidate.exists():
        raise error(f"{candidate}: not a regular file")
    raise error(f"{candidate}: no such file")


def read_text(path: str | os.PathLike, kind: str, error: type[Exception], latin1: bool = False) -> str:
    """The text of a user's ``kind`` file; unreadable, binary (a NUL byte in the first 8 KiB) or
    non-UTF-8 content is a one-line ``error``. A UTF-8 byte-order mark is dropped; ``latin1``
    accepts Latin-1 text instead of refusing it (old controllers' G-code comments)."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise error(f"{path}: cannot read ({exc.strerror})") from None
    if b"\x00" in raw[:8192]:
        raise error(f"{path}: binary file; expected a {kind} text file")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        if latin1:
            return raw.decode("latin-1")
        raise error(f"{path}: not UTF-8 text (byte {exc.start}); expected a {kind} text file") from None
