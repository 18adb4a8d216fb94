"""The designer's Panel layout: toolbar (undo, redo, save, export), the membership functions of
every variable with typed breakpoints, the rule grid, the control surface, the advice on a path,
the settings and the difference to the file on disk. Every edit goes to the
:class:`~fuzzyfeed.designer.document.Document`; :meth:`DesignerView.refresh` then redraws all.

Every control has a label (grid cells and breakpoints: a label kept for screen readers, the
visible headers saying the same); the layout is in reading order, so the tab order follows it.
"""

from __future__ import annotations

import html
import time

from fuzzyfeed.designer.compute import control_surface, path_advice
from fuzzyfeed.designer.document import Document
from fuzzyfeed.designer.figures import MembershipFigure, PathFigures, SurfaceFigures, unit_label
from fuzzyfeed.errors import FileConflictError, FuzzyfeedError
from fuzzyfeed.fuzzy.rules import PAPER

#: A label that stays for screen readers but takes no room (the headers show it).
HIDDEN_LABEL = (":host label { position: absolute !important; width: 1px; height: 1px; margin: -1px; "
                "overflow: hidden; clip: rect(0 0 0 0); white-space: nowrap; border: 0; padding: 0; }")
#: Number fields without their step buttons (unlabelled tab stops; the arrow keys step instead).
NO_SPIN = ".bk-spin-btn { display: none !important; }"
ROLES = ("input 1 (grid rows)", "input 2 (grid columns)", "output")
EXPORTS = (("fcl", ".fcl", "Export FCL"), ("fll", ".fll", "Export FLL"), ("fis", ".fis", "Export .fis"))
SETTINGS = (("window_points", "int", "window WS (points)"), ("dk_clip_1_mm", "float", "Dk clip (1/mm)"),
            ("filter", "choice", "filter"), ("filter_points", "int", "filter size M (points)"),
            ("feed_floor_pct", "float", "feed floor (%)"))


def _set(widget, value) -> None:
    if widget.value != value:
        widget.value = value


def _error_html(message: str | None) -> str:
    if not message:
        return ""
    return f'<div class="ff-error" role="alert" style="color:#b00020">{html.escape(message)}</div>'


