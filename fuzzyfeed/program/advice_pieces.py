"""A program's advice as the pieces its moves are written as, and its CSV rows as they stream.

:func:`advised_feeds` advises a program's cuts once: in pieces where the table allows it
(:func:`~fuzzyfeed.program.stream.stream_program_advice`,
:func:`~fuzzyfeed.program.stream_machine.stream_machine_advice`: bit for bit the whole cuts'
advice), else whole (:func:`~fuzzyfeed.program.feeds.advise_program`). It keeps the pieces' feeds
(per move: move, end fraction, feed) and hands every piece's CSV rows to a ``sink`` as they are
made (``advise --machine -o``: the CSV written while the advice runs, the advice run once). The
rows of a small advice (up to :data:`KEEP_ROWS` samples) are kept; larger ones are made again,
piece by piece, only when asked for after the advice (:meth:`AdvisedFeeds.pieces`).
:func:`applied_columns` adds the ``advised`` column: where the advice is applied.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.fuzzy.rules import MACHINE, RuleTable
from fuzzyfeed.machine.description import Machine
from fuzzyfeed.program.feeds import advice_columns, advise_program
from fuzzyfeed.program.model import Program

#: Samples of the advice whose CSV rows are kept from the advice (~0.1 KB a sample); more are made
#: again, piece by piece, when they are asked for after the advice.
KEEP_ROWS = 200_000


@dataclass(frozen=True, eq=False)
class AdvisedFeeds:
    """The advice of a program's cuts as the pieces its moves are written as (move, end fraction,
    feed mm/min, in move order); the per-sample CSV rows are made again piece by piece when asked
    (:meth:`pieces`: the advice in pieces, bit for bit the whole cuts' advice), never held for a
    whole program."""

    piece_move: np.ndarray
    piece_end: np.ndarray
    piece_feed_mm_min: np.ndarray
    remake: object            # () -> iterator of column dicts, in sample order

    def pieces(self):
        return self.remake()


def applied_columns(cols: dict, advised_cuts) -> dict:
    """A piece's CSV columns (:func:`~fuzzyfeed.program.feeds.advice_columns`) plus ``advised``:
    1 on the cuts (0-based) in ``advised_cuts``; on the others feed_pct is 100 and feed_mm_min
    the programmed F."""
    cols = dict(cols)
    applied = np.isin(cols["cut"] - 1, list(advised_cuts))
    cols["feed_pct"] = np.where(applied, cols["feed_pct"], 100.0)
    cols["feed_mm_min"] = np.where(applied, cols["feed_mm_min"], cols["programmed_feed_mm_min"])
    cols["advised"] = applied.astype(np.int64)
    return cols


def advised_feeds(program: Program, table: RuleTable, machine: Machine, cuts: list[int], *,
                  cap_mm_min, step_mm: float, feed_step_mm_min: float, min_piece_mm: float,
                  sink=None) -> AdvisedFeeds:
    """The advice of ``cuts`` for ``machine``: in pieces (a machine table with a filter in mm or none,
    or a plain table), else the whole cuts' (:func:`~fuzzyfeed.program.feeds.advise_program`).
    ``sink(columns)`` is called with each piece's CSV columns as the advice makes them, in sample
    order (the advice runs once for the pieces and the rows)."""
    from fuzzyfeed.program.stream import concat_pieces, stream_program_advice
    from fuzzyfeed.program.stream_machine import stream_machine_advice, streams

    kw = dict(cuts=cuts, cap_mm_min=cap_mm_min, step_mm=step_mm, feed_step_mm_min=feed_step_mm_min,
              min_piece_mm=min_piece_mm)
    geometry: dict = {}            # the cuts' G1-run fits, made once for the advice and its CSV rows
    if table.inputs == MACHINE and streams(table):

        def stream():
            return stream_machine_advice(program, table, machine, geometry=geometry, **kw)
    elif table.inputs != MACHINE:
        def stream():
            return stream_program_advice(program, table, **kw)
    else:
        pa = advise_program(program, table, machine=machine, **kw)
        columns = advice_columns(pa)
        if sink is not None:
            sink(columns)
        return AdvisedFeeds(pa.piece_move, pa.piece_end, pa.piece_feed_mm_min, lambda: iter([columns]))
    first = stream()      # arguments checked here
    kept: list | None = []
    rows = 0
    pieces = []
    for p in first:       # the rows kept up to KEEP_ROWS samples (then made again when asked)
        if sink is not None:
            sink(p.columns)
        rows += len(p.columns["s_mm"])
        if kept is not None and rows <= KEEP_ROWS:
            kept.append(p.columns)
        else:
            kept = None
        pieces.append((p.piece_move, p.piece_end, p.piece_feed_mm_min))
    pm, pe, pf = (np.concatenate(c) for c in zip(*pieces)) if pieces else concat_pieces([])
    if sink is not None:
        geometry.clear()  # the rows were taken: the fits are made again only if they are asked again
    if kept is not None:
        return AdvisedFeeds(pm, pe, pf, lambda: iter(kept))
    return AdvisedFeeds(pm, pe, pf, lambda: (p.columns for p in stream()))
