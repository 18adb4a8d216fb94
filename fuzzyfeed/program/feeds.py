"""Advised feeds for a whole program: the fuzzy advice per cut, applied under the program's own F.

For every cut (:mod:`fuzzyfeed.program.model`) the advisor (seed 002) runs on the cut's exact
geometry (:func:`fuzzyfeed.program.cuts.sample_cut`) and gives a fraction φ = feed % / 100 at every
sample. The feed of a segment between two samples is min(φ_i, φ_i+1) × F, with F the feed the
program has at that move (its ceiling, also for plunges and ramps), capped by ``cap_mm_min`` if
given; it is rounded *down* to a multiple of ``feed_step_mm_min`` (one step is the floor, but
never above F). A move is split only where that rounded feed changes inside it, into pieces of at
least ``min_piece_mm`` (a short slow stretch grows into its faster neighbours, a short fast one takes
its slower neighbour's feed: no feed is ever raised); a
move shorter than 2 × ``min_piece_mm``, a G5.2 block, a move whose line also stops the program
(M0/M1/M2/M30/M60) and a multi-turn arc keep one feed, the slowest over the move. Moves outside cuts (rapids, cycles, moves from unknown positions,
G93/G95 moves) keep their programmed feed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.program.cuts import DEFAULT_STEP_MM, CutSamples, sample_cut
from fuzzyfeed.errors import InputError, PathFormatError
from fuzzyfeed.fuzzy.advisor import FuzzyAdvice, advise_details
from fuzzyfeed.fuzzy.engine import compile_table
from fuzzyfeed.fuzzy.rules import MACHINE, RuleTable
from fuzzyfeed.machine.description import Machine
from fuzzyfeed.program.model import NO_FEED_RULE, NURBS, Program

#: Default feed quantisation for programs (mm/min).
DEFAULT_PROGRAM_FEED_STEP_MM_MIN = 10.0
#: Shortest piece a move is split into (mm): a shorter stretch takes the slower neighbour's feed,
#: and a move shorter than twice this keeps one feed (the slowest over it).
DEFAULT_MIN_PIECE_MM = 1.0


@dataclass(frozen=True, eq=False)
class ProgramAdvice:
    """Advice for a program: per advised cut its samples and fuzzy advice, and the pieces every
    advised move is written as (move, end fraction, feed mm/min), in move order."""

    program: Program
    cuts: tuple[CutSamples, ...]
    advice: tuple[FuzzyAdvice, ...]
    ceiling_mm_min: tuple[np.ndarray, ...]   # per cut, per sample: the F the fraction applies to
    piece_move: np.ndarray
    piece_end: np.ndarray
    piece_feed_mm_min: np.ndarray
    feed_step_mm_min: float
    cap_mm_min: float | None
    table: RuleTable

    def fraction(self, i: int) -> np.ndarray:
        return self.advice[i].feed_pct / 100.0


def quantise_down(feed_mm_min: np.ndarray, step: float, ceiling: np.ndarray) -> np.ndarray:
    """Round down to a multiple of ``step``, at least one step, never above ``ceiling``."""
    q = np.floor(feed_mm_min / step + 1e-9) * step
    q = np.maximum(q, step)
    return np.minimum(q, ceiling)


def checked_cuts(program: Program, cuts: list[int] | None, step_mm: float,
                 feed_step_mm_min: float) -> list[int]:
    """The cuts to advise (all when ``cuts`` is None), after checking the sampling step, the feed
    step and that every move of those cuts has an F > 0 (one line naming the first that has none)."""
    if not (np.isfinite(step_mm) and step_mm > 0):
        raise InputError(f"step_mm = {step_mm!r}; the sampling step must be finite and > 0")
    if not (np.isfinite(feed_step_mm_min) and feed_step_mm_min > 0):
        raise InputError(f"feed_step_mm_min = {feed_step_mm_min!r}; must be finite and > 0")
    if program.n_cuts == 0:
        raise PathFormatError(f"{program.path}: no feed move (G1, G2/G3 or G5.2) in G94 found; "
                              "nothing to advise")
    chosen = list(range(program.n_cuts)) if cuts is None else list(cuts)
    feed = program.feed_mm_min
    for k in chosen:
        moves = program.cut_moves(k)
        bad = ~(feed[moves] > 0)
        if bad.any():
            line = int(program.move_line[moves[np.argmax(bad)]]) + 1
            raise PathFormatError(f"{program.path}:{line}: {NO_FEED_RULE}")
    return chosen


def advise_program(program: Program, table: RuleTable, *, cuts: list[int] | None = None,
                   step_mm: float = DEFAULT_STEP_MM, cap_mm_min: float | None = None,
                   feed_step_mm_min: float = DEFAULT_PROGRAM_FEED_STEP_MM_MIN,
                   min_piece_mm: float = DEFAULT_MIN_PIECE_MM, machine: Machine | None = None) -> ProgramAdvice:
    """Advise the cuts ``cuts`` (default: all) of ``program`` (see the module docstring). A machine
    table reads the ``machine``'s inputs at every sample, with the program's F there as the feed
    its ratios refer to and the cut's exact junction angles and corners."""
    chosen = checked_cuts(program, cuts, step_mm, feed_step_mm_min)
    engine = compile_table(table)
    feed = program.feed_mm_min
    cut_samples, advices, ceilings = [], [], []
    pm, pe, pf = [], [], []
    for k in chosen:
        cs = sample_cut(program, k, step_mm)
        ceil_sample = feed[cs.sample_move]
        if cap_mm_min is not None:
            ceil_sample = np.minimum(ceil_sample, cap_mm_min)
        if table.inputs == MACHINE:
            # the feed the machine can run here: F, or less where the axes cannot reach F along the
            # path (an F far above the machine is the machine's speed, not a thousandfold margin)
            reach_mm_min = 60.0 * machine.move_velocity(cs.samples.tangent)
            ceil_sample = ceil_mm_min = np.minimum(ceil_sample, reach_mm_min)
            adv = advise_details(cs.samples, table, 100.0, engine=engine, machine=machine,
                                 ceiling_mm_s=ceil_mm_min / 60.0, turn_angle=cs.turn_angle,
                                 corner=cs.corner, entry_direction=cs.entry_direction)
        else:
            adv = advise_details(cs.samples, table, 100.0, engine=engine)
        phi = adv.feed_pct / 100.0
        ceiling_seg = feed[cs.seg_move]
        if cap_mm_min is not None:
            ceiling_seg = np.minimum(ceiling_seg, cap_mm_min)
        seg_phi = np.minimum(phi[:-1], phi[1:])
        reachable_seg = ceiling_seg
        if table.inputs == MACHINE:
            # a fraction of the feed the machine can run along the segment (below its own F only
            # where the axes cannot reach F); 100 % keeps the program's F
            reachable_seg = np.minimum(ceiling_seg, 60.0 * machine.speed_along(cs.samples.xyz))
        p_move, p_end, p_feed = move_pieces(program, cs.seg_move, cs.seg_f1, np.diff(cs.samples.s), seg_phi,
                                            ceiling_seg, reachable_seg, feed_step_mm_min, min_piece_mm)
        pm.append(p_move)
        pe.append(p_end)
        pf.append(p_feed)
        cut_samples.append(cs)
        advices.append(adv)
        ceilings.append(ceil_sample)
    return ProgramAdvice(program=program, cuts=tuple(cut_samples), advice=tuple(advices),
                         ceiling_mm_min=tuple(ceilings), piece_move=np.concatenate(pm),
                         piece_end=np.concatenate(pe), piece_feed_mm_min=np.concatenate(pf),
                         feed_step_mm_min=feed_step_mm_min, cap_mm_min=cap_mm_min, table=table)


