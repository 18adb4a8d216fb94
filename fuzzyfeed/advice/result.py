"""What :func:`~fuzzyfeed.advice.pipeline.advise_file` returns: one :class:`AdviceResult` per kind
of file (a program, a program run on a machine, a program with nothing to advise, a drawing's
paths, one shape), each with the advised program text (``.text``), the per-point table
(:meth:`~AdviceResult.frame`, a pandas DataFrame; the CSV's columns), the value report on a machine
(``.value``), :meth:`~AdviceResult.write` (CSV and its sidecar, G-code, plot, value report, in one
output transaction of :mod:`fuzzyfeed.base.outputs`), :meth:`~AdviceResult.plot` and a rich
``_repr_html_`` for notebooks."""

from __future__ import annotations

import functools
import html
import os
from dataclasses import dataclass

#: write()'s keywords and the flag each is named by in messages, in the command's order.
OUTPUT_FLAGS = {"csv": "-o", "gcode": "--gcode", "gcode_g52": "--gcode-g52", "plot": "--plot",
                "report": "--report"}


def _path(value) -> str | None:
    return None if value is None else os.fspath(value)


@dataclass(frozen=True, eq=False)
class PNG:
    """A picture's PNG bytes, shown inline by notebooks."""

    data: bytes

    def _repr_png_(self) -> bytes:
        return self.data


def _in_settings(member):
    """``member`` (a method or a property) run inside the shape settings its result was made with
    (:attr:`AdviceResult.settings`): a result computes when it is asked (its columns, text, files),
    after :func:`~fuzzyfeed.advice.pipeline.advise_file` has returned, and must compute what the
    command line computes with the same options (``--point-tolerance``, ``--path-tolerance``,
    ``--units``)."""
    if isinstance(member, property):
        return property(_in_settings(member.fget), member.fset, member.fdel, member.__doc__)
    if not callable(member) or isinstance(member, (staticmethod, classmethod, type)):
        return member

    @functools.wraps(member)
    def run(self, *args, **kwargs):
        settings = self.__dict__.get("settings")
        if settings is None:
            return member(self, *args, **kwargs)
        from fuzzyfeed.advice.options import shape_settings

        with shape_settings(*settings):
            return member(self, *args, **kwargs)
    return run


def _wrap_public(cls) -> None:
    for name, member in list(vars(cls).items()):
        if (not name.startswith("_") or name == "_repr_html_") and (callable(member) or isinstance(member, property)):
            setattr(cls, name, _in_settings(member))


