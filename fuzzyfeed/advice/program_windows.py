"""A long program advised without a machine window by window (issue 36: memory bounded by a window
of lines, not by the program): ``advise PROGRAM -o x.csv [--gcode y.ngc] [--plot p.png]
[--verify-rs274]`` on a program of at least :data:`~fuzzyfeed.program.windows.MIN_LINES` lines.
The CSV and the program are written as the windows are advised
(:func:`~fuzzyfeed.program.window_advice.advise_in_windows`), the plot drawn from a trace thinned
as the rows come (:mod:`fuzzyfeed.report.plot_trace`), the rewrite checked by rs274 streamed
(:mod:`fuzzyfeed.program.verify_windows`); the result is the whole read's, byte for byte. Where
the windows cannot give it (see :mod:`fuzzyfeed.program.windows`), and for anything else asked of
the result (the text, the columns), the program is read whole and advised as before
(:class:`~fuzzyfeed.advice.program.ProgramResult`). Outputs the whole read refuses (``--report``
without a machine, ``--gcode-g52``, the same file twice, ``--verify-rs274`` without ``--gcode``)
are refused before anything is read.
"""

from __future__ import annotations

import contextlib
import warnings
from pathlib import Path

from fuzzyfeed.advice.result import AdviceResult


def windowed_lines(path: Path) -> int | None:
    """The program's line count when it is long enough to be read in windows, else None."""
    from fuzzyfeed.program.windows import MIN_LINES, scan_file

    try:
        if path.stat().st_size < MIN_LINES * 4:     # a line of a program is at least a few bytes
            return None
    except OSError:
        return None
    scan = scan_file(path)
    return scan.n_lines if scan is not None and scan.n_lines >= MIN_LINES else None


def windowed_result(spec, options, path: Path, table, step_mm: float, step: float, tools, whole, checks,
                    feed_note):
    """A :class:`WindowedProgramResult` for a long program whose table is the plain one (None: read
    it whole). ``whole()`` makes the whole read's result, ``checks(csv, gcode, gcode_g52, plot,
    report)`` refuses outputs a program cannot have, ``feed_note(cap)`` the sidecar's F note."""
    from fuzzyfeed.fuzzy.rules import MACHINE

    if table.inputs == MACHINE or windowed_lines(path) is None:
        return None
    return WindowedProgramResult(spec, options, path, table, step_mm, step, tools, whole, checks, feed_note)


class _WindowedResult(AdviceResult):
    """A long program's result written window by window; ``whole()`` makes the whole read's result
    where the windows cannot give it, and for whatever else is asked of the result."""

    def __init__(self, source, options, path: Path, table, step_mm: float, feed_step_mm_min: float,
                 tools, whole, checks, feed_note, window_lines: int | None = None):
        self.source, self.options, self.path, self.table = source, options, path, table
        self.step_mm, self.feed_step_mm_min, self.tools = step_mm, feed_step_mm_min, tools
        self._make_whole, self._checks, self._feed_note = whole, checks, feed_note
        self._whole = None
        self.window_lines = window_lines

    def whole(self):
        if self._whole is None:
            self._whole = self._make_whole()
        return self._whole

    @property
    def text(self) -> str:
        return self.whole().text

    def columns(self) -> dict:
        return self.whole().columns()

    def _in_windows(self, write_windows, forget, csv, gcode, gcode_g52, plot, report) -> list[str]:
        """``write_windows()``'s lines, the reader's notices said once; where a window cannot be
        joined exactly (:class:`~fuzzyfeed.program.windows.Fallback`) or the windows refuse, what
        the windows kept is dropped (``forget()``) and the whole read writes."""
        from fuzzyfeed.errors import FuzzyfeedError
        from fuzzyfeed.program.windows import Fallback

        fallback = False
        try:
            with warnings.catch_warnings(record=True) as said:
                warnings.simplefilter("always")
                lines = write_windows()
        except (Fallback, FuzzyfeedError):
            fallback = True
        if fallback:     # outside the except: its traceback would keep the windows' arrays alive
            forget()
            return self.whole()._write(csv, gcode, gcode_g52, plot, report)
        for w in said:           # the reader's notices, once (none when the whole read took over)
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        return lines


