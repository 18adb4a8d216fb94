"""A program's chains (:func:`fuzzyfeed.program.run.program_path`) kept in a scratch directory, one
file per column, read back a slice at a time (issue 36: under ``--machine`` a long program's chains
are built from its windows of lines, :class:`~fuzzyfeed.program.path_builder.PathBuilder`, and run
part by part; nothing per segment of the program is held but what a run keeps).

Per vertex: the point (3 float64) and the arc radius (float64); per segment: the feed (mm/s,
float64), rapid (bool), the program move (int64, the file's count), whether it is measured (bool),
the move's program line (int64, 0-based, the file's) and its cut (int64, the file's, −1: none):
~59 bytes a segment. Slices are read with explicit seeks and reads (``np.fromfile``), never mapped
(mapped pages count in the resident set). A chain shorter than
:data:`~fuzzyfeed.program.run.CARRIED_MIN_SEGMENTS` is handed out whole, in memory (a
:class:`~fuzzyfeed.program.run.Chain`, its run planned whole as before); a longer one as a
:class:`StoredChain` whose columns read slices (its run: :func:`~fuzzyfeed.machine.chain_pass.stream_chain`,
part by part).
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fuzzyfeed.machine.planner import Motion
from fuzzyfeed.program.path_builder import PathBuilder

#: Segments buffered before the open chain's columns are appended to their files.
WRITE_SEGMENTS = 1 << 16
#: Gaps (items) below which the indices of a gathered read are read as one slice.
_GATHER_GAP = 4096
#: The most items one slice of a gathered read (or scattered write) spans.
_GATHER_SPAN = 1 << 16

_VERTEX = (("points", np.float64, 3), ("radius", np.float64, 1))
_SEGMENT = (("feed", np.float64, 1), ("rapid", np.bool_, 1), ("move", np.int64, 1), ("measured", np.bool_, 1),
            ("line", np.int64, 1), ("cut", np.int64, 1))


class StoredColumn:
    """Items ``[start, start + size)`` of a column file, read a slice at a time (``stored`` marks
    it for the code that takes arrays or these: :func:`as_column`)."""

    stored = True

    def __init__(self, handle, dtype, width: int, start: int, size: int):
        self._handle, self.dtype, self._width = handle, np.dtype(dtype), width
        self._start, self.size = start, size
        self.shape = (size,) if width == 1 else (size, width)

    def __len__(self) -> int:
        return self.size

    def _read(self, a: int, b: int) -> np.ndarray:
        n = max(b - a, 0)
        item = self.dtype.itemsize * self._width
        self._handle.seek((self._start + a) * item)
        out = np.fromfile(self._handle, dtype=self.dtype, count=n * self._width)
        if out.size != n * self._width:
            raise OSError("a chain store's file is shorter than its index")
        return out if self._width == 1 else out.reshape(n, self._width)

    def __getitem__(self, key):
        if isinstance(key, slice):
            a, b, step = key.indices(self.size)
            if step != 1:
                raise IndexError("a stored column is read in slices of step 1")
            return self._read(a, b)
        if isinstance(key, (int, np.integer)):
            k = int(key) + (self.size if key < 0 else 0)
            if not 0 <= k < self.size:
                raise IndexError(f"index {key} out of {self.size}")
            return self._read(k, k + 1)[0]
        idx = np.asarray(key)
        if idx.dtype == bool:
            raise IndexError("a stored column takes slices or integer indices")
        return self.gather(idx.astype(np.int64))

    def __setitem__(self, key, values) -> None:
        """Items ``key`` (a slice of step 1) written to the file (a column the store added to itself:
        :meth:`ChainStore.add_column`; its handle is open for writing)."""
        if not isinstance(key, slice):
            raise IndexError("a stored column is written in slices (or by scatter)")
        a, b, step = key.indices(self.size)
        if step != 1:
            raise IndexError("a stored column is written in slices of step 1")
        block = np.ascontiguousarray(np.broadcast_to(np.asarray(values, dtype=self.dtype), (max(b - a, 0),)))
        self._handle.seek((self._start + a) * self.dtype.itemsize)
        block.tofile(self._handle)

    def scatter(self, idx: np.ndarray, values: np.ndarray) -> None:
        """Items ``idx`` (sorted, unique, in range) set to ``values``: read, changed and written in
        slices of nearby indices (:meth:`gather`'s)."""
        idx = np.asarray(idx, dtype=np.int64)
        values = np.asarray(values, dtype=self.dtype)
        for a, b in _slices(idx):
            g = idx[a:b]
            block = self._read(int(g[0]), int(g[-1]) + 1)
            block[g - g[0]] = values[a:b]
            self[int(g[0]):int(g[-1]) + 1] = block

    def gather(self, idx: np.ndarray) -> np.ndarray:
        """The items at ``idx`` (any shape, in range), read in slices of nearby indices."""
        flat = idx.ravel()
        if flat.size == 0:
            return np.zeros((0,) + self.shape[1:], self.dtype).reshape(idx.shape + self.shape[1:])
        if flat.min() < 0 or flat.max() >= self.size:
            raise IndexError(f"index out of {self.size}")
        u, inv = np.unique(flat, return_inverse=True)
        parts = []
        for a, b in _slices(u):
            g = u[a:b]
            block = self._read(int(g[0]), int(g[-1]) + 1)
            parts.append(block[g - g[0]])
        return np.concatenate(parts)[inv].reshape(idx.shape + self.shape[1:])

    def scaled(self, factor: float) -> ScaledColumn:
        """This column times ``factor``, read as it is (a uniform trial's feeds on the store)."""
        return ScaledColumn(self, factor)


def _slices(u: np.ndarray) -> list[tuple[int, int]]:
    """Runs [a, b) of the sorted unique indices ``u`` each read as one slice: nearby indices
    (gaps up to :data:`_GATHER_GAP`) together, no slice spanning more than :data:`_GATHER_SPAN` items."""
    out, a = [], 0
    breaks = np.flatnonzero(np.diff(u) > _GATHER_GAP) + 1
    while a < u.size:
        gap = breaks[np.searchsorted(breaks, a, side="right")] if breaks.size and breaks[-1] > a else u.size
        b = min(int(gap), int(np.searchsorted(u, u[a] + _GATHER_SPAN, side="left")))
        out.append((a, max(b, a + 1)))
        a = out[-1][1]
    return out


class ScaledColumn:
    """A :class:`StoredColumn` times a factor: every read the column's values times it (bit for bit
    the product of the whole column, element by element)."""

    stored = True

    def __init__(self, column: StoredColumn, factor: float):
        self.column, self.factor = column, float(factor)
        self.dtype, self.size, self.shape = column.dtype, column.size, column.shape

    def __len__(self) -> int:
        return self.size

    def __getitem__(self, key):
        return self.column[key] * self.factor

    def gather(self, idx: np.ndarray) -> np.ndarray:
        return self.column.gather(idx) * self.factor


def as_column(values, dtype) -> object:
    """``values`` as an array of ``dtype``, or itself when it is a :class:`StoredColumn`."""
    return values if getattr(values, "stored", False) else np.asarray(values, dtype=dtype)


@dataclass(frozen=True, eq=False)
class StoredMotion:
    """A chain's :class:`~fuzzyfeed.machine.planner.Motion` in the store: the same four columns,
    read a slice at a time, and the largest |coordinate| of its points."""

    points: StoredColumn
    feed_mm_s: StoredColumn
    rapid: StoredColumn
    arc_radius_mm: StoredColumn
    coordinate_max: float

    @property
    def n_segments(self) -> int:
        return self.feed_mm_s.size


@dataclass(frozen=True, eq=False)
class StoredChain:
    """A long chain in the store (:class:`~fuzzyfeed.program.run.Chain`'s fields, and per segment
    its move's program line and cut)."""

    motion: StoredMotion
    seg_move: StoredColumn
    seg_measured: StoredColumn
    seg_line: StoredColumn
    seg_cut: StoredColumn


@dataclass(frozen=True)
class ChainEntry:
    """Where a chain's columns start in the store, its size and its largest |coordinate|."""

    vertex0: int
    segment0: int
    n_segments: int
    coordinate_max: float


class ChainStore:
    """The chains of a program written once to ``folder`` (:meth:`writer`, then :meth:`close_writing`),
    read back chain by chain (:meth:`chain`, :meth:`columns`)."""

    def __init__(self, folder: Path, chord_tol_mm: float):
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.chord_tol_mm = chord_tol_mm
        self.entries: list[ChainEntry] = []
        self._out = {name: open(self.folder / name, "wb") for name, _, _ in _VERTEX + _SEGMENT}
        self._in: dict | None = None
        self._extra: dict[str, tuple] = {}       # columns added after writing (add_column)
        self._n_vertices = self._n_segments = 0
        self._pending: dict[str, list] = {name: [] for name, _, _ in _VERTEX + _SEGMENT}
        self._pending_segments = 0
        self._chain_vertices = self._chain_segments = 0   # the open chain's, written so far
        self._chain_max = 0.0

    # writing -------------------------------------------------------------------------------
    def builder(self) -> PathBuilder:
        """A builder whose chains go to this store: ``add(program, (move0, line0, cut0))`` with the
        window's first move, line and cut in the file's count."""
        return PathBuilder(self.chord_tol_mm, self._chunk, self._close_chain)

    def _chunk(self, program, tag, pts, radius, feed, rapid, seg_move, measured) -> None:
        move0, line0, cut0 = tag
        cut = program.cut[seg_move].astype(np.int64)
        self.append(pts, radius, feed, rapid, seg_move + move0, measured,
                    program.move_line[seg_move].astype(np.int64) + line0, np.where(cut >= 0, cut + cut0, -1))

    def append(self, pts, radius, feed, rapid, move, measured, line, cut) -> None:
        """The open chain's next rows: its vertices (the chain's first with its first rows) and
        segments, every column as the store keeps it (:meth:`end_chain` closes the chain)."""
        p = self._pending
        for name, values in (("points", pts), ("radius", radius), ("feed", feed), ("rapid", rapid), ("move", move),
                             ("measured", measured), ("line", line), ("cut", cut)):
            p[name].append(values)
        if pts.size:
            self._chain_max = max(self._chain_max, float(np.abs(pts).max()))
        self._pending_segments += feed.size
        if self._pending_segments >= WRITE_SEGMENTS:
            self._write_pending()

    def _write_pending(self) -> None:
        for name, dtype, _ in _VERTEX + _SEGMENT:
            parts = self._pending[name]
            if parts:
                block = np.ascontiguousarray(np.concatenate(parts), dtype=dtype)
                block.tofile(self._out[name])
                if name == "points":
                    self._chain_vertices += block.shape[0]
                elif name == "feed":
                    self._chain_segments += block.shape[0]
            parts.clear()
        self._pending_segments = 0

    def _close_chain(self, has_segments: bool) -> None:
        if has_segments:
            self._write_pending()
            if self._chain_vertices != self._chain_segments + 1:
                raise AssertionError("a stored chain's vertices are not its segments + 1")
            self.entries.append(ChainEntry(self._n_vertices, self._n_segments, self._chain_segments,
                                           self._chain_max))
            self._n_vertices += self._chain_vertices
            self._n_segments += self._chain_segments
        elif self._chain_segments:
            raise AssertionError("a chain written in part has no segment")
        for parts in self._pending.values():
            parts.clear()
        self._pending_segments = self._chain_vertices = self._chain_segments = 0
        self._chain_max = 0.0

    def end_chain(self) -> None:
        """The chain :meth:`append` wrote closed (a builder's chains close themselves)."""
        self._close_chain(True)

    def close_writing(self) -> None:
        for handle in self._out.values():
            handle.close()
        self._in = {name: open(self.folder / name, "rb") for name, _, _ in _VERTEX + _SEGMENT}

    def close(self) -> None:
        """Every file closed (the folder is the caller's to remove)."""
        for handles in (self._out, self._in or {}):
            for handle in handles.values():
                handle.close()

    def add_column(self, name: str, dtype, like: str | None = None) -> None:
        """A segment column of the store's own, written as well as read (:meth:`StoredColumn.__setitem__`:
        a pass's feeds, a plan's speed profile), ``n_segments`` items: a copy of column ``like``,
        or zeros."""
        if self._in is None or name in self._in:
            raise ValueError(f"column {name!r}: the store is being written, or has it")
        file = self.folder / name
        if like is None:
            with open(file, "wb") as handle:
                handle.truncate(self._n_segments * np.dtype(dtype).itemsize)
        else:
            shutil.copyfile(self.folder / like, file)
        self._extra[name] = (np.dtype(dtype), 1)
        self._in[name] = open(file, "r+b")

    # reading -------------------------------------------------------------------------------
    @property
    def n_segments(self) -> int:
        return self._n_segments

    def _column(self, name: str, start: int, size: int) -> StoredColumn:
        dtype, width = self._extra.get(name) or next((d, w) for n, d, w in _VERTEX + _SEGMENT if n == name)
        return StoredColumn(self._in[name], dtype, width, start, size)

    def stored_chain(self, i: int) -> StoredChain:
        e = self.entries[i]
        v, s, n = e.vertex0, e.segment0, e.n_segments
        motion = StoredMotion(self._column("points", v, n + 1), self._column("feed", s, n),
                              self._column("rapid", s, n), self._column("radius", v, n + 1), e.coordinate_max)
        return StoredChain(motion, self._column("move", s, n), self._column("measured", s, n),
                           self._column("line", s, n), self._column("cut", s, n))

    def chain(self, i: int, whole_below: int | None = None):
        """Chain ``i``: in memory (a :class:`~fuzzyfeed.program.run.Chain`) when it has fewer than
        ``whole_below`` segments (default :data:`~fuzzyfeed.program.run.CARRIED_MIN_SEGMENTS`),
        else a :class:`StoredChain`."""
        from fuzzyfeed.program.run import CARRIED_MIN_SEGMENTS, Chain

        st = self.stored_chain(i)
        limit = CARRIED_MIN_SEGMENTS if whole_below is None else whole_below
        if st.motion.n_segments >= limit:
            return st
        m = st.motion
        return Chain(Motion(m.points[:], m.feed_mm_s[:], m.rapid[:], m.arc_radius_mm[:]), st.seg_move[:],
                     st.seg_measured[:])


class StoredChains:
    """The store's chains as a sequence (each made when asked: :meth:`ChainStore.chain`)."""

    def __init__(self, store: ChainStore, whole_below: int | None = None):
        self.store, self.whole_below = store, whole_below

    def __len__(self) -> int:
        return len(self.store.entries)

    def __getitem__(self, i: int):
        if not -len(self) <= i < len(self):
            raise IndexError(i)
        return self.store.chain(i % len(self), self.whole_below)

    def __iter__(self):
        for i in range(len(self)):
            yield self.store.chain(i, self.whole_below)


@dataclass(frozen=True, eq=False)
class StoredPath:
    """A :class:`~fuzzyfeed.program.run.ProgramPath` whose chains are in a :class:`ChainStore`
    (``program`` None: what the runs need of the program is in the store's columns)."""

    store: ChainStore
    chains: StoredChains
    chord_tol_mm: float
    program: None = None

    @classmethod
    def of(cls, store: ChainStore, whole_below: int | None = None) -> StoredPath:
        return cls(store, StoredChains(store, whole_below), store.chord_tol_mm)

    @property
    def n_segments(self) -> int:
        return self.store.n_segments

    def segment_column(self, i: int, name: str) -> StoredColumn:
        """Chain ``i``'s segment column ``name`` (``line``, ``cut``, ``move``, ...), read in slices."""
        e = self.store.entries[i]
        return self.store._column(name, e.segment0, e.n_segments)