class AdviceResult:
    """Base of the results; the subclasses fill in :meth:`columns`, :meth:`_write` and the rest.
    Every public method and property of a result runs inside the shape settings it was made with
    (``settings``: ``(source, units, point_tolerance, path_tolerance)``, set by
    :func:`~fuzzyfeed.advice.pipeline.advise_file`), so a result asked later gives what the command
    gives."""

    #: "program", "program on a machine", "program, nothing to advise", "drawing", "shape"
    kind: str = ""
    source: str = ""
    options = None

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        _wrap_public(cls)

    # -- what it holds ----------------------------------------------------------------------
    @property
    def text(self) -> str | None:
        """The advised program (None for a drawing's several paths)."""
        return None

    @property
    def value(self):
        """The value report (:class:`~fuzzyfeed.report.value.ValueReport`) of a program run on a
        machine: as written, advised, uniform slowdown, limit reference; else None."""
        return None

    def value_table(self):
        """The value report's four runs as a pandas DataFrame (run, time_s, max_um, p99_um, and
        whether the run holds the tolerance); a program on a machine only."""
        report = self.value
        if report is None:
            from fuzzyfeed.errors import MachineLimitsError

            raise MachineLimitsError(f"{self.source}: the value report runs a G-code program on a machine "
                                     "(give machine=NAME or FILE)")
        import pandas as pd

        return pd.DataFrame({"run": [r.label for r in report.rows],
                             "time_s": [r.time_s for r in report.rows],
                             "max_um": [r.max_um for r in report.rows],
                             "p99_um": [r.p99_um for r in report.rows],
                             "holds": [r.max_um <= report.tol_um * (1 + 1e-9) for r in report.rows]}).set_index("run")

    def columns(self) -> dict:
        """The CSV's columns (name -> array), one row per advised point."""
        raise NotImplementedError

    def frame(self):
        """The per-point table as a pandas DataFrame (the CSV's columns)."""
        import pandas as pd

        return pd.DataFrame(self.columns())

    def summary(self) -> list[str]:
        """The lines ``fuzzyfeed advise`` prints before it says what it wrote."""
        return []

    def figures(self) -> dict:
        """The summary figures (``cuts``, ``cuts_advised``, ``time_written_s``, ``time_advised_s``,
        ``feed_pct_min``, ``feed_pct_mean``; on a machine the value report's row too): what a
        batch records per file."""
        raise NotImplementedError

    # -- files ------------------------------------------------------------------------------
    def write(self, csv=None, gcode=None, gcode_g52=None, plot=None, report=None) -> list[str]:
        """Write the outputs asked for: ``csv`` (with its metadata sidecar), ``gcode`` (the advised
        program), ``gcode_g52`` (a NURBS shape as G5.2 blocks), ``plot`` (PNG), ``report`` (the
        value report, .html or .csv; a program on a machine). All appear together or none (one
        output transaction; inside a caller's, they join it). Returns the lines the command
        prints about them."""
        paths = {key: _path(value) for key, value in
                 (("csv", csv), ("gcode", gcode), ("gcode_g52", gcode_g52), ("plot", plot), ("report", report))}
        from fuzzyfeed.base.outputs import OutputSet, current

        if current() is not None:
            return self._write(**paths)
        from fuzzyfeed.io.csv import metadata_path

        outputs = [(OUTPUT_FLAGS[key], path) for key, path in paths.items() if path is not None]
        if paths["csv"] is not None and metadata_path(paths["csv"]) is not None:
            outputs.append(("-o (its sidecar)", metadata_path(paths["csv"])))
        with OutputSet(outputs, [("SHAPE", self.source)]):
            return self._write(**paths)

    def _write(self, csv, gcode, gcode_g52, plot, report) -> list[str]:
        raise NotImplementedError

    def plot(self, path=None):
        """The plot ``--plot`` draws: written to ``path`` (PNG) if given, else returned as a
        :class:`PNG` that a notebook shows."""
        if path is not None:
            self._plot(os.fspath(path))
            return None
        import tempfile

        with tempfile.TemporaryDirectory() as folder:
            target = os.path.join(folder, "plot.png")
            self._plot(target)
            with open(target, "rb") as handle:
                return PNG(handle.read())

    def _plot(self, output) -> None:
        from fuzzyfeed.errors import ExportError

        raise ExportError(f"{self.source}: {self.kind}: nothing to plot")

    # -- notebooks --------------------------------------------------------------------------
    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.kind} {self.source}>"

    def _repr_html_(self) -> str:
        parts = [f"<div><b>{html.escape(os.path.basename(str(self.source).split('#')[0]) or self.source)}"
                 f"</b> ({html.escape(self.kind)})", "<pre>" + html.escape("\n".join(self.summary())) + "</pre>"]
        report = self.value
        if report is not None:
            parts.append("<table><tr><th>run</th><th>time (s)</th><th>max contour error (µm)</th>"
                         "<th>p99 (µm)</th></tr>")
            for row in report.rows:
                style = ' style="color:#b00"' if row.max_um > report.tol_um * (1 + 1e-9) else ""
                parts.append(f"<tr{style}><td>{html.escape(row.label)}</td><td>{row.time_s:.2f}</td>"
                             f"<td>{row.max_um:.1f}</td><td>{row.p99_um:.1f}</td></tr>")
            parts.append(f"</table><p>{html.escape(report.verdict())}</p>")
        parts.append("</div>")
        return "\n".join(parts)


_wrap_public(AdviceResult)
