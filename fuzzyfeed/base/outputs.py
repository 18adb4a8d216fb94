"""One output transaction per command: every destination checked first, written last, all at once.

:class:`OutputSet` takes the destinations (``(label, path)`` pairs, label = the flag that named
them, e.g. ``-o``) and the inputs of a command. At construction it refuses, in one line naming the
flag and the path: an empty name, a folder, a missing or unwritable folder, a read-only file, a
block device or socket, two outputs naming the same file, and an output that is an input (same
path, via a symlink or a hard link). While it is active (``with OutputSet(...)``) every
:func:`fuzzyfeed.base.atomic.atomic_write` to one of its destinations writes a temporary file next to
the *real* target (a symlink is written through, the link kept); nothing replaces a target until
the block ends without an error, and then all temporary files are renamed together (SIGINT,
SIGTERM and SIGHUP held back during the renames). An error, Ctrl-C, SIGTERM or SIGHUP removes every
temporary file and leaves every target as it was. A character device (``/dev/null``, a terminal),
a FIFO or ``-`` (standard output) is not replaced: its bytes are kept in an unnamed temporary file
and streamed to it at commit. New files get ``0666 & ~umask``; a replaced file keeps its mode.
"""

from __future__ import annotations

import contextlib
import contextvars
import io
import os
import shutil
import signal
import stat
import sys
import tempfile
import threading
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from fuzzyfeed.errors import FuzzyfeedError


class OutputPathError(OSError, FuzzyfeedError):
    """An output file cannot be written where the user asked (or would replace an input)."""


class Terminated(SystemExit):
    """SIGTERM or SIGHUP arrived while outputs were pending: temporary files removed, exit 128+N."""

    def __init__(self, signum: int):
        super().__init__(128 + signum)
        self.signum = signum
        self.signal_name = signal.Signals(signum).name


#: Signals that end a command: temporary files are removed first, renames are never half done.
_END_SIGNALS = tuple(s for s in (getattr(signal, "SIGTERM", None), getattr(signal, "SIGHUP", None)) if s)
_COMMIT_BLOCKED = {s for s in (signal.SIGINT, *_END_SIGNALS)}

_current: contextvars.ContextVar[OutputSet | None] = contextvars.ContextVar("fuzzyfeed_outputs", default=None)


