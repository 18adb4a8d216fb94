"""A long program advised on a machine window by window (issue 36: ``advise PROGRAM --machine M -o
x.csv --gcode y.ngc`` with memory bounded by a window of lines and a part of a chain, not by the
program): :func:`fuzzyfeed.report.value.evaluate_program`'s stages, in passes over the file.

1. The windows of lines (:func:`~fuzzyfeed.program.windows.read_windows`) build the program's
   chains (:class:`~fuzzyfeed.program.path_builder.PathBuilder`: the open chain carried across a
   join) into a scratch store (:mod:`fuzzyfeed.program.chain_store`, ~60 bytes a segment, read
   back a slice at a time); the coverage is summed window by window.
2. The run as written from the store (:func:`~fuzzyfeed.program.run.run_program`: a long chain
   planned and run part by part, the servo's state carried, bit for bit the whole plan's run): its
   rows, the largest error of every cut (the store's cut column), where the largest errors are.
   Its largest error per segment goes to a scratch file as the run makes it (:func:`_spilled`),
   read back in blocks for the cuts' maxima and the uniform search's hot segments.
3. The windows read again: every cut advised (a machine table in pieces,
   :func:`~fuzzyfeed.program.stream_machine.stream_machine_advice`; the entry rapid of a window's
   first cut taken from the windows before; a cut split between windows advised from its file in
   pieces, :func:`~fuzzyfeed.program.long_cut_machine.advise_long_cut_machine`, bit for bit the
   whole cut's), the CSV rows handed on as they come (``advised`` 1 on
   the cuts over the tolerance), the window's lines rewritten with the pieces of those cuts
   (:func:`~fuzzyfeed.program.rewrite.rewrite_chunks`, the F in force carried) to a scratch file.
4. The advised run: that file read in windows into a second store, run as in 2.
5. The uniform slowdown on the store (:func:`~fuzzyfeed.program.uniform.uniform_slowdown`,
   ``check=False``: its trials plan and run the hot stretches part by part, the time from the
   planner window by window); with ``check`` (``--report``) its checking run
   (:func:`~fuzzyfeed.program.uniform.check_uniform`) and the limit reference
   (:func:`~fuzzyfeed.program.reference.limit_reference`: its refined chains, feeds, profiles and
   events in scratch files beside the store, a long chain read a window at a time) on the store too, and the value plot's trace drawn from both stores block by block.

Where a step cannot give the whole read's result — a cut split between windows with arcs or G5.2
blocks, a table advised whole, places the uniform slowdown sets apart (and with them the limit
reference), any error — it raises
:class:`~fuzzyfeed.program.windows.Fallback` and the caller reads the program whole. Nothing is
guessed.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fuzzyfeed.base.memory import release_free_memory
from fuzzyfeed.machine.description import Machine
from fuzzyfeed.program.chain_store import ChainStore, StoredPath
from fuzzyfeed.program.model import HOME, LINE, RAPID
from fuzzyfeed.program.windows import WINDOW_LINES, Fallback, read_windows

#: Segments of a stored column read at a time for the run's per-cut summaries.
BLOCK_SEGMENTS = 1 << 20


@dataclass
class StoreTotals:
    """What the read of the windows (stage 1) counted: lines, moves, cuts, the coverage parts."""

    lines: int = 0
    moves: int = 0
    cuts: int = 0
    windows: int = 0
    coverages: list | None = None      # (line0, Coverage) of every window


def build_store(path, store: ChainStore, tools, window_lines: int, coverage: bool = False,
                advised: bool = False) -> StoreTotals:
    """Stage 1 (module docstring) of the program at ``path`` into ``store`` (closed for writing at
    the end). ``coverage``: keep every window's coverage. A cut split between windows is the whole
    read's: the windows' moves are however they are cut, the open chain is carried across the join
    and the continued window's cut 0 is the cut of the window before (its ``cut0``), counted once.
    ``advised``: the program's cuts are to be advised — a split cut with arcs or G5.2 blocks (not
    advised from its file) raises :class:`~fuzzyfeed.program.windows.Fallback` here, before the run."""
    from fuzzyfeed.program.coverage import program_coverage
    from fuzzyfeed.program.cuts import cut_moves

    totals = StoreTotals(coverages=[] if coverage else None)
    builder = store.builder()
    rest: list = []
    move0 = 0
    for win in read_windows(path, tools=tools, window_lines=window_lines, rest=rest):
        wp = win.program
        split = ([0] if win.continued else []) + ([wp.n_cuts - 1] if win.continues else [])
        if advised and any(np.any(cut_moves(wp, k)[1] != LINE) for k in split):
            raise Fallback("a cut longer than a window with arcs or G5.2 blocks")
        builder.add(wp, (move0, win.line0, win.cut0))
        move0 += wp.kind.size
        totals.lines += len(wp.lines)
        totals.cuts += wp.n_cuts - int(win.continued)
        totals.windows += 1
        if coverage:
            totals.coverages.append((win.line0, program_coverage(wp)))
        del wp, win
        release_free_memory()          # the window's freed heap: else it creeps up window by window
    builder.finish()
    store.close_writing()
    totals.moves = move0
    totals.lines += sum(len(block) for block in rest)
    return totals


def cut_max_um(sp: StoredPath, run, n_cuts: int) -> np.ndarray:
    """Largest contour error (µm) of every cut (:meth:`~fuzzyfeed.program.run.ProgramRun.cut_max_um`
    on the store: the cut of every segment read from its column)."""
    out = np.zeros(n_cuts)
    for i, r in enumerate(run.runs):
        seg_max = r.stream.seg_max_mm
        col = sp.segment_column(i, "cut")
        for a in range(0, seg_max.size, BLOCK_SEGMENTS):
            b = min(a + BLOCK_SEGMENTS, seg_max.size)
            c, m = col[a:b], seg_max[a:b]
            ok = (c >= 0) & (m > 0)
            np.maximum.at(out, c[ok], m[ok] * 1e3)
    return out


def where(sp: StoredPath, run, attr: str, seg_attr: str, xyz_attr: str):
    """:meth:`~fuzzyfeed.program.run.ProgramRun.worst` (``max_mm``…) or ``worst_air`` on the store:
    (program line, 0-based, of the move commanded then, the point), or None."""
    best = None
    for i, r in enumerate(run.runs):
        v, seg = getattr(r.stream, attr), getattr(r.stream, seg_attr)
        if seg >= 0 and (best is None or v > best[0]):
            best = (v, i, int(seg), getattr(r.stream, xyz_attr))
    if best is None:
        return None
    return int(sp.segment_column(best[1], "line")[best[2]]), best[3]


class _Entry:
    """The last move of the windows read so far that is not transparent to a cut's entry (a rapid,
    home or line that does not move is: :func:`~fuzzyfeed.program.cuts._entry_direction`)."""

    def __init__(self):
        self.tail = None          # (kind, start, end) or None

    def first_cut(self, wp) -> tuple | None:
        """The entry direction of the window's cut 0, as the whole read finds it (its walk back
        may pass the window's start), or None when the window has no cut."""
        from types import SimpleNamespace

        from fuzzyfeed.program.cuts import _entry_direction, cut_moves

        if wp.n_cuts == 0:
            return None
        first = int(cut_moves(wp, 0)[0][0])
        kind, start, end = wp.kind[:first + 1], wp.start[:first + 1], wp.end[:first + 1]
        if self.tail is not None:
            kind = np.concatenate([[self.tail[0]], kind])
            start = np.vstack([self.tail[1][None, :], start])
            end = np.vstack([self.tail[2][None, :], end])
            first += 1
        return _entry_direction(SimpleNamespace(kind=kind, start=start, end=end), first)

    def after(self, wp) -> None:
        """The window ``wp`` read: its last move not transparent becomes the tail."""
        for m in range(wp.kind.size - 1, -1, -1):
            if not (int(wp.kind[m]) in (RAPID, HOME, LINE) and np.array_equal(wp.end[m], wp.start[m])):
                self.tail = (int(wp.kind[m]), wp.start[m].copy(), wp.end[m].copy())
                return


