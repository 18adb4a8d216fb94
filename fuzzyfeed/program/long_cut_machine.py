"""A cut longer than a window of lines advised for a machine from its file in pieces (issue 36):
:func:`fuzzyfeed.program.stream_machine.stream_machine_advice`'s pieces of the whole cut, bit for
bit, with memory bounded by a window and a few pieces, not by the cut.

The cut is read once into a scratch folder and planned as the plain advice's long cut is
(:func:`~fuzzyfeed.program.long_cut.store_moves`, :func:`~fuzzyfeed.program.long_cut.plan_stored`:
the G1-run fit in chunks — the κ and corners :func:`~fuzzyfeed.program.cuts.run_geometry` gives a
cut of lines — pass 0's plan and s carried), the margin the machine's
(:func:`~fuzzyfeed.program.stream_machine.cut_margin_mm` of the cut's largest F, read back from the
folder). Passes 1, 1b and 2 are the whole cut's (:func:`~fuzzyfeed.program.stream_machine.machine_cut_advice`)
over the stored pieces (:func:`~fuzzyfeed.program.long_cut.stored_pieces`); the entry's safe feed on
the first piece takes the direction of the rapid leading into the cut, which the caller found in
the windows before (:class:`fuzzyfeed.program.machine_windows._Entry`).

Only a cut of straight G1 moves with F > 0 is advised so, with a table that streams (no filter
over points): else :class:`~fuzzyfeed.program.windows.Fallback` and the program is read whole.
"""

from __future__ import annotations

from collections.abc import Iterator

from fuzzyfeed.base.spill import scratch_folder
from fuzzyfeed.fuzzy.engine import compile_table
from fuzzyfeed.fuzzy.rules import MACHINE, RuleTable
from fuzzyfeed.machine.description import Machine
from fuzzyfeed.program.long_cut import PASS_SPLIT, plan_stored, store_moves, stored_pieces
from fuzzyfeed.program.stream import AdvicePiece
from fuzzyfeed.program.stream_machine import cut_margin_mm, machine_cut_advice, streams
from fuzzyfeed.program.windows import Fallback, Window


def advise_long_cut_machine(path, first: Window, k: int, table: RuleTable, machine: Machine, entry, *,
                            step_mm: float, cap_mm_min, feed_step_mm_min: float, min_piece_mm: float,
                            piece_points: int, tools, window_lines: int) -> Iterator[AdvicePiece]:
    """The pieces of the cut starting as cut ``k`` of window ``first`` (module docstring), entered
    along ``entry`` (the rapid's direction, or None), with the file's cut number and lines;
    ``piece_move`` holds ordinals of the cut's sampled moves."""
    if table.inputs != MACHINE or not streams(table):
        raise Fallback(f"rule table {table.name!r} is advised whole")
    rows = max(2, int(window_lines) // PASS_SPLIT)
    with scratch_folder("fuzzyfeed-longcut-") as folder:
        moves = store_moves(path, first, k, tools, window_lines, step_mm, folder)
        top_f = max(float(blk["feed_mm_min"].max()) for blk in moves.chunks(rows, fields=("feed_mm_min",)))
        plan = plan_stored(moves, folder, cut_margin_mm(table, machine, top_f, cap_mm_min), piece_points, rows,
                           step_mm)
        yield from machine_cut_advice(lambda: stored_pieces(moves, plan, rows, step_mm), len(plan.pieces),
                                      plan.length, first.cut0 + k, table, machine, compile_table(table), entry,
                                      cap_mm_min, feed_step_mm_min, min_piece_mm)
