"""The chains of a program built move by move (:func:`fuzzyfeed.program.run.program_path`'s rules),
from one :class:`~fuzzyfeed.program.model.Program` or from the windows of lines of a long one
(:mod:`fuzzyfeed.program.windows`): what crosses a window's join — the open chain, the last end
point and the last vertex — is this object's state, so the chains are the same floats however the
moves come. The chains go to the caller in chunks (``on_chunk``) and closes (``on_close``): in
memory for :func:`~fuzzyfeed.program.run.program_path`, to a scratch file for
:mod:`fuzzyfeed.program.chain_store`.

A chain's vertices: its start point (radius NaN, no segment), then one per segment (a line's end,
an arc's chord ends within the chord tolerance, radius the arc's except at its last).
"""

from __future__ import annotations

import math

import numpy as np

from fuzzyfeed.program.model import ARC, HOME, LINE, NURBS, RAPID, Program, arc_geometry, arc_points

#: Moves handled per chunk (the per-segment lists become arrays at each).
PATH_CHUNK_MOVES = 1 << 15


def _arc_chords(program: Program, m: int, chord_tol_mm: float) -> tuple[np.ndarray, float]:
    """Points (k, 3) after the start of arc move ``m``, chords within ``chord_tol_mm``, and the radius."""
    g = arc_geometry(program, m)
    r = g["radius"]
    if r > chord_tol_mm:
        step = 2.0 * np.arccos(1.0 - chord_tol_mm / r)
    else:
        step = np.pi / 2
    k = max(1, int(np.ceil(abs(g["sweep"]) / step)))
    return arc_points(program, m, np.arange(1, k + 1) / k), r


def _nurbs_chords(program: Program, m: int, chord_tol_mm: float) -> np.ndarray:
    curve = program.nurbs[int(m)]
    lo, hi = curve.domain
    probe = np.linspace(lo, hi, max(64, 16 * (curve.span_breaks.size - 1)))
    kmax = float(np.max(curve.curvature(probe)))
    step = np.sqrt(8.0 * chord_tol_mm / kmax) if kmax > 0 else curve.length
    k = max(1, int(np.ceil(curve.length / max(step, 1e-6))))
    u = curve.param_at_length(np.linspace(0.0, curve.length, k + 1)[1:])
    pts = curve(u)
    out = np.column_stack([pts[:, 0], pts[:, 1], np.full(k, program.start[m, 2])]) if pts.shape[1] == 2 else pts
    out[-1] = program.end[m]
    return out


def _plain_moves(program: Program, run: np.ndarray) -> np.ndarray:
    """Moves :meth:`PathBuilder._add_plain` takes: not run, or a line/rapid with finite ends at
    more than 1e-9 mm from its start (the per-move rule's length, the same floats)."""
    d = program.end - program.start
    length = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])
    line = (program.kind != ARC) & (program.kind != NURBS)
    finite = np.isfinite(program.start).all(axis=1) & np.isfinite(program.end).all(axis=1)
    return ~run | (line & finite & (length > 1e-9))


