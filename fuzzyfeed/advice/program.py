"""A G-code program advised (``advise PROGRAM.ngc``): cut by cut under its own F
(:func:`~fuzzyfeed.program.feeds.advise_program`) and written back with the advised F words, or, on a
machine, run as written and the cuts that break the tolerance advised, with the value report
(:func:`~fuzzyfeed.report.value.evaluate_program`). ``PROGRAM.ngc#N`` advises cut N only."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fuzzyfeed.advice.machine_program import machine_result
from fuzzyfeed.advice.options import AdviceOptions
from fuzzyfeed.advice.program_outputs import (G52_REFUSAL, check_outputs, feed_note, refuse_report, verifier,
                                               write_text)
from fuzzyfeed.advice.result import AdviceResult
from fuzzyfeed.errors import ExportError, MachineLimitsError

#: The CSV columns of a program's advice (fuzzyfeed.program.feeds.advice_columns), written as
#: a header alone when a program has nothing to advise.
ADVICE_COLUMNS = ("cut", "source_line", "u", "x_mm", "y_mm", "z_mm", "s_mm", "curvature_1_mm",
                  "curvature_window_max_1_mm", "curvature_variation", "feed_pct_controller", "feed_pct",
                  "programmed_feed_mm_min", "feed_mm_min")


def advise_program_file(spec: str, options: AdviceOptions) -> AdviceResult:
    """The program ``spec`` (``FILE`` or ``FILE#N``) advised with ``options``."""
    from fuzzyfeed.geometry.sampling import DEFAULT_POINTS
    from fuzzyfeed.io.points import pick_by_index
    from fuzzyfeed.io.shapes import resolve_shape_path, split_selector
    from fuzzyfeed.program.cuts import DEFAULT_STEP_MM
    from fuzzyfeed.program.feeds import DEFAULT_PROGRAM_FEED_STEP_MM_MIN
    from fuzzyfeed.program.read import read_program

    cap = options.feed_mm_min
    if options.line_numbers or options.g52_whole:
        flag = "--line-numbers" if options.line_numbers else "--g52-whole"
        raise ExportError(f"{flag}: a program written back keeps its own lines and words; "
                          "leave the flag out")
    if options.rule_strengths:
        raise ExportError("--rule-strengths is for shapes; a program's CSV has one row per sample "
                          "of every cut")
    if options.points != DEFAULT_POINTS:
        raise MachineLimitsError("--points is for shapes; a program is sampled every --step-mm "
                                 "along its cuts")
    base, selector = split_selector(spec)
    path = resolve_shape_path(base)
    machine, table = options.machine, options.table
    tools = None
    if options.tool_table is not None:
        from fuzzyfeed.program.tools import read_tool_table

        tools = read_tool_table(options.tool_table, options.tool_units)
    from fuzzyfeed.base.memory import fix_mmap_threshold

    fix_mmap_threshold()               # large programs: the columns a read drops go back to the system
    step = options.feed_step_mm_min or DEFAULT_PROGRAM_FEED_STEP_MM_MIN
    step_mm = options.step_mm or DEFAULT_STEP_MM
    if selector is None and machine is None and options.reference:
        from fuzzyfeed.advice.program_windows import windowed_result

        verify = verifier(options, tools)     # rs274 missing: refused before anything is read

        def whole():                   # the whole read, where the windows cannot give its result
            program = read_program(path, tools=tools)
            if program.n_cuts == 0:
                return NothingResult(spec, options, path, program)
            return ProgramResult(spec, options, path, program, table, None, step_mm, step, verify)

        def checks(csv, gcode, gcode_g52, plot, report):
            check_outputs(csv, gcode, gcode_g52, plot)
            refuse_report(report)
        windowed = windowed_result(spec, options, path, table, step_mm, step, tools, whole, checks, feed_note)
        if windowed is not None:       # a long program: read, advised and written in windows
            return windowed
    if selector is None and machine is not None:
        from fuzzyfeed.advice.program_windows import windowed_machine_result

        def whole_machine():           # the whole read, where the windows cannot give its result
            program = read_program(path, tools=tools)
            if program.n_cuts == 0:
                return NothingResult(spec, options, path, program)
            return machine_result(spec, options, program, table, cap, step, step_mm, None, tools)

        windowed = windowed_machine_result(spec, options, path, table, step_mm, step, tools, whole_machine,
                                           check_outputs, feed_note)
        if windowed is not None:       # a long program: its chains and advice made in windows
            return windowed
    program = read_program(path, tools=tools)
    if program.n_cuts == 0:            # nothing to advise: the program as it is, and one notice
        return NothingResult(spec, options, path, program)
    cuts = None
    if selector is not None and program.n_cuts:
        described = [f"{k + 1} (line {int(program.move_line[program.cut_moves(k)[0]]) + 1})"
                     for k in range(program.n_cuts)]
        cuts = [pick_by_index(program.path, selector, described)]
    if machine is not None:
        return machine_result(spec, options, program, table, cap, step, step_mm, cuts, tools)
    if not options.reference:
        raise MachineLimitsError("--no-reference: the value report needs a machine (--machine FILE, or "
                                 "a machine flag such as --contour-tol-um)")
    return ProgramResult(spec, options, path, program, table, cuts, step_mm, step, verifier(options, tools))


class ProgramResult(AdviceResult):
    """A program advised without a machine: every cut (or the one picked) under its own F.

    The advice runs in pieces (:func:`~fuzzyfeed.program.stream.stream_program_advice`: the same
    rows and feeds as advising each cut whole, memory bounded by a piece): :meth:`write` writes the
    CSV piece by piece and the program in chunks, keeping only the pieces' feeds (per move) and the
    advised fraction at every sample (for the summary). A plot, or a table that reads a machine's
    terms, takes the whole cuts' advice (:attr:`advice`, under the sample budget of a cut).
    :meth:`columns` / :meth:`frame` hold every sample's row (about 110 bytes a sample: ~0.1 GB on a
    10⁶-move raster at the default step) and :attr:`text` the whole rewritten program."""

    kind = "program"

    def __init__(self, source, options, path: Path, program, table, cuts, step_mm: float,
                 feed_step_mm_min: float, verify=None):
        from fuzzyfeed.fuzzy.rules import MACHINE
        from fuzzyfeed.program.coverage import program_coverage

        self.source, self.options, self.path, self.program = source, options, path, program
        self.table, self.cuts, self.step_mm, self.feed_step_mm_min = table, cuts, step_mm, feed_step_mm_min
        self.coverage = program_coverage(program)
        self._verify = verify
        self._text = None
        self.verification = None     # what rs274 said of the rewrite (verify_rs274), once it is made
        self._whole = None           # the whole cuts' ProgramAdvice, once asked for (plot)
        self._pieces = None          # (move, end, feed) of the advised pieces, once advised
        self._feed_pct = None        # the advised fraction at every sample, once advised
        self._in_pieces = table.inputs != MACHINE
        # the arguments and the cuts' F are checked now (errors at advise time); pieces made when consumed
        self._pending = self._start() if self._in_pieces else None

    def _start(self):
        from fuzzyfeed.program.stream import stream_program_advice

        return stream_program_advice(self.program, self.table, cuts=self.cuts, step_mm=self.step_mm,
                                     cap_mm_min=self.options.feed_mm_min,
                                     feed_step_mm_min=self.feed_step_mm_min)

    @property
    def advice(self):
        """The whole cuts' :class:`~fuzzyfeed.program.feeds.ProgramAdvice` (every sample's
        features and feed profile; refused when a cut needs more samples than the budget)."""
        from fuzzyfeed.program.feeds import advise_program

        if self._whole is None:
            self._whole = advise_program(self.program, self.table, cuts=self.cuts, step_mm=self.step_mm,
                                         cap_mm_min=self.options.feed_mm_min,
                                         feed_step_mm_min=self.feed_step_mm_min)
        return self._whole

    def _advise(self, sink=None) -> None:
        """Advise (in pieces unless the whole advice is made), each piece's rows to ``sink``;
        keep the pieces' feeds and the advised fractions."""
        if self._whole is not None or not self._in_pieces:
            pa = self.advice
            if sink is not None:
                sink(self.columns())
            self._pieces = (pa.piece_move, pa.piece_end, pa.piece_feed_mm_min)
            self._feed_pct = np.concatenate([a.feed_pct for a in pa.advice])
            return
        stream, self._pending = self._pending, None
        pm, pe, pf, pct = [], [], [], []
        for piece in stream if stream is not None else self._start():
            if sink is not None:
                sink(piece.columns)
            pct.append(piece.columns["feed_pct"])
            pm.append(piece.piece_move)
            pe.append(piece.piece_end)
            pf.append(piece.piece_feed_mm_min)
        self._pieces = (np.concatenate(pm), np.concatenate(pe), np.concatenate(pf))
        self._feed_pct = np.concatenate(pct)

    def _advised(self) -> tuple:
        if self._pieces is None:
            self._advise()
        return self._pieces

    @property
    def text(self) -> str:
        from fuzzyfeed.program.rewrite import rewrite_program

        if self._text is None:
            pieces = self._advised()
            if self._verify is not None:
                self._text, self.verification = self._verify(self.program, *pieces)
            else:
                self._text = rewrite_program(self.program, *pieces)
        return self._text

    def columns(self) -> dict:
        from fuzzyfeed.program.feeds import advice_columns

        if self._whole is not None or not self._in_pieces:
            return advice_columns(self.advice)
        parts = []
        self._advise(parts.append)
        return {name: np.concatenate([p[name] for p in parts]) for name in parts[0]}

    def _times(self):
        from fuzzyfeed.program.feeds import pieces_times

        return pieces_times(self.program, *self._advised())

    def _n_advised(self) -> int:
        return self.program.n_cuts if self.cuts is None else len(self.cuts)

    def summary(self) -> list[str]:
        program, cap, step = self.program, self.options.feed_mm_min, self.feed_step_mm_min
        t_prog, t_adv = self._times()
        fr = self._feed_pct
        n_split = int(np.sum(np.diff(self._pieces[0]) == 0))
        return [f"{self.path.name}: {len(program.lines)} lines, {program.kind.size} moves, {program.n_cuts} "
                f"cut(s), {self._n_advised()} advised; rules {self.table.name!r}; F from the program"
                + (f", capped at {cap:g} mm/min" if cap else ""),
                f"advised fraction of the programmed F  min {fr.min():.2f} %  mean {fr.mean():.2f} %  "
                f"max {fr.max():.2f} %   (F rounded down to {step:g} mm/min steps)",
                f"feed moves of the advised cuts: {t_prog:.3f} s at the programmed F, {t_adv:.3f} s at "
                f"the advised F (no acceleration); {n_split} split points",
                self.coverage.summary(),
                *([self.verification.summary()] if self.verification is not None else [])]

    def figures(self) -> dict:
        t_prog, t_adv = self._times()
        fr = self._feed_pct
        return {"cuts": self.program.n_cuts, "cuts_advised": self._n_advised(), "time_written_s": t_prog,
                "time_advised_s": t_adv, "feed_pct_min": float(fr.min()), "feed_pct_mean": float(fr.mean()),
                **self.coverage.figures(),
                **({} if self.verification is None else self.verification.figures())}

    def _write(self, csv, gcode, gcode_g52, plot, report) -> list[str]:
        from fuzzyfeed.base.atomic import atomic_write
        from fuzzyfeed.fuzzy.provenance import provenance
        from fuzzyfeed.io.csv import ColumnStream, tee, write_metadata

        check_outputs(csv, gcode, gcode_g52, plot)
        refuse_report(report)
        if self._verify is not None and not gcode:
            raise ExportError("--verify-rs274 checks the rewritten program: give --gcode OUT.ngc (or a machine)")
        trace = None
        if plot:                         # the plot's trace kept as the rows come (report/plot_trace.py)
            from fuzzyfeed.report.plot_trace import FuzzyTrace

            trace = FuzzyTrace()
        cap = self.options.feed_mm_min
        if csv is not None:              # rows written as the pieces come
            with atomic_write(csv, "w", newline="") as handle:
                out = ColumnStream(handle, csv)
                self._advise(out.write if trace is None else tee(out.write, trace.add))
            record = provenance(self.table, cap or 0.0, str(self.path), out.rows)
            record["F_mm_min"] = feed_note(cap)
            write_metadata(csv, out.names, record)
        elif trace is not None:
            self._advise(trace.add)
        if plot:
            self._plot_trace(trace, plot)
        if gcode:
            if self._text is not None or self._verify is not None:
                write_text(gcode, self.text)
            else:                        # the rewritten program in chunks, never whole
                from fuzzyfeed.program.rewrite import rewrite_chunks

                pieces = self._advised()
                with atomic_write(gcode, "w", newline="") as handle:
                    for chunk in rewrite_chunks(self.program, *pieces):
                        handle.write(chunk)
        lines = []
        if csv is not None or plot:
            lines.append("wrote " + " and ".join(p for p in (csv, plot) if p))
        if gcode:
            lines.append(f"wrote {gcode}")
        return lines

    def _plot(self, output) -> None:
        from fuzzyfeed.report.plot_trace import FuzzyTrace

        trace = FuzzyTrace()
        self._advise(trace.add)
        self._plot_trace(trace, output)

    def _plot_trace(self, trace, output) -> None:
        """The advised cuts end to end (:func:`~fuzzyfeed.report.plot_trace.plot_trace`: the rows
        thinned as they come, the same plot whether the program was read whole or in windows)."""
        from fuzzyfeed.report.plot_trace import plot_trace

        plot_trace(trace, self.table, f"{self.path.name}: {self._n_advised()} cut(s) end to end", output)


class NothingResult(AdviceResult):
    """A program with no cut: written back unchanged, its CSV a header alone, one notice."""

    kind = "program, nothing to advise"

    def __init__(self, source, options, path: Path, program):
        import warnings

        from fuzzyfeed.errors import FuzzyfeedNotice
        from fuzzyfeed.program.model import why_nothing_to_advise

        self.source, self.options, self.path, self.program = source, options, path, program
        self.reason = why_nothing_to_advise(program)
        warnings.warn(f"{path}: nothing to advise ({self.reason}); the program is "
                      "written back unchanged", FuzzyfeedNotice, stacklevel=3)

    @property
    def text(self) -> str:
        return self.path.read_bytes().decode("utf-8", "surrogateescape")

    def columns(self) -> dict:
        return {name: np.zeros(0) for name in ADVICE_COLUMNS}

    def figures(self) -> dict:
        from fuzzyfeed.program.coverage import program_coverage

        return {"cuts": 0, "cuts_advised": 0, "time_written_s": 0.0, "time_advised_s": 0.0,
                **program_coverage(self.program).figures()}

    def _write(self, csv, gcode, gcode_g52, plot, report) -> list[str]:
        from fuzzyfeed.base.atomic import atomic_write
        from fuzzyfeed.io.csv import write_columns, write_metadata

        if gcode_g52:
            raise ExportError(G52_REFUSAL)
        if csv is not None:
            write_columns(csv, self.columns())
            write_metadata(csv, list(ADVICE_COLUMNS), {"source": str(self.path), "generator": "fuzzyfeed",
                                                       "advice": f"nothing to advise: {self.reason}"})
        if gcode:
            with atomic_write(gcode, "wb") as handle:
                handle.write(self.path.read_bytes())
        written = [p for p in (csv, gcode) if p]
        return ["wrote " + " and ".join(written)] if written else []

