"""A G-code program advised on a machine, read whole (``advise PROGRAM --machine M``): run as written,
the cuts that break the tolerance advised, the value report
(:func:`~fuzzyfeed.report.value.evaluate_program`); a long one is read in windows instead
(:mod:`fuzzyfeed.advice.program_windows`)."""

from __future__ import annotations

import sys

import numpy as np

from fuzzyfeed.advice.program_outputs import check_outputs, feed_note, verifier, write_text
from fuzzyfeed.advice.result import AdviceResult


def machine_result(spec, options, program, table, cap, step, step_mm, cuts, tools):
    """The :class:`MachineProgramResult` of ``program`` read whole (its evaluation made when needed)."""
    from fuzzyfeed.report.value import evaluate_program

    machine = options.machine
    tty = sys.stderr.isatty()

    def progress(stage: str) -> None:
        if tty:
            print(f"fuzzyfeed: {program.path.name}: {stage} ...", file=sys.stderr, flush=True)

    verify = verifier(options, tools)

    def evaluate(sink=None):
        return evaluate_program(program, machine, table, cap_mm_min=cap, feed_step_mm_min=step,
                                step_mm=step_mm, cuts=cuts, reference=options.reference,
                                progress=progress, verify=verify, tools=tools, check_uniform=False,
                                sink=sink)
    return MachineProgramResult(spec, options, program, evaluate)


class MachineProgramResult(AdviceResult):
    """A program on a machine: run as written, the cuts that break the tolerance advised, the
    value report (``.value``). The evaluation (:func:`~fuzzyfeed.report.value.evaluate_program`)
    runs when first needed: by :meth:`write` with a CSV, which takes its rows as the advice makes
    them (the advice runs once), else by whatever asks first. The uniform slowdown's checking run
    (a whole run at its factor) and the limit reference are made when the report is asked for:
    ``.value``, ``figures()`` or ``--report`` (not for the plot); the summary printed without them
    marks the uniform row as not checked (:data:`~fuzzyfeed.report.value.UNCHECKED`) and says the
    limit reference was not run."""

    kind = "program on a machine"

    def __init__(self, source, options, program, evaluate):
        self.source, self.options, self.program = source, options, program
        self._evaluate = evaluate     # (sink=None) -> Evaluation
        self._evaluation = None
        self._columns = None
        self._feed_pct = None         # (min, mean) of the CSV's feed_pct, when the rows streamed

    @property
    def evaluation(self):
        if self._evaluation is None:
            self._evaluation = self._evaluate()
        return self._evaluation

    @evaluation.setter
    def evaluation(self, value) -> None:
        self._evaluation = value

    @property
    def text(self) -> str:
        return self.evaluation.text

    @property
    def value(self):
        self.evaluation = self.evaluation.checked()
        return self.evaluation.report

    def columns(self) -> dict:
        if self._columns is None:
            self._columns = self.evaluation.columns()
        return self._columns

    def summary(self) -> list[str]:
        ev, program, machine = self.evaluation, self.program, self.options.machine
        left = program.n_cuts - len(ev.advised_cuts)
        return [f"{program.path.name}: {len(program.lines)} lines, {program.n_cuts} cut(s); {machine.describe()}",
                f"advised {len(ev.advised_cuts)} cut(s) that break the tolerance as written; {left} left as written",
                *ev.report.lines()]

    def figures(self) -> dict:
        r, ev = self.value, self.evaluation
        if self._feed_pct is None:
            columns = self.columns()
            self._feed_pct = (float(columns["feed_pct"].min()), float(columns["feed_pct"].mean()))
        row = {k: v for k, v in r.csv_row().items() if k not in ("program", "written_time_s", "advised_time_s")}
        return {"cuts": self.program.n_cuts, "cuts_advised": len(ev.advised_cuts), "time_written_s": r.written.time_s,
                "time_advised_s": r.advised.time_s, "feed_pct_min": self._feed_pct[0],
                "feed_pct_mean": self._feed_pct[1], **row}

    def _write(self, csv, gcode, gcode_g52, plot, report) -> list[str]:
        from fuzzyfeed.fuzzy.provenance import provenance
        from fuzzyfeed.io.csv import write_metadata

        check_outputs(csv, gcode, gcode_g52, plot)
        cap, machine = self.options.feed_mm_min, self.options.machine
        if csv is not None:              # rows written as the pieces come
            from fuzzyfeed.base.atomic import atomic_write
            from fuzzyfeed.io.csv import ColumnStream

            with atomic_write(csv, "w", newline="") as handle:
                out = ColumnStream(handle, csv)
                if self._evaluation is None:      # the advice made now, its rows written as they come
                    pct = _FeedPct(out.write)
                    self._evaluation = self._evaluate(sink=pct)
                    self._feed_pct = pct.figures()
                else:                             # made before: its rows made again, piece by piece
                    for part in (self.evaluation.column_pieces() if self._columns is None else [self._columns]):
                        out.write(part)
            record = provenance(self.options.table, cap or 0.0, str(self.program.path), out.rows)
            record["F_mm_min"] = feed_note(cap)
            record["machine"] = machine.describe()
            write_metadata(csv, out.names, record)
        if report:
            self.evaluation = self.evaluation.checked()
        if gcode:
            write_text(gcode, self.text)
        if plot:
            self.plot(plot)
        if report:
            from fuzzyfeed.report.value_files import write_value_report

            write_value_report([self.value], report)
        written = [p for p in (csv, gcode, plot, report) if p]
        return ["wrote " + ", ".join(written)] if written else []

    def _plot(self, output) -> None:
        from fuzzyfeed.report.value_files import plot_value

        plot_value(self.evaluation.report, output)

    def report_html(self) -> str:
        """The value report as one HTML page (``--report FILE.html``)."""
        from fuzzyfeed.report.value_files import report_table_html

        return report_table_html([self.value])


class _FeedPct:
    """A CSV sink passing each piece on to ``write`` and keeping the feed_pct column's min and mean."""

    def __init__(self, write):
        self.write, self.low, self.total, self.count = write, np.inf, 0.0, 0

    def __call__(self, cols: dict) -> None:
        self.write(cols)
        pct = np.asarray(cols["feed_pct"])
        if pct.size:
            self.low = min(self.low, float(pct.min()))
            self.total += float(np.sum(pct))
            self.count += pct.size

    def figures(self) -> tuple[float, float] | None:
        return None if self.count == 0 else (self.low, self.total / self.count)