class PathBuilder:
    """Chains built move by move (module docstring). ``on_chunk(program, tag, points, radius,
    feed, rapid, seg_move, measured)``: vertices (points (k, 3), radius (k,)) and segments (feed
    mm/s, rapid, the program move — ``program``'s own index — and whether it is measured) of the
    open chain, in order; ``on_close(has_segments)``: the open chain ends (dropped by the caller
    when it has no segment)."""

    def __init__(self, chord_tol_mm: float, on_chunk, on_close):
        self.chord_tol_mm = chord_tol_mm
        self.on_chunk, self.on_close = on_chunk, on_close
        self.last_end: list[float] | None = None
        self.prev = (0.0, 0.0, 0.0)
        self.open = False          # a chain is open (its start point given)
        self.segments = 0          # the open chain's segments so far
        self._reset()

    def _reset(self) -> None:
        self.rows: list[int] = []
        self.pool: list[np.ndarray] = []
        self.n_pool = 0
        self.feed: list[float] = []
        self.rapid: list[bool] = []
        self.radius: list[float] = []
        self.seg_move: list[int] = []
        self.measured: list[bool] = []

    def _pooled(self, block: np.ndarray) -> list[int]:
        self.pool.append(block)
        self.n_pool += block.shape[0]
        n = self.n_pool
        return list(range(-n + block.shape[0] - 1, -n - 1, -1))

    def _flush(self, program: Program, tag) -> None:
        if self.rows:
            idx = np.array(self.rows, dtype=np.int64)
            pts = np.empty((idx.size, 3))
            own = idx >= 0
            pts[own] = program.end[idx[own]]
            if self.pool:
                pts[~own] = np.vstack(self.pool)[-1 - idx[~own]]
            self.segments += len(self.feed)
            self.on_chunk(program, tag, pts, np.array(self.radius, dtype=float), np.array(self.feed, dtype=float),
                          np.array(self.rapid, dtype=bool), np.array(self.seg_move, dtype=np.int64),
                          np.array(self.measured, dtype=bool))
        self._reset()

    def _close(self, program: Program, tag) -> None:
        self._flush(program, tag)
        if self.open:
            self.on_close(self.segments > 0)
        self.open, self.segments, self.last_end = False, 0, None

    def finish(self, program: Program | None = None, tag=None) -> None:
        """The last chain ends."""
        self._close(program, tag)

    def _add_plain(self, program: Program, tag, c0: int, c1: int, run: np.ndarray, stop: np.ndarray) -> None:
        """Moves ``c0..c1-1`` of ``program``, each not run or a line/rapid longer than 1e-9 mm with
        finite ends (:func:`_plain_moves`), the open chain's last vertex its last move's end: the
        chains, chunks and closes of :meth:`add`'s move-by-move rules, in arrays. Every run move is a
        segment from its start, so a chain is a group of run moves each starting where the one before
        ended, with no stop between."""
        start, end = program.start[c0:c1], program.end[c0:c1]
        run, stop = run[c0:c1], stop[c0:c1]
        kinds, n = program.kind[c0:c1], c1 - c0
        cont = np.zeros(n, dtype=bool)       # the move continues the chain open before it
        cont[1:] = run[1:] & run[:-1] & ~stop[:-1] & (start[1:] == end[:-1]).all(axis=1)
        cont[0] = bool(run[0]) and self.open and start[0].tolist() == self.last_end
        if self.open and not cont[0]:
            self._close(program, tag)
        first = np.flatnonzero(run & ~cont)                  # each new chain's first move
        ends = np.flatnonzero(run & ~np.append(cont[1:], False))    # each chain's last move here
        heads = ([0] if cont[0] else []) + first.tolist()
        rapid_all = (kinds == RAPID) | (kinds == HOME)
        feed_all = np.where(rapid_all, np.nan, program.feed_mm_min[c0:c1] / 60.0)
        meas_all = ~rapid_all & (program.cut[c0:c1] >= 0)
        for i0, i1 in zip(heads, ends.tolist()):
            moves = slice(i0, i1 + 1)
            pts = end[moves].copy() if cont[i0] else np.vstack([start[i0][None, :], end[moves]])
            self.open = True
            self.segments += i1 + 1 - i0
            self.on_chunk(program, tag, pts, np.full(pts.shape[0], np.nan), feed_all[moves].copy(),
                          rapid_all[moves].copy(), np.arange(c0 + i0, c0 + i1 + 1, dtype=np.int64),
                          meas_all[moves].copy())
            if stop[i1] or i1 + 1 < n:
                self._close(program, tag)
            else:
                self.last_end = end[i1].tolist()
                self.prev = tuple(self.last_end)
        self._reset()

    def add(self, program: Program, tag=None) -> None:
        """The moves of ``program`` (a window's; ``tag``, passed back to ``on_chunk`` with its
        chunks, says which), the chain left open at its end."""
        kinds = program.kind
        feed_mode = program.feed_mode[program.move_line] if program.move_line.size else np.zeros(0)
        runnable = np.isin(kinds, [RAPID, HOME, LINE, ARC, NURBS])
        feed_move = np.isin(kinds, [LINE, ARC, NURBS])
        runnable &= ~feed_move | ((feed_mode == 94) & (program.feed_mm_min > 0))
        if program.known is not None:
            # a move from a point the reader cannot place (the machine's position at the start, after
            # G28/G53, ...) is not run: its start, direction and length are not known, so neither is
            # the servo's lag it leaves; the chain restarts at its end, from rest
            runnable &= program.known
        # a line with a stop code stops the tool after its motion
        stops = program.stops if program.stops is not None else program.no_split & ~(kinds == ARC)
        run_a, stop_a = runnable, np.asarray(stops, bool)
        tol = self.chord_tol_mm
        chunk = PATH_CHUNK_MOVES
        plain = _plain_moves(program, run_a)
        for c0 in range(0, kinds.size, chunk):
            c1 = min(c0 + chunk, kinds.size)
            if plain[c0:c1].all() and (not self.open or self.prev == tuple(self.last_end)):
                self._add_plain(program, tag, c0, c1, run_a, stop_a)
                continue
            run_l, kind_l, stop_l = run_a[c0:c1].tolist(), kinds[c0:c1].tolist(), stop_a[c0:c1].tolist()
            start_l, end_l = program.start[c0:c1].tolist(), program.end[c0:c1].tolist()
            feed_l, cut_l = program.feed_mm_min[c0:c1].tolist(), program.cut[c0:c1].tolist()
            rows, radius, feed, rapid = self.rows, self.radius, self.feed, self.rapid
            seg_move, measured = self.seg_move, self.measured
            for i in range(c1 - c0):
                m = c0 + i
                if not run_l[i]:
                    self._close(program, tag)
                    rows, radius, feed, rapid = self.rows, self.radius, self.feed, self.rapid
                    seg_move, measured = self.seg_move, self.measured
                    continue
                start, end = start_l[i], end_l[i]
                if self.last_end is not None and start != self.last_end:
                    self._close(program, tag)
                    rows, radius, feed, rapid = self.rows, self.radius, self.feed, self.rapid
                    seg_move, measured = self.seg_move, self.measured
                kind = kind_l[i]
                if not self.open:                  # a new chain: its start point
                    rows.extend(self._pooled(program.start[m][None, :]))
                    radius.append(np.nan)
                    self.prev = tuple(start)
                    self.open = True
                prev = self.prev
                is_rapid = kind in (RAPID, HOME)
                f = np.nan if is_rapid else feed_l[i] / 60.0
                meas = (not is_rapid) and cut_l[i] >= 0
                if kind == ARC or kind == NURBS:
                    if kind == ARC:
                        new, r = _arc_chords(program, m, tol)
                        rads = [r] * (new.shape[0] - 1) + [np.nan]
                    else:
                        new = _nurbs_chords(program, m, tol)
                        rads = [np.nan] * new.shape[0]
                    steps = np.linalg.norm(np.diff(np.vstack([np.array(prev)[None, :], new]), axis=0), axis=1)
                    keep = steps > 1e-9
                    if keep.any():
                        new = new[keep]
                        rads = [r for r, k in zip(rads, keep) if k]
                        rads[-1] = np.nan
                        n = new.shape[0]
                        rows.extend(self._pooled(new))
                        self.prev = tuple(new[-1].tolist())
                        radius.extend(rads)
                        feed.extend([f] * n)
                        rapid.extend([is_rapid] * n)
                        seg_move.extend([m] * n)
                        measured.extend([meas] * n)
                else:
                    dx, dy, dz = end[0] - prev[0], end[1] - prev[1], end[2] - prev[2]
                    if math.sqrt(dx * dx + dy * dy + dz * dz) > 1e-9:
                        rows.append(m)
                        self.prev = (end[0], end[1], end[2])
                        radius.append(np.nan)
                        feed.append(f)
                        rapid.append(is_rapid)
                        seg_move.append(m)
                        measured.append(meas)
                self.last_end = end
                if stop_l[i]:
                    self._close(program, tag)
                    rows, radius, feed, rapid = self.rows, self.radius, self.feed, self.rapid
                    seg_move, measured = self.seg_move, self.measured
            self._flush(program, tag)
