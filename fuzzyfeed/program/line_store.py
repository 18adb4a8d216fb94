"""A program's original lines, compactly: one UTF-8 buffer and the offsets of its lines.

A tuple of 10⁶ short ``str`` costs ~75 MB (a ~50-byte object and an 8-byte slot per line); the
same lines as one ``bytes`` (``surrogatepass``: any ``str`` comes back as it was) and an int64
offset per line, ~30 MB. :class:`LineStore` is a read-only sequence of ``str``: ``len``,
indexing (a line decoded when asked), slices, iteration (decoded a block of lines at a time) and
equality with any sequence of the same strings.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence

import numpy as np

_CODEC = ("utf-8", "surrogatepass")
#: Lines decoded at once when iterating.
_BLOCK = 1 << 14


class LineStore(Sequence):
    """The lines (without their line breaks, none of which may contain ``"\\n"``) of a program."""

    __slots__ = ("_data", "_starts")

    def __init__(self, lines: Iterable[str]):
        lines = lines if isinstance(lines, (list, tuple)) else list(lines)
        data = "\n".join(lines).encode(*_CODEC)
        breaks = np.flatnonzero(np.frombuffer(data, dtype=np.uint8) == 10)
        if breaks.size != max(len(lines) - 1, 0):
            raise ValueError("a line holds a line break")
        starts = np.empty(len(lines) + 1, dtype=np.int64)
        starts[0] = 0
        starts[1:-1] = breaks + 1
        starts[-1] = len(data) + 1          # each line ends one byte before the next starts
        self._data, self._starts = data, starts

    def __len__(self) -> int:
        return self._starts.size - 1

    def _line(self, i: int) -> str:
        return self._data[self._starts[i]:self._starts[i + 1] - 1].decode(*_CODEC)

    def __getitem__(self, index):
        if isinstance(index, slice):
            return tuple(self._line(i) for i in range(*index.indices(len(self))))
        i = index.__index__()
        n = len(self)
        if i < 0:
            i += n
        if not 0 <= i < n:
            raise IndexError("line index out of range")
        return self._line(i)

    def __iter__(self) -> Iterator[str]:
        n = len(self)
        for lo in range(0, n, _BLOCK):
            hi = min(lo + _BLOCK, n)
            yield from self._data[self._starts[lo]:self._starts[hi] - 1].decode(*_CODEC).split("\n")

    def __eq__(self, other) -> bool:
        if isinstance(other, LineStore):
            return self._data == other._data and np.array_equal(self._starts, other._starts)
        if isinstance(other, (list, tuple)):
            return len(other) == len(self) and all(a == b for a, b in zip(self, other))
        return NotImplemented

    __hash__ = None

    @property
    def nbytes(self) -> int:
        """Bytes held (the buffer and the offsets)."""
        return len(self._data) + self._starts.nbytes

    def __repr__(self) -> str:
        return f"LineStore({len(self)} lines, {self.nbytes} bytes)"
