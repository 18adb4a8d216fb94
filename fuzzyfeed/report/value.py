"""What advice buys on a machine (issue 32, "Say what it bought"): one program run four ways on the
same controller and servo model (:mod:`fuzzyfeed.program.run`) —

- **as written**: the program's own F words;
- **advised**: the program fuzzyfeed writes (its text read back and run), the cuts that break the
  tolerance as written advised with the table (a machine table by default), the others left alone;
- **uniform**: every F times the one factor that just holds the tolerance
  (:func:`~fuzzyfeed.program.uniform.uniform_slowdown`);
- **limit reference**: feeds lowered piece by piece only where the run breaks the tolerance
  (:func:`~fuzzyfeed.program.reference.limit_reference`).

Each row: cycle time (rapids included) and the largest and 99th-percentile contour error of the
feed moves. When the program as written holds the tolerance its feeds are left alone and the
report says so; where even the limit reference cannot hold it, the report says where. The value
plot's feed trace is :mod:`fuzzyfeed.report.value_trace`'s.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fuzzyfeed.base.memory import release_free_memory
from fuzzyfeed.fuzzy.rules import RuleTable
from fuzzyfeed.machine.description import Machine
from fuzzyfeed.program.coverage import Coverage, program_coverage
from fuzzyfeed.program.verify import Verification
from fuzzyfeed.program.advice_pieces import KEEP_ROWS, AdvisedFeeds, advised_feeds, applied_columns  # noqa: F401
from fuzzyfeed.program.model import Program
from fuzzyfeed.program.read import parse_program
from fuzzyfeed.program.apart import apart_lines
from fuzzyfeed.program.reference import limit_reference
from fuzzyfeed.program.uniform import Uniform, check_uniform, uniform_slowdown
from fuzzyfeed.program.rewrite import rewrite_program
from fuzzyfeed.program.run import ProgramPath, ProgramRun, program_path, run_program, without_plan
from fuzzyfeed.report.value_trace import FeedTrace, feed_trace


@dataclass(frozen=True)
class ValueRow:
    label: str
    time_s: float
    max_um: float
    p99_um: float
    air_um: float = float("nan")     # largest error in the air (the tool nearest a rapid), not in the part

    @classmethod
    def of(cls, label: str, run: ProgramRun) -> ValueRow:
        return cls(label, run.time_s, run.max_um, run.p99_um, run.air_max_um)


@dataclass(frozen=True, eq=False)
class ValueReport:
    name: str
    machine: Machine
    table: str
    written: ValueRow
    advised: ValueRow
    uniform: ValueRow
    uniform_factor: float
    reference: ValueRow | None
    reference_converged: bool
    holds_as_written: bool
    advised_cuts: tuple[int, ...]
    worst_advised: tuple[int, tuple[float, float, float]] | None
    trace: FeedTrace | None = None
    coverage: Coverage | None = None     # the judged part (issue 40): no verdict beyond it
    verification: Verification | None = None   # what rs274 said of the rewrite (--verify-rs274)
    worst_air: tuple[int, tuple[float, float, float]] | None = None
    reference_deferred: bool = False     # the limit reference left to the report (Evaluation.checked)
    uniform_apart: tuple = ()            # places no uniform factor holds (program/apart.Apart), left out of its row
    reference_apart: bool = False        # the limit reference's largest error is on a line of those places

    @property
    def partial(self) -> bool:
        """Part of the program's feed moves were not judged (see :mod:`fuzzyfeed.program.coverage`)."""
        return self.coverage is not None and not self.coverage.complete

    @property
    def tol_um(self) -> float:
        return self.machine.contour_tol_um

    @property
    def rows(self) -> list[ValueRow]:
        rows = [self.written, self.advised, self.uniform]
        return rows + ([self.reference] if self.reference is not None else [])

    def lines(self) -> list[str]:
        """The report as text: one row per run, then the verdict."""
        tol = self.tol_um
        out = [f"{self.name}: value on machine {self.machine.name!r} (contour tolerance {tol:g} um), "
               f"rules {self.table!r}",
               f"  {'':24s} {'time (s)':>10s} {'max (um)':>10s} {'p99 (um)':>10s}"]
        for r in self.rows:
            flag = "  over" if r.max_um > tol * (1 + 1e-9) else ""
            p99 = f"{r.p99_um:10.1f}" if np.isfinite(r.p99_um) else f"{'-':>10s}"
            out.append(f"  {r.label:24s} {r.time_s:10.2f} {r.max_um:10.1f} {p99}{flag}")
        if self.coverage is not None:
            out.append("  " + self.coverage.summary())
        if self.verification is not None:
            out.append("  " + self.verification.summary())
        out.append("  " + self.verdict())
        air = self.air_line()
        if air:
            out.append("  " + air)
        out.extend("  " + line for line in self.apart_lines(APART_SHOWN))
        if self.reference_deferred:
            out.append("  limit reference: not run (--report runs it)")
        if self.uniform.label.endswith(UNCHECKED):
            out.append(f"  {UNCHECKED} uniform: the factor the stretches over the tolerance hold (time from the "
                       "planner, max of those stretches, no p99); not checked by a run of the whole program "
                       "at that factor (--report runs it)")
        elif self.uniform.label.endswith(UNCHECKED + " (at least)"):
            out.append(f"  {UNCHECKED} uniform: the error does not come down with the feed there (at half the "
                       "factor it stayed above 0.9 of itself): the search stopped at this bound (--report "
                       "searches on)")
        return out

    def apart_lines(self, shown: int | None = None) -> list[str]:
        """The places the uniform slowdown set apart (:func:`~fuzzyfeed.program.apart.apart_lines`)."""
        return apart_lines(self.uniform_apart, shown)

    def air_line(self) -> str:
        """Where the rows' errors are: max and p99 are in the part (the tool nearest a feed move);
        the largest error in the air (the tool still nearest a rapid it lags behind, as the next
        feed move starts) is said apart, with where, when it passes the tolerance (as written or
        advised); an error in the air within the tolerance is not worth a line."""
        w, a = self.written, self.advised
        if not (w.air_um > self.tol_um or a.air_um > self.tol_um):
            return ""
        text = (f"in the air (tool still nearest a rapid when a feed move starts; not in the part, no F changes "
                f"it): as written {w.air_um:.1f} um, advised {a.air_um:.1f} um")
        if self.worst_air is not None:
            text += f", largest at {self._where(*self.worst_air)}"
        return text

    def _where(self, line: int, xyz) -> str:
        """'line N (x, y, z)' of a place in the run the figures are of: the advised program's line
        once the program is advised (the rewrite inserts lines: the input's numbers would mislead)."""
        of = "" if self.holds_as_written else " of the advised program"
        return f"line {line + 1}{of} ({', '.join(f'{c:g}' for c in xyz)})"

    def verdict(self) -> str:
        tol = self.tol_um
        w, a, u = self.written, self.advised, self.uniform
        cov = self.coverage
        if self.holds_as_written and self.partial:
            return (f"as written the judged part ({cov.length_share()}) holds the tolerance "
                    f"(max {w.max_um:.1f} um <= {tol:g} um): its feeds are left alone; not judged: "
                    f"{cov.not_judged_text()}")
        if self.holds_as_written:
            return (f"as written the program holds the tolerance (max {w.max_um:.1f} um <= {tol:g} um): "
                    "its feeds are left alone")
        at_most = "at most " if u.label.endswith("(at least)") else ""
        parts = [f"advised: {a.time_s / w.time_s:.2f} x the time as written, "
                 f"{at_most}{a.time_s / u.time_s:.2f} x the uniform slowdown"]
        if self.reference is not None:
            parts.append(f"{a.time_s / self.reference.time_s:.2f} x the limit reference")
        text = ", ".join(parts)
        if a.max_um <= tol * (1 + 1e-9) and self.partial:
            text += f"; holds the tolerance on the judged part ({cov.length_share()})"
        elif a.max_um <= tol * (1 + 1e-9):
            text += "; holds the tolerance"
        elif self.worst_advised is not None:
            text += f"; {a.max_um:.1f} um at {self._where(*self.worst_advised)} is over the tolerance"
        if self.reference is not None and not self.reference_converged:
            if self.reference_apart:
                text += (f"; the limit reference ends at {self.reference.max_um:.1f} um at a place the uniform "
                         "slowdown sets apart (no feed holds it there)")
            elif a.max_um <= tol * (1 + 1e-9) or u.max_um <= tol * (1 + 1e-9):
                text += f"; the limit reference stopped at {self.reference.max_um:.1f} um (its passes ran out)"
            else:
                text += (f"; even the limit reference ends at {self.reference.max_um:.1f} um: no feed holds "
                         "the tolerance there")
        if self.partial:
            text += f"; not judged: {cov.not_judged_text()}"
        return text

    def csv_row(self) -> dict[str, object]:
        row: dict[str, object] = {"program": self.name, "machine": self.machine.name,
                                  "contour_tol_um": self.tol_um, "rules": self.table,
                                  "holds_as_written": self.holds_as_written,
                                  "uniform_factor": self.uniform_factor}
        row["uniform_is_bound"] = self.uniform.label.endswith("(at least)")
        row["uniform_set_apart"] = len(self.uniform_apart)
        row["uniform_set_apart_max_um"] = max((p.floor_um for p in self.uniform_apart), default=0.0)
        for key, r in (("written", self.written), ("advised", self.advised), ("uniform", self.uniform),
                       ("reference", self.reference)):
            row[f"{key}_time_s"] = r.time_s if r is not None else float("nan")
            row[f"{key}_max_um"] = r.max_um if r is not None else float("nan")
            row[f"{key}_p99_um"] = r.p99_um if r is not None else float("nan")
        if self.coverage is not None:
            row.update(self.coverage.figures())
        if self.verification is not None:
            row.update(self.verification.figures())
        return row


