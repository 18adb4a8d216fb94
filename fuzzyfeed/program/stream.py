"""The plain advice of a program in pieces: memory bounded by a piece, not by a cut or the program.

A cut is advised in pieces of whole moves (the *core*, about ``piece_points`` samples) sampled with
a margin of moves on each side. Every stage of the advice reaches a bounded stretch of path: the
curvature of a sample two moves (the three-point estimate over move ends; runs of G1 moves are
fitted once per cut on their vertices, :func:`fuzzyfeed.program.cuts.run_geometry`), Dκ the
window ahead (``window_mm``), the corner cap of the filter a peak's cone (it passes 100 % at
(1 + 100 / rise) half windows), the average half a filter window. With margins of twice that reach
every core sample gets the value advising the whole cut at once gives it, bit for bit, given the
four things that are not local, carried from pass to pass instead:

- the arc length s, summed one segment at a time from the cut start: pass 0 samples the cut piece
  by piece and keeps s at every move end (a per-move array); later pieces start from it;
- the cut's length (u = s / length; the windows' rounding allowance and the filter's symmetric
  ends refer to it): from pass 0;
- Dκ's min–max normalisation over the cut: pass 1 finds the clipped Dκ's range piece by piece;
- the filter's cumulative sums (a weighted average by cumulative sums depends on where the sum
  starts): handed from each piece to the next over the margin;
- corner-mean's guard (its cap is held above the cut's lowest controller output at a curvature
  peak, :func:`fuzzyfeed.fuzzy.filters.corner_cap`): pass 1 keeps κ and Dκ at the peaks, the
  controller gives their outputs once Dκ's range is known.

Pass 2 advises each piece and yields its CSV rows and the pieces its moves are written as, in
move order; nothing holds more than a piece's samples. The refusal of the sample budget
(:data:`fuzzyfeed.geometry.sampling.MAX_POINTS`) stays for one *move* that needs more samples
than the budget (a move is never split between pieces): raise ``--step-mm``.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.fuzzy.advisor import point_sequence_table
from fuzzyfeed.fuzzy.engine import compile_table
from fuzzyfeed.fuzzy.features import features, normalise
from fuzzyfeed.fuzzy.filters import CORNER_RISE_PCT, curvature_peaks, filter_terms
from fuzzyfeed.fuzzy.rules import MACHINE, RuleTable
from fuzzyfeed.fuzzy.windows import forward_bounds, range_max, window_mean
from fuzzyfeed.geometry.sampling import MAX_POINTS
from fuzzyfeed.program.cuts import (DEFAULT_STEP_MM, cut_moves, move_lengths, move_sample_counts,
                                    path_length, run_geometry, sample_moves)
from fuzzyfeed.program.feeds import (DEFAULT_MIN_PIECE_MM, DEFAULT_PROGRAM_FEED_STEP_MM_MIN,
                                     checked_cuts, move_pieces)
from fuzzyfeed.program.model import Program

#: Samples in a piece's core (its margins add a few hundred): bounds the memory of the advice.
DEFAULT_PIECE_POINTS = 100_000
#: Fewest moves in a margin (the three-point estimate at a move end reaches one move).
MIN_MARGIN_MOVES = 3


@dataclass(frozen=True, eq=False)
class AdvicePiece:
    """One piece of a cut's advice: its CSV rows (``columns``, as
    :func:`fuzzyfeed.program.feeds.advice_columns` has them for those samples) and the pieces its
    moves are written as (move, end fraction, feed mm/min)."""

    cut: int
    columns: dict
    piece_move: np.ndarray
    piece_end: np.ndarray
    piece_feed_mm_min: np.ndarray


@dataclass(frozen=True, eq=False)
class CutPiece:
    """One piece of a cut advised in pieces as a pass reads it: its core's first and last vertex
    ``a``, ``b`` and first move sampled ``lo`` (the cut's count), what holds its moves
    (``program``: F, lines, no_split, kind; ``ms.seg_move`` numbers them, ``move0`` + those are
    the cut's moves), its samples ``ms`` and their s, the cut's sample at vertex ``lo`` (``g_lo``)
    and at the next piece's (``nxt``, None for the last)."""

    p: int
    a: int
    b: int
    lo: int
    program: object
    ms: object
    s: np.ndarray
    g_lo: int
    nxt: int | None
    move0: int


@dataclass(frozen=True)
class _Plan:
    cores: np.ndarray     # (P + 1,) move bounds of the cores
    lo: np.ndarray        # (P,) first move sampled (margin)
    hi: np.ndarray        # (P,) one past the last move sampled


def margin_mm(table: RuleTable) -> float:
    """The stretch of path a sample's advice depends on, doubled (``table`` with mm windows)."""
    flat = table.filter_mm / 2
    reach = table.window_mm + flat + flat * (1 + 100.0 / CORNER_RISE_PCT)
    return 2.0 * reach + 1.0


def plan_pieces(lengths: np.ndarray, counts: np.ndarray, piece_points: int, margin: float) -> _Plan:
    """Cores of at least ``piece_points`` samples, ``margin`` mm and :data:`MIN_MARGIN_MOVES`
    moves (the last may be shorter: it is merged into the one before), each sampled with margins of
    at least ``margin`` mm (or to the cut's end) on both sides."""
    n = lengths.size
    cum_len = np.concatenate([[0.0], np.cumsum(lengths)])
    cum_cnt = np.concatenate([[0], np.cumsum(counts)])
    bounds = [0]
    while bounds[-1] < n:
        a = bounds[-1]
        b = max(int(np.searchsorted(cum_cnt, cum_cnt[a] + piece_points, side="left")),
                int(np.searchsorted(cum_len, cum_len[a] + margin, side="left")), a + MIN_MARGIN_MOVES)
        bounds.append(min(b, n))
    if len(bounds) > 2:
        a = bounds[-2]
        if (cum_cnt[n] - cum_cnt[a] < piece_points or cum_len[n] - cum_len[a] < margin
                or n - a < MIN_MARGIN_MOVES):
            del bounds[-2]
    cores = np.array(bounds)
    a, b = cores[:-1], cores[1:]
    lo = np.searchsorted(cum_len, cum_len[a] - margin, side="right") - 1
    lo = np.maximum(np.minimum(lo, a - MIN_MARGIN_MOVES), 0)
    hi = np.searchsorted(cum_len, cum_len[b] + margin, side="left")
    hi = np.minimum(np.maximum(hi, b + MIN_MARGIN_MOVES), n)
    return _Plan(cores=cores, lo=lo, hi=hi)


def cut_arc_lengths(plan: _Plan, n: int, piece) -> np.ndarray:
    """Pass 0 of the advice in pieces: s at every vertex 0..n of the cut (its length at n), summed
    piece after piece. ``piece(p, sv) -> (lo, hi, samples, s)`` samples piece p with s anchored at
    its first vertex whose sample is the whole cut's (``sv`` known there: the pieces' cores follow
    each other)."""
    sv = np.full(n + 1, np.nan)
    sv[0] = 0.0
    for p in range(plan.lo.size):
        a, b = int(plan.cores[p]), int(plan.cores[p + 1])
        lo, _, ms, s = piece(p, sv)
        sv[a + 1:b + 1] = s[ms.vertex_sample[a + 1 - lo:b + 1 - lo]]
    return sv


def stream_program_advice(program: Program, table: RuleTable, *, cuts: list[int] | None = None,
                          step_mm: float = DEFAULT_STEP_MM, cap_mm_min: float | None = None,
                          feed_step_mm_min: float = DEFAULT_PROGRAM_FEED_STEP_MM_MIN,
                          min_piece_mm: float = DEFAULT_MIN_PIECE_MM,
                          piece_points: int = DEFAULT_PIECE_POINTS) -> Iterator[AdvicePiece]:
    """:func:`fuzzyfeed.program.feeds.advise_program` without a machine, piece by piece (see the
    module docstring): the same CSV rows and pieces, in order. The arguments, the cuts' F and the
    table are checked here, at the call; the pieces are made as the iterator is consumed."""
    if isinstance(piece_points, bool) or not isinstance(piece_points, (int, np.integer)) or piece_points < 1:
        raise InputError(f"piece_points = {piece_points!r}; must be an integer >= 1")
    if table.inputs == MACHINE:
        raise InputError(f"rule table {table.name!r} reads the machine's terms: the advice in pieces "
                         "is the plain table's (advise_program takes a machine)")
    chosen = checked_cuts(program, cuts, step_mm, feed_step_mm_min)
    return _cuts(program, chosen, table, step_mm, cap_mm_min, feed_step_mm_min, min_piece_mm, piece_points)


def _cuts(program, chosen, table, step_mm, cap, feed_step, min_piece, piece_points) -> Iterator[AdvicePiece]:
    engine = compile_table(table)
    seq = point_sequence_table(table)
    for k in chosen:
        yield from _advise_cut(program, k, seq, engine, step_mm, cap, feed_step, min_piece, piece_points)


def dk_range(pieces, engine, clip: float, window_mm: float, span, corner: bool):
    """Pass 1 of a cut advised in pieces: the range (lo, hi) of the clipped Dκ (windowed max of κ,
    seed 002 eq. 10) over the pieces' cores and, for corner-mean, the controller's lowest output at
    a curvature peak of the cut (its cap is held above it; None otherwise). ``pieces`` yields
    (a, b, lo, ms, s): the core's first and last vertex, the piece's first vertex, its samples, s."""
    dk_lo, dk_hi = np.inf, -np.inf
    peak_k, peak_raw = [], []
    for a, b, lo, ms, s in pieces:
        raw = range_max(ms.curvature, *forward_bounds(s.size, s=s, length_mm=window_mm, span=span))
        core = slice(int(ms.vertex_sample[a - lo]), int(ms.vertex_sample[b - lo]) + 1)
        c = np.minimum(raw[core], clip)
        dk_lo, dk_hi = min(dk_lo, float(c.min())), max(dk_hi, float(c.max()))
        if corner:
            at = curvature_peaks(ms.curvature)[core]
            peak_k.append(ms.curvature[core][at])
            peak_raw.append(raw[core][at])
    lowest = None
    if corner:
        pk = np.concatenate(peak_k)
        if pk.size:
            lowest = float(engine.feed_pct(pk, normalise(np.concatenate(peak_raw), clip, (dk_lo, dk_hi))).min())
    return dk_lo, dk_hi, lowest


def _advise_cut(program, k, table, engine, step_mm, cap, feed_step, min_piece, piece_points):
    moves, kinds, chord = cut_moves(program, k)
    n = moves.size
    counts = move_sample_counts(program, moves, kinds, chord, step_mm)
    if counts.max() + 1 > MAX_POINTS:
        i = int(np.argmax(counts))
        raise InputError(f"{program.path}:{int(program.move_line[moves[i]]) + 1}: cut {k + 1}: one move "
                         f"sampled every {step_mm:g} mm (--step-mm) needs {counts[i] + 1:.4g} points, more "
                         f"than the budget of {MAX_POINTS:,} (a move is advised whole; raise --step-mm)")
    lengths = move_lengths(program, moves, kinds, chord)
    plan = plan_pieces(lengths, counts, min(int(piece_points), MAX_POINTS), margin_mm(table))
    geo = run_geometry(program, moves, kinds)
    gstart = np.concatenate([[0], np.cumsum(counts)])      # global sample index of every vertex
    n_pieces = plan.lo.size

    def piece(p, sv):
        lo, hi = int(plan.lo[p]), int(plan.hi[p])
        ms = sample_moves(program, moves, kinds, chord, step_mm, lo, hi, geo)
        va = lo + 1 if lo > 0 else 0          # first vertex whose sample is the whole cut's
        s = path_length(ms.xyz, int(ms.vertex_sample[va - lo]), float(sv[va]))
        return lo, hi, ms, s

    sv = cut_arc_lengths(plan, n, piece)      # pass 0
    length = float(sv[-1])
    span = (0.0, length)
    # pass 1: the range of the clipped Dκ over the cut (and κ, Dκ at the curvature peaks)
    clip = table.dk_clip_1_mm
    corner = table.filter == "corner-mean"
    def cores():
        for p in range(n_pieces):
            lo, _, ms, s = piece(p, sv)
            yield int(plan.cores[p]), int(plan.cores[p + 1]), lo, ms, s

    dk_lo, dk_hi, lowest = dk_range(cores(), engine, clip, table.window_mm, span, corner)
    # pass 2: the advice, piece by piece, the filter's cumulative sums handed on
    carry = CarriedSums()
    for p in range(n_pieces):
        a, b = int(plan.cores[p]), int(plan.cores[p + 1])
        lo, hi, ms, s = piece(p, sv)
        nxt = int(gstart[plan.lo[p + 1]]) if p + 1 < n_pieces else None
        yield piece_advice(program, ms, s, a, b, lo, cut=k, table=table, engine=engine, span=span,
                           bounds=(dk_lo, dk_hi), lowest=lowest, carry=carry, g_lo=int(gstart[lo]), nxt=nxt,
                           cap=cap, feed_step=feed_step, min_piece=min_piece)


def piece_advice(program, ms, s: np.ndarray, a: int, b: int, lo: int, *, cut: int, table: RuleTable, engine,
                 span: tuple, bounds: tuple, lowest: float | None, carry: CarriedSums, g_lo: int,
                 nxt: int | None, cap: float | None, feed_step: float, min_piece: float,
                 move0: int = 0) -> AdvicePiece:
    """Pass 2 of a cut advised in pieces, one piece: features (seed 002 eqs. 9–10, Dκ normalised by
    the cut's ``bounds``), the controller, the filter with ``carry``'s sums (the piece's first
    sample is the cut's ``g_lo``, the next piece's ``nxt``), the floor, and the core's CSV rows and
    written pieces (:func:`~fuzzyfeed.program.feeds.move_pieces`). ``program``: what holds the
    moves ``ms.seg_move`` numbers (F, lines, no_split, kind; their ``piece_move`` + ``move0``);
    ``ms``, ``s``: the piece's samples from move ``lo`` and their arc length; ``a``, ``b``: the
    core's first and last vertex; ``cut``: the cut's number (0-based)."""
    clip = table.dk_clip_1_mm
    total = span[1] if span[1] > 0 else 1.0
    feats = features(ms.curvature, table.window_points, clip, s, table.window_mm, span=span, bounds=bounds)
    ctrl = engine.feed_pct(feats.curvature_1_mm, feats.curvature_variation)
    v, wlo, whi, w = filter_terms(ctrl, table.filter, table.filter_points, s, table.filter_mm,
                                  feats.curvature_1_mm, span=span, lowest=lowest)
    c0 = int(ms.vertex_sample[a - lo])    # the core's first sample
    c1 = int(ms.vertex_sample[b - lo])    # ... and last
    smooth = carry.smooth(v, wlo, whi, w, g_lo, c0, c1, nxt)
    pct = np.clip(smooth, table.feed_floor_pct, 100.0)
    r0 = c0 if a == 0 else c0 + 1
    rows = slice(r0, c1 + 1)
    feed = program.feed_mm_min
    sample_move = np.concatenate([[ms.seg_move[0]], ms.seg_move])[rows]
    ceil = feed[sample_move]
    if cap is not None:
        ceil = np.minimum(ceil, cap)
    columns = {"cut": np.full(c1 + 1 - r0, cut + 1), "source_line": program.move_line[sample_move] + 1,
               "u": s[rows] / total, "x_mm": ms.xyz[rows, 0], "y_mm": ms.xyz[rows, 1],
               "z_mm": ms.xyz[rows, 2], "s_mm": s[rows], "curvature_1_mm": ms.curvature[rows],
               "curvature_window_max_1_mm": feats.window_max_1_mm[rows],
               "curvature_variation": feats.curvature_variation[rows],
               "feed_pct_controller": ctrl[rows], "feed_pct": pct[rows],
               "programmed_feed_mm_min": ceil, "feed_mm_min": pct[rows] / 100.0 * ceil}
    segs = slice(c0, c1)
    seg_move, seg_phi, ceiling_seg = segment_ceilings(program, ms, pct, segs, cap)
    pm, pe, pf = move_pieces(program, seg_move, ms.seg_f1[segs], np.diff(s)[segs], seg_phi, ceiling_seg,
                             ceiling_seg, feed_step, min_piece)
    return AdvicePiece(cut=cut, columns=columns, piece_move=pm + move0, piece_end=pe, piece_feed_mm_min=pf)


class CarriedSums:
    """The filter's cumulative sums (weights, weighted values) of the whole cut, handed from one
    piece to the next over its margin: a weighted average by cumulative sums depends on where the
    sum starts, so every piece sums on from the whole cut's value at its core's first sample."""

    def __init__(self) -> None:
        self.g0, self.cw, self.cv = 0, np.zeros(1), np.zeros(1)

    def smooth(self, v, wlo, whi, w, g_lo: int, c0: int, c1: int, nxt: int | None) -> np.ndarray:
        """The filtered values of a piece (:func:`~fuzzyfeed.fuzzy.filters.filter_terms`'s
        ``v, wlo, whi, w``; the plain values when ``wlo`` is None) whose first sample is the cut's
        sample ``g_lo``, core samples ``c0..c1``; ``nxt``: the next piece's first sample (None: last)."""
        if wlo is None:
            return v.copy()
        head = slice(g_lo - self.g0, g_lo - self.g0 + c0 + 1)
        cw = np.empty(v.size + 1)
        cv = np.empty(v.size + 1)
        cw[:c0 + 1] = self.cw[head]
        cv[:c0 + 1] = self.cv[head]
        cw[c0:] = np.cumsum(np.concatenate([[cw[c0]], w[c0:]]))
        cv[c0:] = np.cumsum(np.concatenate([[cv[c0]], w[c0:] * v[c0:]]))
        smooth = window_mean(v, wlo, whi, w, sums=(cw, cv))
        if nxt is not None:             # hand on the sums the next piece's margin needs
            self.g0 = nxt
            self.cw = cw[nxt - g_lo:c1 + 1].copy()
            self.cv = cv[nxt - g_lo:c1 + 1].copy()
        return smooth



def segment_ceilings(program, ms, pct: np.ndarray, segs: slice, cap: float | None):
    """Per sampling segment of ``segs``: its program move, the advised fraction (the lower of its
    two samples' ``pct`` / 100, so no point of the segment runs above its advice) and the feed
    ceiling (the move's F, capped at ``cap``), for :func:`~fuzzyfeed.program.feeds.move_pieces`."""
    phi = pct / 100.0
    seg_move = ms.seg_move[segs]
    ceiling_seg = program.feed_mm_min[seg_move]
    if cap is not None:
        ceiling_seg = np.minimum(ceiling_seg, cap)
    return seg_move, np.minimum(phi[:-1], phi[1:])[segs], ceiling_seg

def concat_pieces(pieces: list[AdvicePiece]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pieces' (move, end, feed) arrays end to end (per move: a program's worth is small)."""
    if not pieces:
        return np.zeros(0, int), np.zeros(0), np.zeros(0)
    return (np.concatenate([p.piece_move for p in pieces]), np.concatenate([p.piece_end for p in pieces]),
            np.concatenate([p.piece_feed_mm_min for p in pieces]))