def advise_windows(path, table, machine: Machine, over, *, cap_mm_min, step_mm: float, feed_step_mm_min: float,
                   min_piece_mm: float, tools, window_lines: int, sink, write) -> None:
    """Stage 3 (module docstring): every cut of the program advised, ``sink(columns)`` each piece's
    CSV rows (the file's cut and line numbers; ``advised`` 1 on the cuts, 0-based, in ``over``),
    ``write(text)`` the program rewritten with the advice of the cuts in ``over``. A cut split
    between windows is advised from the file in pieces
    (:func:`~fuzzyfeed.program.long_cut_machine.advise_long_cut_machine`, its entry carried from the
    windows before; a plain table's: :func:`~fuzzyfeed.program.long_cut.advise_long_cut`), each
    window taking the pieces of its own moves (:class:`~fuzzyfeed.program.window_advice.WindowCuts`)."""
    from fuzzyfeed.fuzzy.rules import MACHINE
    from fuzzyfeed.program import stream as stream_module
    from fuzzyfeed.program.advice_pieces import applied_columns
    from fuzzyfeed.program.cuts import _entry_direction, cut_moves
    from fuzzyfeed.program.rewrite import rewrite_chunks
    from fuzzyfeed.program.stream import stream_program_advice
    from fuzzyfeed.program.stream_machine import stream_machine_advice, streams
    from fuzzyfeed.program.window_advice import WindowCuts, file_columns

    if table.inputs == MACHINE and not streams(table):
        raise Fallback(f"rule table {table.name!r} is advised whole")
    over_a = np.asarray(sorted(over), dtype=np.int64)
    kw = dict(cap_mm_min=cap_mm_min, step_mm=step_mm, feed_step_mm_min=feed_step_mm_min,
              min_piece_mm=min_piece_mm)
    carry = {"f": None}
    rest: list = []
    newline = None
    entry = _Entry()
    cuts = WindowCuts()

    def advise(win, regular):
        wp = win.program
        if table.inputs != MACHINE:
            return stream_program_advice(wp, table, cuts=regular, **kw)
        # the window's cut 0 entered by a rapid of the windows before (a continued window's cut 0 is
        # not advised here)
        entries = {} if win.continued else {0: entry.first_cut(wp)}
        return stream_machine_advice(wp, table, machine, cuts=regular, entries=entries, **kw)

    def advise_long(win, k):
        from fuzzyfeed.program.long_cut import advise_long_cut
        from fuzzyfeed.program.long_cut_machine import advise_long_cut_machine

        lw = dict(kw, piece_points=stream_module.DEFAULT_PIECE_POINTS, tools=tools, window_lines=window_lines)
        if table.inputs != MACHINE:
            return advise_long_cut(path, win, k, table, **lw)
        wp = win.program
        into = entry.first_cut(wp) if k == 0 else _entry_direction(wp, int(cut_moves(wp, k)[0][0]))
        return advise_long_cut_machine(path, win, k, table, machine, into, **lw)

    def taken(cols, offset: bool, win):
        if offset:
            cols = file_columns(cols, win)
        if sink is not None:
            sink(applied_columns(cols, over))

    try:
        for win in read_windows(path, tools=tools, window_lines=window_lines, rest=rest):
            wp = win.program
            newline = wp.newline
            pm, pe, pf = cuts.pieces(win, advise, advise_long, taken)
            keep = np.isin(wp.cut[pm] + win.cut0, over_a) if pm.size else np.zeros(0, bool)
            for chunk in rewrite_chunks(wp, pm[keep], pe[keep], pf[keep], carry=carry):
                write(chunk)
            entry.after(wp)
            del wp, win, pm, pe, pf, keep
            release_free_memory()      # the window's freed heap: else it creeps up window by window
    finally:
        cuts.close()
    cuts.ended()
    for block in rest:
        if block:
            write(newline.join(block) + newline)