def cuts_over(run: ProgramRun, tol_um: float) -> list[int]:
    """The cuts whose largest contour error as run is over the tolerance."""
    return [int(k) for k in np.flatnonzero(run.cut_max_um() > tol_um)]


#: The mark of a uniform row found on the hot stretches and not checked by a whole run.
UNCHECKED = "*"
#: Places set apart by the uniform slowdown listed in the text report (the HTML lists them all).
APART_SHOWN = 5


def uniform_row(u: Uniform) -> ValueRow:
    """The uniform slowdown's row: checked by a whole run, or a bound, or from the hot stretches
    (no p99; marked :data:`UNCHECKED` when no whole run checked it)."""
    if u.bounded:
        mark = "" if u.checked else UNCHECKED
        return ValueRow(f"uniform x<{_factor(u.factor)}{mark} (at least)", u.time_s, float("nan"), float("nan"))
    if u.run is None:
        mark = "" if u.checked else UNCHECKED
        return ValueRow(f"uniform x{_factor(u.factor)}{mark}", u.time_s, u.max_um, float("nan"))
    if u.apart:              # its max outside the places set apart (ValueReport.apart_lines)
        return ValueRow(f"uniform x{_factor(u.factor)}", u.run.time_s, u.max_um, u.run.p99_um, u.run.air_max_um)
    return ValueRow.of(f"uniform x{_factor(u.factor)}", u.run)