class WindowedProgramResult(_WindowedResult):
    """A long program advised in windows when written (module docstring); ``whole()`` makes the
    whole read's :class:`~fuzzyfeed.advice.program.ProgramResult` when it is needed."""

    kind = "program"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._totals = None
        self.verification = None     # what rs274 said of the rewrite (verify_rs274), once written
        self._trace = None           # the plot's thinned trace (report/plot_trace.py), once written

    @property
    def windowed(self) -> bool:
        """True once the outputs were written window by window."""
        return self._totals is not None

    @property
    def advice(self):
        return self.whole().advice

    def _write(self, csv, gcode, gcode_g52, plot, report) -> list[str]:
        if self._whole is None:          # refused before anything is read (as the whole read refuses them)
            self._checks(csv, gcode, gcode_g52, plot, report)
            if self.options.verify_rs274:
                _need_gcode(gcode)
        if (csv is None and gcode is None and plot is None) or self._whole is not None:
            return self.whole()._write(csv, gcode, gcode_g52, plot, report)

        def forget():
            self._totals = self.verification = self._trace = None
        return self._in_windows(lambda: self._write_windows(csv, gcode, plot), forget,
                                csv, gcode, gcode_g52, plot, report)

    def _write_windows(self, csv, gcode, plot=None) -> list[str]:
        from fuzzyfeed.base.atomic import atomic_write
        from fuzzyfeed.fuzzy.provenance import provenance
        from fuzzyfeed.io.csv import ColumnStream, write_metadata
        from fuzzyfeed.program.window_advice import advise_in_windows
        from fuzzyfeed.program.windows import WINDOW_LINES

        cap = self.options.feed_mm_min
        window_lines = self.window_lines or WINDOW_LINES
        verify = bool(self.options.verify_rs274)
        sinks = []
        if plot is not None:             # the plot's trace, kept as the rows come
            from fuzzyfeed.report.plot_trace import FuzzyTrace

            self._trace = FuzzyTrace()
            sinks.append(self._trace.add)
        with contextlib.ExitStack() as stack:
            out = write = spill = None
            if csv is not None:
                out = ColumnStream(stack.enter_context(atomic_write(csv, "w", newline="")), csv)
                sinks.insert(0, out.write)
            if verify:                   # the rewrite to a scratch file, checked, then copied
                import tempfile
                from pathlib import Path

                from fuzzyfeed.program.verify_windows import PieceSpill

                scratch = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="fuzzyfeed-rs274-")))
                spill = PieceSpill(scratch / "pieces")
                first = scratch / "first" / self.path.name
                first.parent.mkdir()
                first_handle = stack.enter_context(open(first, "w", newline=""))
                write = first_handle.write
            elif gcode is not None:
                write = stack.enter_context(atomic_write(gcode, "w", newline="")).write
            self._totals = advise_in_windows(self.path, self.table, step_mm=self.step_mm, cap_mm_min=cap,
                                             feed_step_mm_min=self.feed_step_mm_min, tools=self.tools,
                                             sink=_tee(sinks), write=write,
                                             window_lines=window_lines, on_window=spill)
            if verify:
                from fuzzyfeed.program.verify_windows import verify_windows

                first_handle.close()
                with atomic_write(gcode, "wb") as handle:
                    self.verification = verify_windows(self.path, first, spill, self.tools, window_lines,
                                                       scratch, handle)
        if csv is not None:
            record = provenance(self.table, cap or 0.0, str(self.path), out.rows)
            record["F_mm_min"] = self._feed_note(cap)
            write_metadata(csv, out.names, record)
        if plot is not None:
            self._plot(plot)
        lines = []
        if csv is not None or plot:
            lines.append("wrote " + " and ".join(p for p in (csv, plot) if p))
        if gcode:
            lines.append(f"wrote {gcode}")
        return lines

    def summary(self) -> list[str]:
        t = self._totals
        if t is None:
            return self.whole().summary()
        cap, step = self.options.feed_mm_min, self.feed_step_mm_min
        mean = t.pct_sum / t.pct_count
        return [f"{self.path.name}: {t.lines} lines, {t.moves} moves, {t.cuts} cut(s), {t.cuts} advised; rules "
                f"{self.table.name!r}; F from the program" + (f", capped at {cap:g} mm/min" if cap else ""),
                f"advised fraction of the programmed F  min {t.pct_min:.2f} %  mean {mean:.2f} %  "
                f"max {t.pct_max:.2f} %   (F rounded down to {step:g} mm/min steps)",
                f"feed moves of the advised cuts: {t.time_written_s:.3f} s at the programmed F, "
                f"{t.time_advised_s:.3f} s at the advised F (no acceleration); {t.splits} split points",
                t.coverage().summary(),
                *([self.verification.summary()] if self.verification is not None else [])]

    def figures(self) -> dict:
        t = self._totals
        if t is None:
            return self.whole().figures()
        return {"cuts": t.cuts, "cuts_advised": t.cuts, "time_written_s": t.time_written_s,
                "time_advised_s": t.time_advised_s, "feed_pct_min": t.pct_min,
                "feed_pct_mean": t.pct_sum / t.pct_count, **t.coverage().figures(),
                **({} if self.verification is None else self.verification.figures())}

    def _plot(self, output) -> None:
        if self._trace is None or self._totals is None:
            return self.whole()._plot(output)
        from fuzzyfeed.report.plot_trace import plot_trace

        plot_trace(self._trace, self.table, f"{self.path.name}: {self._totals.cuts} cut(s) end to end", output)


