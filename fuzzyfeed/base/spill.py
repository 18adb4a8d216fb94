"""Rows of named arrays kept on disk instead of in memory: written once in chunks, read back in
chunks as often as needed (a long cut's parsed moves, read once from its file and then by every
pass of its advice: :mod:`fuzzyfeed.program.long_cut`).

A :class:`Spill` keeps each field in its own file of raw values (``ndarray.tofile``) in a folder;
a chunk is read back with a seek and ``np.fromfile`` of its rows, so what it holds in memory is the
chunk asked for. Nothing is mapped (``np.memmap``'s pages would count in the resident set as they
are read). The values come back bit for bit (dtype, shape of a row, NaN payloads). The folder is
the caller's: :func:`scratch_folder` gives one that is removed on every exit, error included.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np


@contextmanager
def scratch_folder(prefix: str = "fuzzyfeed-spill-") -> Iterator[Path]:
    """A new folder in the system's temporary directory, removed with its files when the block
    ends, normally or by an exception (also when a generator holding it is closed)."""
    with tempfile.TemporaryDirectory(prefix=prefix) as folder:
        yield Path(folder)


class Spill:
    """Rows of named fields (each an array whose first axis is the row) appended in chunks to
    files ``<folder>/<name>.<field>``, read back by rows (module docstring). The fields, their
    dtypes and row shapes are fixed by the first :meth:`append`; every later chunk must match."""

    def __init__(self, folder: Path, name: str):
        self.folder = Path(folder)
        self.name = str(name)
        self.rows = 0
        self._layout: dict[str, tuple[np.dtype, tuple]] | None = None

    def _file(self, field: str) -> Path:
        return self.folder / f"{self.name}.{field}"

    def append(self, chunk: dict[str, np.ndarray]) -> None:
        """Write one chunk: every field the same number of rows."""
        arrays = {k: np.asarray(v) for k, v in chunk.items()}
        sizes = {a.shape[0] if a.ndim else -1 for a in arrays.values()}
        if len(sizes) != 1 or -1 in sizes:
            raise ValueError(f"spill {self.name!r}: fields of {sorted(sizes)} rows in one chunk; need one count")
        layout = {k: (a.dtype, a.shape[1:]) for k, a in arrays.items()}
        if self._layout is None:
            self._layout = layout
        elif layout != self._layout:
            raise ValueError(f"spill {self.name!r}: a chunk of {layout} after {self._layout}")
        for k, a in arrays.items():          # opened for each chunk: no handle outlives a call
            with open(self._file(k), "ab" if self.rows else "wb") as handle:
                np.ascontiguousarray(a).tofile(handle)
        self.rows += sizes.pop()

    def __len__(self) -> int:
        return self.rows

    @property
    def fields(self) -> tuple[str, ...]:
        return tuple(self._layout or ())

    def read(self, a: int, b: int) -> dict[str, np.ndarray]:
        """Rows a..b-1 of every field (new arrays)."""
        got = list(self.chunks(max(b - a, 1), a, b))
        if got:
            return got[0]
        return {k: np.zeros((0, *shape), dtype) for k, (dtype, shape) in (self._layout or {}).items()}

    def chunks(self, rows: int, start: int = 0, stop: int | None = None,
               fields: tuple[str, ...] | None = None) -> Iterator[dict[str, np.ndarray]]:
        """Rows ``start..stop-1`` (all by default) in chunks of ``rows`` (the last shorter), each
        a dict of new arrays read from the files (nothing mapped); ``fields``: only those."""
        if isinstance(rows, bool) or not isinstance(rows, (int, np.integer)) or rows < 1:
            raise ValueError(f"rows = {rows!r}; must be an integer >= 1")
        stop = self.rows if stop is None else int(stop)
        if not 0 <= start <= stop <= self.rows:
            raise ValueError(f"spill {self.name!r}: rows {start}..{stop} asked, {self.rows} written")
        if start == stop:
            return
        layout = self._layout if fields is None else {k: self._layout[k] for k in fields}
        handles = {k: open(self._file(k), "rb") for k in layout}
        try:
            for k, (dtype, shape) in layout.items():
                handles[k].seek(int(start) * dtype.itemsize * int(np.prod(shape, dtype=np.int64)), os.SEEK_SET)
            for a in range(int(start), stop, int(rows)):
                n = min(int(rows), stop - a)
                out = {}
                for k, (dtype, shape) in layout.items():
                    per = int(np.prod(shape, dtype=np.int64))
                    got = np.fromfile(handles[k], dtype=dtype, count=n * per)
                    if got.size != n * per:
                        raise OSError(f"{self._file(k)}: {got.size // max(per, 1)} rows read at row {a}, {n} written")
                    out[k] = got.reshape((n, *shape))
                yield out
        finally:
            for handle in handles.values():
                handle.close()


class SpilledValues:
    """One array of float64 written once from the front in consecutive pieces (:meth:`open`, then
    the callable it returns, piece after piece), read back by slices like an array's
    (``values[a:b]``, ``len``): a run's largest error per segment kept out of memory (issue 36).
    Each :meth:`open` starts the array again (a run made again), in a new :class:`Spill` of the
    ``folder``; what an earlier one wrote is no longer read."""

    stored = True
    dtype = np.dtype(np.float64)

    def __init__(self, folder: Path, name: str):
        self.folder, self.name = Path(folder), str(name)
        self._spill: Spill | None = None
        self._opened = 0

    def open(self):
        """Start the array again: returns ``add(values)``, which appends the next piece."""
        self._opened += 1
        spill = self._spill = Spill(self.folder, f"{self.name}.{self._opened}")

        def add(values: np.ndarray) -> None:
            if np.size(values):
                spill.append({"v": np.asarray(values, dtype=np.float64)})
        return add

    @property
    def size(self) -> int:
        return 0 if self._spill is None else self._spill.rows

    @property
    def shape(self) -> tuple[int]:
        return (self.size,)

    def __len__(self) -> int:
        return self.size

    def __getitem__(self, key):
        if not isinstance(key, slice):
            raise IndexError("spilled values are read in slices")
        a, b, step = key.indices(self.size)
        if step != 1:
            raise IndexError("spilled values are read in slices of step 1")
        return self._spill.read(a, b)["v"] if b > a else np.zeros(0)

    def blocks(self, rows: int):
        """(first index, values) of the array in pieces of ``rows``."""
        for a in range(0, self.size, rows):
            yield a, self[a:a + rows]
