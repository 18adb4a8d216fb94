"""The designer's Bokeh figures and how each is refilled after an edit. Every figure and data
source has a ``name`` (``mf-<variable>``, ``surface-image``, ``path-feed``, …) so a browser test
can find what is drawn."""

from __future__ import annotations

import numpy as np

from fuzzyfeed.designer.compute import (Projection, Surface, breakpoint_axis, breakpoint_rows,
                                        membership_lines, project_surface)
from fuzzyfeed.fuzzy.rules import UNITS, Variable

TOOLS = "pan,wheel_zoom,box_zoom,reset,save"
#: Once a plot is laid out: its canvas (operated by mouse only; the typed fields and the grid do the
#: same by keyboard) leaves the tab order and is described to screen readers as an image.
_LABEL_CANVAS = """
const view = Bokeh.index.find_one(fig);
if (view != null && view.canvas_view.events_el.getAttribute('role') != 'img') {
  const el = view.canvas_view.events_el;
  el.tabIndex = -1;
  el.setAttribute('role', 'img');
  el.setAttribute('aria-label', label);
}
"""


def plot(name: str, label: str, **kw):
    """A Bokeh figure named ``name`` (for tests), toolbar above, no logo link, its canvas
    labelled ``label`` for screen readers."""
    from bokeh.models import CustomJS
    from bokeh.plotting import figure

    kw.setdefault("tools", TOOLS)
    fig = figure(name=name, toolbar_location="above", **kw)
    fig.toolbar.logo = None
    fig.js_on_change("inner_width", CustomJS(args={"fig": fig, "label": label}, code=_LABEL_CANVAS))
    return fig


def _palette(n: int) -> list[str]:
    from bokeh.palettes import Category10

    return [Category10[10][i % 10] for i in range(n)]


def unit_label(name: str) -> str:
    unit = UNITS.get(name, "")
    return f"{name} ({unit})" if unit else name


def feed_palette() -> list[str]:
    """Colours of the output, slow (red) to fast (green): heatmap, 3-D view, path."""
    from bokeh.palettes import RdYlGn11

    return list(reversed(RdYlGn11))


class MembershipFigure:
    """The membership functions of one variable; its breakpoints drag along x (PointDrawTool)."""

    def __init__(self, var: Variable, width: int = 440, height: int = 170):
        from bokeh.models import ColumnDataSource, PointDrawTool, Range1d

        self.name = var.name
        self.colors = _palette(len(var.terms))
        self.lines = ColumnDataSource(name=f"mf-lines-{var.name}")
        self.points = ColumnDataSource(name=f"mf-points-{var.name}")
        self.labels = ColumnDataSource(name=f"mf-labels-{var.name}")
        fig = plot(f"mf-{var.name}", f"membership functions of {var.name}; drag a breakpoint, or "
                   "type it in the fields below", width=width, height=height, tools="wheel_zoom,reset",
                   x_axis_label=unit_label(var.name) + ", spaced by breakpoints",
                   y_axis_label="membership", y_range=(-0.08, 1.3), x_range=Range1d(0, 1))
        fig.multi_line("xs", "ys", source=self.lines, line_color="color", line_width=2)
        dots = fig.scatter("x", "y", source=self.points, size=9, fill_color="color",
                           line_color="black", name=f"mf-dots-{var.name}")
        fig.text("x", "y", "text", source=self.labels, text_align="center", text_font_size="9pt",
                 text_color="color", y_offset=-2)
        drag = PointDrawTool(renderers=[dots], add=False, description="drag a breakpoint")
        fig.add_tools(drag)
        fig.toolbar.active_drag = drag
        self.figure = fig
        self.update(var)

    def update(self, var: Variable) -> None:
        """Draw ``var`` on its breakpoint axis (every interval between breakpoints equally wide,
        ticks at the breakpoints: membership functions stay straight between them)."""
        self.breaks = breakpoint_axis(var)
        index = np.arange(self.breaks.size, dtype=float)

        def pos(x):
            return np.interp(np.asarray(x, dtype=float), self.breaks, index).tolist()

        xs, ys = membership_lines(var)
        self.lines.data = {"xs": [pos(x) for x in xs], "ys": ys, "color": self.colors[:len(xs)]}
        rows = breakpoint_rows(var)
        color = {t.label: c for t, c in zip(var.terms, self.colors)}
        rows["color"] = [color[t] for t in rows["term"]]
        rows["value"] = rows["x"]
        rows["x"] = pos(rows["x"])
        self.points.data = rows
        peaks = [float(np.mean(pos(t.points[1:-1]))) for t in var.terms]
        self.labels.data = {"x": peaks, "y": [1.1] * len(peaks), "text": list(var.labels),
                            "color": self.colors[:len(peaks)]}
        self.figure.x_range.start, self.figure.x_range.end = -0.1, self.breaks.size - 0.9
        _breakpoint_ticks(self.figure.xaxis[0], self.breaks)

    def moved(self, old: dict, new: dict) -> list[tuple[str, int, float]]:
        """(term, index, value) of the breakpoints a drag moved, from the source's data
        before/after (positions on the axis as drawn, turned back into values)."""
        if len(new.get("x", ())) != len(old.get("x", ())):
            return []
        index = np.arange(self.breaks.size, dtype=float)
        return [(t, int(k), float(np.interp(xn, index, self.breaks)))
                for t, k, xo, xn in zip(old["term"], old["index"], old["x"], new["x"])
                if xn != xo and np.isfinite(xn)]


def _breakpoint_ticks(axis, breaks: np.ndarray) -> None:
    from bokeh.models import FixedTicker

    ticks = list(range(breaks.size))
    if isinstance(axis.ticker, FixedTicker):
        axis.ticker.ticks = ticks
    else:
        axis.ticker = FixedTicker(ticks=ticks)
    axis.major_label_overrides = {i: f"{b:g}" for i, b in enumerate(breaks)}


