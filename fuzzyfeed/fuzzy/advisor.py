"""The fuzzy feedrate advisor (seed 002): features → Mamdani engine → average filter → feed.

Feed % = centroid of the controller (exact, see :mod:`fuzzyfeed.fuzzy.engine`), smoothed by the
table's filter over M = ``table.filter_points`` points or ``table.filter_mm`` mm (seed 002's centred
average, or the default corner-mean that never raises a corner's feed; see
:mod:`fuzzyfeed.fuzzy.filters`), then held to [feed_floor_pct, 100]. Feed [mm/s] = feed % / 100 ×
F_max.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fuzzyfeed.base.checks import expect
from fuzzyfeed.errors import InputError, MachineLimitsError
from fuzzyfeed.fuzzy.engine import FuzzyEngine, compile_table
from fuzzyfeed.fuzzy.features import Features, features
from fuzzyfeed.fuzzy.filters import average_filter, smooth_feed  # noqa: F401  (average_filter: API)
from fuzzyfeed.fuzzy.rules import RuleTable, load_rule_table
from fuzzyfeed.machine.limits import MAX_LIMIT
from fuzzyfeed.machine.profile import FeedProfile
from fuzzyfeed.geometry.sampling import POINT_STEP_MM, PathSamples, tangent_breaks


def point_sequence_table(table: RuleTable) -> RuleTable:
    """``table`` with its windows as lengths for a point sequence, whose points are where the file
    put them: ``window_mm`` and ``filter_mm`` as given, else the stretch WS and M points cover at
    :data:`fuzzyfeed.geometry.sampling.POINT_STEP_MM` (the step whole programs are sampled at). Counted in
    points, a window would reach 30 mm along a line cut into 1 mm steps and 0.4 mm along an arc
    flattened finely beside it."""
    return replace(table,
                   window_mm=table.window_mm or (table.window_points - 1) * POINT_STEP_MM,
                   filter_mm=table.filter_mm or (table.filter_points - 1) * POINT_STEP_MM)


@dataclass(frozen=True, eq=False)
class FuzzyAdvice:
    """Everything the advisor computed, for plots and CSV: the profile plus its intermediates."""

    profile: FeedProfile
    features: Features
    controller_pct: np.ndarray     # engine output before the filter
    feed_pct: np.ndarray           # after filter, floor and cap (= profile.feed_pct)
    table: RuleTable

    def rule_strengths(self) -> tuple[list[str], np.ndarray]:
        """Rule names and the firing strength of every rule at every point, (N, n_rules)."""
        engine = compile_table(self.table)
        return engine.rule_names, engine.firing_strengths(self.features.curvature_1_mm,
                                                          self.features.curvature_variation)


def _check_feed(max_feed_mm_s: float) -> float:
    try:
        f = float(max_feed_mm_s)
    except (TypeError, ValueError):
        raise MachineLimitsError(f"max feed = {max_feed_mm_s!r}; must be a number > 0 (mm/s)") from None
    if not np.isfinite(f) or f <= 0 or f > MAX_LIMIT:
        raise MachineLimitsError(f"max feed = {max_feed_mm_s!r} mm/s; the maximum feed must be "
                                 f"finite and > 0 (and at most {MAX_LIMIT:g})")
    return f


def advise_details(samples: PathSamples, table: RuleTable | None = None, max_feed_mm_s: float = 100.0,
                   engine: FuzzyEngine | None = None) -> FuzzyAdvice:
    """Run the advisor on ``samples`` and keep the features and the unfiltered controller output."""
    expect(samples, PathSamples, "samples", "PathSamples (sample_uniform_u, sample_shape)")
    if table is not None:
        expect(table, RuleTable, "table", "a RuleTable (load_rule_table) or None")
    f_max = _check_feed(max_feed_mm_s)
    if samples.curve is not None and np.isfinite(samples.d1).all():  # a NURBS, not a point sequence
        u, angle = tangent_breaks(samples.curve)
        if u.size:
            x = samples.curve(float(u[0]))
            raise InputError(f"the path turns {angle[0]:.1f} deg at u = {u[0]:g} ({', '.join(f'{c:g}' for c in x)}) "
                             "mm: a corner has infinite curvature and no feed can be advised through it; "
                             "round the corner or split the path there")
    table = table if table is not None else (engine.table if engine is not None else load_rule_table())
    engine = engine if engine is not None else compile_table(table)
    if not np.isfinite(samples.d1).all():  # a point sequence: its spacing is the file's, not ours
        table = point_sequence_table(table)
    feats = features(samples.curvature, table.window_points, table.dk_clip_1_mm, samples.s,
                     table.window_mm)
    raw = engine.feed_pct(feats.curvature_1_mm, feats.curvature_variation)
    pct = np.clip(smooth_feed(raw, table.filter, table.filter_points, samples.s, table.filter_mm,
                              feats.curvature_1_mm), table.feed_floor_pct, 100.0)
    profile = FeedProfile(samples=samples, feed_mm_s=pct / 100.0 * f_max, method="fuzzy",
                          max_feed_mm_s=f_max)
    return FuzzyAdvice(profile=profile, features=feats, controller_pct=raw, feed_pct=pct, table=table)


def advise(samples: PathSamples, table: RuleTable | None = None, max_feed_mm_s: float = 100.0) -> FeedProfile:
    """The fuzzy advisor's :class:`FeedProfile` (method "fuzzy"); ``table`` defaults to rules/paper.toml."""
    return advise_details(samples, table, max_feed_mm_s).profile
