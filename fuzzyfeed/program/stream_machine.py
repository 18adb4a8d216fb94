"""A machine table's advice of a program in pieces: memory bounded by a piece, not by a cut.

The machine inputs of a sample (:func:`fuzzyfeed.fuzzy.machine_inputs.machine_features`) reach a
bounded stretch of path, as the plain advice's features do (:mod:`fuzzyfeed.program.stream`): the
safe feed of a curve is the sample's own, a junction's is measured over a few tolerances either
side (:func:`~fuzzyfeed.machine.safe_feed.junction_safe_feed`), the cut's entry over the rapid's
braking lag a·τ²; the settling minimum reaches v·t_settle + margin, v at most the fastest feed of
the cut; the filter as the plain advice's. Pieces of whole moves sampled with margins of twice
that reach give every core sample the whole cut's value, bit for bit, given what is not local,
carried from pass to pass:

- s at every move end and the cut's length (pass 0, as the plain advice);
- the settling minimum's speed levels: geometric between the cut's slowest hot spot and the
  fastest feed around a hot spot (pass 1, :func:`~fuzzyfeed.fuzzy.machine_inputs.settling_min`'s
  ``levels``);
- the entry's safe feed, on the first piece only (its samples reach past the braking lag);
- corner-mean's guard (the controller's lowest output at a curvature peak, pass 1b) and the
  filter's cumulative sums (:class:`~fuzzyfeed.program.stream.CarriedSums`).

Pass 2 advises each piece and yields its CSV rows (the columns of
:func:`fuzzyfeed.program.feeds.advice_columns` for a machine table) and the pieces its moves are
written as, in move order. A table whose filter window counts points (no ``filter_mm``) is advised
whole (:func:`fuzzyfeed.program.feeds.advise_program`, under the sample budget).
"""

from __future__ import annotations

from collections.abc import Iterator
from types import SimpleNamespace

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.fuzzy.engine import compile_table
from fuzzyfeed.fuzzy.filters import CORNER_RISE_PCT, curvature_peaks, filter_terms
from fuzzyfeed.fuzzy.machine_inputs import (NEAR_MARGIN_MM, RATIO_TOP, entry_safe_feed, hot_spots,
                                            settling_min)
from fuzzyfeed.fuzzy.rules import MACHINE, RuleTable
from fuzzyfeed.geometry.sampling import MAX_POINTS
from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.safe_feed import (CORNER_SCALE_TOLERANCES, RUN_SCALE_TOLERANCES, curve_safe_feed,
                                         junction_safe_feed, settle_time_s)
from fuzzyfeed.program.cuts import (DEFAULT_STEP_MM, _entry_direction, cut_moves, move_lengths,
                                    move_sample_counts, path_length, run_geometry, sample_moves,
                                    sample_tangents)
from fuzzyfeed.program.feeds import (DEFAULT_MIN_PIECE_MM, DEFAULT_PROGRAM_FEED_STEP_MM_MIN,
                                     checked_cuts, move_pieces)
from fuzzyfeed.program.model import Program
from fuzzyfeed.program.stream import (DEFAULT_PIECE_POINTS, AdvicePiece, CarriedSums, CutPiece, cut_arc_lengths,
                                      plan_pieces, segment_ceilings)


def streams(table: RuleTable) -> bool:
    """Whether a machine ``table`` is advised in pieces (its filter is none or counts mm)."""
    return table.filter == "none" or table.filter_mm is not None


def machine_margin_mm(table: RuleTable, machine: Machine, top_feed_mm_s: float) -> float:
    """Twice the stretch of path a sample's machine advice depends on (+1 mm), the fastest feed of
    the cut ``top_feed_mm_s`` bounding the settling reach."""
    tol = machine.contour_tol_mm
    tau = machine.servo.time_constant_s
    inputs = max(top_feed_mm_s * settle_time_s(machine) + NEAR_MARGIN_MM,
                 max(CORNER_SCALE_TOLERANCES, RUN_SCALE_TOLERANCES) * tol,
                 machine.tangential_acc_mm_s2 * tau * tau, tol)
    flat = (table.filter_mm or 0.0) / 2
    filt = 0.0 if table.filter == "none" else flat + flat * (1 + 100.0 / CORNER_RISE_PCT)
    return 2.0 * (inputs + filt) + 1.0


