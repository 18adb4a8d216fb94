"""The value plot's feed trace (:mod:`fuzzyfeed.report.value`): the F in force along the feed moves
of the program as written and as advised, end to end over the cuts, and where the tool passed
beyond the tolerance as written; made block by block (:data:`TRACE_BLOCK` segments at a time) and
thinned to what the plot draws, never a row per segment of a whole program (issue 36).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.program.run import ProgramPath, ProgramRun


@dataclass(frozen=True, eq=False)
class FeedTrace:
    """The F in force along the feed moves of the cuts, end to end (for the value plot): per run
    label the arc length where each segment starts and ends (mm) and its F (mm/min); the advised
    program's segments (start, end points) with their F as a fraction of the written F there; and
    where the tool passed beyond the tolerance as written (arc length along the feed moves and
    position, at most one point per 0.1 mm). Thinned for the plot (:func:`feed_trace`): touching
    steps of one F are one step, touching segments of one fraction one segment where it passes
    within :data:`TRACE_THIN_SHARE` of the extent of the points it replaces."""

    s_mm: dict[str, tuple[np.ndarray, np.ndarray]]
    feed_mm_min: dict[str, np.ndarray]
    segments: np.ndarray            # (n, 2, 3) the advised program's measured segments
    advised_fraction: np.ndarray    # (n,)
    over_s_mm: np.ndarray
    over_xyz: np.ndarray



def _along(path: ProgramPath, block: int | None = None):
    """Per measured segment of ``path``, end to end over its chains: start and end arc length,
    F (mm/min), start and end points, and per chain the offset of its first measured segment.
    With ``block``: an iterator of these (without the offsets) over runs of at most ``block``
    segments of a chain, in order (the arc lengths summed on from block to block)."""
    if block is not None:
        return _along_blocks(path, block)
    s0, s1, feed, a, b, offsets = [], [], [], [], [], []
    offset = 0.0
    for chain in path.chains:
        m = chain.motion
        keep = chain.seg_measured
        lk = np.linalg.norm(np.diff(m.points, axis=0), axis=1)[keep]
        start = offset + np.cumsum(lk) - lk          # a chain with no measured segment adds none
        offsets.append(offset)
        s0.append(start)
        s1.append(start + lk)
        feed.append(m.feed_mm_s[keep] * 60.0)
        a.append(m.points[:-1][keep])
        b.append(m.points[1:][keep])
        offset += float(lk.sum())
    cat = (lambda parts, shape: np.concatenate(parts) if parts else np.zeros(shape))
    return (cat(s0, 0), cat(s1, 0), cat(feed, 0), cat(a, (0, 3)), cat(b, (0, 3)), offsets)


def _along_blocks(path: ProgramPath, block: int):
    offset = 0.0
    for chain in path.chains:
        m = chain.motion
        total = 0.0
        for lo in range(0, m.n_segments, block):
            hi = min(lo + block, m.n_segments)
            keep = chain.seg_measured[lo:hi]
            lk = np.linalg.norm(np.diff(m.points[lo:hi + 1], axis=0), axis=1)[keep]
            start = offset + total + np.cumsum(lk) - lk
            yield (start, start + lk, m.feed_mm_s[lo:hi][keep] * 60.0, m.points[lo:hi][keep],
                   m.points[lo + 1:hi + 1][keep])
            total += float(lk.sum())
        offset += total


#: Segments of the feed trace handled at once (the trace of a 10⁶-segment program is made block by
#: block and thinned: what the plot draws, not a row per segment).
TRACE_BLOCK = 1 << 16
#: Consecutive segments of one advised fraction are drawn as one where it passes within this share
#: of the path's extent (in x, y: what the plot draws) of every point it replaces.
TRACE_THIN_SHARE = 1e-4


def _thin_steps(s0: np.ndarray, s1: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A step plot's runs of one value over touching steps (to 1e-9 of their arc length) merged:
    the same drawing."""
    if f.size == 0:
        return s0, s1, f
    first = np.ones(f.size, bool)
    first[1:] = (f[1:] != f[:-1]) | (np.abs(s0[1:] - s1[:-1]) > 1e-9 * np.maximum(1.0, np.abs(s1[:-1])))
    starts = np.flatnonzero(first)
    ends = np.append(starts[1:], f.size) - 1
    return s0[starts], s1[ends], f[starts]


def _thin_segments(a: np.ndarray, b: np.ndarray, frac: np.ndarray, eps: float):
    """Runs of touching segments of one fraction replaced by one segment where every point of the
    run lies within ``eps`` (x, y) of it; other runs kept segment by segment."""
    n = frac.size
    if n == 0:
        return a, b, frac
    first = np.ones(n, bool)
    first[1:] = (frac[1:] != frac[:-1]) | np.any(a[1:] != b[:-1], axis=1)
    run = np.cumsum(first) - 1
    starts = np.flatnonzero(first)
    ends = np.append(starts[1:], n) - 1
    p, q = a[starts][run, :2], b[ends][run, :2]
    d = q - p
    dd = np.einsum("ij,ij->i", d, d)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.clip(np.where(dd > 0, np.einsum("ij,ij->i", a[:, :2] - p, d) / dd, 0.0), 0.0, 1.0)
    off = np.linalg.norm(a[:, :2] - (p + t[:, None] * d), axis=1)
    bad = np.zeros(starts.size, bool)
    np.logical_or.at(bad, run, (off > eps) & ~first)
    sel = first | bad[run]
    out_b = b[sel].copy()
    merged = first[sel] & ~bad[run[sel]]
    out_b[merged] = b[ends[run[sel][merged]]]
    return a[sel], out_b, frac[sel]