def _tee(sinks):
    """None, or one CSV sink handing each piece's rows to every one of ``sinks``."""
    if not sinks:
        return None
    from fuzzyfeed.io.csv import tee

    return tee(*sinks)


def _need_gcode(gcode) -> None:
    from fuzzyfeed.errors import ExportError

    if not gcode:
        raise ExportError("--verify-rs274 checks the rewritten program: give --gcode OUT.ngc (or a machine)")


def windowed_machine_result(spec, options, path: Path, table, step_mm: float, step: float, tools, whole, checks,
                            feed_note):
    """A :class:`WindowedMachineResult` for a long program on a machine (None: read it whole).
    ``whole()`` makes the whole read's :class:`~fuzzyfeed.advice.machine_program.MachineProgramResult`,
    ``checks(csv, gcode, gcode_g52, plot)`` refuses outputs a program cannot have."""
    if options.verify_rs274 or windowed_lines(path) is None:
        return None
    return WindowedMachineResult(spec, options, path, table, step_mm, step, tools, whole, checks, feed_note)


class WindowedMachineResult(_WindowedResult):
    """A long program on a machine, evaluated in windows when written with ``-o`` and/or ``--gcode``
    (:func:`~fuzzyfeed.program.machine_windows.evaluate_in_windows`: the chains in a scratch store,
    runs part by part; the scratch directory removed on every exit): the CSV rows written as the
    advice makes them, the advised program copied from its scratch file, ``--report`` (the uniform
    slowdown checked and the limit reference, on the store; the plot's trace drawn from it),
    ``--plot`` beside ``-o`` or ``--gcode`` (the value plot of that trace), the summary the whole
    read's, byte for byte. Whatever else is asked of the result (the text, the columns, the value
    report, a plot alone) reads the program whole (``whole()``), as does any window the machine
    path cannot join exactly (:class:`~fuzzyfeed.program.windows.Fallback`)."""

    kind = "program on a machine"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._runs = None
        self.report = None

    @property
    def windowed(self) -> bool:
        """True once the outputs were written window by window."""
        return self._runs is not None

    @property
    def value(self):
        return self.whole().value

    def figures(self) -> dict:
        return self.whole().figures()

    def _plot(self, output) -> None:
        if self.report is not None and self.report.trace is not None:   # drawn by the windows
            from fuzzyfeed.report.value_files import plot_value

            return plot_value(self.report, output)
        return self.whole()._plot(output)

    def _write(self, csv, gcode, gcode_g52, plot, report) -> list[str]:
        if self._whole is None:
            self._checks(csv, gcode, gcode_g52, plot)
        if (csv is None and gcode is None) or self._whole is not None:
            return self.whole()._write(csv, gcode, gcode_g52, plot, report)

        def forget():
            self._runs = self.report = None
        return self._in_windows(lambda: self._write_windows(csv, gcode, report, plot), forget, csv, gcode,
                                gcode_g52, plot, report)

    def _write_windows(self, csv, gcode, report_file=None, plot=None) -> list[str]:
        import shutil
        import sys
        import tempfile

        from fuzzyfeed.base.atomic import atomic_write
        from fuzzyfeed.fuzzy.provenance import provenance
        from fuzzyfeed.io.csv import ColumnStream, write_metadata
        from fuzzyfeed.program.machine_windows import evaluate_in_windows
        from fuzzyfeed.program.windows import WINDOW_LINES
        from functools import partial

        from fuzzyfeed.report.value import windowed_report
        from fuzzyfeed.report.value_trace import feed_trace

        cap, machine = self.options.feed_mm_min, self.options.machine
        tty = sys.stderr.isatty()

        def progress(stage: str) -> None:
            if tty:
                print(f"fuzzyfeed: {self.path.name}: {stage} ...", file=sys.stderr, flush=True)

        with contextlib.ExitStack() as stack:
            scratch = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="fuzzyfeed-machine-")))
            out = None
            if csv is not None:
                out = ColumnStream(stack.enter_context(atomic_write(csv, "w", newline="")), csv)
            runs = evaluate_in_windows(self.path, machine, self.table, scratch, cap_mm_min=cap,
                                       feed_step_mm_min=self.feed_step_mm_min, step_mm=self.step_mm,
                                       tools=self.tools, window_lines=self.window_lines or WINDOW_LINES,
                                       sink=None if out is None else out.write, progress=progress,
                                       check=report_file is not None, reference=self.options.reference,
                                       trace=None if report_file is None and plot is None else partial(
                                           feed_trace, tol_um=machine.contour_tol_um))
            report = windowed_report(runs, self.path.name, machine, self.table, self.options.reference)
            if gcode is not None:
                with atomic_write(gcode, "wb") as handle, open(runs.advised_file, "rb") as src:
                    shutil.copyfileobj(src, handle)
            if plot is not None:
                from fuzzyfeed.report.value_files import plot_value

                plot_value(report, plot)
            if report_file is not None:
                from fuzzyfeed.report.value_files import write_value_report

                write_value_report([report], report_file)
        if csv is not None:
            record = provenance(self.table, cap or 0.0, str(self.path), out.rows)
            record["F_mm_min"] = self._feed_note(cap)
            record["machine"] = machine.describe()
            write_metadata(csv, out.names, record)
        self._runs, self.report = runs, report
        written = [p for p in (csv, gcode, plot, report_file) if p]
        return ["wrote " + ", ".join(written)]

    def summary(self) -> list[str]:
        runs = self._runs
        if runs is None:
            return self.whole().summary()
        left = runs.cuts - len(runs.advised_cuts)
        return [f"{self.path.name}: {runs.lines} lines, {runs.cuts} cut(s); {self.options.machine.describe()}",
                f"advised {len(runs.advised_cuts)} cut(s) that break the tolerance as written; {left} left as written",
                *self.report.lines()]
