"""The limit reference's state (:func:`~fuzzyfeed.program.reference.limit_reference`): the refined
chains (:func:`refine_chain`) and per chain its feeds, its plan's speed profile (:class:`Profile`)
and its events (:class:`Events`), what its passes read and write chain by chain.
:class:`HeldState` holds them in memory (a path in memory); :class:`StoredState` in scratch files
(a path in a scratch store, :class:`~fuzzyfeed.program.chain_store.StoredPath`, issue 36:
``advise --machine --report`` on a program read in windows of lines), not in memory:

- The refined chains (:func:`refine_into`, a stored chain's segments
  refined a block of :data:`REFINE_SEGMENTS` at a time: each segment's pieces depend on it alone)
  go to a :class:`~fuzzyfeed.program.chain_store.ChainStore` of their own in a folder beside the
  path's store, read back as a run takes them (a chain shorter than
  :data:`~fuzzyfeed.program.run.CARRIED_MIN_SEGMENTS` whole, a longer one by slices).
- Per refined segment its feed (a copy of the refined feeds, lowered by the passes) and its plan's
  speed profile (v_entry, v_peak, v_exit, acc: 40 B a segment) are that store's own columns
  (:meth:`~fuzzyfeed.program.chain_store.ChainStore.add_column`), read and written by slices:
  :func:`~fuzzyfeed.machine.plan_parts.changed_sweep` reads and overwrites a long chain's profile a
  plan window at a time; a short chain's are read whole when the pass takes it.
- Per chain its events (the ticks over the tolerance a pass reads) in a
  :class:`~fuzzyfeed.base.spill.Spill` of that folder, a new one each time they change, read back
  whole when the pass takes the chain (O(events), not O(segments)).
- The whole runs kept for the final run keep no events (:meth:`StoredState.kept`): their rows and
  summaries only (the largest errors per segment already go to the caller's ``seg_sinks``).

Nothing is mapped (mapped pages count in the resident set: the store's own rule).
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass, replace

import numpy as np

from fuzzyfeed.base.spill import Spill
from fuzzyfeed.machine.planner import Motion, Plan
from fuzzyfeed.program import run as program_run
from fuzzyfeed.program.chain_store import ChainStore, StoredPath
from fuzzyfeed.program.run import Chain, ChainRun, ProgramPath

#: Segments of a stored chain refined at a time.
REFINE_SEGMENTS = 1 << 16
_PROFILE = ("v_entry", "v_peak", "v_exit", "acc")


def _pieces(motion, piece_mm: float):
    """Per segment of ``motion`` its piece count (:func:`refine_chain`), the new vertices after the
    first (the end of a segment's last piece: its end vertex bit for bit), their arc radii (NaN inside
    a segment) and per new segment the segment it is a piece of; None when no segment is cut."""
    m = motion
    length = np.linalg.norm(np.diff(m.points, axis=0), axis=1)
    pieces = np.where(m.rapid, 1, np.maximum(1, np.ceil(length / piece_mm).astype(np.int64)))
    if (pieces == 1).all():
        return None
    seg = np.repeat(np.arange(length.size), pieces)
    first = np.repeat(np.cumsum(pieces) - pieces, pieces)
    frac = (np.arange(seg.size) - first + 1) / pieces[seg]
    pts = m.points[seg] + (m.points[seg + 1] - m.points[seg]) * frac[:, None]
    is_end = frac == 1.0
    pts[is_end] = m.points[seg[is_end] + 1]
    return pts, np.where(is_end, m.arc_radius_mm[seg + 1], np.nan), seg


def refine_chain(chain: Chain, piece_mm: float) -> Chain:
    """``chain`` with every feed segment longer than ``piece_mm`` cut into equal pieces (straight
    junctions: the controller runs it the same way)."""
    m = chain.motion
    rows = _pieces(m, piece_mm)
    if rows is None:
        return chain
    pts, radius, seg = rows
    motion = Motion(np.vstack([m.points[:1], pts]), m.feed_mm_s[seg], m.rapid[seg],
                    np.concatenate([m.arc_radius_mm[:1], radius]))
    return Chain(motion, chain.seg_move[seg], chain.seg_measured[seg])


@dataclass(frozen=True, eq=False)
class Profile:
    """What a pass compares of a chain's plan (~32 bytes a segment of its ~104): per segment the
    entry, peak and exit speed and the acceleration (the first plan's own arrays, no copy; each
    pass overwrites them with its plan's, window by window:
    :func:`~fuzzyfeed.machine.plan_parts.changed_sweep`; on the store: columns read and written by
    slices)."""

    v_entry: np.ndarray
    v_peak: np.ndarray
    v_exit: np.ndarray
    acc: np.ndarray

    @classmethod
    def of(cls, plan: Plan) -> Profile:
        return cls(plan.v_entry, plan.v_peak, plan.v_exit, plan.acc)

    def arrays(self) -> tuple:
        return self.v_entry, self.v_peak, self.v_exit, self.acc


#: The events' fields a pass reads (:class:`Events`).
EVENT_FIELDS = ("contour_mm", "speed_mm_s", "tick_segment", "nearest_segment", "lookback_segment")


@dataclass(frozen=True, eq=False)
class Events:
    """What a pass of the limit reference needs of a chain's run, spliced from the stretches
    re-run: the events (ticks over the tolerance; the passes lower the feeds from them, never from
    the largest error per segment)."""

    contour_mm: np.ndarray
    speed_mm_s: np.ndarray
    tick_segment: np.ndarray
    nearest_segment: np.ndarray
    lookback_segment: np.ndarray

    @classmethod
    def of(cls, stream) -> Events:
        return cls(*(getattr(stream, name) for name in EVENT_FIELDS))

    def splice(self, stream, redone: tuple[np.ndarray, np.ndarray]) -> Events:
        """These events with those on the segments ``redone`` (runs [start, stop), sorted, apart:
        :func:`~fuzzyfeed.machine.plan_parts.changed_sweep`'s) taken from ``stream``, a run of
        their stretches made part by part (:func:`~fuzzyfeed.machine.plan_parts.stream_parts`)."""
        old = ~_member(redone, self.tick_segment)
        new = _member(redone, stream.tick_segment)
        return Events(*(np.concatenate([getattr(self, k)[old], getattr(stream, k)[new]]) for k in EVENT_FIELDS))


def _member(runs: tuple[np.ndarray, np.ndarray], x: np.ndarray) -> np.ndarray:
    """Whether each of ``x`` lies in one of the ``runs`` (starts, stops: [start, stop), sorted, not
    overlapping): a bool array of ``x``'s shape."""
    starts, stops = runs
    if starts.size == 0:
        return np.zeros(np.shape(x), bool)
    at = np.searchsorted(starts, x, side="right") - 1
    return (at >= 0) & (x < stops[np.maximum(at, 0)])


class HeldState:
    """The limit reference's state of a path in memory: the refined chains, per chain its feeds,
    its plan's speed profile and its events, in lists (what the passes of
    :func:`~fuzzyfeed.program.reference.limit_reference` ask of a state; the stored one:
    :class:`StoredState`)."""

    def __init__(self, path: ProgramPath, piece_mm: float):
        chains = tuple(refine_chain(c, piece_mm) for c in path.chains)
        self.path = ProgramPath(program=path.program, chains=chains, chord_tol_mm=path.chord_tol_mm)
        self.n = len(chains)
        self._feeds: list = [c.motion.feed_mm_s.copy() for c in chains]
        self._profiles: list = [None] * self.n
        self._events: list = [None] * self.n

    def chain(self, i: int) -> Chain:
        return self.path.chains[i]

    def feed(self, i: int) -> np.ndarray:
        return self._feeds[i]

    def feeds_at(self, i: int):
        """``at -> feeds`` of chain i at the sorted indices ``at``."""
        return lambda at: self._feeds[i][at]

    def lower(self, i: int, at: np.ndarray, values: np.ndarray) -> None:
        new = self._feeds[i].copy()          # a Motion made its feeds read-only
        new[at] = values
        self._feeds[i] = new

    def profile(self, i: int, n: int | None = None) -> Profile:
        """Chain i's profile; with ``n``: a new one of n segments to fill."""
        if n is not None:
            self._profiles[i] = Profile(np.empty(n), np.empty(n), np.empty(n), np.empty(n))
        return self._profiles[i]

    def set_profile(self, i: int, profile: Profile) -> None:
        self._profiles[i] = profile

    def events(self, i: int) -> Events:
        return self._events[i]

    def set_events(self, i: int, ev: Events) -> None:
        self._events[i] = ev

    def drop_events(self) -> None:
        """The passes are over: their events and profiles go."""
        self._events = self._profiles = None

    def kept(self, run: ChainRun) -> ChainRun:
        return run

    def feeds(self) -> tuple:
        return tuple(self._feeds)

    def held(self):
        return None

    def close(self) -> None:
        pass


def refine_into(path: StoredPath, piece_mm: float, out: ChainStore, block: int = REFINE_SEGMENTS) -> None:
    """Every chain of ``path`` refined (:func:`~fuzzyfeed.program.reference.refine_chain`'s rows,
    bit for bit) into ``out`` (closed for writing at the end), a block of segments at a time."""
    src = path.store
    for i in range(len(src.entries)):
        st = src.stored_chain(i)
        m = st.motion
        for a in range(0, m.n_segments, block):
            b = min(a + block, m.n_segments)
            sub = Motion(m.points[a:b + 1], m.feed_mm_s[a:b], m.rapid[a:b], m.arc_radius_mm[a:b + 1])
            rows = _pieces(sub, piece_mm)
            seg = np.arange(b - a) if rows is None else rows[2]
            pts, radius = (sub.points[1:], sub.arc_radius_mm[1:]) if rows is None else rows[:2]
            if a == 0:                       # the chain's first vertex
                pts, radius = np.vstack([sub.points[:1], pts]), np.concatenate([sub.arc_radius_mm[:1], radius])
            cols = [c[a:b][seg] for c in (m.feed_mm_s, m.rapid, st.seg_move, st.seg_measured, st.seg_line, st.seg_cut)]
            out.append(pts, radius, *cols)
        out.end_chain()
    out.close_writing()


class StoredState:
    """What :func:`~fuzzyfeed.program.reference.limit_reference` asks of a state (the in-memory one:
    :class:`HeldState`), in scratch files (module docstring) in the folder
    ``<path's store folder>.reference``, removed by :meth:`close`."""

    def __init__(self, path: StoredPath, piece_mm: float):
        self.folder = path.store.folder.with_name(path.store.folder.name + ".reference")
        store = self.store = ChainStore(self.folder, path.chord_tol_mm)
        try:
            refine_into(path, piece_mm, store, REFINE_SEGMENTS)
            store.add_column("feeds", np.float64, like="feed")
            for name in _PROFILE:
                store.add_column(name, np.float64)
        except BaseException:
            self.close()
            raise
        self.path = StoredPath.of(store)
        self.n = len(store.entries)
        self._events: list[Spill | None] = [None] * self.n
        self._made = 0

    def _whole(self, i: int) -> bool:
        """Whether chain i is handed out whole, in memory (:meth:`ChainStore.chain`'s rule: a
        chain run whole, its plan kept, shorter than :data:`~fuzzyfeed.program.run.CARRIED_MIN_SEGMENTS`)."""
        return self.store.entries[i].n_segments < program_run.CARRIED_MIN_SEGMENTS

    def chain(self, i: int):
        return self.path.chains[i]

    def feed(self, i: int):
        """Chain i's feeds: an array for a chain handed out whole, else its column."""
        col = self.path.segment_column(i, "feeds")
        return col[:] if self._whole(i) else col

    def feeds_at(self, i: int):
        return self.path.segment_column(i, "feeds").gather

    def lower(self, i: int, at: np.ndarray, values: np.ndarray) -> None:
        self.path.segment_column(i, "feeds").scatter(at, values)

    def profile(self, i: int, _n: int | None = None) -> Profile:
        """Chain i's profile: its columns (read and written by slices)."""
        return Profile(*(self.path.segment_column(i, name) for name in _PROFILE))

    def set_profile(self, i: int, profile: Profile) -> None:
        for col, values in zip(self.profile(i).arrays(), profile.arrays()):
            col[:] = values

    def events(self, i: int) -> Events:
        spill = self._events[i]
        if spill is None or spill.rows == 0:
            return Events(np.zeros(0), np.zeros(0), *(np.zeros(0, np.int64) for _ in range(3)))
        got = spill.read(0, spill.rows)
        return Events(*(got[k] for k in EVENT_FIELDS))

    def set_events(self, i: int, ev: Events) -> None:
        """Chain i's events written to a new spill (the one before removed)."""
        self._remove(self._events[i])
        self._made += 1
        spill = Spill(self.folder, f"events{i}.{self._made}")
        if ev.contour_mm.size:
            spill.append({k: getattr(ev, k) for k in EVENT_FIELDS})
        self._events[i] = spill

    def _remove(self, spill: Spill | None) -> None:
        for field in () if spill is None else spill.fields:
            (self.folder / f"{spill.name}.{field}").unlink(missing_ok=True)

    def drop_events(self) -> None:
        """The passes are over: their events' files go."""
        for spill in self._events:
            self._remove(spill)
        self._events = [None] * self.n

    def kept(self, run: ChainRun) -> ChainRun:
        """``run`` without its events (its rows and summaries: what the final run reports)."""
        s = run.stream
        none = np.zeros(0)
        idx = np.zeros(0, np.int64)
        stream = replace(s, tick_time_s=none, contour_mm=none, speed_mm_s=none, nearest_xyz=np.zeros((0, 3)),
                         tick_segment=idx, nearest_segment=idx, lookback_segment=idx)
        return ChainRun(plan=run.plan, stream=stream, tick_move=idx, time_s=run.time_s)

    def feeds(self) -> tuple:
        """Per chain its feeds' column (read by slices until :meth:`close`)."""
        return tuple(self.path.segment_column(i, "feeds") for i in range(self.n))

    def held(self) -> StoredState:
        return self

    def close(self) -> None:
        """The refined store's files closed and its folder removed."""
        self.store.close()
        shutil.rmtree(self.folder, ignore_errors=True)
