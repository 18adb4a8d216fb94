"""What differs between two rule tables, and where on a path their advice differs
(``fuzzyfeed rules diff A B [--shape SHAPE]``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.fuzzy.rules import FEATURE_KEYS, OPTIONAL_FEATURE_KEYS, RuleTable


def _fmt(points: tuple[float, ...]) -> str:
    return "[" + ", ".join(f"{x:.17g}" for x in points) + "]"


def table_differences(a: RuleTable, b: RuleTable) -> list[str]:
    """One line per difference in settings, universes, terms (added, removed, changed, order)
    and grid cells; empty when the two tables compute the same advice. Name, source and path are
    not compared (they say where a table came from, not what it does)."""
    out = []
    for key in FEATURE_KEYS + OPTIONAL_FEATURE_KEYS:
        va, vb = getattr(a, key), getattr(b, key)
        if va != vb:
            out.append(f"features.{key}: {va!r} -> {vb!r}")
    for va, vb in zip(a.variables, b.variables):
        if va.universe != vb.universe:
            out.append(f"{va.name}.universe: {list(va.universe)} -> {list(vb.universe)}")
        for label in va.labels:
            if label not in vb.labels:
                out.append(f"{va.name}.{label}: removed (was {_fmt(va.term(label).points)})")
            elif va.term(label).points != vb.term(label).points:
                out.append(f"{va.name}.{label}: {_fmt(va.term(label).points)} -> "
                           f"{_fmt(vb.term(label).points)}")
        for label in vb.labels:
            if label not in va.labels:
                out.append(f"{va.name}.{label}: added {_fmt(vb.term(label).points)}")
        common_a = [x for x in va.labels if x in vb.labels]
        common_b = [x for x in vb.labels if x in va.labels]
        if common_a != common_b:
            out.append(f"{va.name}: term order {', '.join(va.labels)} -> {', '.join(vb.labels)}")
    ka, da = a.curvature.labels, a.curvature_variation.labels
    kb, db = b.curvature.labels, b.curvature_variation.labels
    for i, row in enumerate(ka):
        for j, col in enumerate(da):
            if row in kb and col in db:
                ca, cb = a.grid[i][j], b.grid[kb.index(row)][db.index(col)]
                if ca != cb:
                    out.append(f"rule ({a.curvature.name} {row}, {a.curvature_variation.name} {col}): "
                               f"{ca} -> {cb}")
    return out


@dataclass(frozen=True)
class FeedChange:
    """A stretch of the path where the two tables' advised feeds differ by more than a threshold."""

    s_start_mm: float
    s_end_mm: float
    max_diff_pct: float        # largest |feed_b − feed_a| in the stretch (% of F), signed
    at_s_mm: float


def feed_changes(s: np.ndarray, feed_a: np.ndarray, feed_b: np.ndarray,
                 threshold_pct: float = 0.01) -> list[FeedChange]:
    """Stretches of arc length where |feed_b − feed_a| > ``threshold_pct`` (both in % of F)."""
    diff = np.asarray(feed_b, dtype=float) - np.asarray(feed_a, dtype=float)
    on = np.abs(diff) > threshold_pct
    out = []
    edges = np.flatnonzero(np.diff(np.concatenate([[0], on.astype(np.int8), [0]])))
    for i0, i1 in zip(edges[::2], edges[1::2]):
        seg = slice(i0, i1)
        k = i0 + int(np.argmax(np.abs(diff[seg])))
        out.append(FeedChange(float(s[i0]), float(s[i1 - 1]), float(diff[k]), float(s[k])))
    return out