class DesignerView:
    """The Panel component over one document and one path (``samples`` may be None)."""

    def __init__(self, document: Document, samples=None, path_name: str = "",
                 max_feed_mm_s: float = 100.0, machine=None):
        import panel as pn

        self.doc, self.samples, self.path_name = document, samples, path_name
        self.machine = machine
        self.max_feed_mm_s = max_feed_mm_s
        self._syncing = False
        self._drawn = None          # the table the surface and the path show
        self._disk = (None, None)   # (table on disk, its advice on the path)
        self.redraw_s = 0.0         # duration of the last refresh
        self._shown_variables = None
        self.errors: dict[tuple[str, str | None], object] = {}
        table = document.table
        self.names = tuple(v.name for v in table.variables)
        self.status = pn.pane.HTML("", sizing_mode="stretch_width")
        toolbar = self._toolbar(pn)
        self.mf = [MembershipFigure(v) for v in table.variables]
        variables = pn.Column(*[self._variable_section(pn, i, v) for i, v in enumerate(table.variables)],
                              width=470)
        f_lo, f_hi = table.variables[2].universe
        self.surface = SurfaceFigures(self.names, (f_lo, f_hi))
        self.azimuth = pn.widgets.IntSlider(label="3-D view: azimuth (deg)", start=-180, end=180,
                                            step=5, value=-60, width=200)
        self.elevation = pn.widgets.IntSlider(label="3-D view: elevation (deg)", start=5, end=85,
                                              step=5, value=30, width=200)
        for w in (self.azimuth, self.elevation):
            w.param.watch(lambda e: self.surface.rotate(self.azimuth.value, self.elevation.value), "value")
        middle = pn.Column(self._grid(pn), pn.pane.Bokeh(self.surface.heatmap),
                           pn.pane.Bokeh(self.surface.view3d), pn.Row(self.azimuth, self.elevation),
                           self._settings(pn), width=540)
        self.summary = pn.pane.HTML("", width=460)
        self.diff = pn.pane.HTML("", width=460)
        right = [self.summary]
        if samples is not None:
            self.path = PathFigures(samples, (f_lo, f_hi), self.names[2])
            right += [pn.pane.Bokeh(self.path.plan), pn.pane.Bokeh(self.path.feed),
                      pn.pane.Bokeh(self.path.kappa)]
        else:
            self.path = None
        right.append(self.diff)
        self.layout = pn.Column(toolbar, self.conflict_row, pn.Row(variables, middle, pn.Column(*right)))
        self.refresh()

    # -- building -----------------------------------------------------------------------------
    def _toolbar(self, pn):
        self.undo = pn.widgets.Button(label="Undo", width=70)
        self.redo = pn.widgets.Button(label="Redo", width=70)
        self.save_to = pn.widgets.TextInput(label="Save to", value=str(self.doc.save_path), width=330)
        self.save = pn.widgets.Button(label="Save", width=70)
        self.undo.on_click(lambda e: self._run(self.doc.undo))
        self.redo.on_click(lambda e: self._run(self.doc.redo))
        self.save.on_click(lambda e: self._save(False))
        self.exports = []
        stem = self.doc.save_path.stem
        for fmt, suffix, label in EXPORTS:
            w = pn.widgets.FileDownload(label=label, filename=stem + suffix, width=110,
                                        callback=lambda fmt=fmt: self._export(fmt))
            self.exports.append(w)
        title = pn.pane.HTML(f"<h2 style='margin:4px 0'>fuzzyfeed rule designer: "
                             f"{html.escape(self.doc.table.name)}</h2>", width=420)
        self.overwrite = pn.widgets.Button(label="Overwrite", width=100)
        self.reload = pn.widgets.Button(label="Reload from disk", width=140)
        self.cancel = pn.widgets.Button(label="Cancel", width=80)
        self.overwrite.on_click(lambda e: self._save(True))
        self.reload.on_click(lambda e: self._conflict_done(self.doc.reload))
        self.cancel.on_click(lambda e: self._conflict_done(None))
        self.conflict_text = pn.pane.HTML("", width=700)
        self.conflict_row = pn.Row(self.conflict_text, self.overwrite, self.reload, self.cancel, visible=False)
        return pn.Column(pn.Row(title, self.undo, self.redo, self.save_to, self.save, *self.exports,
                                align="end"), self.status)

    def _error_pane(self, pn, section: str, key: str | None, width: int = 440):
        pane = pn.pane.HTML("", width=width, margin=(0, 5))
        self.errors[(section, key)] = pane
        return pane

    def _variable_section(self, pn, i: int, var):
        name = var.name
        items = [pn.pane.HTML(f"<h3 style='margin:6px 0 0 0'>{ROLES[i]}: {html.escape(unit_label(name))}</h3>"),
                 self._error_pane(pn, name, None), pn.pane.Bokeh(self.mf[i].figure)]
        self.mf[i].points.on_change("data", lambda attr, old, new, i=i: self._dragged(i, old, new))
        lo = pn.widgets.FloatInput(label=f"{name} universe from", width=85, stylesheets=[HIDDEN_LABEL, NO_SPIN])
        hi = pn.widgets.FloatInput(label=f"{name} universe to", width=85, stylesheets=[HIDDEN_LABEL, NO_SPIN])
        for k, w in enumerate((lo, hi)):
            w.param.watch(lambda e, k=k: self._typed(self.doc.set_universe, name, k, e.new), "value")
        self.universe_inputs = getattr(self, "universe_inputs", {})
        self.universe_inputs[name] = (lo, hi)
        width = 4 if any(len(t.points) == 4 for t in var.terms) else 3
        head = "".join(f"<span style='display:inline-block;width:95px;text-align:center'>{c}</span>"
                       for c in "abcd"[:width])
        items.append(pn.pane.HTML(f"<div aria-hidden='true'><span style='display:inline-block;width:60px'>"
                                  f"</span>{head}</div>", margin=(0, 5)))
        items += [pn.Row(pn.pane.HTML("<b>universe</b>", width=50, margin=(12, 5)), lo, hi, margin=0),
                  self._error_pane(pn, name, "universe")]
        self.point_inputs = getattr(self, "point_inputs", {})
        for term in var.terms:
            row = [pn.pane.HTML(f"<b>{html.escape(term.label)}</b>", width=50, margin=(12, 5))]
            for k in range(len(term.points)):
                w = pn.widgets.FloatInput(label=f"{name} {term.label} {'abcd'[k]}", width=85,
                                          stylesheets=[HIDDEN_LABEL, NO_SPIN])
                w.param.watch(lambda e, t=term.label, k=k: self._typed(self.doc.set_point, name, t, k, e.new),
                              "value")
                self.point_inputs[(name, term.label, k)] = w
                row.append(w)
            items += [pn.Row(*row, margin=0), self._error_pane(pn, name, term.label)]
        return pn.Column(*items)

    def _grid(self, pn):
        rows_var, cols_var, out = self.doc.table.variables
        self.cells = {}
        header = [pn.pane.HTML("", width=50)]
        header += [pn.pane.HTML(f"<b>{html.escape(c)}</b>", width=74, styles={"text-align": "center"})
                   for c in cols_var.labels]
        lines = [pn.Row(*header, margin=0)]
        for r in rows_var.labels:
            row = [pn.pane.HTML(f"<b>{html.escape(r)}</b>", width=50, margin=(10, 5))]
            for c in cols_var.labels:
                w = pn.widgets.Select(label=f"rule: {rows_var.name} {r}, {cols_var.name} {c}",
                                      options=list(out.labels), width=74, stylesheets=[HIDDEN_LABEL])
                w.param.watch(lambda e, r=r, c=c: self._typed(self.doc.set_cell, r, c, e.new), "value")
                self.cells[(r, c)] = w
                row.append(w)
            lines.append(pn.Row(*row, margin=0))
        title = pn.pane.HTML(f"<h3 style='margin:6px 0 0 0'>rules: IF {html.escape(rows_var.name)} is ROW "
                             f"AND {html.escape(cols_var.name)} is COLUMN THEN {html.escape(out.name)} is</h3>")
        return pn.Column(title, self._error_pane(pn, "rules", None), *lines)

    def _settings(self, pn):
        from fuzzyfeed.fuzzy.filters import FILTER_KINDS

        self.setting_inputs = {}
        items = [pn.pane.HTML("<h3 style='margin:6px 0 0 0'>settings [features]</h3>")]
        for key, kind, label in SETTINGS:
            if kind == "int":
                w = pn.widgets.IntInput(label=label, width=150, stylesheets=[NO_SPIN])
            elif kind == "float":
                w = pn.widgets.FloatInput(label=label, width=150, stylesheets=[NO_SPIN])
            else:
                w = pn.widgets.Select(label=label, options=list(FILTER_KINDS), width=150)
            w.param.watch(lambda e, key=key: self._typed(self.doc.set_feature, key, e.new), "value")
            self.setting_inputs[key] = w
        keys = [k for k, _, _ in SETTINGS]
        for pair in (keys[:3], keys[3:]):
            items.append(pn.Row(*[self.setting_inputs[k] for k in pair]))
        items += [self._error_pane(pn, "features", k) for k in keys]
        return pn.Column(*items)

    # -- events -------------------------------------------------------------------------------
    def _typed(self, edit, *args) -> None:
        if self._syncing or args[-1] is None:
            return
        self._run(edit, *args)

    def _dragged(self, i: int, old: dict, new: dict) -> None:
        if self._syncing:
            return
        moves = self.mf[i].moved(old, new)
        self._shown_variables = None    # redraw the dots where the document puts them
        if moves:
            self._run(self.doc.set_points, self.names[i], moves, True)
        else:
            self.refresh()  # an added or deleted point: put the breakpoints back

    def _run(self, edit, *args) -> None:
        message = None
        try:
            edit(*args)
        except FuzzyfeedError as exc:
            message = str(exc)
        self.refresh()
        if message:
            self.status.object = _error_html(message)

    def _save(self, overwrite: bool) -> None:
        target = self.save_to.value.strip() or None
        try:
            path = self.doc.save(target, overwrite)
        except FileConflictError as exc:
            self.conflict_text.object = self._conflict_html(str(exc), target)
            self.conflict_row.visible = True
            return
        except (FuzzyfeedError, OSError) as exc:
            self.status.object = _error_html(str(exc))
            return
        self.conflict_row.visible = False
        self.refresh()
        self.status.object = f'<div class="ff-saved" role="status">saved {html.escape(str(path))}</div>'

    def _conflict_html(self, message: str, target) -> str:
        from fuzzyfeed.designer.document import validate_text
        from fuzzyfeed.fuzzy.diff import table_differences
        from pathlib import Path

        path = Path(target) if target else self.doc.save_path
        try:
            now = validate_text(path.read_text(encoding="utf-8-sig"), path)
        except (OSError, UnicodeDecodeError) as exc:
            now = None
            message += f" ({exc})"
        lines = table_differences(now, self.doc.table) if hasattr(now, "variables") else []
        diff = "".join(f"<li>{html.escape(x)}</li>" for x in lines)
        return (f'<div class="ff-conflict" role="alert"><b>{html.escape(message)}</b>'
                + (f"<br>the draft against the file there now (rules diff):<ul>{diff}</ul>" if lines else "")
                + "</div>")

    def _conflict_done(self, action) -> None:
        self.conflict_row.visible = False
        if action is not None:
            self._run(action)

    def _export(self, fmt: str):
        import io

        try:
            return io.StringIO(self.doc.export(fmt))
        except FuzzyfeedError as exc:
            self.status.object = _error_html(str(exc))
            return io.StringIO("")

    # -- redraw -------------------------------------------------------------------------------
    def refresh(self) -> None:
        """Redraw every panel from the document (the surface and path only if the table changed)."""
        from panel.io import hold

        start = time.perf_counter()
        with hold():       # every change of this redraw goes to the browser in one message
            self._syncing = True
            try:
                self._sync_inputs()
                if self.doc.table is not self._drawn:
                    self._draw_table()
            finally:
                self._syncing = False
            self._show_state()
            self._push()
        self.redraw_s = time.perf_counter() - start

    def _sync_inputs(self) -> None:
        variables = self.doc.variables
        shown = self._shown_variables or (None, None, None)
        self._shown_variables = variables
        for fig, var, before in zip(self.mf, variables, shown):
            if var != before:       # only the variable edited is redrawn
                fig.update(var)
                for w, x in zip(self.universe_inputs[var.name], var.universe):
                    _set(w, x)
                for term in var.terms:
                    for k, x in enumerate(term.points):
                        _set(self.point_inputs[(var.name, term.label, k)], x)
        grid = self.doc.grid
        rows, cols = self.doc.table.variables[0].labels, self.doc.table.variables[1].labels
        for i, r in enumerate(rows):
            for j, c in enumerate(cols):
                _set(self.cells[(r, c)], grid[i][j])
        settings = self.doc.settings()
        for key, w in self.setting_inputs.items():
            if key in settings:
                _set(w, settings[key])

    def _draw_table(self) -> None:
        table = self.doc.table
        self.surface.update(control_surface(table), self.azimuth.value, self.elevation.value)
        self._drawn = table
        if self.path is None:
            self.summary.object = "<p>no path (give --shape SHAPE or --program FILE)</p>"
            return
        if table.inputs != PAPER and self.machine is None:
            self.summary.object = (f"<p>a table with inputs = {html.escape(table.inputs)!r} reads the "
                                   "machine's terms: start the designer with --machine FILE (or a machine "
                                   "flag) to see its advice on the path</p>")
            return
        advice = path_advice(self.samples, table, self.max_feed_mm_s, self.machine)
        disk = self.doc.disk_table
        if self._disk[0] is not disk:
            self._disk = (disk, path_advice(self.samples, disk, self.max_feed_mm_s, self.machine))
        self.path.update(advice.feed_pct, self._disk[1].feed_pct)
        pct, t = advice.feed_pct, advice.profile.travel_time_s()
        t_disk = self._disk[1].profile.travel_time_s()
        self.summary.object = (
            f'<div class="ff-summary"><b>{html.escape(self.path_name)}</b>: {pct.size} points, '
            f"{self.samples.s[-1]:.1f} mm, F = {self.max_feed_mm_s * 60:g} mm/min<br>"
            f"advised {html.escape(self.names[2])}: min {pct.min():.1f} %, mean "
            f'<span class="ff-mean">{pct.mean():.2f}</span> %, max {pct.max():.1f} %<br>'
            f"time at the advised feed: {t:.3f} s (table on disk: {t_disk:.3f} s)"
            + self._machine_line(advice) + "</div>")

    def _machine_line(self, advice) -> str:
        """With a machine: the advised path run through its planner and servo."""
        if self.machine is None:
            return ""
        from fuzzyfeed.designer.compute import path_on_machine

        t, err = path_on_machine(self.samples, advice.profile.feed_mm_s, self.machine)
        tol = self.machine.contour_tol_um
        flag = "within" if err <= tol else "over"
        return (f"<br>on machine {html.escape(self.machine.name)!s}: {t:.3f} s, max contour error "
                f'<span class="ff-error">{err:.1f}</span> um ({flag} its {tol:g} um)')

    def _show_state(self) -> None:
        doc, err = self.doc, self.doc.error
        for (section, key), pane in self.errors.items():
            pane.object = _error_html(err.message) if err and (err.section, err.key) == (section, key) else ""
        shown = err is not None and (err.section, err.key) in self.errors
        if err is None:
            self.status.object = ""
        else:
            self.status.object = _error_html(
                ("" if shown else err.message + "; ") + "the draft breaks a rule (shown next to its "
                "field): the plots show the last valid table, and it cannot be saved")
        self.undo.disabled, self.redo.disabled = not doc.can_undo, not doc.can_redo
        self.save.disabled = err is not None
        for w in self.exports:
            w.disabled = err is not None
        lines = doc.differences()
        items = "".join(f"<li>{html.escape(x)}</li>" for x in lines)
        self.diff.object = (f'<div class="ff-diff"><h3 style="margin:6px 0 0 0">changes against {html.escape(str(doc.path))}'
                            f" (rules diff): {len(lines)}</h3>" + (f"<ul>{items}</ul>" if items else "") + "</div>")

    def _push(self) -> None:
        """In a notebook, send the changed Bokeh models to the page (a server does it itself)."""
        import panel as pn

        if pn.state.curdoc is not None and pn.state.curdoc.session_context is not None:
            return
        from panel.io.notebook import push_notebook

        try:
            push_notebook(self.layout)
        except Exception:  # noqa: BLE001 - not displayed yet: nothing to push to
            pass
