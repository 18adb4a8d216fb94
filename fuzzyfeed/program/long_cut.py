"""A cut longer than a window of lines advised from its file in pieces (issue 36): memory bounded by
a window and a few pieces, not by the cut.

The windowed read (:mod:`fuzzyfeed.program.windows`) splits such a cut between windows
(:attr:`~fuzzyfeed.program.windows.Window.continues`). :func:`advise_long_cut` gives the pieces
:func:`fuzzyfeed.program.stream.stream_program_advice` gives for the whole cut, bit for bit. The
cut is read from its file once, from the first window's start state in windows of a quarter of the
windows' lines, and its moves as the passes read them (end points, chord, sample count, F, line,
the split flags: ~80 B a move) are written to a scratch folder (:class:`~fuzzyfeed.base.spill.Spill`,
removed on every exit, error included); every pass then reads them back a chunk at a time:

1. the G1-run fit's two scans (:func:`fuzzyfeed.geometry.polyline_stream.fit_chunks`: the rounding
   quantum's counts, the extent, the tiny moves' clusters — exact integers and the same sums);
2. pass 0 of the stream: the pieces' plan and s at every core vertex, s at each piece's anchor kept
   (one float a piece) and the cut's length;
3. pass 1: the clipped Dκ's range and the curvature peaks' κ and Dκ;
4. pass 2: the advice of each piece (:func:`~fuzzyfeed.program.stream.piece_advice`, the stream's),
   the filter's sums handed on.

Pass 0 runs the fit's last pass (per-vertex κ and corners) in step with the moves and writes its κ
and corners to the scratch folder too (9 B a vertex); passes 1 and 2 read them back with the moves.
A pass holds the moves from the piece before's core to the piece after's margin (the plan is
made greedily from the cut's start as the stream makes it: the cumulative sample counts and lengths
carried, the last piece merged where the stream merges it). Pieces carry their moves as ordinals
of the cut's sampled moves (``ordinals``).

Only a cut of straight G1 moves is advised so (arcs and G5.2 blocks: :class:`Fallback`, the program is
read whole), with F > 0 everywhere and no move over the sample budget (else the whole read says why).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from fuzzyfeed.base.spill import Spill, scratch_folder
from fuzzyfeed.fuzzy.advisor import point_sequence_table
from fuzzyfeed.fuzzy.engine import compile_table
from fuzzyfeed.geometry.polyline_chords import WINDOW_VERTICES
from fuzzyfeed.geometry.sampling import MAX_POINTS, segment_pieces
from fuzzyfeed.program.cuts import RunGeometry, cut_moves, path_length, sample_moves
from fuzzyfeed.program.model import LINE
from fuzzyfeed.program.stream import (MIN_MARGIN_MOVES, AdvicePiece, CarriedSums, CutPiece, dk_range, margin_mm,
                                      piece_advice)
from fuzzyfeed.program.windows import Fallback, Window, read_windows

#: The passes read the cut in windows of this fraction of the windows' lines.
PASS_SPLIT = 4
#: Vertices a window of the cut's G1-run fit holds (:func:`~fuzzyfeed.geometry.polyline_stream.fit_chunks`).
FIT_WINDOW = WINDOW_VERTICES


def cut_windows(path, first: Window, k: int, tools, window_lines: int) -> Iterator[tuple[Window, np.ndarray]]:
    """The windows of the cut that starts as cut ``k`` (the last) of window ``first`` and goes on
    in the windows after it, read again from ``first``'s start in windows of
    ``window_lines // PASS_SPLIT`` lines (the reader's working memory is a window's), with its
    sampled moves in each (:func:`~fuzzyfeed.program.cuts.cut_moves`). The cut is found by the line
    of its first move; the windows give the whole read's moves however they are cut."""
    at = int(first.program.move_line[first.program.cut_moves(k)[0]]) + first.line0
    lines = max(2, int(window_lines) // PASS_SPLIT)
    j = None
    for win in read_windows(path, tools=tools, window_lines=lines, start=first):
        p = win.program
        if j is None:
            starts = [c for c in range(p.n_cuts) if int(p.move_line[p.cut_moves(c)[0]]) + win.line0 == at]
            if not starts:
                continue
            j = starts[0]
            goes_on = j == p.n_cuts - 1 and win.continues
        else:
            if not win.continued:
                raise Fallback("a cut split between windows read again differently")
            j = 0
            goes_on = win.continues and p.n_cuts == 1
        every = p.cut_moves(j)
        if not np.all(p.feed_mm_min[every] > 0):
            raise Fallback("a move without F: the whole read names it")
        moves, kinds, _ = cut_moves(p, j)
        if np.any(kinds != LINE):
            raise Fallback("a cut longer than a window with arcs or G5.2 blocks")
        yield win, moves
        if not goes_on:
            return
    raise Fallback("a cut split between windows not found again")


def _blocks(path, first, k, tools, window_lines, step_mm):
    """The cut's moves window after window as arrays (the view's fields), checked."""
    for win, moves in cut_windows(path, first, k, tools, window_lines):
        p = win.program
        start, end = p.start[moves], p.end[moves]
        chord = np.linalg.norm(end - start, axis=1)
        feed = p.feed_mm_min[moves]
        count = segment_pieces(chord, step_mm).astype(np.int64)
        if count.size and count.max() + 1 > MAX_POINTS:
            raise Fallback("a move over the sample budget: the whole read names it")
        yield dict(start=start, end=end, chord=chord, count=count, feed_mm_min=feed,
                   move_line=p.move_line[moves] + win.line0, no_split=p.no_split[moves],
                   comp_unknown=None if p.comp_unknown is None else p.comp_unknown[moves])


_MOVE_FIELDS = ("start", "end", "chord", "count", "feed_mm_min", "move_line", "no_split", "comp_unknown")


class _Pass:
    """One pass over the cut: a buffer of its moves [b0, b1) and vertices [b0, b1] with the fit's κ
    and corners, the cumulative sample counts and lengths (as the stream's plan sums them) and s."""

    def __init__(self, blocks: Iterator[dict], n: int, fit=None, keep=None, vertices: Iterator | None = None):
        self._blocks = blocks
        self.n = n                               # the cut's moves
        self._moves: deque = deque()            # blocks read, not yet in the buffer
        self._first = True
        # κ and corners: from the fit, which pulls the blocks as it reads the points (each piece
        # also to ``keep(κ, corner)``), or read back (``vertices``: (κ, corner) chunks) with the
        # blocks pulled here
        self._pull = vertices is not None
        self._pieces = vertices if self._pull else self._fitted(fit, keep)
        self.done = False
        self.b0 = 0
        self.f = {name: None for name in _MOVE_FIELDS}
        self.vk = np.zeros(0)
        self.vc = np.zeros(0, bool)
        self.cum_cnt = np.zeros(1, np.int64)
        self.cum_len = np.zeros(1)
        self.sv = np.full(1, np.nan)
        self.sv[0] = 0.0
        self.n_moves = 0                         # moves in the buffer (b1 - b0)

    def _fitted(self, fit, keep):
        for kappa, _, corner in fit.pieces(self._points):
            if keep is not None:
                keep(kappa, corner)
            yield kappa, corner

    def _points(self):
        for blk in self._blocks:
            self._moves.append(blk)
            if not len(blk["end"]):
                continue
            pts = np.vstack([blk["start"][:1], blk["end"]]) if self._first else blk["end"]
            self._first = False
            yield pts

    def grow(self) -> bool:
        """Read on: False at the cut's end."""
        if self.done:
            return False
        try:
            kappa, corner = next(self._pieces)
        except StopIteration:
            self.done = True
            return False
        self.vk = np.concatenate([self.vk, kappa])
        self.vc = np.concatenate([self.vc, corner])
        want = self.b0 + self.vk.size - 1 - (self.b0 + self.n_moves)   # moves whose both ends are known
        parts = []
        while want > 0:
            if self._pull and not self._moves:
                blk = next(self._blocks, None)
                if blk is None:
                    raise RuntimeError(f"the cut's moves read back end before its vertices ({self.b1 + want - 1})")
                self._moves.append(blk)
                continue
            blk = self._moves[0]
            take = min(want, len(blk["end"]))
            parts.append({k: (None if v is None else v[:take]) for k, v in blk.items()})
            rest = {k: (None if v is None else v[take:]) for k, v in blk.items()}
            if len(rest["end"]):
                self._moves[0] = rest
            else:
                self._moves.popleft()
            want -= take
        if parts:
            for name in _MOVE_FIELDS:
                vals = [p[name] for p in parts]
                new = None if vals[0] is None else np.concatenate(vals)
                old = self.f[name]
                self.f[name] = new if old is None else np.concatenate([old, new])
            added = sum(len(p["end"]) for p in parts)
            cnt = np.concatenate([p["count"] for p in parts])
            ln = np.concatenate([p["chord"] for p in parts])
            self.cum_cnt = np.concatenate([self.cum_cnt, self.cum_cnt[-1] + np.cumsum(cnt)])
            self.cum_len = np.concatenate([self.cum_len, np.cumsum(np.concatenate([self.cum_len[-1:], ln]))[1:]])
            self.sv = np.concatenate([self.sv, np.full(added, np.nan)])
            self.n_moves += added
        return True

    def close(self) -> None:
        """Stop the pass's reads and drop its buffer (the fit's generator refers back to the pass)."""
        self._pieces.close()
        self._blocks.close()
        self._moves.clear()
        self.f = {name: None for name in _MOVE_FIELDS}
        self.vk = self.vc = self.cum_cnt = self.cum_len = self.sv = None

    @property
    def b1(self) -> int:
        return self.b0 + self.n_moves

    def release(self, a: int) -> None:
        """Moves and vertices before ``a`` are not read again."""
        cut = a - self.b0
        if cut <= 0:
            return
        for name in _MOVE_FIELDS:
            if self.f[name] is not None:
                self.f[name] = self.f[name][cut:].copy()
        self.vk, self.vc = self.vk[cut:].copy(), self.vc[cut:].copy()
        self.cum_cnt, self.cum_len, self.sv = self.cum_cnt[cut:].copy(), self.cum_len[cut:].copy(), self.sv[cut:].copy()
        self.b0 = a
        self.n_moves -= cut

    def until(self, test) -> None:
        """Read on until ``test()`` holds or the cut ends."""
        while not test() and self.grow():
            pass

    def view(self):
        """The buffer as the program and run geometry :func:`~fuzzyfeed.program.cuts.sample_moves`
        and :func:`~fuzzyfeed.program.feeds.move_pieces` read (move indices from b0)."""
        n = self.n_moves
        own = np.where(self.vc[:n + 1], np.inf, self.vk[:n + 1])
        mn = np.minimum(own[:-1], own[1:])
        vc = self.vc[:n + 1].copy()
        if self.b0 == 0:
            vc[0] = False
        if self.b0 + n == self.n:
            vc[-1] = False
        geo = RunGeometry(self.vk[:n + 1], vc, np.where(np.isfinite(mn), mn, 0.0))
        prog = SimpleNamespace(kind=np.full(n, LINE, dtype=np.int8), **self.f)
        return prog, geo


def advise_long_cut(path, first: Window, k: int, table, *, step_mm: float, cap_mm_min, feed_step_mm_min: float,
                    min_piece_mm: float, piece_points: int, tools, window_lines: int) -> Iterator[AdvicePiece]:
    """The pieces of the cut starting as cut ``k`` of window ``first`` (module docstring), with
    the file's cut number and lines; ``piece_move`` holds ordinals of the cut's sampled moves."""
    with scratch_folder("fuzzyfeed-longcut-") as folder:
        moves = store_moves(path, first, k, tools, window_lines, step_mm, folder)
        yield from _advise_stored(moves, folder, first.cut0 + k, table, step_mm=step_mm, cap_mm_min=cap_mm_min,
                                  feed_step_mm_min=feed_step_mm_min, min_piece_mm=min_piece_mm,
                                  piece_points=piece_points, rows=max(2, int(window_lines) // PASS_SPLIT))


def store_moves(path, first: Window, k: int, tools, window_lines: int, step_mm: float, folder) -> Spill:
    """The one read of the cut from its file: its moves (the fields :class:`_Pass` reads, ~80 B a
    move) written to ``folder`` window after window as :func:`_blocks` checks them."""
    moves = Spill(folder, "moves")
    for blk in _blocks(path, first, k, tools, window_lines, step_mm):
        if len(blk["end"]):
            comp = blk["comp_unknown"]      # None: no move waits on compensation (False everywhere)
            moves.append(dict(blk, comp_unknown=np.zeros(len(blk["end"]), bool) if comp is None else comp))
    return moves


def _advise_stored(moves: Spill, folder, cut_no: int, table, *, step_mm: float, cap_mm_min, feed_step_mm_min: float,
                   min_piece_mm: float, piece_points: int, rows: int) -> Iterator[AdvicePiece]:
    """:func:`advise_long_cut` from the cut's stored moves, read back ``rows`` at a time."""
    engine = compile_table(table)
    seq = point_sequence_table(table)
    plan = plan_stored(moves, folder, margin_mm(seq), piece_points, rows, step_mm)
    # pass 1: the range of the clipped Dκ (and κ, Dκ at the curvature peaks)
    dk_lo, dk_hi, lowest = dk_range(((pc.a, pc.b, pc.lo, pc.ms, pc.s) for pc in stored_pieces(moves, plan, rows, step_mm)),
                                    engine, seq.dk_clip_1_mm, seq.window_mm, plan.span, seq.filter == "corner-mean")
    # pass 2: the advice, piece by piece
    carry = CarriedSums()
    for pc in stored_pieces(moves, plan, rows, step_mm):
        yield piece_advice(pc.program, pc.ms, pc.s, pc.a, pc.b, pc.lo, cut=cut_no, table=seq, engine=engine,
                           span=plan.span, bounds=(dk_lo, dk_hi), lowest=lowest, carry=carry, g_lo=pc.g_lo,
                           nxt=pc.nxt, cap=cap_mm_min, feed_step=feed_step_mm_min, min_piece=min_piece_mm,
                           move0=pc.move0)


@dataclass(frozen=True, eq=False)
class StoredPlan:
    """Pass 0 of a stored cut (:func:`plan_stored`): its moves ``n``, its pieces (core ``a..b``,
    sampled moves ``lo..hi``, s at vertex ``lo + 1`` (0 at 0), the cut's sample at vertex ``lo``),
    its length and the fit's κ and corners at every vertex (a spill)."""

    n: int
    pieces: tuple
    length: float
    vertices: Spill

    @property
    def span(self) -> tuple[float, float]:
        return (0.0, self.length)


def _sample(ps: _Pass, lo: int, hi: int, step_mm: float):
    prog, geo = ps.view()
    return prog, sample_moves(prog, np.arange(ps.n_moves), prog.kind, prog.chord, step_mm, lo - ps.b0, hi - ps.b0, geo)


def plan_stored(moves: Spill, folder, margin: float, piece_points: int, rows: int, step_mm: float) -> StoredPlan:
    """Pass 0 of a cut from its stored ``moves`` (module docstring): the G1-run fit read in chunks
    (its κ and corners kept in ``folder``), the pieces planned as
    :func:`~fuzzyfeed.program.stream.plan_pieces` plans them with ``margin`` mm and
    ``piece_points``, s carried from piece to piece."""
    from fuzzyfeed.geometry.polyline_stream import fit_chunks

    def chunks():
        first_block = True
        for blk in moves.chunks(rows, fields=("start", "end")):
            yield np.vstack([blk["start"][:1], blk["end"]]) if first_block else blk["end"]
            first_block = False

    fit = fit_chunks(chunks, window=FIT_WINDOW)
    n = fit.n - 1                                   # moves: the vertices less one
    if n != len(moves):
        raise RuntimeError(f"the cut's fit has {fit.n} points for {len(moves)} moves")
    pp = min(int(piece_points), MAX_POINTS)
    plan = []
    vertices = Spill(folder, "vertices")
    ps = _Pass(moves.chunks(rows), n, fit=fit,
               keep=lambda kappa, corner: vertices.append({"kappa": kappa, "corner": corner}))
    ps.until(lambda: ps.n_moves >= 1)

    def bound_after(a):
        i = a - ps.b0
        t_cnt, t_len = ps.cum_cnt[i] + pp, ps.cum_len[i] + margin
        ps.until(lambda: ps.cum_cnt[-1] >= t_cnt and ps.cum_len[-1] >= t_len and ps.b1 >= min(a + MIN_MARGIN_MOVES, n))
        b = max(int(np.searchsorted(ps.cum_cnt, t_cnt, side="left")), int(np.searchsorted(ps.cum_len, t_len, side="left")),
                i + MIN_MARGIN_MOVES) + ps.b0
        return min(b, n)

    def short_tail(a):        # the stream's rule: the last core merged into the one before
        i, j = a - ps.b0, n - ps.b0
        return (ps.cum_cnt[j] - ps.cum_cnt[i] < pp or ps.cum_len[j] - ps.cum_len[i] < margin
                or n - a < MIN_MARGIN_MOVES)

    a = 0
    b = bound_after(0)
    while True:
        nb = bound_after(b) if b < n else None
        if nb == n and b > 0 and short_tail(b) and a < b:
            # bounds [.., a, b, n] with the last core short: [a, n) is one core
            b, nb = n, None
        ia, ib = a - ps.b0, b - ps.b0
        lo = int(np.searchsorted(ps.cum_len, ps.cum_len[ia] - margin, side="right")) - 1 + ps.b0
        if lo < ps.b0 and ps.b0 > 0:
            raise Fallback("a margin reaching before the piece before")
        lo = max(min(lo, a - MIN_MARGIN_MOVES), 0)
        t_len = ps.cum_len[ib] + margin
        ps.until(lambda: ps.cum_len[-1] >= t_len and ps.b1 >= min(b + MIN_MARGIN_MOVES, n))
        hi = int(np.searchsorted(ps.cum_len, t_len, side="left")) + ps.b0
        hi = min(max(hi, b + MIN_MARGIN_MOVES), n)
        if lo < ps.b0:
            raise Fallback("a margin reaching before the buffer")
        va = lo + 1 if lo > 0 else 0
        anchor = float(ps.sv[va - ps.b0])
        _, ms = _sample(ps, lo, hi, step_mm)
        s = path_length(ms.xyz, int(ms.vertex_sample[va - lo]), anchor)
        ps.sv[a + 1 - ps.b0:b + 1 - ps.b0] = s[ms.vertex_sample[a + 1 - lo:b + 1 - lo]]
        plan.append((a, b, lo, hi, anchor, int(ps.cum_cnt[lo - ps.b0])))
        if b >= n:
            length = float(ps.sv[n - ps.b0])
            break
        ps.release(min(a, lo))
        a, b = b, nb
    ps.until(lambda: False)                      # the fit to its end: every vertex kept
    ps.close()
    if len(vertices) != n + 1:
        raise RuntimeError(f"the cut's fit kept {len(vertices)} vertices of {n + 1}")
    return StoredPlan(n, tuple(plan), length, vertices)


def stored_pieces(moves: Spill, plan: StoredPlan, rows: int, step_mm: float) -> Iterator[CutPiece]:
    """One pass over a stored cut: its pieces (:class:`CutPiece`) in order, the moves and the
    fit's κ and corners read back ``rows`` at a time, the buffer dropped behind each piece."""
    pieces = plan.pieces
    ps = _Pass(moves.chunks(rows), plan.n,
               vertices=((v["kappa"], v["corner"]) for v in plan.vertices.chunks(rows)))
    try:
        for p, (a, b, lo, hi, anchor, g_lo) in enumerate(pieces):
            ps.until(lambda: ps.b1 >= hi)
            prog, ms = _sample(ps, lo, hi, step_mm)
            va = lo + 1 if lo > 0 else 0
            s = path_length(ms.xyz, int(ms.vertex_sample[va - lo]), anchor)
            nxt = pieces[p + 1][5] if p + 1 < len(pieces) else None
            yield CutPiece(p, a, b, lo, prog, ms, s, g_lo, nxt, ps.b0)
            del prog, ms, s
            nxt_lo = pieces[p + 1][2] if p + 1 < len(pieces) else hi
            ps.release(min(nxt_lo, a))
    finally:
        ps.close()
