"""Atomic file output: write to a temporary file beside the target, then rename over it.

A failure halfway (bad data found while writing, a full disk, Ctrl-C, SIGTERM) leaves no partial
file and keeps whatever was at the target before. The work is done by
:mod:`fuzzyfeed.base.outputs`: inside a command's output transaction the rename waits until every
output of the command is written; a symlink is written through, a device/FIFO/``-`` streamed to,
and a new file gets ``0666 & ~umask``.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from typing import IO

from fuzzyfeed.base.outputs import OutputPathError, write_output

__all__ = ["OutputPathError", "atomic_write"]


@contextmanager
def atomic_write(path: str | os.PathLike, mode: str = "w", newline: str | None = None) -> Iterator[IO]:
    """Open ``path`` for writing (``"w"`` text UTF-8, or ``"wb"``); it appears only on success."""
    with write_output(path, mode, newline) as handle:
        yield handle