def cut_margin_mm(table: RuleTable, machine: Machine, top_f_mm_min: float, cap: float | None) -> float:
    """:func:`machine_margin_mm` of a cut whose largest F is ``top_f_mm_min``: its fastest ceiling
    is that F capped at ``cap``, at most what the axes reach along a direction (min over axes of
    v_i / |u_i| <= sqrt(3) max v_i for a unit u)."""
    top = min(top_f_mm_min, cap if cap is not None else np.inf,
              60.0 * np.sqrt(3.0) * float(np.max(machine.axis_vel_mm_s)))
    return machine_margin_mm(table, machine, top / 60.0)


def stream_machine_advice(program: Program, table: RuleTable, machine: Machine, *,
                          cuts: list[int] | None = None, step_mm: float = DEFAULT_STEP_MM,
                          cap_mm_min: float | None = None,
                          feed_step_mm_min: float = DEFAULT_PROGRAM_FEED_STEP_MM_MIN,
                          min_piece_mm: float = DEFAULT_MIN_PIECE_MM,
                          piece_points: int = DEFAULT_PIECE_POINTS,
                          geometry: dict | None = None, entries: dict | None = None) -> Iterator[AdvicePiece]:
    """:func:`fuzzyfeed.program.feeds.advise_program` with a machine table, piece by piece (module
    docstring): the same CSV rows and pieces, in order. Arguments and the cuts' F are checked at the
    call; the pieces are made as the iterator is consumed. ``geometry``: a dict kept between runs
    of the same advice, cut -> its :func:`~fuzzyfeed.program.cuts.run_geometry` (17 bytes a move;
    its fit runs window by window, :data:`~fuzzyfeed.geometry.polyline.WINDOW_VERTICES`).
    ``entries``: cut -> the direction of the rapid leading into it, for cuts whose rapid lies
    before ``program``'s first move (a window of lines: :mod:`fuzzyfeed.program.machine_windows`);
    the others' is read from ``program``."""
    if isinstance(piece_points, bool) or not isinstance(piece_points, (int, np.integer)) or piece_points < 1:
        raise InputError(f"piece_points = {piece_points!r}; must be an integer >= 1")
    if table.inputs != MACHINE:
        raise InputError(f"rule table {table.name!r} reads κ and Dκ: its advice in pieces is "
                         "fuzzyfeed.program.stream's")
    if not streams(table):
        raise InputError(f"rule table {table.name!r}: filter {table.filter!r} over filter_points has no "
                         "filter_mm; the advice in pieces needs a window in mm")
    chosen = checked_cuts(program, cuts, step_mm, feed_step_mm_min)
    engine = compile_table(table)
    return (piece for k in chosen for piece in _advise_cut(program, k, table, machine, engine, step_mm,
                                                           cap_mm_min, feed_step_mm_min, min_piece_mm,
                                                           int(piece_points), geometry,
                                                           None if entries is None else entries.get(k)))


