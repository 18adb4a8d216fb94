"""A program's advice plot (``advise PROGRAM --plot``) from a trace thinned as the advice is made
(issue 36): the CSV's rows of every piece go through :class:`FuzzyTrace`, which keeps a bounded
number of them, and :func:`~fuzzyfeed.report.plot.draw_fuzzy` draws what it kept. Nothing per
sample of the program is held; the same rows in any split give the same trace.

- Lines against arc length (feed %, controller %, κ, Dκ): the arc length is cut into buckets of a
  width ``w`` (a power of two times :data:`FIRST_WIDTH_MM`, doubled, buckets merged, while more
  than :data:`MAX_BUCKETS` hold samples); each bucket keeps its first and last sample and, for
  every line, the samples of its least and greatest value (the first on ties). Every bucket is a
  small fraction of a pixel column of the printed plot, so every column is drawn over the same
  values from the same least to the same greatest: the same picture (min/max decimation).
- The path coloured by the feed: the xy plane is cut into square cells of a side ``c`` (a power
  of two times :data:`FIRST_CELL_MM`, doubled while more than :data:`MAX_SEGMENTS` segments are
  kept); of the segments between consecutive samples of a cut no longer than ``c``, each cell
  keeps the last drawn whose middle lies in it, the longer ones are all kept; they are drawn in the
  path's order, a kept short one stretched about its middle to √2 cells (it stands for its cell:
  no gaps; it moves by less than a cell, under a pixel). The colour scale and the axes run over every segment and sample, not only those
  kept. A cell is well under a pixel of the printed plot and a line 2 points wide: each pixel
  shows the colour of the last pass over it, as when every segment is drawn.
A program whose rows fit under these bounds keeps them all: its plot is drawn from every sample.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Most buckets of the arc length holding samples (the plot is ~900 pixels wide).
MAX_BUCKETS = 8192
#: Most path segments kept (each cell a few times smaller than a pixel of the path's panel).
MAX_SEGMENTS = 1 << 18
#: The smallest bucket width and cell side (mm): a power of two, far under any pixel.
FIRST_WIDTH_MM = 2.0 ** -20
FIRST_CELL_MM = 2.0 ** -20
#: A kept segment shorter than this many cell sides is drawn this long, about its middle, along
#: itself (it stands for the segments of its cell that are not drawn: no gap between the kept ones).
CELL_COVER = 2.0 ** 0.5
#: Rows taken before they are thinned with those kept (memory: a few times this many rows).
PENDING_ROWS = 1 << 17
_SERIES = ("feed_pct_controller", "feed_pct", "curvature_1_mm", "curvature_variation")


@dataclass(frozen=True, eq=False)
class FuzzyTraceData:
    """What :func:`~fuzzyfeed.report.plot.draw_fuzzy` draws (module docstring)."""

    s: np.ndarray
    lines: dict               # name (_SERIES) -> values at s
    segments: np.ndarray      # (n, 2, 2)
    mid: np.ndarray           # (n,) feed (mm/min) of each segment
    value_range: tuple
    lo_xy: np.ndarray
    hi_xy: np.ndarray
    max_feed_mm_s: float
    cuts: int


def _first_per_group(group: np.ndarray, *keys: np.ndarray) -> np.ndarray:
    """Index of the first row of each group ordered by ``keys`` (last key most significant after
    the group), ties in row order: ``group`` non-decreasing."""
    order = np.lexsort((*keys[::-1], group)) if keys else np.arange(group.size)
    g = group[order]
    first = np.ones(g.size, bool)
    first[1:] = g[1:] != g[:-1]
    return order[first]


class FuzzyTrace:
    """Takes a program advice's CSV rows piece by piece (:meth:`add`, in order), keeps the thinned
    trace (module docstring); :meth:`data` what is drawn."""

    def __init__(self, max_buckets: int = MAX_BUCKETS, max_segments: int = MAX_SEGMENTS):
        self.max_buckets, self.max_segments = int(max_buckets), int(max_segments)
        self.width, self.cell = FIRST_WIDTH_MM, FIRST_CELL_MM
        self._rows = {k: np.zeros(0) for k in ("s", *_SERIES)}
        self._rows["i"] = np.zeros(0, dtype=np.int64)
        self._seg = {"a": np.zeros((0, 2)), "b": np.zeros((0, 2)), "v": np.zeros(0),
                     "i": np.zeros(0, dtype=np.int64)}
        self._n = 0                      # samples seen
        self._offset = 0.0               # arc length of the cuts before (end to end)
        self._cut = None                 # the cut of the last sample, its s, xy and feed
        self._last = None
        self._v_lo, self._v_hi = np.inf, -np.inf
        self._lo_xy, self._hi_xy = np.full(2, np.inf), np.full(2, -np.inf)
        self._f_max = -np.inf
        self._pending: list = []         # (rows, segments) taken since the last flush
        self._pending_n = 0
        self.cuts = 0

    def add(self, cols: dict) -> None:
        n = int(np.asarray(cols["cut"]).size)
        if n == 0:
            return
        cut = np.asarray(cols["cut"])
        s_cut = np.asarray(cols["s_mm"], dtype=float)
        xy = np.stack([np.asarray(cols["x_mm"], float), np.asarray(cols["y_mm"], float)], axis=1)
        ceil = np.asarray(cols["programmed_feed_mm_min"], dtype=float)
        pct = np.asarray(cols["feed_pct"], dtype=float)
        feed = pct / 100.0 * ceil / 60.0 * 60.0          # as the whole advice's profile has it (mm/min)
        # arc length end to end: each cut runs on from the length of the cuts before (its last s)
        s = np.empty(n)
        prev_cut = self._cut
        prev_s = None if self._last is None else self._last[0]
        offset = self._offset
        lo = 0
        for hi in [*(np.flatnonzero(cut[1:] != cut[:-1]) + 1).tolist(), n]:
            if prev_cut is not None and cut[lo] != prev_cut:
                offset += prev_s
                self.cuts += 1
            elif prev_cut is None:
                self.cuts += 1
            s[lo:hi] = offset + s_cut[lo:hi]
            prev_cut, prev_s = cut[lo], float(s_cut[hi - 1])
            lo = hi
        # segments between consecutive samples of one cut (the first one joins the row before)
        same = np.ones(n, bool)
        same[0] = self._cut is not None and cut[0] == self._cut
        same[1:] = cut[1:] == cut[:-1]
        prev_xy = np.vstack([self._last[1][None, :] if self._last is not None else xy[:1], xy[:-1]])
        prev_f = np.concatenate([[self._last[2] if self._last is not None else feed[0]], feed[:-1]])
        idx = self._n + np.arange(n, dtype=np.int64)
        on = same
        seg_a, seg_b, seg_v = prev_xy[on], xy[on], (0.5 * (prev_f + feed))[on]
        self._cut = int(cut[-1])
        self._last = (float(s_cut[-1]), xy[-1].copy(), float(feed[-1]))
        self._offset = offset
        self._n += n
        if seg_v.size:
            self._v_lo = min(self._v_lo, float(seg_v.min()))
            self._v_hi = max(self._v_hi, float(seg_v.max()))
        self._lo_xy = np.minimum(self._lo_xy, xy.min(axis=0))
        self._hi_xy = np.maximum(self._hi_xy, xy.max(axis=0))
        self._f_max = max(self._f_max, float(ceil.max()))
        self._pending.append(({"s": s, "i": idx, **{k: np.asarray(cols[k], dtype=float) for k in _SERIES}},
                              {"a": seg_a, "b": seg_b, "v": seg_v, "i": idx[on]}))
        self._pending_n += n
        if self._pending_n >= PENDING_ROWS:
            self._flush()

    def _flush(self) -> None:
        """The rows and segments taken since the last flush thinned with those kept (the result
        is the same whenever this runs: the sizes only grow, the least that bound them is found)."""
        if not self._pending:
            return
        self._rows = {k: np.concatenate([self._rows[k], *(r[k] for r, _ in self._pending)]) for k in self._rows}
        self._seg = {k: np.concatenate([self._seg[k], *(g[k] for _, g in self._pending)]) for k in self._seg}
        self._pending, self._pending_n = [], 0
        self._thin_rows()
        self._thin_segments()

    # -- the lines against arc length ------------------------------------------------------
    def _keep_rows(self) -> np.ndarray:
        r = self._rows
        group = np.floor(r["s"] / self.width).astype(np.int64)
        keep = [_first_per_group(group), _first_per_group(group, -r["i"])]
        for k in _SERIES:
            keep.append(_first_per_group(group, r[k]))
            keep.append(_first_per_group(group, -r[k]))
        return np.unique(np.concatenate(keep)), np.unique(group).size

    def _thin_rows(self) -> None:
        while True:
            keep, buckets = self._keep_rows()
            self._rows = {k: v[keep] for k, v in self._rows.items()}
            if buckets <= self.max_buckets:
                return
            self.width *= 2.0

    # -- the path --------------------------------------------------------------------------
    def _thin_segments(self) -> None:
        while True:
            g = self._seg
            a, b = g["a"], g["b"]
            short = np.linalg.norm(b - a, axis=1) <= self.cell
            mid = np.floor(0.5 * (a + b) / self.cell).astype(np.int64)
            key = (mid[:, 0] + (1 << 31)) * (1 << 32) + (mid[:, 1] + (1 << 31))
            sk = np.flatnonzero(short)
            # the last (largest index) segment of each cell among the short ones
            order = sk[np.lexsort((-g["i"][sk], key[sk]))]
            first = np.ones(order.size, bool)
            first[1:] = key[order][1:] != key[order][:-1]
            keep = np.sort(np.concatenate([np.flatnonzero(~short), order[first]]))
            self._seg = {k: v[keep] for k, v in g.items()}
            if keep.size <= self.max_segments:
                return
            self.cell *= 2.0

    def data(self) -> FuzzyTraceData:
        self._flush()
        r, g = self._rows, self._seg
        a, b = g["a"].copy(), g["b"].copy()
        if self.cell > FIRST_CELL_MM:    # thinned: a cell's last segment drawn across the whole cell
            d = b - a
            n = np.linalg.norm(d, axis=1)
            grow = (n > 0) & (n < CELL_COVER * self.cell)
            half = (0.5 * CELL_COVER * self.cell / np.where(grow, n, 1.0))[:, None] * d
            m = 0.5 * (a + b)
            a[grow], b[grow] = (m - half)[grow], (m + half)[grow]
        return FuzzyTraceData(s=r["s"], lines={k: r[k] for k in _SERIES},
                              segments=np.stack([a, b], axis=1) if g["v"].size else np.zeros((0, 2, 2)),
                              mid=g["v"], value_range=(self._v_lo, self._v_hi), lo_xy=self._lo_xy,
                              hi_xy=self._hi_xy, max_feed_mm_s=self._f_max / 60.0, cuts=self.cuts)


def plot_trace(trace: FuzzyTrace, table, title: str, output) -> None:
    """The advice plot of a program (:func:`~fuzzyfeed.report.plot.draw_fuzzy`) from its trace."""
    from fuzzyfeed.report.plot import draw_fuzzy

    d = trace.data()
    draw_fuzzy(d.s, d.lines["feed_pct_controller"], d.lines["feed_pct"], d.lines["curvature_1_mm"],
               d.lines["curvature_variation"], d.segments, d.mid, d.value_range, d.lo_xy, d.hi_xy, table,
               d.max_feed_mm_s, title, output)