@dataclass(frozen=True, eq=False)
class Evaluation:
    """A program advised for a machine: the advice of every cut (:class:`AdvisedFeeds`), which cuts
    it is applied to (those that break the tolerance as written), the program text to write and the
    report. ``uniform`` and ``path``: the uniform slowdown and the written program's path, kept when
    the uniform row is not yet checked by a whole run (:meth:`checked`)."""

    advice: AdvisedFeeds
    advised_cuts: tuple[int, ...]
    text: str
    report: ValueReport
    uniform: Uniform | None = None
    path: ProgramPath | None = None

    def checked(self) -> Evaluation:
        """This evaluation with the uniform slowdown checked by a whole run
        (:func:`~fuzzyfeed.program.uniform.check_uniform`) and the limit reference run, where
        :func:`evaluate_program` left them (``check_uniform=False``); itself when nothing is left."""
        u, r = self.uniform, self.report
        if self.path is None:
            return self
        if u is not None and not u.checked:
            u = check_uniform(self.path, r.machine, u)
            if u.run is not None:      # its rows, not its plans (~0.1 KB a segment), during the reference
                u = replace(u, run=ProgramRun(u.run.path, u.run.machine,
                                              tuple(without_plan(c) for c in u.run.runs)))
            r = replace(r, uniform=uniform_row(u), uniform_factor=u.factor, uniform_apart=u.apart)
        if r.reference_deferred:
            ref = limit_reference(self.path, r.machine)
            r = replace(r, reference=ValueRow.of("limit reference", ref.run), reference_converged=ref.converged,
                        reference_apart=_at_apart(ref.run, r.uniform_apart),
                        reference_deferred=False)
            del ref
            release_free_memory()      # the passes' freed heap, before the CSV rows are made again
        return replace(self, report=r, uniform=u, path=None)

    def column_pieces(self):
        """The CSV columns (:func:`~fuzzyfeed.program.feeds.advice_columns`) plus ``advised``: 1 on
        the cuts the advice is applied to; on the others feed_pct is 100 and feed_mm_min the F;
        piece by piece, in sample order."""
        for cols in self.advice.pieces():
            yield applied_columns(cols, self.advised_cuts)

    def columns(self) -> dict[str, np.ndarray]:
        """:meth:`column_pieces` end to end."""
        parts = list(self.column_pieces())
        return {name: np.concatenate([p[name] for p in parts]) for name in parts[0]}