def _advise_cut(program, k, table, machine, engine, step_mm, cap, feed_step, min_piece, piece_points, cache,
                entry_given=None):
    moves, kinds, chord = cut_moves(program, k)
    n = moves.size
    counts = move_sample_counts(program, moves, kinds, chord, step_mm)
    if counts.max() + 1 > MAX_POINTS:
        i = int(np.argmax(counts))
        raise InputError(f"{program.path}:{int(program.move_line[moves[i]]) + 1}: cut {k + 1}: one move "
                         f"sampled every {step_mm:g} mm (--step-mm) needs {counts[i] + 1:.4g} points, more "
                         f"than the budget of {MAX_POINTS:,} (a move is advised whole; raise --step-mm)")
    lengths = move_lengths(program, moves, kinds, chord)
    margin = cut_margin_mm(table, machine, float(program.feed_mm_min[moves].max()), cap)
    plan = plan_pieces(lengths, counts, min(piece_points, MAX_POINTS), margin)
    geo = cache.get(k) if cache is not None else None
    if geo is None:
        geo = run_geometry(program, moves, kinds)
        if cache is not None:
            cache[k] = geo
    gstart = np.concatenate([[0], np.cumsum(counts)])
    n_pieces = plan.lo.size
    entry = _entry_direction(program, int(moves[0])) if entry_given is None else entry_given

    def piece(p, sv):
        lo, hi = int(plan.lo[p]), int(plan.hi[p])
        ms = sample_moves(program, moves, kinds, chord, step_mm, lo, hi, geo)
        va = lo + 1 if lo > 0 else 0
        s = path_length(ms.xyz, int(ms.vertex_sample[va - lo]), float(sv[va]))
        return lo, hi, ms, s

    sv = cut_arc_lengths(plan, n, piece)      # pass 0: s at every vertex (the cut's length)

    def pieces():
        for p in range(n_pieces):
            lo, _, ms, s = piece(p, sv)
            nxt = int(gstart[plan.lo[p + 1]]) if p + 1 < n_pieces else None
            yield CutPiece(p, int(plan.cores[p]), int(plan.cores[p + 1]), lo, program, ms, s, int(gstart[lo]), nxt, 0)

    yield from machine_cut_advice(pieces, n_pieces, float(sv[-1]), k, table, machine, engine, entry, cap, feed_step,
                                  min_piece)


def machine_cut_advice(pieces, n_pieces: int, length: float, k: int, table, machine, engine, entry, cap, feed_step,
                       min_piece) -> Iterator[AdvicePiece]:
    """Passes 1, 1b and 2 (module docstring) of cut ``k`` (0-based, the number its rows get) of
    ``length`` mm in ``n_pieces`` pieces: ``pieces()`` gives a pass over them
    (:class:`~fuzzyfeed.program.stream.CutPiece`, s already carried by pass 0), ``entry`` the
    direction of the rapid leading into the cut."""
    settle = settle_time_s(machine)

    def safe(pc):
        """Ceiling (mm/min, per sample: F capped, and the machine's reach along the path), safe feed
        (mm/s) and the reach (mm/s) along the segment leaving each sample (the last: the one arriving),
        which is :meth:`~fuzzyfeed.machine.description.Machine.speed_along` of each segment, the same floats."""
        ms, s = pc.ms, pc.s
        sample_move = np.concatenate([[ms.seg_move[0]], ms.seg_move])
        ceil = pc.program.feed_mm_min[sample_move]
        if cap is not None:
            ceil = np.minimum(ceil, cap)
        reach = machine.move_velocity(sample_tangents(ms.xyz))
        ceil = np.minimum(ceil, 60.0 * reach)
        ceiling = ceil / 60.0
        if not (np.isfinite(ceiling) & (ceiling > 0)).all():
            raise InputError(f"ceiling_mm_s: needs one finite feed > 0 per sample ({ceiling.size})")
        v_curve = curve_safe_feed(machine, np.where(ms.corner, 0.0, ms.curvature))
        v_safe = np.minimum(v_curve, junction_safe_feed(machine, ms.turn_angle, ms.xyz, s))
        if pc.lo == 0:     # the cut's entry: its samples reach past the rapid's braking lag
            v_safe[0] = min(v_safe[0], entry_safe_feed(SimpleNamespace(s=s, xyz=ms.xyz), entry, machine))
        return sample_move, ceil, ceiling, v_safe, reach

    def controller(v_safe, s, ceiling, levels):
        near = settling_min(v_safe, s, settle, ceiling, levels=levels, span=span)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.nan_to_num(np.clip(v_safe / ceiling, 0.0, RATIO_TOP), nan=RATIO_TOP, posinf=RATIO_TOP)
            near_r = np.nan_to_num(np.clip(near / ceiling, 0.0, RATIO_TOP), nan=RATIO_TOP, posinf=RATIO_TOP)
        return ratio, near_r, engine.feed_pct(ratio, near_r)

    def core_of(pc):
        return slice(int(pc.ms.vertex_sample[pc.a - pc.lo]), int(pc.ms.vertex_sample[pc.b - pc.lo]) + 1)

    def pass2(levels, lowest):
        return _pass2(pieces(), k, table, machine, safe, controller, cap, feed_step, min_piece, span, total,
                      levels, lowest)

    span = (0.0, length)
    total = length if length > 0 else 1.0
    if n_pieces == 1:        # the cut in one piece: its own levels and guard are the cut's
        yield from pass2(None, None)
        return
    # pass 1: the settling levels (slowest hot spot, fastest feed around a hot spot) over the cut
    lo_v, hi_v = np.inf, -np.inf
    for pc in pieces():
        _, _, ceiling, v_safe, _ = safe(pc)
        hot, around = hot_spots(v_safe, ceiling)
        core = core_of(pc)
        h = hot[core]
        if h.any():
            lo_v = min(lo_v, float(v_safe[core][h].min()))
            hi_v = max(hi_v, float(around[core][h].max()))
    levels = (lo_v, hi_v) if np.isfinite(lo_v) else None
    # pass 1b (corner-mean): the controller's lowest output at a curvature peak of the cut
    lowest = None
    if table.filter == "corner-mean":
        found = []
        for pc in pieces():
            _, _, ceiling, v_safe, _ = safe(pc)
            raw = controller(v_safe, pc.s, ceiling, levels)[2]
            core = core_of(pc)
            at = curvature_peaks(pc.ms.curvature)[core]
            found.append(raw[core][at])
        pk = np.concatenate(found)
        lowest = float(pk.min()) if pk.size else None
    yield from pass2(levels, lowest)