def move_pieces(program: Program, seg_move: np.ndarray, seg_f1: np.ndarray, seg_len: np.ndarray,
                seg_phi: np.ndarray, ceiling_seg: np.ndarray, reachable_seg: np.ndarray,
                feed_step_mm_min: float, min_piece_mm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pieces (move, end fraction, feed mm/min) of whole moves from their segments' fractions
    ``seg_phi`` of ``reachable_seg`` under ``ceiling_seg`` (see the module docstring)."""
    q = quantise_down(np.where(seg_phi >= 1.0, ceiling_seg, seg_phi * reachable_seg), feed_step_mm_min,
                      ceiling_seg)
    # one feed per move where it may not be split: the slowest over the move
    new_move = np.ones(q.size, bool)
    new_move[1:] = seg_move[1:] != seg_move[:-1]
    first = np.flatnonzero(new_move)
    move_len = np.add.reduceat(seg_len, first)
    move_min = np.minimum.reduceat(q, first)
    grp = np.cumsum(new_move) - 1
    whole = (program.no_split[seg_move] | (program.kind[seg_move] == NURBS)
             | (move_len[grp] < 2 * min_piece_mm))
    if program.comp_unknown is not None:   # LinuxCNC's compensation rules need the move whole
        whole |= program.comp_unknown[seg_move]
    q = np.where(whole, move_min[grp], q)
    q = hold_min_length(q, seg_len, first, min_piece_mm)
    change = new_move.copy()
    change[1:] |= q[1:] != q[:-1]
    last = np.append(change[1:], True)          # last segment of each piece
    p_end = np.where(np.append(new_move[1:], True)[last], 1.0, seg_f1[last])
    return seg_move[last], p_end, q[last]


def hold_min_length(q: np.ndarray, seg_len: np.ndarray, move_first: np.ndarray, min_len: float) -> np.ndarray:
    """Per segment feeds ``q`` with every run of equal feed inside a move at least ``min_len`` long
    (``move_first``: the first segment of each move), never raising a feed: a short run slower than
    its neighbours grows into the faster one(s) segment by segment; a short run faster than a
    neighbour drops to the nearest slower neighbour's feed."""
    q = q.copy()
    bounds = np.append(move_first, q.size)
    for a, b in zip(bounds[:-1], bounds[1:]):
        if b - a < 2 or (q[a:b] == q[a]).all():
            continue
        seg = q[a:b]
        lens = seg_len[a:b]
        for _ in range(b - a):
            starts = np.flatnonzero(np.concatenate([[True], seg[1:] != seg[:-1]]))
            if starts.size < 2:
                break
            ends = np.append(starts[1:], seg.size)
            run_len = np.add.reduceat(lens, starts)
            short = np.flatnonzero(run_len < min_len - 1e-9)
            if short.size == 0:
                break
            r = int(short[np.argmin(run_len[short])])
            s0, s1 = starts[r], ends[r]
            sides = [v for v in ((seg[s0 - 1], s0 - 1) if s0 > 0 else None,
                                 (seg[s1], s1) if s1 < seg.size else None) if v is not None]
            slower = [f for f, _ in sides if f < seg[s0]]
            if slower:
                # short and faster than a neighbour: it takes the nearest slower neighbour's feed
                seg[s0:s1] = max(slower)
            else:
                # short and slowest: it grows by one segment into its faster neighbour
                _, at = max(sides)
                seg[at] = seg[s0]
        q[a:b] = seg
    return q


def advice_columns(pa: ProgramAdvice) -> dict[str, np.ndarray]:
    """CSV columns of a program's advice: one row per sample of every advised cut, with the cut
    number (1-based) and the source line (1-based) of the move each sample lies on."""
    cols: dict[str, list] = {}
    for cs, adv, ceil in zip(pa.cuts, pa.advice, pa.ceiling_mm_min):
        n = len(cs.samples)
        part = {"cut": np.full(n, cs.cut + 1),
                "source_line": pa.program.move_line[cs.sample_move] + 1}
        part.update(cs.samples.columns())
        part.update(adv.term_columns(ceil))
        part["feed_pct"] = adv.feed_pct
        part["programmed_feed_mm_min"] = ceil
        part["feed_mm_min"] = adv.feed_pct / 100.0 * ceil
        for key, value in part.items():
            cols.setdefault(key, []).append(np.asarray(value))
    return {key: np.concatenate(parts) for key, parts in cols.items()}


def program_times(pa: ProgramAdvice) -> tuple[float, float]:
    """Time (s) of the advised cuts' feed moves at the programmed feeds and at the written
    (advised, rounded) feeds, ignoring acceleration."""
    return pieces_times(pa.program, pa.piece_move, pa.piece_end, pa.piece_feed_mm_min)


def pieces_times(program: Program, piece_move: np.ndarray, piece_end: np.ndarray,
                 piece_feed_mm_min: np.ndarray) -> tuple[float, float]:
    """:func:`program_times` from the pieces alone."""
    lengths = program.move_lengths()
    moves = np.unique(piece_move)
    t_prog = float(np.sum(lengths[moves] / program.feed_mm_min[moves])) * 60.0
    starts = np.concatenate([[0.0], piece_end[:-1]])
    same = np.concatenate([[False], piece_move[1:] == piece_move[:-1]])
    starts = np.where(same, starts, 0.0)
    frac = piece_end - starts
    t_adv = float(np.sum(lengths[piece_move] * frac / piece_feed_mm_min)) * 60.0
    return t_prog, t_adv