class SurfaceFigures:
    """The control surface as a heatmap (axes spaced by the breakpoints) and in 3-D."""

    def __init__(self, names: tuple[str, str, str], z_range: tuple[float, float], width: int = 420):
        from bokeh.models import ColorBar, ColumnDataSource, LinearColorMapper, Range1d

        self.names = names
        self.z_range = z_range
        self.mapper = LinearColorMapper(palette=feed_palette(), low=z_range[0], high=z_range[1])
        self.image = ColumnDataSource(name="surface-image")
        heat = plot("surface-heatmap", f"control surface: {names[2]} over {names[0]} and {names[1]}",
                    width=width, height=320, x_range=Range1d(0, 1), y_range=Range1d(0, 1),
                    x_axis_label=unit_label(names[0]) + ", spaced by breakpoints",
                    y_axis_label=unit_label(names[1]), title=f"{unit_label(names[2])} (exact centroid)")
        heat.image("image", x="x", y="y", dw="dw", dh="dh", source=self.image, color_mapper=self.mapper)
        heat.add_layout(ColorBar(color_mapper=self.mapper, width=10), "right")
        heat.grid.visible = False
        self.heatmap = heat
        self.quads = ColumnDataSource(name="surface-quads")
        self.edges = ColumnDataSource(name="surface-edges")
        self.axis_labels = ColumnDataSource(name="surface-labels")
        view = plot("surface-3d", "control surface in 3-D; turn it with the sliders below", width=width,
                    height=320, tools="pan,wheel_zoom,reset,save", match_aspect=True,
                    title="control surface in 3-D")
        view.patches("xs", "ys", source=self.quads, fill_color={"field": "z", "transform": self.mapper},
                     line_color="#333333", line_width=0.3)
        view.multi_line("xs", "ys", source=self.edges, line_color="black")
        view.text("x", "y", "text", source=self.axis_labels, text_font_size="9pt", text_align="center")
        view.axis.visible = False
        view.grid.visible = False
        self.view3d = view

    def update(self, surface: Surface, azimuth_deg: float, elevation_deg: float) -> None:
        m, n = surface.u_breaks.size - 1, surface.v_breaks.size - 1
        self.image.data = {"image": [surface.z], "x": [0.0], "y": [0.0], "dw": [float(m)], "dh": [float(n)]}
        self.heatmap.x_range.start, self.heatmap.x_range.end = 0.0, float(m)
        self.heatmap.y_range.start, self.heatmap.y_range.end = 0.0, float(n)
        _breakpoint_ticks(self.heatmap.xaxis[0], surface.u_breaks)
        _breakpoint_ticks(self.heatmap.yaxis[0], surface.v_breaks)
        self.surface = surface
        self.rotate(azimuth_deg, elevation_deg)

    def rotate(self, azimuth_deg: float, elevation_deg: float) -> None:
        p: Projection = project_surface(self.surface, self.z_range, azimuth_deg, elevation_deg)
        self.quads.data = {"xs": p.xs, "ys": p.ys, "z": p.z}
        self.edges.data = {"xs": p.edge_xs, "ys": p.edge_ys}
        self.axis_labels.data = {"x": p.label_x, "y": p.label_y, "text": list(self.names)}


class PathFigures:
    """The advice on a path: the path coloured by the advised feed, the feed along the arc length
    (with the table on disk dashed) and the curvature."""

    def __init__(self, samples, z_range: tuple[float, float], output: str, width: int = 460):
        from bokeh.models import ColorBar, ColumnDataSource, LinearColorMapper

        self.mapper = LinearColorMapper(palette=feed_palette(), low=z_range[0], high=z_range[1])
        self.path = ColumnDataSource(name="path-feed",
                                     data={"x": samples.x, "y": samples.y, "feed": np.zeros(samples.s.size)})
        plan = plot("path-plan", "the path coloured by the advised feed", width=width, height=330,
                    match_aspect=True, x_axis_label="x (mm)", y_axis_label="y (mm)", title="path coloured by the advised feed")
        plan.scatter("x", "y", source=self.path, size=3,
                     color={"field": "feed", "transform": self.mapper})
        plan.add_layout(ColorBar(color_mapper=self.mapper, width=10, title=f"{output} %"), "right")
        self.plan = plan
        self.along = ColumnDataSource(name="path-along", data={"s": samples.s, "feed": np.zeros(samples.s.size),
                                                               "disk": np.zeros(samples.s.size),
                                                               "curvature": samples.curvature})
        feed = plot("path-feed-s", "advised feed along the path, draft and table on disk", width=width,
                    height=210, y_axis_label=f"{output} (%)", title="advised feed along the path")
        feed.line("s", "disk", source=self.along, line_dash="dashed", color="gray",
                  legend_label="table on disk")
        feed.line("s", "feed", source=self.along, color="#1f77b4", line_width=2, legend_label="draft")
        feed.legend.location = "bottom_right"
        feed.legend.label_text_font_size = "8pt"
        kappa = plot("path-curvature-s", "curvature along the path", width=width, height=170,
                     x_range=feed.x_range, x_axis_label="arc length s (mm)", y_axis_label="curvature (1/mm)")
        kappa.line("s", "curvature", source=self.along, color="black")
        self.feed, self.kappa = feed, kappa

    def update(self, feed_pct: np.ndarray, disk_pct: np.ndarray) -> None:
        self.path.data["feed"] = feed_pct          # one column sent, not the whole source
        self.along.data["feed"] = feed_pct
        if not np.array_equal(self.along.data["disk"], disk_pct):
            self.along.data["disk"] = disk_pct