@dataclass(frozen=True)
class RunFigures:
    """What the value report's row takes of a run (:meth:`fuzzyfeed.report.value.ValueRow.of`)."""

    time_s: float
    max_um: float
    p99_um: float
    air_max_um: float

    @classmethod
    def of(cls, run) -> RunFigures:
        return cls(run.time_s, run.max_um, run.p99_um, run.air_max_um)


@dataclass(frozen=True)
class ReferenceFigures:
    """What the value report takes of the limit reference (:func:`~fuzzyfeed.program.reference.limit_reference`)
    run on the store: its run's figures and whether it holds the tolerance."""

    run: RunFigures
    converged: bool


@dataclass(frozen=True, eq=False)
class WindowedRuns:
    """What the value report (:func:`fuzzyfeed.report.value.windowed_report`) takes of a program
    evaluated in windows: the run as written (no plans) and the advised run's figures (None when no
    cut is over: the program is left as written), where the largest errors are (the advised run's, or the written
    one's), the uniform slowdown (None when no cut is over), the cuts advised, the coverage, the
    program's lines and cuts, and the advised program (a scratch file the caller copies)."""

    written: object
    advised: object
    worst: tuple | None
    air: tuple | None
    uniform: object
    advised_cuts: tuple[int, ...]
    coverage: object
    lines: int
    cuts: int
    advised_file: Path
    trace: object = None                        # the value plot's feed trace (``trace``), when asked
    reference: ReferenceFigures | None = None   # the limit reference (``check`` with ``reference``)


