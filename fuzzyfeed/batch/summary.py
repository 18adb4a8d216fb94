"""The batch's summary: one row per input (``summary.csv``) and a page with its plots
(``summary.html``: time saved or added per program, error as written against advised).

The figures of a row are what the per-file work returned (``figures`` of its manifest entry):
the advise command's ``cuts``, ``time_written_s``, ``time_advised_s``, ``feed_pct_min``,
``feed_pct_mean``, and whatever else it returns (with a machine, its value report's row:
``written_max_um``, ``advised_max_um``, ``uniform_time_s``, ...). A figure in µm named with
``written`` that has a twin named with ``advised`` is plotted as written against advised; a
column a file does not have is left empty.
"""

from __future__ import annotations

import base64
import html
import io
import os
import re

#: The summary's first columns, in order; any other figure follows them.
LEADING = ("file", "kind", "status", "reason", "cuts", "time_written_s", "time_advised_s",
           "time_saved_s", "feed_pct_min", "feed_pct_mean", "judged_length_pct", "not_judged")
#: The summary's last columns.
TRAILING = ("cuts_advised", "compute_s", "earlier_run", "notes")
#: Statuses of a file that did not get results.
FAILED = ("refused", "failed")


def summary_frame(sources, entries: dict[str, dict], kept: set[str]):
    """One row per source, in the sources' order: its entry's status, reason and figures; a source
    without an entry (the batch was interrupted first) has status ``not run``."""
    import pandas as pd

    rows, extra = [], []
    for src in sources:
        entry = entries.get(src.rel)
        if entry is None:
            rows.append({"file": src.rel, "kind": src.kind, "status": "not run",
                         "reason": "the batch was stopped before this file was advised"})
            continue
        figures = dict(entry.get("figures") or {})
        for key in figures:
            if key not in LEADING and key not in TRAILING and key not in extra:
                extra.append(key)
        row = {"file": src.rel, "kind": src.kind, "status": entry.get("status", ""),
               "reason": entry.get("reason", ""), **figures,
               "compute_s": entry.get("compute_s"), "earlier_run": src.rel in kept,
               "notes": entry.get("notes", "")}
        written, advised = figures.get("time_written_s"), figures.get("time_advised_s")
        if written is not None and advised is not None:
            row["time_saved_s"] = written - advised
        rows.append(row)
    columns = [*LEADING, *extra, *TRAILING]
    frame = pd.DataFrame(rows, columns=columns)
    for name in ("cuts", "cuts_advised"):
        frame[name] = frame[name].astype("Int64")
    frame["earlier_run"] = frame["earlier_run"].astype("boolean")
    for name in ("file", "kind", "status", "reason", "notes", "not_judged"):
        frame[name] = frame[name].astype(object).fillna("").astype(str)
    return frame


def write_summary(out_dir: str | os.PathLike, frame) -> tuple[str, str]:
    """Write ``summary.csv`` and ``summary.html`` into ``out_dir`` (atomically); returns their paths."""
    from fuzzyfeed.base.atomic import atomic_write

    csv_path = os.path.join(os.fspath(out_dir), "summary.csv")
    html_path = os.path.join(os.fspath(out_dir), "summary.html")
    with atomic_write(csv_path, "w", newline="") as handle:
        frame.to_csv(handle, index=False, lineterminator="\n")
    with atomic_write(html_path, "w") as handle:
        handle.write(summary_html(frame))
    return csv_path, html_path


#: The word that marks a figure as written (``time_written_s``, ``written_max_um``).
_WRITTEN = re.compile(r"(^|_)written(_|$)")


def pairs(frame) -> list[tuple[str, str, str]]:
    """(name, written column, advised column) of every figure given as written and advised (the
    same name with ``advised`` for ``written``), the time first."""
    found = []
    for column in frame.columns:
        if _WRITTEN.search(column):
            advised = _WRITTEN.sub(r"\1advised\2", column, count=1)
            if advised in frame.columns:
                name = _WRITTEN.sub(lambda m: "_" if m.group(1) and m.group(2) else "", column, count=1)
                found.append((name, column, advised))
    found.sort(key=lambda p: (p[1] != "time_written_s", p[1]))
    return found


def counts(frame) -> dict[str, int]:
    """How many files ended in each status."""
    return {str(k): int(v) for k, v in frame["status"].value_counts().items()}


