"""Figures of a comparison (matplotlib imported on call): feeds, acceleration, jerk, chord and
contour error."""

from __future__ import annotations

import os

import numpy as np

from fuzzyfeed.report.plot import _pyplot, colored_path, save_figure

#: Line style per method, so every figure reads the same.
STYLE = {"fuzzy": ("tab:orange", "-"), "fuzzy-safe": ("tab:red", "--"), "slw": ("tab:blue", "-"),
         "constant": ("tab:gray", ":"), "bound": ("black", "-."), "slw-tol": ("tab:cyan", "-.")}


def comparison_figure(comparison):
    """The 4 × 2 figure of ``fuzzyfeed compare --plot`` (returned, not saved)."""
    plt = _pyplot()
    fig, axes = plt.subplots(4, 2, figsize=(14, 16))
    ax_feed, ax_path = axes[0]
    ax_acc, ax_jerk = axes[1]
    ax_chord, ax_contour = axes[2]
    gs = axes[3, 0].get_gridspec()
    for ax in axes[3]:
        ax.remove()
    ax_table = fig.add_subplot(gs[3, :])
    limits = comparison.limits
    for method, sim in comparison.simulations.items():
        color, ls = STYLE.get(method, (None, "-"))
        s_tick = sim.law.s_mm
        ax_feed.plot(s_tick, sim.law.feed_mm_s * 60.0, color=color, ls=ls, lw=1.2, label=method)
        ax_acc.plot(s_tick, sim.law.acc_mm_s2, color=color, ls=ls, lw=1.0, label=method)
        ax_jerk.plot(s_tick, np.abs(sim.law.jerk_mm_s3), color=color, ls=ls, lw=0.8, label=method)
        ax_chord.plot(0.5 * (s_tick[:-1] + s_tick[1:]), sim.chord_err_mm * 1e3, color=color, ls=ls,
                      lw=1.0, label=method)
        ax_contour.plot(s_tick, sim.tracking.contour_mm * 1e3, color=color, ls=ls, lw=1.0, label=method)
    ax_feed.set_ylabel("feed (mm/min)")
    ax_feed.set_title(f"{comparison.name}: feed along the path")
    ax_acc.axhline(limits.tangential_acc_mm_s2, color="k", lw=0.6, ls=":")
    ax_acc.axhline(-limits.tangential_acc_mm_s2, color="k", lw=0.6, ls=":")
    ax_acc.set_ylabel("tangential acceleration (mm/s²)")
    ax_acc.set_ylim(-4 * limits.tangential_acc_mm_s2, 4 * limits.tangential_acc_mm_s2)
    ax_jerk.set_yscale("symlog", linthresh=limits.jerk_mm_s3 / 10)
    ax_jerk.axhline(limits.jerk_mm_s3, color="k", lw=0.6, ls=":")
    ax_jerk.set_ylabel("|jerk| (mm/s³, symlog)")
    ax_chord.axhline(limits.chord_tol_mm * 1e3, color="k", lw=0.6, ls=":", label="tolerance")
    ax_chord.set_yscale("log")
    ax_chord.set_ylabel("chord error (µm)")
    servo = next(iter(comparison.simulations.values())).metrics.servo
    ax_contour.set_yscale("log")
    top = max(float(sim.tracking.contour_mm.max()) for sim in comparison.simulations.values()) * 1e3
    if top > 0:
        ax_contour.set_ylim(bottom=top * 1e-5)
    ax_contour.set_ylabel("contour error (µm, log)")
    ax_contour.set_title(f"servo: {servo}", fontsize=9)
    ax_contour.set_xlabel("arc length s (mm) of the set-point")
    for ax in (ax_feed, ax_acc, ax_jerk, ax_chord, ax_contour):
        ax.set_xlabel("arc length s (mm)")
        ax.grid(True, alpha=0.3)
    ax_feed.legend(loc="lower right", fontsize=8)
    ax_chord.legend(loc="lower right", fontsize=8)
    fuzzy = comparison.profiles["fuzzy"]
    colored_path(ax_path, comparison.samples, fuzzy.feed_mm_min, "advised feed (mm/min)", cmap="viridis")
    ax_path.set_title("path coloured by the fuzzy advice")
    ax_table.axis("off")
    rows = [[m, f"{r['cycle_time_s']:.3f}", f"{r['ratio_to_bound']:.3f}", f"{r['chord_err_max_um']:.3g}",
             f"{r['contour_err_max_um']:.4g}", f"{r['contour_err_mean_um']:.4g}", f"{r['contour_err_rms_um']:.4g}",
             str(sum(v for k, v in r.items() if k.startswith("violations_")))]
            for m, r in ((sim.metrics.method, sim.metrics.row()) for sim in comparison.simulations.values())]
    table = ax_table.table(cellText=rows, colLabels=["method", "cycle (s)", "/ bound", "chord max (µm)",
                                                     "contour max (µm)", "contour mean (µm)",
                                                     "contour rms (µm)", "violating ticks"],
                           loc="upper center")
    table.scale(1, 1.6)
    ax_table.text(0.0, 0.25, "\n".join(comparison.cross_check.lines()), fontsize=8, va="top",
                  transform=ax_table.transAxes, wrap=True)
    fig.tight_layout()
    return fig


def plot_comparison(comparison, output: str | os.PathLike) -> None:
    save_figure(comparison_figure(comparison), output)


def pareto_figure(points: dict[str, list[tuple[float, float, str]]], title: str,
                  ylabel: str = "max chord error (µm)"):
    """Cycle time against an error: ``points`` maps a family to (time, error µm, label)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 6))
    for family, pts in points.items():
        color, ls = STYLE.get(family, (None, "-"))
        t = [p[0] for p in pts]
        e = [p[1] for p in pts]
        ax.plot(t, e, marker="o", color=color, ls=ls, label=family)
        for ti, ei, label in pts:
            ax.annotate(label, (ti, ei), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.set_xlabel("cycle time (s)")
    ax.set_ylabel(ylabel)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    return fig
