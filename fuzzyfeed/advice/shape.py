"""A shape, a drawing's contour or a point list advised (seed 002's controller, or the machine
table on a machine): sampled, :func:`~fuzzyfeed.fuzzy.advisor.advise_details`, one CSV row per
point; a drawing with several paths advised path by path into one CSV (column ``path``)."""

from __future__ import annotations

import numpy as np

from fuzzyfeed.advice.options import AdviceOptions
from fuzzyfeed.advice.result import AdviceResult
from fuzzyfeed.errors import ExportError, InputError, MachineLimitsError
from fuzzyfeed.machine.limits import DEFAULT_FEED_MM_S

#: Default maximum feed F (mm/min) of a shape when ``feed_mm_min`` is not given: the machine default's.
DEFAULT_FEED_MM_MIN = DEFAULT_FEED_MM_S * 60.0


def shape_feed_mm_min(options: AdviceOptions) -> float:
    """A shape's F: ``feed_mm_min``, else :data:`DEFAULT_FEED_MM_MIN`."""
    return DEFAULT_FEED_MM_MIN if options.feed_mm_min is None else options.feed_mm_min


def advise_path(samples, options: AdviceOptions, max_feed_mm_s: float | None = None):
    """The advice on one sampled path (:class:`~fuzzyfeed.fuzzy.advisor.FuzzyAdvice`) with the
    options' table and machine at F = ``max_feed_mm_s`` (default: the options' F): the one place
    a shape, a drawing's paths and the designer's path are advised."""
    from fuzzyfeed.fuzzy.advisor import advise_details

    feed = shape_feed_mm_min(options) / 60.0 if max_feed_mm_s is None else max_feed_mm_s
    return advise_details(samples, options.table, feed, machine=options.machine)


def _samples(shape, options: AdviceOptions):
    from fuzzyfeed.geometry.sampling import POINT_STEP_MM
    from fuzzyfeed.io.shapes import sample_shape

    return sample_shape(shape, options.points, max_step_mm=POINT_STEP_MM)


def advise_shape_file(spec: str, options: AdviceOptions) -> AdviceResult:
    """Every path of ``spec`` (a drawing's contours; the one path of any other file or of
    ``FILE#SELECTOR``) advised with ``options``."""
    from fuzzyfeed.io.shapes import load_shape, load_shapes, split_selector

    if options.step_mm is not None:
        raise MachineLimitsError("--step-mm applies to G-code programs only; shapes take --points")
    if not options.reference:
        raise MachineLimitsError(f"--no-reference: the value report runs a G-code program on a machine; "
                                 f"{spec} is not a program")
    if options.tool_table is not None:
        raise ExportError("--tool-table applies to G-code programs only (cutter compensation)")
    if options.verify_rs274:
        raise ExportError("--verify-rs274 applies to G-code programs only (it checks the rewritten program)")
    _, selector = split_selector(spec)
    shapes = None if selector is not None else load_shapes(spec)
    if shapes is not None and len(shapes) > 1:
        return PathsResult(spec, options, shapes)
    shape = load_shape(spec) if not shapes else shapes[0]
    try:
        advice = advise_path(_samples(shape, options), options)
    except InputError as exc:  # the message names the user's file
        raise InputError(f"{spec}: {exc}") from None
    return ShapeResult(spec, options, shape, advice)


def advice_columns(advice, rule_strengths: bool = False) -> dict[str, np.ndarray]:
    """The CSV columns of a fuzzy advice, units in the names (plus w_K_D per rule if asked)."""
    profile = advice.profile
    cols = dict(profile.samples.columns())
    cols.update(advice.term_columns(profile.max_feed_mm_s * 60.0))
    cols["feed_pct"] = profile.feed_pct
    cols["feed_mm_min"] = profile.feed_mm_min
    if rule_strengths:
        _, w = advice.rule_strengths()
        for n, (k, d, _) in enumerate(advice.table.rules):
            cols[f"w_{k}_{d}"] = w[:, n]
    return cols