def evaluate_in_windows(path, machine: Machine, table, scratch: Path, *, cap_mm_min=None,
                        feed_step_mm_min: float = 10.0, step_mm: float = 0.25, min_piece_mm: float = 1.0,
                        tools=None, window_lines: int = WINDOW_LINES, sink=None, progress=None,
                        check: bool = False, reference: bool = True, trace=None) -> WindowedRuns:
    """The runs and advice of :func:`~fuzzyfeed.report.value.evaluate_program` (``check_uniform=False``,
    no ``cuts``, no ``verify``) of the program at ``path`` in windows (module docstring), its scratch
    files in ``scratch`` (the caller's, removed by it). ``sink(columns)``: the CSV rows as they come.
    ``check``: what :meth:`~fuzzyfeed.report.value.Evaluation.checked` adds for ``--report``, on the
    store: the uniform slowdown checked by a whole run (:func:`~fuzzyfeed.program.uniform.check_uniform`)
    and, with ``reference``, the limit reference. ``trace(written_path, written_run, advised_path)``:
    the value plot's trace, made while the stores are open (the advised path is the written one
    when no cut is over)."""
    from fuzzyfeed.errors import FuzzyfeedError
    from fuzzyfeed.program.run import run_program
    from fuzzyfeed.program.uniform import uniform_slowdown
    from fuzzyfeed.program.window_advice import WindowTotals

    step = progress or (lambda _name: None)
    scratch = Path(scratch)
    tol = machine.contour_tol_um
    stores = []
    try:
        step("as written")
        store = ChainStore(scratch / "written", machine.chord_tol_mm)
        stores.append(store)
        totals = build_store(path, store, tools, window_lines, coverage=True, advised=True)
        if totals.cuts == 0:
            raise Fallback("no cut: the whole read says so")
        sp = StoredPath.of(store)
        written = run_program(sp, machine, keep_plans=False, seg_sinks=_spilled(scratch / "seg_max", "written"))
        over = [int(k) for k in np.flatnonzero(cut_max_um(sp, written, totals.cuts) > tol)]
        release_free_memory()
        step("advice")
        advised_file = scratch / "advised.ngc"
        with open(advised_file, "w", encoding="utf-8", newline="") as handle:   # as atomic_write writes text
            advise_windows(path, table, machine, over, cap_mm_min=cap_mm_min, step_mm=step_mm,
                           feed_step_mm_min=feed_step_mm_min, min_piece_mm=min_piece_mm, tools=tools,
                           window_lines=window_lines, sink=sink, write=handle.write)
        cov = WindowTotals(coverages=totals.coverages).coverage()
        release_free_memory()          # the windows' freed heap, before the runs
        advised, u, drawn, ref = None, None, None, None
        if not over:
            worst = where(sp, written, "max_mm", "max_segment", "max_xyz")
            air = where(sp, written, "air_max_mm", "air_segment", "air_xyz")
            drawn = None if trace is None else trace(sp, written, sp)
        else:
            step("advised run")
            adv_store = ChainStore(scratch / "advised", machine.chord_tol_mm)
            stores.append(adv_store)
            build_store(advised_file, adv_store, tools, window_lines)
            asp = StoredPath.of(adv_store)
            run = run_program(asp, machine, keep_plans=False, seg_sinks=_spilled(scratch / "seg_max", "advised"))
            worst = where(asp, run, "max_mm", "max_segment", "max_xyz")
            air = where(asp, run, "air_max_mm", "air_segment", "air_xyz")
            # what the report takes of it (its errors per segment go before the uniform slowdown)
            advised = RunFigures.of(run)
            drawn = None if trace is None else trace(sp, written, asp)
            del run
            release_free_memory()
            step("uniform slowdown")
            u = uniform_slowdown(sp, machine, written, check=False)
            if check:
                u, ref = _checked(sp, machine, u, reference, step, scratch / "seg_max")
    except FuzzyfeedError as exc:
        raise Fallback(str(exc)) from None
    finally:
        for s in stores:
            s.close()
    return WindowedRuns(written, advised, worst, air, u, tuple(over), cov, totals.lines, totals.cuts, advised_file,
                        drawn, ref)