def current_umask() -> int:
    """The process umask (read by setting it and putting it back)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _name(label: str, path: str) -> str:
    return f"{label} {path}" if label else str(path)


@dataclass
class _Destination:
    label: str
    path: str                      # as the user wrote it
    kind: str                      # "file", "stream" (device/FIFO) or "stdout"
    target: Path | None = None     # real path (symlinks resolved); None for stdout
    mode: int = 0o644
    key: object = None             # identity: (st_dev, st_ino) or the real path
    tmp: str | None = None         # pending temporary file (kind "file")
    buffer: IO[bytes] | None = None  # pending bytes (kinds "stream", "stdout")

    @property
    def name(self) -> str:
        return _name(self.label, self.path)


def _identity(path: str | os.PathLike) -> tuple[int, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_dev, st.st_ino)


def _check_destination(label: str, path: str | os.PathLike, umask: int) -> _Destination:
    text = os.fspath(path)
    if not isinstance(text, str):
        text = os.fsdecode(text)
    if text == "":
        raise OutputPathError(f"{label or 'output'}: the file name is empty")
    if text == "-":
        return _Destination(label, text, "stdout", key="-")
    if text.endswith(os.sep):
        raise OutputPathError(f"{_name(label, text)}: ends with {os.sep}; give a file name, not a folder")
    name = _name(label, text)
    try:
        real = Path(os.path.realpath(text, strict=False))
        st = os.stat(real) if os.path.lexists(real) else None
    except OSError as exc:
        raise OutputPathError(f"{name}: cannot be resolved ({exc.strerror or exc})") from None
    except ValueError as exc:  # embedded NUL
        raise OutputPathError(f"{name}: not a usable file name ({exc})") from None
    if os.path.islink(text) and st is None and os.path.lexists(real):
        raise OutputPathError(f"{name}: a symbolic link loop")
    if st is not None:
        if stat.S_ISDIR(st.st_mode):
            raise OutputPathError(f"{name}: is a folder; give a file name")
        if stat.S_ISCHR(st.st_mode) or stat.S_ISFIFO(st.st_mode):
            if not os.access(real, os.W_OK):
                raise OutputPathError(f"{name}: not writable (permission denied)")
            return _Destination(label, text, "stream", target=real, key=(st.st_dev, st.st_ino))
        if not stat.S_ISREG(st.st_mode):
            raise OutputPathError(f"{name}: is a block device or socket; refusing to write to it")
        if not os.access(real, os.W_OK) or not st.st_mode & 0o222:
            raise OutputPathError(f"{name}: is read-only; refusing to replace it")
    folder = real.parent
    if not folder.is_dir():
        raise OutputPathError(f"{name}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputPathError(f"{name}: folder {folder} is not writable")
    if st is not None:
        return _Destination(label, text, "file", target=real, mode=stat.S_IMODE(st.st_mode),
                            key=(st.st_dev, st.st_ino))
    return _Destination(label, text, "file", target=real, mode=0o666 & ~umask, key=str(real))


def _input_path(spec: str | os.PathLike) -> str | None:
    """The file an input argument reads (``FILE#SELECTOR`` -> ``FILE``), or None (a shipped name)."""
    text = os.fspath(spec)
    if not isinstance(text, str):
        text = os.fsdecode(text)
    if os.path.exists(text):
        return text
    if "#" in text:
        head = text.rsplit("#", 1)[0]
        if os.path.exists(head):
            return head
    return None


@dataclass
class OutputSet:
    """The destinations of one command, checked now, written by :meth:`open`, renamed by :meth:`commit`.

    ``outputs`` and ``inputs`` are ``(label, path)`` pairs; a path of None is skipped."""

    outputs: Iterable[tuple[str, str | os.PathLike | None]]
    inputs: Iterable[tuple[str, str | os.PathLike | None]] = ()
    stdout: IO | None = None
    destinations: list[_Destination] = field(init=False, default_factory=list)

    def __post_init__(self) -> None:
        umask = current_umask()
        self.stdout = self.stdout if self.stdout is not None else sys.stdout
        for label, path in self.outputs:
            if path is None:
                continue
            dest = _check_destination(label, path, umask)
            for other in self.destinations:
                if dest.key == other.key and dest.kind != "stream":
                    what = "standard output" if dest.kind == "stdout" else "the same file"
                    raise OutputPathError(f"{dest.name}: {other.label or other.path} already writes to "
                                          f"{what}; give every output its own file")
            self.destinations.append(dest)
        for label, spec in self.inputs:
            if spec is None:
                continue
            path = _input_path(spec)
            ident = _identity(path) if path is not None else None
            if ident is None:
                continue
            for dest in self.destinations:
                if dest.key == ident or dest.key == str(Path(os.path.realpath(path))):
                    raise OutputPathError(f"{dest.name}: is the input {label} ({spec}); refusing to "
                                          "overwrite an input, choose another output file")
        self._token = None
        self._old_handlers: dict[int, object] = {}

    # -- lookup -------------------------------------------------------------------------------
    def find(self, path: str | os.PathLike) -> _Destination | None:
        """The destination ``path`` names (same text, or the same real file), else None."""
        text = os.fspath(path)
        for dest in self.destinations:
            if dest.path == text:
                return dest
        if text == "-":
            return None
        real = os.path.realpath(text)
        for dest in self.destinations:
            if dest.target is not None and str(dest.target) == real:
                return dest
        return None

    # -- writing ------------------------------------------------------------------------------
    @contextlib.contextmanager
    def open(self, path: str | os.PathLike, mode: str = "w", newline: str | None = None) -> Iterator[IO]:
        """A handle for ``path`` (one of the destinations): a temporary file kept until commit."""
        dest = self.find(path)
        if dest is None:
            raise OutputPathError(f"{path}: not one of this command's outputs")
        if mode not in ("w", "wb"):
            raise ValueError(f"mode {mode!r}: use 'w' or 'wb'")
        self._discard(dest)
        binary = mode == "wb"
        if dest.kind == "file":
            assert dest.target is not None
            try:
                # the name is cut so that a name near the file system's limit still has room
                fd, tmp = tempfile.mkstemp(prefix=f".{dest.target.name[:64]}.", suffix=".part",
                                           dir=dest.target.parent)
            except OSError as exc:
                raise OutputPathError(f"{dest.name}: cannot write ({exc.strerror})") from None
            dest.tmp = tmp
            try:
                os.fchmod(fd, dest.mode)
                raw = os.fdopen(fd, "wb")
            except BaseException:
                os.close(fd)
                self._discard(dest)
                raise
        else:
            raw = tempfile.TemporaryFile("w+b")
            dest.buffer = raw
        handle: IO = raw if binary else io.TextIOWrapper(raw, encoding="utf-8", newline=newline)
        try:
            yield handle
            handle.flush()
            if dest.kind == "file":
                os.fsync(raw.fileno())
                handle.close()
            elif not binary:
                handle.detach()
        except OSError as exc:
            self._discard(dest, handle)
            if isinstance(exc, FuzzyfeedError):
                raise
            raise OutputPathError(f"{dest.name}: cannot write ({exc.strerror or exc})") from None
        except BaseException:
            self._discard(dest, handle)
            raise

    def _discard(self, dest: _Destination, handle: IO | None = None) -> None:
        if handle is not None:
            with contextlib.suppress(Exception):
                handle.close()
        if dest.tmp is not None:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(dest.tmp)
            dest.tmp = None
        if dest.buffer is not None:
            with contextlib.suppress(Exception):
                dest.buffer.close()
            dest.buffer = None

    def abort(self) -> None:
        """Remove every pending temporary file; targets stay as they were."""
        for dest in self.destinations:
            self._discard(dest)

    def commit(self) -> list[str]:
        """Rename every temporary file over its target and stream the buffered bytes; returns the
        paths written. SIGINT/SIGTERM/SIGHUP are held back until all renames are done."""
        written = []
        blocked = threading.current_thread() is threading.main_thread()
        if blocked:
            old_mask = signal.pthread_sigmask(signal.SIG_BLOCK, _COMMIT_BLOCKED)
        try:
            for dest in self.destinations:
                if dest.tmp is not None:
                    try:
                        os.replace(dest.tmp, dest.target)
                    except OSError as exc:
                        raise OutputPathError(f"{dest.name}: cannot write ({exc.strerror})") from None
                    dest.tmp = None
                    written.append(dest.path)
        finally:
            if blocked:
                signal.pthread_sigmask(signal.SIG_SETMASK, old_mask)
        for dest in self.destinations:  # devices, FIFOs, stdout: after the files, may block on a reader
            if dest.buffer is None:
                continue
            dest.buffer.seek(0)
            try:
                if dest.kind == "stdout":
                    out = self.stdout
                    out.flush()
                    target = getattr(out, "buffer", None)
                    if target is not None:
                        shutil.copyfileobj(dest.buffer, target)
                        target.flush()
                    else:
                        out.write(dest.buffer.read().decode("utf-8", errors="replace"))
                        out.flush()
                else:
                    with open(dest.target, "wb") as target:
                        shutil.copyfileobj(dest.buffer, target)
            except BrokenPipeError:
                if dest.kind != "stdout":  # `fuzzyfeed ... -o - | head`: the reader had enough
                    raise OutputPathError(f"{dest.name}: cannot write (the reader closed it)") from None
                with contextlib.suppress(OSError):  # no second error when Python flushes at exit
                    os.dup2(os.open(os.devnull, os.O_WRONLY), self.stdout.fileno())
            except OSError as exc:
                raise OutputPathError(f"{dest.name}: cannot write ({exc.strerror or exc})") from None
            finally:
                self._discard(dest)
            written.append(dest.path)
        return written

    # -- the transaction ----------------------------------------------------------------------
    def __enter__(self) -> OutputSet:
        self._token = _current.set(self)
        if threading.current_thread() is threading.main_thread():
            for signum in _END_SIGNALS:
                if signal.getsignal(signum) == signal.SIG_DFL:
                    self._old_handlers[signum] = signal.signal(signum, _raise_terminated)
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if exc_type is None:
                try:
                    self.commit()
                except BaseException:
                    self.abort()
                    raise
            else:
                self.abort()
        finally:
            for signum, handler in self._old_handlers.items():
                signal.signal(signum, handler)
            self._old_handlers.clear()
            if self._token is not None:
                _current.reset(self._token)
                self._token = None


def _raise_terminated(signum, frame) -> None:
    raise Terminated(signum)


def current() -> OutputSet | None:
    """The active output transaction (inside ``with OutputSet(...)``), if any."""
    return _current.get()


@contextlib.contextmanager
def write_output(path: str | os.PathLike, mode: str = "w", newline: str | None = None) -> Iterator[IO]:
    """Open ``path`` for writing inside the active transaction if it is one of its destinations,
    else inside a transaction of its own (checked, temporary file, renamed on success)."""
    active = current()
    if active is not None and active.find(path) is not None:
        with active.open(path, mode, newline) as handle:
            yield handle
        return
    with OutputSet([("", path)]) as own, own.open(path, mode, newline) as handle:
        yield handle