def evaluate_program(program: Program, machine: Machine, table: RuleTable, *, cap_mm_min: float | None = None,
                     feed_step_mm_min: float = 10.0, step_mm: float = 0.25, min_piece_mm: float = 1.0,
                     cuts: list[int] | None = None, reference: bool = True, progress=None,
                     max_ticks: float | None = None, verify=None, tools: dict | None = None,
                     check_uniform: bool = True, sink=None) -> Evaluation:
    """Advise ``program`` for ``machine`` and measure what it bought (module docstring): the cuts
    (of ``cuts``, default all) that break the tolerance as written get the advice, the others keep
    their feeds. ``progress(step)`` is called with a short name before each stage. ``max_ticks``
    bounds the servo periods of the uniform slowdown's checking run (beyond it the row takes the
    planner's time and the largest error of the hot stretches, and no p99).
    ``verify(program, move, end, feed) -> (text, Verification)`` replaces the plain rewrite (rs274's
    check, :func:`fuzzyfeed.program.verify.verified_rewrite`): the advised run is of its text.
    ``tools``: the tool table the program was read with (the advised text is read with it too, so
    its compensated moves are the tool centre's path as the written program's are).
    ``check_uniform=False`` leaves the uniform slowdown's checking run (a whole run at the factor,
    1/factor times the program's time: the longest of all) and the limit reference (``reference``)
    to :meth:`Evaluation.checked` (what ``advise --machine`` does without ``--report``): the uniform
    row is then marked :data:`UNCHECKED` (time from the planner, max of the hot stretches, no p99)
    and the report has no limit reference row, saying so. ``sink(columns)``: each piece's CSV
    columns (:meth:`Evaluation.column_pieces`' rows) as the advice makes them (the advice runs once)."""
    step = progress or (lambda _name: None)
    tol = machine.contour_tol_um
    step("as written")
    path = program_path(program, machine.chord_tol_mm)
    # its rows, times and hot segments, not its plans (~0.1 KB a segment): the uniform slowdown
    # plans its trials afresh at each factor
    written = run_program(path, machine, keep_plans=False)
    chosen = list(range(program.n_cuts)) if cuts is None else list(cuts)
    over = [k for k in cuts_over(written, tol) if k in chosen]
    step("advice")
    pa = advised_feeds(program, table, machine, chosen, cap_mm_min=cap_mm_min, step_mm=step_mm,
                       feed_step_mm_min=feed_step_mm_min, min_piece_mm=min_piece_mm,
                       sink=None if sink is None else (lambda cols: sink(applied_columns(cols, over))))
    release_free_memory()
    keep = np.isin(program.cut[pa.piece_move], over) if pa.piece_move.size else np.zeros(0, bool)
    checked = None
    if verify is None:
        text = rewrite_program(program, pa.piece_move[keep], pa.piece_end[keep], pa.piece_feed_mm_min[keep])
    else:
        step("rs274")
        text, checked = verify(program, pa.piece_move[keep], pa.piece_end[keep], pa.piece_feed_mm_min[keep])
    u, ref_apart = None, False
    if not over:
        uniform_factor, u_row = 1.0, ValueRow.of(f"uniform x{_factor(1.0)}", written)
        ref_row, converged = (ValueRow.of("limit reference", written) if reference else None), True
        advised_row, worst, air = ValueRow.of("advised", written), written.worst(), written.worst_air()
        trace = feed_trace(path, written, path, tol)
    else:
        step("advised run")
        advised_path = program_path(_advised_model(program, text, tools, verify is None, pa.piece_move[keep],
                                                   pa.piece_end[keep], pa.piece_feed_mm_min[keep]),
                                    machine.chord_tol_mm)
        advised_run = run_program(advised_path, machine, keep_plans=False)   # reported, not searched on
        # what the report takes of the advised run, then the run and its path go (a 10⁶-move
        # program: ~0.2 GB) before the uniform slowdown's search
        advised_row, worst, air = ValueRow.of("advised", advised_run), advised_run.worst(), advised_run.worst_air()
        trace = feed_trace(path, written, advised_path, tol)
        del advised_run, advised_path
        release_free_memory()
        step("uniform slowdown")
        u = uniform_slowdown(path, machine, written, check=check_uniform,
                             **({} if max_ticks is None else {"max_ticks": max_ticks}))
        uniform_factor, u_row = u.factor, uniform_row(u)
        ref_row, converged, ref_apart = None, True, False
        if reference and check_uniform:
            step("limit reference")
            ref = limit_reference(path, machine)
            ref_row, converged = ValueRow.of("limit reference", ref.run), ref.converged
            ref_apart = _at_apart(ref.run, u.apart)
            del ref
            release_free_memory()      # the passes' freed heap, before the CSV rows are made again
    report = ValueReport(
        name=program.path.name, machine=machine, table=table.name,
        written=ValueRow.of("as written", written),
        advised=advised_row,
        uniform=u_row,
        uniform_factor=uniform_factor, reference=ref_row, reference_converged=converged,
        holds_as_written=not over, advised_cuts=tuple(over),
        worst_advised=None if worst is None else (worst[0], tuple(float(c) for c in worst[1])),
        trace=trace, coverage=program_coverage(program),
        verification=checked, worst_air=None if air is None else (air[0], tuple(float(c) for c in air[1])),
        reference_deferred=bool(over) and reference and not check_uniform,
        uniform_apart=() if u is None else u.apart, reference_apart=ref_apart)
    pending = (u is not None and not u.checked) or report.reference_deferred
    return Evaluation(advice=pa, advised_cuts=tuple(over), text=text, report=report,
                      uniform=u if pending else None, path=path if pending else None)


