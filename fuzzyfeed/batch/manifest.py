"""The batch manifest: one JSON entry per input under ``RESULTS_DIR/.manifest/``, holding the
SHA-256 of the input's bytes, of the options and the fuzzyfeed version that made its results, its
status and figures. An entry is written in the same output transaction as the file's results
(renamed last), so an entry never names results that are not there; a rerun keeps every file whose
entry still matches. One batch at a time holds a results folder (an advisory lock)."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
from collections.abc import Iterator
from pathlib import Path

from fuzzyfeed.errors import BatchError

#: The manifest folder inside RESULTS_DIR.
MANIFEST_DIR = ".manifest"
#: Statuses a rerun keeps when input, options and version are unchanged (a refusal is repeatable;
#: a failure — an exception, a killed worker, a result that could not be written — is tried again).
KEPT_STATUSES = ("ok", "refused")


def sha256_file(path: str | os.PathLike) -> str:
    """Hex SHA-256 of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def options_sha256(argv: list[str] | tuple[str, ...]) -> str:
    """Hex SHA-256 of the options every file is advised with: the arguments, and the bytes of every
    argument that names a file (a rule table, a machine file), so editing that file redoes the batch."""
    digest = hashlib.sha256()
    for arg in argv:
        digest.update(arg.encode("utf-8", "surrogateescape") + b"\0")
        if os.path.isfile(arg):
            digest.update(b"file:" + sha256_file(arg).encode() + b"\0")
    return digest.hexdigest()


def entry_path(out_dir: str | os.PathLike, rel: str) -> str:
    """Where the manifest entry of the input at ``rel`` lives."""
    return os.path.join(os.fspath(out_dir), MANIFEST_DIR, *rel.split("/")) + ".json"


def stop_path(out_dir: str | os.PathLike, run_id: str) -> str:
    """The file that tells the workers of run ``run_id`` to stop after their current file."""
    return os.path.join(os.fspath(out_dir), MANIFEST_DIR, f"stop-{run_id}")


def read_entry(path: str | os.PathLike) -> dict | None:
    """A manifest entry, or None when there is none or it cannot be read (then the file is redone)."""
    try:
        with open(path, encoding="utf-8") as handle:
            entry = json.load(handle)
    except (OSError, ValueError):
        return None
    return entry if isinstance(entry, dict) else None


def entry_text(entry: dict) -> str:
    return json.dumps(entry, indent=1, sort_keys=False, ensure_ascii=False, allow_nan=False) + "\n"


def file_key(options: str, argv) -> str:
    """Hex SHA-256 of what a file's results depend on besides its bytes and the version: the batch's
    options digest and the file's own arguments (its path as given, which the results record, and
    where they go)."""
    return hashlib.sha256("\0".join((options, *argv)).encode("utf-8", "surrogateescape")).hexdigest()


def is_current(entry: dict | None, input_sha256: str | None, key: str, version: str, outputs=()) -> bool:
    """True when ``entry`` was made from these input bytes, options (``key``, see :func:`file_key`)
    and fuzzyfeed version, ended in a kept status and (if it succeeded) its results ``outputs`` are
    all still there."""
    if not entry or input_sha256 is None or entry.get("status") not in KEPT_STATUSES:
        return False
    if (entry.get("input_sha256"), entry.get("options_sha256"), entry.get("fuzzyfeed")) != \
            (input_sha256, key, version):
        return False
    return entry["status"] != "ok" or all(os.path.isfile(p) for p in outputs)


def remove_outputs(paths) -> None:
    """Remove the results a file had before it failed (they no longer match its input)."""
    for path in paths:
        with contextlib.suppress(FileNotFoundError, IsADirectoryError):
            os.unlink(path)


def remove_partial_files(out_dir: str | os.PathLike) -> int:
    """Remove the temporary files (``.NAME.*.part``) a killed worker left in RESULTS_DIR and the stop
    files of earlier runs; returns how many. Only names of those patterns are touched."""
    import re

    removed = 0
    manifest = os.path.join(os.fspath(out_dir), MANIFEST_DIR)
    for here, _, names in os.walk(out_dir):
        for name in names:
            stop = here == manifest and re.fullmatch(r"stop-[0-9a-f]{32}", name)
            if (name.startswith(".") and name.endswith(".part")) or stop:
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(os.path.join(here, name))
                    removed += 1
    return removed


@contextlib.contextmanager
def results_lock(out_dir: str | os.PathLike) -> Iterator[None]:
    """Hold RESULTS_DIR for one batch (``.manifest/lock``, an advisory lock); a second batch on the
    same folder is refused in one line while the first runs."""
    folder = Path(out_dir) / MANIFEST_DIR
    folder.mkdir(parents=True, exist_ok=True)
    fd = os.open(folder / "lock", os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            _lock(fd)
        except OSError:
            raise BatchError(f"--out {out_dir}: another batch is writing to this folder; wait for it "
                             "or choose another folder") from None
        yield
    finally:
        os.close(fd)


def _lock(fd: int) -> None:
    """Lock an open file without waiting (flock; on Windows, msvcrt's byte lock); OSError if held."""
    try:
        import fcntl
    except ImportError:        # Windows
        import msvcrt

        msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
        return
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
