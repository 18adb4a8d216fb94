"""Plots (matplotlib, imported on call). Every function writes a PNG atomically or returns a figure."""

from __future__ import annotations

import os

import numpy as np

from fuzzyfeed.base.atomic import atomic_write
from fuzzyfeed.geometry.sampling import PathSamples


def _pyplot():
    # no backend is forced: headless machines fall back to Agg, Jupyter keeps its inline backend
    import matplotlib.pyplot as plt

    return plt


#: Resolution of the PNG files written.
SAVE_DPI = 130


def save_figure(fig, output: str | os.PathLike) -> None:
    """Write ``fig`` as PNG atomically and close it."""
    plt = _pyplot()
    try:
        with atomic_write(output, "wb") as handle:
            fig.savefig(handle, format="png", dpi=SAVE_DPI)
    finally:
        plt.close(fig)


def path_segments(samples: PathSamples, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The path's steps in the xy plane (n, 2, 2) and each one's value (the mean of its ends).
    A step between samples that is longer than its arc length is not path but a jump between the
    pieces of a path (a program's rapid between two cuts): it is left out."""
    pts = samples.xyz[:, :2]
    chord = np.linalg.norm(np.diff(np.asarray(samples.xyz, dtype=float), axis=0), axis=1)
    ds = np.diff(np.asarray(samples.s, dtype=float))
    on_path = chord <= ds * (1.0 + 1e-6) + 1e-9 * max(1.0, float(samples.s[-1]))
    segments = np.stack([pts[:-1], pts[1:]], axis=1)[on_path]
    mid = (0.5 * (values[:-1] + values[1:]))[on_path]
    return segments, mid


def colored_path(ax, samples: PathSamples, values: np.ndarray, label: str, cmap: str = "viridis",
                 log: bool = False):
    """Draw the path in the xy plane as a line coloured by ``values``; returns the colorbar
    (:func:`path_segments`: jumps between pieces left out)."""
    segments, mid = path_segments(samples, values)
    pts = samples.xyz[:, :2]
    return draw_segments(ax, segments, mid, (float(mid.min()), float(mid.max())), pts.min(axis=0),
                         pts.max(axis=0), label, cmap, log)


def draw_segments(ax, segments: np.ndarray, mid: np.ndarray, value_range: tuple[float, float], lo_xy, hi_xy,
                  label: str, cmap: str = "viridis", log: bool = False):
    """Segments (n, 2, 2) coloured by ``mid`` on a scale over ``value_range`` (the values of every
    segment of the path, also those not drawn), the axes over ``lo_xy``..``hi_xy`` (mm); returns
    the colorbar."""
    from matplotlib.collections import LineCollection
    from matplotlib.colors import LogNorm, Normalize

    v_lo, v_hi = value_range
    if log:
        positive = mid[mid > 0]
        # four decades below the peak are enough to see where a path is sharp
        floor = max(positive.min(), v_hi * 1e-4) if positive.size else 1e-6
        norm = LogNorm(vmin=floor, vmax=max(v_hi, floor * 10))
        mid = np.maximum(mid, floor)
    else:
        norm = Normalize(vmin=v_lo, vmax=v_hi if v_hi > v_lo else v_lo + 1)
    lc = LineCollection(segments, array=mid, cmap=cmap, norm=norm, linewidths=2.0)
    ax.add_collection(lc)
    ax.set_xlim(lo_xy[0] - 1, hi_xy[0] + 1)
    ax.set_ylim(lo_xy[1] - 1, hi_xy[1] + 1)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    return ax.figure.colorbar(lc, ax=ax, label=label, shrink=0.8)


def plot_shape_curvature(samples: PathSamples, title: str, output: str | os.PathLike) -> None:
    """Path coloured by curvature (log scale) and κ(s) on a log axis."""
    plt = _pyplot()
    fig, (ax_path, ax_k) = plt.subplots(1, 2, figsize=(12, 5), gridspec_kw={"width_ratios": [1, 1.3]})
    colored_path(ax_path, samples, samples.curvature, "curvature (1/mm)", cmap="plasma", log=True)
    ax_path.set_title(f"{title}: path coloured by curvature")
    ax_k.semilogy(samples.s, np.maximum(samples.curvature, 1e-6), lw=1.0)
    ax_k.set_xlabel("arc length s (mm)")
    ax_k.set_ylabel("curvature κ (1/mm)")
    ax_k.set_title(f"curvature along the path (length {samples.length:.3f} mm)")
    ax_k.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    save_figure(fig, output)


# ---- fuzzy advisor (seed 002) ------------------------------------------------------------------

def plot_fuzzy_advice(advice, title: str, output: str | os.PathLike) -> None:
    """Fuzzy advice: feed % against arc length (controller output and filtered feed) over κ and the
    normalised Dκ, and the path coloured by the advised feed (mm/min)."""
    samples = advice.profile.samples
    segments, mid = path_segments(samples, advice.profile.feed_mm_min)
    pts = samples.xyz[:, :2]
    draw_fuzzy(samples.s, advice.controller_pct, advice.feed_pct, advice.features.curvature_1_mm,
               advice.features.curvature_variation, segments, mid, (float(mid.min()), float(mid.max())),
               pts.min(axis=0), pts.max(axis=0), advice.table, advice.profile.max_feed_mm_s, title, output)


def draw_fuzzy(s, controller_pct, feed_pct, curvature, variation, segments, mid, value_range, lo_xy, hi_xy,
               table, max_feed_mm_s: float, title: str, output: str | os.PathLike) -> None:
    """:func:`plot_fuzzy_advice`'s figure from its arrays: the lines against arc length ``s``, the
    path's segments coloured by ``mid`` (:func:`draw_segments`); a long program's come thinned
    (:mod:`fuzzyfeed.report.plot_trace`)."""
    plt = _pyplot()
    fig = plt.figure(figsize=(13, 7.5))
    grid = fig.add_gridspec(2, 2, width_ratios=[1.5, 1], height_ratios=[1, 1])
    ax_f = fig.add_subplot(grid[0, 0])
    ax_k = fig.add_subplot(grid[1, 0], sharex=ax_f)
    ax_p = fig.add_subplot(grid[:, 1])
    ax_f.plot(s, controller_pct, lw=0.8, color="0.6", label="controller (before filter)")
    ax_f.plot(s, feed_pct, lw=1.6, color="C0",
              label=f"advised feed ({table.filter} filter, M = "
                    + (f"{table.filter_mm:g} mm)" if table.filter_mm
                       else f"{table.filter_points} points)"))
    ax_f.axhline(table.feed_floor_pct, color="C3", lw=0.8, ls=":", label="feed floor")
    ax_f.set_ylabel("feed (% of max)")
    ax_f.set_ylim(0, 105)
    ax_f.grid(True, alpha=0.3)
    ax_f.legend(loc="lower right", fontsize=8)
    ax_f.set_title(f"{title}: fuzzy feed advice ({table.name} rules, "
                   f"F = {max_feed_mm_s * 60:g} mm/min)")
    ax_k.semilogy(s, np.maximum(curvature, 1e-5), lw=1.0, color="C1",
                  label="curvature κ (1/mm)")
    ax_k.set_ylabel("curvature κ (1/mm)")
    ax_k.set_xlabel("arc length s (mm)")
    ax_k.grid(True, which="both", alpha=0.3)
    ax_d = ax_k.twinx()
    ax_d.plot(s, variation, lw=1.0, color="C2",
              label="normalised Dκ (WS = " + (f"{table.window_mm:g} mm)" if table.window_mm
                                              else f"{table.window_points} points)"))
    ax_d.set_ylabel("normalised Dκ")
    ax_d.set_ylim(-0.02, 1.05)
    lines = ax_k.get_lines() + ax_d.get_lines()
    ax_k.legend(lines, [ln.get_label() for ln in lines], loc="lower right", fontsize=8)
    draw_segments(ax_p, segments, mid, value_range, lo_xy, hi_xy, "advised feed (mm/min)", cmap="turbo_r")
    ax_p.set_title("path coloured by advised feed")
    fig.tight_layout()
    save_figure(fig, output)


def _input_labels(table) -> tuple[str, str]:
    """Axis labels of a table's two inputs (paper: κ on a symlog axis; machine: linear ratios)."""
    if table.inputs == "machine":
        return ("safe-feed ratio here (x programmed F)", "safe-feed ratio near (x programmed F)")
    return ("curvature κ (1/mm, symlog)", "normalised curvature variation Dκ")


def _kappa_axis(ax, table) -> None:
    if table.inputs == "machine":
        ax.set_xlim(*table.curvature.universe)
        return
    lo, hi = table.curvature.universe
    positive = [p for t in table.curvature.terms for p in t.points if p > 0]
    ax.set_xscale("symlog", linthresh=min(positive) if positive else 0.01, linscale=0.5)
    ax.set_xlim(lo, hi)


def plot_rule_surface(table, output: str | os.PathLike, points: int = 241) -> None:
    """The controller's surface feed %(κ, Dκ) as a map with contours (κ on a symlog axis, so the
    small curvatures where most terms sit stay visible) and the membership functions."""
    from fuzzyfeed.fuzzy.engine import compile_table, membership

    plt = _pyplot()
    engine = compile_table(table)
    k_lo, k_hi = table.curvature.universe
    d_lo, d_hi = table.curvature_variation.universe
    k_breaks = [p for t in table.curvature.terms for p in t.points]
    positive = [p for p in k_breaks if p > 0] or [max(k_hi, 1e-9) * 1e-2]
    k_axis = np.union1d(np.concatenate([[k_lo], np.geomspace(min(positive) / 10, k_hi, points)]),
                        k_breaks)
    k_axis = k_axis[(k_axis >= k_lo) & (k_axis <= k_hi)]
    d_axis = np.union1d(np.linspace(d_lo, d_hi, points),
                        [p for t in table.curvature_variation.terms for p in t.points])
    kk, dd = np.meshgrid(k_axis, d_axis)
    zz = engine.feed_pct(kk.ravel(), dd.ravel()).reshape(kk.shape)
    fig = plt.figure(figsize=(13, 7.5))
    grid = fig.add_gridspec(3, 2, width_ratios=[1.25, 1])
    ax_s = fig.add_subplot(grid[:, 0])
    f_lo, f_hi = table.feed.universe
    mesh = ax_s.pcolormesh(kk, dd, zz, cmap="turbo_r", vmin=f_lo, vmax=f_hi, shading="gouraud")
    levels = np.arange(np.ceil(zz.min() / 10) * 10, zz.max() + 1e-9, 10)
    if levels.size:
        cs = ax_s.contour(kk, dd, zz, levels=levels, colors="k", linewidths=0.6)
        ax_s.clabel(cs, fmt="%g %%", fontsize=7)
    _kappa_axis(ax_s, table)
    ax_s.set_ylim(d_lo, d_hi)
    x_label, y_label = _input_labels(table)
    ax_s.set_xlabel(x_label)
    ax_s.set_ylabel(y_label)
    ax_s.set_title(f"control surface: {table.name} rules, feed % (exact centroid)")
    fig.colorbar(mesh, ax=ax_s, label="feed (% of max)")
    for row, (var, xlabel) in enumerate(((table.curvature, x_label), (table.curvature_variation, y_label),
                                         (table.feed, "feed (% of max)"))):
        ax = fig.add_subplot(grid[row, 1])
        lo, hi = var.universe
        x = np.union1d(np.linspace(lo, hi, 2001), [p for t in var.terms for p in t.points])
        if row == 0:
            x = np.union1d(x, k_axis)
        mu = membership(var, x)
        for j, term in enumerate(var.terms):
            line, = ax.plot(x, mu[:, j], lw=1.3, label=term.label)
            a, b, c, d = term.trapezoid
            peak = b if b == c else (b + c) / 2
            if row == 0 and b != c and table.inputs != "machine":
                peak = (b * c) ** 0.5 if b > 0 else c / 3
            ax.text(peak, 1.04, term.label, ha="center", va="bottom", fontsize=7, color=line.get_color())
        ax.set_ylim(-0.03, 1.18)
        ax.set_xlim(lo, hi)
        if row == 0:
            _kappa_axis(ax, table)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("membership")
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    save_figure(fig, output)


def plot_schedule(traj, bound=None, title: str = "", output: str | os.PathLike | None = None,
                  feed_cap=None):
    """A schedule (slw.schedule: the LP's or the window's): feed against arc length with the feed limit
    (and the time-optimal bound), and feed, tangential acceleration and jerk against time with their
    limits. ``feed_cap`` ((s_mm, feed_mm_s), e.g. a program's F words) is drawn as part of the feed
    limit."""
    from fuzzyfeed.machine.limits import feed_limits
    from fuzzyfeed.geometry.sampling import sample_by_arc_length

    plt = _pyplot()
    lim = traj.limits
    fig, axes = plt.subplots(4, 1, figsize=(11, 11))
    ax = axes[0]
    samples = sample_by_arc_length(traj.curve, n=min(20000, max(2000, int(traj.s_mm[-1] / 0.05))))
    limit = feed_limits(samples, lim)
    if feed_cap is not None:
        from fuzzyfeed.slw.feed_cap import FeedCap

        limit = np.minimum(limit, FeedCap(*feed_cap, float(samples.s[-1]))(samples.s))
    ax.plot(samples.s, limit * 60, color="0.6", lw=1.0, label="feed limit")
    if bound is not None:  # a Bound (its own grid) or a FeedProfile
        b_s, b_v = ((bound.s_mm, bound.feed_mm_s) if hasattr(bound, "s_mm")
                    else (bound.samples.s, bound.feed_mm_s))
        b_time = bound.time_s if hasattr(bound, "time_s") else bound.travel_time_s()
        ax.plot(b_s, b_v * 60, color="tab:green", lw=1.0, ls="--",
                label="time-optimal bound (no jerk limit)")
    window = bool(traj.n_blocks)  # the look-ahead window's blocks, or the whole-path LP's profile
    ax.plot(traj.s_mm, traj.feed_mm_s * 60, color="tab:blue", lw=1.2,
            label="scheduled feed (" + ("look-ahead window" if window else "whole-path LP") + ")")
    crit = traj.critical_s_mm
    if crit.size:
        ax.plot(crit, np.interp(crit, traj.s_mm, traj.feed_mm_s) * 60, "v", color="tab:red", ms=5,
                label=f"{'block junctions' if window else 'the profile’s valleys and rests'} ({crit.size})")
    ax.set_xlabel("arc length s (mm)")
    ax.set_ylabel("feed (mm/min)")
    ax.set_title(f"{title}: jerk-limited schedule, cycle time {traj.cycle_time_s:.3f} s"
                 + (f", bound {b_time:.3f} s" if bound is not None else ""))
    ax.legend(loc="lower right", fontsize=8)
    t = traj.t_s
    for ax, y, limit, label in ((axes[1], traj.feed_mm_s * 60, lim.feed_mm_min, "feed (mm/min)"),
                                (axes[2], traj.acc_mm_s2, lim.tangential_acc_mm_s2,
                                 "tangential acc (mm/s²)\n(dotted: smallest axis limit)"),
                                (axes[3], traj.jerk_mm_s3, lim.jerk_mm_s3, "tangential jerk (mm/s³)")):
        ax.plot(t, y, lw=1.0)
        ax.axhline(limit, color="tab:red", lw=0.8, ls=":")
        if ax is not axes[1]:
            ax.axhline(-limit, color="tab:red", lw=0.8, ls=":")
        ax.set_ylabel(label)
        ax.set_xlabel("time (s)")
        ax.grid(True, alpha=0.3)
    axes[0].grid(True, alpha=0.3)
    fig.tight_layout()
    if output is None:
        return fig
    save_figure(fig, output)
    return None