def _at_apart(run: ProgramRun, apart: tuple) -> bool:
    """The largest error of ``run`` (the limit reference's) is on a program line of a place set apart."""
    worst = run.worst()
    return bool(apart) and worst is not None and worst[0] in {p.line for p in apart}


def _advised_model(program: Program, text: str, tools, plain: bool, *pieces) -> Program:
    """The advised program's model: built from the written one when the text is the plain rewrite
    and :func:`~fuzzyfeed.program.advised.advised_program` reproduces it, else the text read back."""
    if plain:
        from fuzzyfeed.program.advised import advised_program

        model = advised_program(program, *pieces)
        if model is not None:
            return model
    return parse_program(text, program.path, tools)


def _factor(c: float) -> str:
    """A uniform factor as printed: three decimals, or three significant digits below 0.01."""
    return f"{c:.3f}" if c >= 0.01 else f"{c:.3g}"


def windowed_report(runs, name: str, machine: Machine, table: RuleTable, reference: bool = True) -> ValueReport:
    """The value report :func:`evaluate_program` (``check_uniform=False``) makes, of a program
    evaluated in windows (``runs``: :class:`~fuzzyfeed.program.machine_windows.WindowedRuns`), or,
    when the windows checked the uniform slowdown and ran the limit reference on the store
    (``evaluate_in_windows(check=True)``), the one :meth:`Evaluation.checked` makes; the feed
    trace when the windows drew it (:func:`~fuzzyfeed.report.value_trace.feed_trace` on the store)."""
    written, over, u = runs.written, runs.advised_cuts, runs.uniform
    ref_row, converged = None, True
    if not over:
        uniform_factor, u_row = 1.0, ValueRow.of(f"uniform x{_factor(1.0)}", written)
        ref_row = ValueRow.of("limit reference", written) if reference else None
        advised_row = ValueRow.of("advised", written)
    else:
        advised_row = ValueRow.of("advised", runs.advised)
        uniform_factor, u_row = u.factor, uniform_row(u)
        if runs.reference is not None:
            ref_row, converged = ValueRow.of("limit reference", runs.reference.run), runs.reference.converged
    worst, air = runs.worst, runs.air
    return ValueReport(
        name=name, machine=machine, table=table.name,
        written=ValueRow.of("as written", written), advised=advised_row, uniform=u_row,
        uniform_factor=uniform_factor, reference=ref_row, reference_converged=converged,
        holds_as_written=not over, advised_cuts=tuple(over),
        worst_advised=None if worst is None else (worst[0], tuple(float(c) for c in worst[1])),
        trace=runs.trace, coverage=runs.coverage, verification=None,
        worst_air=None if air is None else (air[0], tuple(float(c) for c in air[1])),
        reference_deferred=bool(over) and reference and runs.reference is None,
        uniform_apart=() if u is None else u.apart, reference_apart=False)
