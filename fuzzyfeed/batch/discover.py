"""Which files a batch advises: every program and drawing under the given folders, globs and files,
each with the relative path its results get under RESULTS_DIR."""

from __future__ import annotations

import glob
import os
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from fuzzyfeed.errors import BatchError

#: Glob characters: a DIR_OR_GLOB argument holding one is expanded (``**`` reaches into sub-folders).
_MAGIC = frozenset("*?[")


@dataclass(frozen=True)
class Source:
    """One input: ``path`` as the advise command is given it (the argument's own spelling joined
    with the path below it), ``rel`` its place under RESULTS_DIR, ``kind`` program or drawing."""

    path: str
    rel: str
    kind: str

    def __post_init__(self) -> None:
        if self.kind not in ("program", "drawing"):
            raise BatchError(f"{self.path}: kind {self.kind!r}; expected 'program' or 'drawing'")
        if PurePosixPath(self.rel).is_absolute() or ".." in PurePosixPath(self.rel).parts:
            raise BatchError(f"{self.path}: relative path {self.rel!r} leaves the results folder")


def _kind(path: str, program_suffixes: tuple[str, ...], drawing_suffixes: tuple[str, ...]) -> str | None:
    suffix = os.path.splitext(path)[1].lower()
    return "program" if suffix in program_suffixes else "drawing" if suffix in drawing_suffixes else None


def _inside(path: str, folder: str) -> bool:
    return path == folder or path.startswith(folder.rstrip(os.sep) + os.sep)


def find_sources(specs: list[str], out_dir: str | os.PathLike, program_suffixes: tuple[str, ...],
                 drawing_suffixes: tuple[str, ...] = (".dxf",)) -> list[Source]:
    """Every program and drawing named by ``specs`` (folders searched recursively, globs expanded,
    files taken as given), sorted by relative path, each real file once. Relative paths are taken
    from the folder all the arguments share. Refused in one line: an argument that names nothing,
    a file that is neither a program nor a drawing, a results folder that is or holds an input
    folder, and no input at all. A results folder inside an input folder is not searched."""
    out_real = os.path.realpath(out_dir)
    found: list[tuple[str, str]] = []          # (path as spelt, real path)
    roots: list[str] = []
    for spec in specs:
        spec = os.fspath(spec)
        if any(c in _MAGIC for c in spec):
            matches = sorted(glob.glob(spec, recursive=True))
            if not matches:
                raise BatchError(f"{spec}: matches no file or folder")
            explicit = False
        elif os.path.isdir(spec) or os.path.isfile(spec):
            matches, explicit = [spec], True
        else:
            raise BatchError(f"{spec}: no such file or folder")
        for match in matches:
            real = os.path.realpath(match)
            if os.path.isdir(match):
                if _inside(real, out_real):
                    raise BatchError(f"--out {out_dir}: is or holds the input folder {match}; results "
                                     "never go beside or over the inputs, choose a folder outside it")
                roots.append(os.path.abspath(match))
                found += _walk(match, out_real, program_suffixes, drawing_suffixes)
            elif os.path.isfile(match):
                kind = _kind(match, program_suffixes, drawing_suffixes)
                if kind is None:
                    if explicit:
                        raise BatchError(f"{match}: not a program ({', '.join(program_suffixes)}) or a "
                                         f"drawing ({', '.join(drawing_suffixes)})")
                    continue
                if _inside(real, out_real):
                    if explicit:
                        raise BatchError(f"--out {out_dir}: holds the input {match}; results never go "
                                         "beside or over the inputs, choose another folder")
                    continue
                roots.append(os.path.dirname(os.path.abspath(match)))
                found.append((match, real))
    unique: dict[str, str] = {}
    for spelt, real in found:
        unique.setdefault(real, spelt)
    if not unique:
        raise BatchError(f"{' '.join(map(str, specs))}: no program ({', '.join(program_suffixes)}) or "
                         f"drawing ({', '.join(drawing_suffixes)}) found")
    base = os.path.commonpath(roots)
    sources = []
    for real, spelt in unique.items():
        rel = PurePosixPath(*Path(os.path.relpath(os.path.abspath(spelt), base)).parts)
        kind = _kind(spelt, program_suffixes, drawing_suffixes)
        sources.append(Source(path=os.path.normpath(spelt), rel=str(rel), kind=kind))
    sources.sort(key=lambda s: s.rel)
    rels = [s.rel for s in sources]
    if len(set(rels)) != len(rels):
        dup = next(r for r in rels if rels.count(r) > 1)
        raise BatchError(f"{dup}: two inputs would write the same results; give their common folder")
    return sources


def _walk(folder: str, out_real: str, program_suffixes, drawing_suffixes) -> list[tuple[str, str]]:
    """(path as spelt, real path) of every program and drawing below ``folder``, the results
    folder left out; symbolic links to folders are not followed (no loops)."""
    files = []
    for here, dirs, names in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if os.path.realpath(os.path.join(here, d)) != out_real)
        for name in sorted(names):
            path = os.path.join(here, name)
            if _kind(name, program_suffixes, drawing_suffixes) is not None and os.path.isfile(path):
                files.append((path, os.path.realpath(path)))
    return files
