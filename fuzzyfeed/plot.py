"""Plots (matplotlib, imported on call). Every function writes a PNG atomically or returns a figure."""

from __future__ import annotations

import os

import numpy as np

from fuzzyfeed.io.atomic import atomic_write
from fuzzyfeed.sampling import PathSamples


def _pyplot():
    # no backend is forced: headless machines fall back to Agg, Jupyter keeps its inline backend
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, output: str | os.PathLike) -> None:
    """Write ``fig`` as PNG atomically and close it."""
    plt = _pyplot()
    try:
        with atomic_write(output, "wb") as handle:
            fig.savefig(handle, format="png", dpi=130)
    finally:
        plt.close(fig)


def colored_path(ax, samples: PathSamples, values: np.ndarray, label: str, cmap: str = "viridis",
                 log: bool = False):
    """Draw the path in the xy plane as a line coloured by ``values``; returns the colorbar."""
    from matplotlib.collections import LineCollection
    from matplotlib.colors import LogNorm, Normalize

    pts = samples.xyz[:, :2]
    segments = np.stack([pts[:-1], pts[1:]], axis=1)
    mid = 0.5 * (values[:-1] + values[1:])
    if log:
        positive = mid[mid > 0]
        # four decades below the peak are enough to see where a path is sharp
        floor = max(positive.min(), mid.max() * 1e-4) if positive.size else 1e-6
        norm = LogNorm(vmin=floor, vmax=max(mid.max(), floor * 10))
        mid = np.maximum(mid, floor)
    else:
        norm = Normalize(vmin=mid.min(), vmax=mid.max() if mid.max() > mid.min() else mid.min() + 1)
    lc = LineCollection(segments, array=mid, cmap=cmap, norm=norm, linewidths=2.0)
    ax.add_collection(lc)
    ax.set_xlim(pts[:, 0].min() - 1, pts[:, 0].max() + 1)
    ax.set_ylim(pts[:, 1].min() - 1, pts[:, 1].max() + 1)
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