def _pass2(pieces, k, table, machine, safe, controller, cap, feed_step, min_piece, span, total, levels, lowest):
    """The advice of every piece of cut ``k`` given what the passes before carried."""
    carry = CarriedSums()
    for pc in pieces:
        program, ms, s, a, b, lo = pc.program, pc.ms, pc.s, pc.a, pc.b, pc.lo
        sample_move, ceil, ceiling, v_safe, reach = safe(pc)
        ratio, near_r, raw = controller(v_safe, s, ceiling, levels)
        v, wlo, whi, w = filter_terms(raw, table.filter, table.filter_points, s, table.filter_mm, ms.curvature,
                                      span=span, lowest=lowest)
        c0, c1 = int(ms.vertex_sample[a - lo]), int(ms.vertex_sample[b - lo])
        pct = np.clip(carry.smooth(v, wlo, whi, w, pc.g_lo, c0, c1, pc.nxt), table.feed_floor_pct, 100.0)
        r0 = c0 if a == 0 else c0 + 1
        rows = slice(r0, c1 + 1)
        ce = ceil[rows]
        columns = {"cut": np.full(c1 + 1 - r0, k + 1), "source_line": program.move_line[sample_move[rows]] + 1,
                   "u": s[rows] / total, "x_mm": ms.xyz[rows, 0], "y_mm": ms.xyz[rows, 1],
                   "z_mm": ms.xyz[rows, 2], "s_mm": s[rows], "curvature_1_mm": ms.curvature[rows],
                   "safe_feed_mm_min": np.minimum(v_safe[rows] * 60.0, ce), "safe_feed_ratio": ratio[rows],
                   "safe_feed_ratio_near": near_r[rows], "feed_pct_controller": raw[rows],
                   "feed_pct": pct[rows], "programmed_feed_mm_min": ce, "feed_mm_min": pct[rows] / 100.0 * ce}
        segs = slice(c0, c1)
        seg_move, seg_phi, ceiling_seg = segment_ceilings(program, ms, pct, segs, cap)
        reachable = np.minimum(ceiling_seg, 60.0 * reach[segs])
        pm, pe, pf = move_pieces(program, seg_move, ms.seg_f1[segs], np.diff(s)[segs], seg_phi, ceiling_seg,
                                 reachable, feed_step, min_piece)
        yield AdvicePiece(cut=k, columns=columns, piece_move=pm + pc.move0, piece_end=pe, piece_feed_mm_min=pf)
