"""The value report as files people open: a plot of where the feed drops along the path, an HTML
page (the table, the verdict and the plot of every program) and a CSV (one row per program)."""

from __future__ import annotations

import base64
import html
import io
import os
from collections.abc import Sequence

import numpy as np

from fuzzyfeed.report.value import ValueReport


def plot_value(report: ValueReport, output: str | os.PathLike | io.BytesIO) -> None:
    """Two panels: the F in force along the feed moves end to end, as written and advised (ticks
    where the program as written takes the tool beyond the tolerance marked on the axis), and the
    path seen from above coloured by the advised fraction of F, those places circled."""
    from fuzzyfeed.report.plot import SAVE_DPI, _pyplot, save_figure

    plt = _pyplot()
    tr = report.trace
    fig, (ax_f, ax_p) = plt.subplots(1, 2, figsize=(13, 5), gridspec_kw={"width_ratios": [1.6, 1]})
    if tr is not None and tr.segments.size:
        from matplotlib.collections import LineCollection

        steps = []
        for label, color, lw in (("as written", "0.6", 2.2), ("advised", "tab:blue", 1.2)):
            s0, s1 = tr.s_mm[label]
            f = tr.feed_mm_min[label]
            steps += ax_f.plot(np.column_stack([s0, s1]).ravel(), np.repeat(f, 2), color=color, lw=lw,
                               label=f"F {label}")
        if tr.over_s_mm.size:
            ax_f.plot(tr.over_s_mm, np.zeros_like(tr.over_s_mm), "|", color="tab:red", ms=10,
                      label=f"beyond {report.tol_um:g} um as written")
        ax_f.set_xlabel("path length along the feed moves (mm)")
        ax_f.set_ylabel("feed F (mm/min)")
        ax_f.set_title(f"{report.name}: where the feed drops")
        ax_f.set_ylim(bottom=-0.04 * max(float(tr.feed_mm_min["as written"].max()), 1.0))
        ax_f.legend(loc="lower right", fontsize=8)
        ax_f.grid(True, alpha=0.3)
        seg = tr.segments[:, :, :2]
        lc = LineCollection(seg, array=100.0 * tr.advised_fraction, cmap="turbo_r", linewidths=1.6)
        lc.set_clim(0, 100)
        ax_p.add_collection(lc)
        if tr.over_xyz.size:
            ax_p.scatter(tr.over_xyz[:, 0], tr.over_xyz[:, 1], facecolors="none", edgecolors="tab:red",
                         s=28, lw=0.6, label=f"beyond {report.tol_um:g} um as written")
            ax_p.legend(loc="upper right", fontsize=7)
        fig.colorbar(lc, ax=ax_p, label="advised F (% of the program's)")
        lo, hi = seg.reshape(-1, 2).min(axis=0), seg.reshape(-1, 2).max(axis=0)
        pad = 0.03 * max(float((hi - lo).max()), 1.0)
        ax_p.set_xlim(lo[0] - pad, hi[0] + pad)
        ax_p.set_ylim(lo[1] - pad, hi[1] + pad)
        ax_p.set_aspect("equal", adjustable="box")
        ax_p.set_xlabel("x (mm)")
        ax_p.set_ylabel("y (mm)")
        ax_p.set_title("path from above, coloured by the advised F")
    fig.tight_layout()
    inline = isinstance(output, io.BytesIO)
    if tr is not None and tr.segments.size:
        _steps_per_column(ax_f, steps, INLINE_DPI if inline else SAVE_DPI)
    if inline:
        fig.savefig(output, format="png", dpi=INLINE_DPI)
        plt.close(fig)
    else:
        save_figure(fig, output)


#: Resolution of the plot inlined in the HTML page.
INLINE_DPI = 110