def summary_html(frame) -> str:
    """A self-contained page: the counts, the plots (PNG inline) and the table."""
    from fuzzyfeed import __version__

    ok = frame[frame["status"] == "ok"]
    parts = [f"<h1>fuzzyfeed batch: {len(frame)} files</h1>",
             "<p>" + ", ".join(f"{html.escape(k)}: {v}" for k, v in counts(frame).items()) + "</p>"]
    if len(ok):
        written, advised = ok["time_written_s"].sum(), ok["time_advised_s"].sum()
        how = ("as the machine runs them" if "contour_tol_um" in frame.columns
               else "feed moves at their F, no acceleration")
        parts.append(f"<p>advised files: {written:.1f} s as written, {advised:.1f} s advised "
                     f"({advised - written:+.1f} s; {how})</p>")
        parts.append(_image(time_figure(ok), "time saved or added per program"))
    errors = [p for p in pairs(frame) if p[0].endswith("_um")]
    for name, written, advised in errors:
        parts.append(_image(error_figure(ok, name, written, advised), f"{name}: as written against advised"))
    if not errors:
        parts.append("<p>No contour error as written and advised in the figures: the advice "
                     "reports it when a machine is given (--machine or a machine flag).</p>")
    failed = frame[frame["status"].isin(FAILED + ("not run",))]
    if len(failed):
        parts.append(f"<h2>Not advised ({len(failed)})</h2>")
        parts.append(failed[["file", "status", "reason"]].to_html(index=False, escape=True, border=0,
                                                                  classes="reasons"))
    partial = frame[frame["not_judged"] != ""]
    if len(partial):   # what the figures above do not cover (issue 40)
        parts.append(f"<h2>Judged in part ({len(partial)})</h2>")
        parts.append(partial[["file", "judged_length_pct", "not_judged"]].to_html(
            index=False, escape=True, border=0, classes="reasons", float_format=lambda v: f"{v:.1f}"))
    parts.append("<h2>All files</h2>")
    shown = frame.drop(columns=["reason", "notes", "not_judged"]).astype(object)
    parts.append(shown.where(frame.drop(columns=["reason", "notes", "not_judged"]).notna(), "").to_html(
        index=False, escape=True, border=0, float_format=lambda v: f"{v:.4g}"))
    style = ("body{font-family:sans-serif;margin:2em}table{border-collapse:collapse;font-size:85%}"
             "td,th{padding:2px 8px;border-bottom:1px solid #ddd;text-align:right}"
             "td:first-child,.reasons td{text-align:left}img{max-width:100%}")
    return (f"<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>fuzzyfeed batch</title>"
            f"<style>{style}</style></head><body>\n" + "\n".join(parts)
            + f"\n<p><small>fuzzyfeed {html.escape(__version__)}</small></p></body></html>\n")


def _image(fig, alt: str) -> str:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    data = base64.b64encode(buffer.getvalue()).decode("ascii")
    return f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,{data}"></figure>'


def time_figure(ok):
    """Bars of advised minus written time per program, sorted (above zero: the advice adds time)."""
    import numpy as np
    from matplotlib.figure import Figure

    delta = (ok["time_advised_s"] - ok["time_written_s"]).to_numpy(dtype=float)
    order = np.argsort(delta)
    names = ok["file"].to_numpy()[order]
    delta = delta[order]
    few = len(delta) <= 40
    fig = Figure(figsize=(9, 3.2 + (0.18 * len(delta) if few else 0)), layout="constrained")
    ax = fig.add_subplot()
    colours = np.where(delta > 0, "#c0392b", "#27ae60")
    if few:
        ax.barh(np.arange(delta.size), delta, color=colours)
        ax.set_yticks(np.arange(delta.size), names, fontsize=7)
        ax.set_xlabel("advised − as written (s)")
        ax.axvline(0, color="k", lw=0.5)
    else:
        ax.bar(np.arange(delta.size), delta, width=1.0, color=colours)
        ax.set_xlabel(f"{delta.size} programs, sorted")
        ax.set_ylabel("advised − as written (s)")
        ax.axhline(0, color="k", lw=0.5)
    ax.set_title("time added (red) or saved (green) per program")
    return fig


def error_figure(ok, name: str, written: str, advised: str):
    """Each program's ``name`` as written (x) against advised (y), log scales, with y = x."""
    import numpy as np
    from matplotlib.figure import Figure

    x = ok[written].to_numpy(dtype=float)
    y = ok[advised].to_numpy(dtype=float)
    keep = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    fig = Figure(figsize=(5.5, 5), layout="constrained")
    ax = fig.add_subplot()
    ax.scatter(x[keep], y[keep], s=12)
    if keep.any():
        lo, hi = min(x[keep].min(), y[keep].min()), max(x[keep].max(), y[keep].max())
        ax.plot([lo, hi], [lo, hi], "k--", lw=0.8, label="advised = as written")
        if "contour_tol_um" in ok.columns:
            for tol in sorted(set(ok["contour_tol_um"].dropna().astype(float))):
                ax.axhline(tol, color="#c0392b", lw=0.8, label=f"tolerance {tol:g} um")
        ax.legend(loc="upper left")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(f"{written}")
    ax.set_ylabel(f"{advised}")
    ax.set_title(f"{name} per program ({int(keep.sum())} of {len(x)} with both)")
    return fig