def column_extremes(x: np.ndarray, y: np.ndarray, x0: float, per_column: float, column0: float = 0.0):
    """The vertices of a polyline (x nondecreasing) a line drawn over pixel columns needs, M4
    (Jugel et al., "M4: A Visualization-Oriented Time Series Data Aggregation", PVLDB 7(10), 2014):
    per column ⌊column0 + (x − x0)·per_column⌋ its first, last, lowest and highest vertex, in the
    polyline's order. Every column is inked from the same lowest to the same highest y and joined
    to its neighbours as before; at most four vertices a column, whatever the length of the line."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    if x.size <= 4:
        return x, y
    col = np.floor(column0 + (x - x0) * per_column).astype(np.int64)
    first = np.flatnonzero(np.concatenate([[True], col[1:] != col[:-1]]))
    last = np.append(first[1:], x.size) - 1
    order = np.lexsort((y, np.repeat(np.arange(first.size), np.diff(np.append(first, x.size)))))
    keep = np.unique(np.concatenate([first, last, order[first], order[last]]))
    return x[keep], y[keep]


def feed_trace(written_path: ProgramPath, written: ProgramRun, advised_path: ProgramPath,
               tol_um: float) -> FeedTrace:
    """The F in force along the measured segments of both programs (for the value plot), made
    block by block and thinned (:data:`TRACE_BLOCK`, :func:`_thin_steps`, :func:`_thin_segments`).
    The paths' chains may be in a scratch store (:class:`~fuzzyfeed.program.chain_store.StoredPath`):
    they are read a block at a time; nothing per segment of a whole program is held but the
    thinned trace (the advised F is compared with the written steps thinned: the step a point
    falls in has the F of the segment it falls in)."""
    written_steps = [_thin_steps(*blk[:3]) for blk in _along(written_path, TRACE_BLOCK)]
    cat = (lambda parts, k, shape: np.concatenate([p[k] for p in parts]) if parts else np.zeros(shape))
    ws0, ws1, wf = cat(written_steps, 0, 0), cat(written_steps, 1, 0), cat(written_steps, 2, 0)
    del written_steps
    lo_xy, hi_xy = np.full(2, np.inf), np.full(2, -np.inf)
    for chain in advised_path.chains:
        points = chain.motion.points
        for a in range(0, len(points), TRACE_BLOCK):
            pts = points[a:a + TRACE_BLOCK]
            if pts.size:
                lo_xy = np.minimum(lo_xy, pts[:, :2].min(axis=0))
                hi_xy = np.maximum(hi_xy, pts[:, :2].max(axis=0))
    eps = TRACE_THIN_SHARE * (float((hi_xy - lo_xy).max()) if np.isfinite(lo_xy).all() else 0.0)
    parts = []
    for as0, as1, af, pa, pb in _along(advised_path, TRACE_BLOCK):
        mid = 0.5 * (as0 + as1)
        idx = np.clip(np.searchsorted(ws0, mid, side="right") - 1, 0, max(wf.size - 1, 0))
        frac = np.clip(af / wf[idx] if wf.size else np.ones_like(af), 0.0, 1.0)
        parts.append((*_thin_steps(as0, as1, af), *_thin_segments(pa, pb, frac, eps)))
    as0, as1, af, pa, pb, frac = (cat(parts, 0, 0), cat(parts, 1, 0), cat(parts, 2, 0), cat(parts, 3, (0, 3)),
                                  cat(parts, 4, (0, 3)), cat(parts, 5, 0))
    os_, ox = _over_points(written_path, written, tol_um)
    if os_.size:
        _, first = np.unique(np.round(os_ / 0.1), return_index=True)
        os_, ox = os_[first], ox[first]
    return FeedTrace(s_mm={"as written": (ws0, ws1), "advised": (as0, as1)},
                     feed_mm_min={"as written": wf, "advised": af},
                     segments=np.stack([pa, pb], axis=1) if pa.size else np.zeros((0, 2, 3)),
                     advised_fraction=frac, over_s_mm=os_, over_xyz=ox)


def _over_points(path: ProgramPath, run: ProgramRun, tol_um: float) -> tuple[np.ndarray, np.ndarray]:
    """Where the tool passed beyond the tolerance in ``run`` (its ticks kept over it): the arc
    length along the measured segments end to end (the chains' offsets :func:`_along`'s) and the
    nearest point. The measured length before a segment is summed block by block as one running
    sum (``np.cumsum`` carried over: the whole chain's sums, bit for bit)."""
    over_s, over_xyz = [], []
    offset = 0.0
    for chain, r in zip(path.chains, run.runs):
        bad = r.contour_mm * 1e3 > tol_um
        seg = r.nearest_segment[bad]
        points, measured = chain.motion.points, chain.seg_measured
        before = np.empty(seg.size)
        carry = total = 0.0
        for lo in range(0, chain.motion.n_segments, TRACE_BLOCK):
            hi = min(lo + TRACE_BLOCK, chain.motion.n_segments)
            keep = measured[lo:hi]
            norms = np.linalg.norm(np.diff(points[lo:hi + 1], axis=0), axis=1)
            total += float(norms[keep].sum())
            if seg.size:
                sums = np.cumsum(np.concatenate([[carry], norms * keep]))   # measured length before each
                here = (seg >= lo) & (seg < hi)
                before[here] = sums[seg[here] - lo]
                carry = float(sums[-1])
        if seg.size:
            xyz = r.nearest_xyz[bad]
            into = np.linalg.norm(xyz - points[seg], axis=1) * measured[seg]
            over_s.append(offset + before + into)
            over_xyz.append(xyz)
        offset += total
    return (np.concatenate(over_s) if over_s else np.zeros(0),
            np.concatenate(over_xyz) if over_xyz else np.zeros((0, 3)))