def _steps_per_column(ax, lines, dpi: float) -> None:
    """The step ``lines`` of ``ax`` with more vertices than four a pixel column of the figure saved
    at ``dpi`` cut to those the columns need (:func:`~fuzzyfeed.report.value_trace.column_extremes`;
    the others drawn as they are): Agg holds a cell for every pixel each edge of a path crosses
    before it fills the path, so a many-cut program's F steps drawn whole cost memory in proportion
    to their cuts (issue 36: ~40 B a line of the program); at most four vertices a column, they
    cost at most the figure's width."""
    from fuzzyfeed.report.value_trace import column_extremes

    x0, x1 = ax.get_xlim()          # autoscaled from the whole lines (the extremes are kept: the same)
    if not x1 > x0:
        return
    box = ax.get_position()
    width_px = ax.figure.get_figwidth() * dpi
    columns = box.width * width_px
    for line in lines:
        x, y = line.get_data()
        if np.size(x) > 4 * columns:
            line.set_data(*column_extremes(x, y, x0, columns / (x1 - x0), box.x0 * width_px))


def report_table_html(reports: Sequence[ValueReport]) -> str:
    """One HTML page: per program its four runs, the verdict and the plot (inline PNG)."""
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             "<title>fuzzyfeed value report</title>",
             "<style>body{font-family:sans-serif;margin:2em;max-width:75em}"
             "table{border-collapse:collapse}td,th{padding:.25em .8em;text-align:right;border-bottom:1px solid #ccc}"
             "td:first-child,th:first-child{text-align:left}.over{color:#b00}</style></head><body>",
             "<h1>fuzzyfeed value report</h1>"]
    for r in reports:
        parts.append(f"<h2>{html.escape(r.name)}</h2>")
        parts.append(f"<p>{html.escape(r.machine.describe())}; rules {html.escape(r.table)!s}</p>")
        parts.append("<table><tr><th>run</th><th>time (s)</th><th>max contour error (µm)</th>"
                     "<th>p99 (µm)</th></tr>")
        for row in r.rows:
            cls = ' class="over"' if row.max_um > r.tol_um * (1 + 1e-9) else ""
            parts.append(f"<tr{cls}><td>{html.escape(row.label)}</td><td>{row.time_s:.2f}</td>"
                         f"<td>{row.max_um:.1f}</td><td>{row.p99_um:.1f}</td></tr>")
        parts.append("</table>")
        if r.coverage is not None:
            parts.append(f"<p>{html.escape(r.coverage.summary())}</p>")
        if r.verification is not None:
            parts.append(f"<p>{html.escape(r.verification.summary())}</p>")
        parts.append(f"<p>{html.escape(r.verdict())}</p>")
        if r.air_line():
            parts.append(f"<p>{html.escape(r.air_line())}</p>")
        apart = r.apart_lines()
        if apart:
            parts.append(f"<p>{html.escape(apart[0])}</p><ul>"
                         + "".join(f"<li>{html.escape(line.strip())}</li>" for line in apart[1:]) + "</ul>")
        buf = io.BytesIO()
        plot_value(r, buf)
        data = base64.b64encode(buf.getvalue()).decode("ascii")
        parts.append(f'<img alt="feed along the path of {html.escape(r.name)}" '
                     f'src="data:image/png;base64,{data}" style="max-width:100%">')
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def write_value_report(reports: Sequence[ValueReport], path: str | os.PathLike) -> None:
    """``path`` ending in .html: the page of :func:`report_table_html`; .csv: one row per program."""
    from fuzzyfeed.base.atomic import atomic_write

    suffix = os.fspath(path).lower().rsplit(".", 1)[-1]
    if suffix in ("html", "htm"):
        with atomic_write(path, "w") as handle:
            handle.write(report_table_html(reports))
        return
    from fuzzyfeed.io.csv import write_columns

    rows = [r.csv_row() for r in reports]
    cols = {key: np.array([int(row[key]) if isinstance(row[key], bool) else row[key] for row in rows])
            for key in rows[0]}
    write_columns(path, cols, allow_nan=tuple(k for k in cols if k.startswith(("reference_", "uniform_", "judged_"))))