def summary(shape_name: str, advice) -> str:
    p = advice.profile
    f = p.feed_mm_min
    pct = p.feed_pct
    t = p.travel_time_s()
    t_const = p.samples.length / p.max_feed_mm_s
    return "\n".join([
        f"{shape_name}: {len(p.samples)} points, length {p.samples.length:.3f} mm, rules "
        f"{advice.table.name!r}, F = {p.max_feed_mm_s * 60:g} mm/min",
        f"feed mm/min  min {f.min():.1f}  mean {f.mean():.1f}  max {f.max():.1f}   "
        f"(% of F: {pct.min():.2f} / {pct.mean():.2f} / {pct.max():.2f})",
        f"time at the advised feeds {t:.4f} s  (at constant F: {t_const:.4f} s)",
        _filter_line(advice),
    ])


def _filter_line(advice) -> str:
    """Smoothness before and after the filter, and the feed at the curvature peaks against the
    controller's (issue 12: a filter must not speed up a corner)."""
    from fuzzyfeed.fuzzy.filters import curvature_peaks

    table = advice.table
    raw, pct = advice.controller_pct, advice.feed_pct
    size = f"{table.filter_mm:g} mm" if table.filter_mm else f"{table.filter_points} points"
    steps = (f"{np.abs(np.diff(raw)).max():.2f} % -> {np.abs(np.diff(pct)).max():.2f} %"
             if raw.size > 1 else "n/a")
    peaks = curvature_peaks(advice.features.curvature_1_mm)
    above = float((pct[peaks] - np.maximum(raw[peaks], table.feed_floor_pct)).max())
    corners = ("never above the controller at a curvature peak" if above <= 1e-9 else
               f"up to {above:.2f} % above the controller at a curvature peak")
    return f"{table.filter} filter over {size}: largest point-to-point change {steps}; {corners}"


def _figures(paths: int, times_s, feed_pct: np.ndarray) -> dict:
    """The summary figures of a shape or drawing (time as written: every path at the constant F)."""
    return {"cuts": paths, "cuts_advised": paths, "time_written_s": float(times_s[0]),
            "time_advised_s": float(times_s[1]), "feed_pct_min": float(feed_pct.min()),
            "feed_pct_mean": float(feed_pct.mean())}


def _refuse_report(spec: str, report) -> None:
    if report is not None:
        raise MachineLimitsError(f"--report: the value report runs a G-code program on a machine; "
                                 f"{spec} is not a program")


class ShapeResult(AdviceResult):
    """One path advised; ``.text`` is it written as a program (``--gcode``)."""

    kind = "shape"

    def __init__(self, source, options, shape, advice):
        self.source, self.options, self.shape, self.advice = source, options, shape, advice

    def _notes(self) -> tuple[str, ...]:
        return (f"rules {self.advice.table.name!r}; F = {self.advice.profile.max_feed_mm_s * 60:g} mm/min "
                "(feed % refers to it)",)

    def _settings(self):
        from fuzzyfeed.advice.gcode import GcodeSettings

        o = self.options
        return GcodeSettings(feed_step_mm_min=o.feed_step_mm_min, line_numbers=o.line_numbers,
                             g52_whole=o.g52_whole, gcode_decimals=o.gcode_decimals, safe_z_mm=o.safe_z_mm,
                             plunge_feed_mm_min=o.plunge_feed_mm_min)

    @property
    def text(self) -> str:
        from fuzzyfeed.advice.gcode import prepare_gcode

        prepared = prepare_gcode(self._settings(), self.advice.profile, self.shape, self._notes(), gcode="OUT.ngc")
        return prepared.files[0][1]

    def columns(self) -> dict:
        return advice_columns(self.advice, self.options.rule_strengths)

    def summary(self) -> list[str]:
        return summary(self.shape.name, self.advice).split("\n")

    def figures(self) -> dict:
        p = self.advice.profile
        return _figures(1, (p.samples.length / p.max_feed_mm_s, p.travel_time_s()), p.feed_pct)

    def provenance(self) -> dict[str, str]:
        """Which table, F and tool path made this advice (CSV sidecar, G-code header)."""
        from fuzzyfeed.fuzzy.provenance import provenance

        shape, advice = self.shape, self.advice
        source = str(shape.path) if getattr(shape, "path", None) else str(self.source)
        if getattr(shape, "source", ""):
            source += f" ({shape.source})"
        return provenance(advice.table, advice.profile.max_feed_mm_s * 60.0, source,
                          len(advice.profile.samples))

    def _write(self, csv, gcode, gcode_g52, plot, report) -> list[str]:
        from fuzzyfeed.advice.gcode import prepare_gcode
        from fuzzyfeed.io.csv import write_columns, write_metadata

        _refuse_report(self.source, report)
        prepared = prepare_gcode(self._settings(), self.advice.profile, self.shape, self._notes(),
                                 output=csv, gcode=gcode, gcode_g52=gcode_g52)   # checked before any file
        lines = []
        if csv is not None:
            columns = self.columns()
            write_columns(csv, columns)
            meta = write_metadata(csv, list(columns), self.provenance())
            lines.append(f"wrote {csv}" + (f" ({meta}: rules, F, source)" if meta else "")
                         + (f" and {plot}" if plot else ""))
        elif plot:
            lines.append(f"wrote {plot}")
        if plot:
            self.plot(plot)
        lines += [f"wrote {path}" for path in prepared.write()]
        return lines

    def _plot(self, output) -> None:
        from fuzzyfeed.report.plot import plot_fuzzy_advice

        plot_fuzzy_advice(self.advice, self.shape.name, output)