def _spilled(folder: Path, name: str):
    """``seg_sinks`` for :func:`~fuzzyfeed.program.run.run_program`: chain i's largest error per
    segment in a scratch file of ``folder`` (:class:`~fuzzyfeed.base.spill.SpilledValues`), read
    back in blocks by what needs it (:func:`cut_max_um`, the uniform search's hot segments)."""
    from fuzzyfeed.base.spill import SpilledValues

    folder.mkdir(exist_ok=True)
    sinks: dict[int, SpilledValues] = {}

    def sink(i: int) -> SpilledValues:
        if i not in sinks:
            sinks[i] = SpilledValues(folder, f"{name}{i}")
        return sinks[i]
    return sink


def _checked(sp: StoredPath, machine: Machine, u, reference: bool, step, seg_max: Path):
    """The uniform slowdown ``u`` checked by a whole run on the store (its run's figures kept, not
    its rows) and, with ``reference``, the limit reference on the store
    (:meth:`~fuzzyfeed.report.value.Evaluation.checked`'s stages, in its order)."""
    from dataclasses import replace

    from fuzzyfeed.program.reference import limit_reference
    from fuzzyfeed.program.uniform import check_uniform

    if not u.checked:
        step("uniform check")
        u = check_uniform(sp, machine, u, seg_sinks=_spilled(seg_max, "uniform"))
        if u.run is not None:
            u = replace(u, run=RunFigures.of(u.run))
        release_free_memory()
    if not reference:
        return u, None
    if u.apart:          # where its largest error is, on a place set apart, is read on the whole program
        raise Fallback("the limit reference beside places set apart is judged on the whole read")
    step("limit reference")
    ref = limit_reference(sp, machine, seg_sinks=_spilled(seg_max, "reference"))
    try:
        out = ReferenceFigures(RunFigures.of(ref.run), ref.converged)
    finally:
        ref.close()           # its refined store, feeds and profiles (scratch files beside the store)
    del ref
    release_free_memory()
    return u, out