class PathsResult(AdviceResult):
    """A drawing's several paths, each advised as a shape; one CSV with a ``path`` column."""

    kind = "drawing"

    def __init__(self, source, options, shapes):
        self.source, self.options, self.shapes = source, options, shapes
        feed = shape_feed_mm_min(options)
        self.feed_mm_min = feed
        self.advice = [advise_path(_samples(shape, options), options) for shape in shapes]

    def columns(self) -> dict:
        parts = []
        for number, advice in enumerate(self.advice, start=1):
            cols = advice_columns(advice, self.options.rule_strengths)
            parts.append({"path": np.full(len(advice.profile.samples), number), **cols})
        return {name: np.concatenate([part[name] for part in parts]) for name in parts[0]}

    def summary(self) -> list[str]:
        lines = [f"{self.source}: {len(self.shapes)} paths, rules {self.options.table.name!r}, "
                 f"F = {self.feed_mm_min:g} mm/min"]
        for number, (shape, advice) in enumerate(zip(self.shapes, self.advice), start=1):
            p = advice.profile
            lines.append(f"path {number} {shape.name}: {len(p.samples)} points, length "
                         f"{p.samples.length:.3f} mm, feed mm/min min {p.feed_mm_min.min():.1f} mean "
                         f"{p.feed_mm_min.mean():.1f} max {p.feed_mm_min.max():.1f}, time "
                         f"{p.travel_time_s():.4f} s")
        return lines

    def figures(self) -> dict:
        times = np.zeros((len(self.shapes), 2))
        for k, advice in enumerate(self.advice):
            p = advice.profile
            times[k] = p.samples.length / p.max_feed_mm_s, p.travel_time_s()
        return _figures(len(self.shapes), times.sum(axis=0), self.columns()["feed_pct"])

    def _write(self, csv, gcode, gcode_g52, plot, report) -> list[str]:
        from fuzzyfeed.fuzzy.provenance import provenance
        from fuzzyfeed.io.csv import write_columns, write_metadata

        _refuse_report(self.source, report)
        for option, value in (("--gcode", gcode), ("--gcode-g52", gcode_g52), ("--plot", plot)):
            if value:
                raise ExportError(f"{option}: {self.source} holds {len(self.shapes)} paths; {option} writes "
                                  f"one path, pick it with {self.source}#path=N")
        if csv is None:
            return []
        columns = self.columns()
        write_columns(csv, columns)
        write_metadata(csv, list(columns), provenance(self.options.table, self.feed_mm_min,
                                                      f"{self.source} ({len(self.shapes)} paths)",
                                                      columns["path"].size))
        return [f"wrote {csv}"]
