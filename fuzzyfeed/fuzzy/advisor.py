"""The fuzzy feedrate advisor (seed 002): features → Mamdani engine → average filter → feed.

Feed % = centroid of the controller (exact, see :mod:`fuzzyfeed.fuzzy.engine`), smoothed by the
table's filter over M = ``table.filter_points`` points or ``table.filter_mm`` mm (seed 002's centred
average, or the default corner-mean that never raises a corner's feed; see
:mod:`fuzzyfeed.fuzzy.filters`), then held to [feed_floor_pct, 100]. Feed [mm/s] = feed % / 100 ×
F_max.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from fuzzyfeed.base.checks import expect
from fuzzyfeed.errors import InputError, MachineLimitsError
from fuzzyfeed.fuzzy.engine import FuzzyEngine, compile_table
from fuzzyfeed.fuzzy.features import Features, features
from fuzzyfeed.fuzzy.filters import average_filter, smooth_feed  # noqa: F401  (average_filter: API)
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.fuzzy.rules import DEFAULT_MACHINE_TABLE, MACHINE, RuleTable
from fuzzyfeed.machine.limits import MAX_LIMIT
from fuzzyfeed.machine.profile import FeedProfile
from fuzzyfeed.geometry.sampling import POINT_STEP_MM, PathSamples, tangent_breaks

if TYPE_CHECKING:   # the machine's modules load only when a machine is given
    from fuzzyfeed.fuzzy.machine_inputs import MachineFeatures
    from fuzzyfeed.machine.description import Machine


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
    """Everything the advisor computed, for plots and CSV: the profile plus its intermediates.
    ``features`` are κ and Dκ (for a machine table κ, and Dκ as zeros); ``machine`` the machine
    inputs of a machine table (None for a paper table)."""

    profile: FeedProfile
    features: Features
    controller_pct: np.ndarray     # engine output before the filter
    feed_pct: np.ndarray           # after filter, floor and cap (= profile.feed_pct)
    table: RuleTable
    machine: MachineFeatures | None = None

    @property
    def engine_inputs(self) -> tuple[np.ndarray, np.ndarray]:
        """The two values the controller read at every point (its rows' and columns' input)."""
        if self.machine is not None:
            return self.machine.safe_feed_ratio, self.machine.safe_feed_ratio_near
        return self.features.curvature_1_mm, self.features.curvature_variation

    def term_columns(self, ceiling_mm_min) -> dict[str, np.ndarray]:
        """The CSV columns of what the controller read and answered: the machine terms (the safe
        feed capped at ``ceiling_mm_min``) or κ's window max and Dκ, then its output in %."""
        if self.machine is not None:
            cols = {"safe_feed_mm_min": np.minimum(self.machine.safe_feed_mm_s * 60.0, ceiling_mm_min),
                    "safe_feed_ratio": self.machine.safe_feed_ratio,
                    "safe_feed_ratio_near": self.machine.safe_feed_ratio_near}
        else:
            cols = {"curvature_window_max_1_mm": self.features.window_max_1_mm,
                    "curvature_variation": self.features.curvature_variation}
        cols["feed_pct_controller"] = self.controller_pct
        return cols

    def rule_strengths(self) -> tuple[list[str], np.ndarray]:
        """Rule names and the firing strength of every rule at every point, (N, n_rules)."""
        engine = compile_table(self.table)
        return engine.rule_names, engine.firing_strengths(*self.engine_inputs)


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
                   engine: FuzzyEngine | None = None, machine: Machine | None = None,
                   ceiling_mm_s: np.ndarray | None = None, turn_angle: np.ndarray | None = None,
                   corner: np.ndarray | None = None, entry_direction=None) -> FuzzyAdvice:
    """Run the advisor on ``samples`` and keep the features and the unfiltered controller output.

    ``table`` defaults to the machine table when a ``machine`` is given, else to seed 002's. A
    machine table (``inputs = "machine"``) reads :func:`~fuzzyfeed.fuzzy.machine_inputs.machine_features`:
    then ``ceiling_mm_s`` (N,) is the feed at each point the advice is a fraction of (default
    ``max_feed_mm_s``), ``turn_angle``/``corner`` the junctions (default: from the points),
    ``entry_direction`` the unit direction of a rapid into the first point (None: none)."""
    expect(samples, PathSamples, "samples", "PathSamples (sample_uniform_u, sample_shape)")
    if table is not None:
        expect(table, RuleTable, "table", "a RuleTable (load_rule_table) or None")
    if machine is not None:
        from fuzzyfeed.machine.description import Machine

        expect(machine, Machine, "machine", "a Machine (load_machine) or None")
    f_max = _check_feed(max_feed_mm_s)
    if samples.curve is not None and np.isfinite(samples.d1).all():  # a NURBS, not a point sequence
        u, angle = tangent_breaks(samples.curve)
        if u.size:
            x = samples.curve(float(u[0]))
            raise InputError(f"the path turns {angle[0]:.1f} deg at u = {u[0]:g} ({', '.join(f'{c:g}' for c in x)}) "
                             "mm: a corner has infinite curvature and no feed can be advised through it; "
                             "round the corner or split the path there")
    if table is None and engine is None and machine is not None:
        table = load_rule_table(DEFAULT_MACHINE_TABLE)
    chosen = table if table is not None else (engine.table if engine is not None else None)
    if chosen is not None and chosen.inputs == MACHINE:
        if machine is None:
            raise MachineLimitsError(f"rule table {chosen.name!r} reads the machine's terms (inputs = "
                                     "'machine'); give a machine (--machine FILE or a machine flag such "
                                     "as --contour-tol-um)")
        return _advise_on_machine(samples, chosen, f_max, engine, machine, ceiling_mm_s, turn_angle, corner,
                                  entry_direction)
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


def _advise_on_machine(samples: PathSamples, table: RuleTable, f_max: float, engine: FuzzyEngine | None,
                       machine: Machine, ceiling_mm_s, turn_angle, corner, entry_direction) -> FuzzyAdvice:
    """A machine table's advice: machine inputs → engine → filter → floor, capped at the ceiling."""
    from fuzzyfeed.fuzzy.machine_inputs import machine_features

    engine = engine if engine is not None and engine.table is table else compile_table(table)
    n = len(samples)
    ceiling = np.full(n, f_max) if ceiling_mm_s is None else np.asarray(ceiling_mm_s, dtype=float)
    if ceiling.shape != (n,) or not (np.isfinite(ceiling) & (ceiling > 0)).all():
        raise InputError(f"ceiling_mm_s: needs one finite feed > 0 per sample ({n})")
    mf = machine_features(samples, ceiling, machine, turn_angle, corner, entry_direction)
    raw = engine.feed_pct(mf.safe_feed_ratio, mf.safe_feed_ratio_near)
    pct = np.clip(smooth_feed(raw, table.filter, table.filter_points, samples.s, table.filter_mm,
                              samples.curvature), table.feed_floor_pct, 100.0)
    feats = Features(curvature_1_mm=np.asarray(samples.curvature, dtype=float),
                     window_max_1_mm=np.zeros(n), curvature_variation=np.zeros(n))
    profile = FeedProfile(samples=samples, feed_mm_s=pct / 100.0 * ceiling, method="fuzzy",
                          max_feed_mm_s=float(ceiling.max()))
    return FuzzyAdvice(profile=profile, features=feats, controller_pct=raw, feed_pct=pct, table=table,
                       machine=mf)


def advise(samples: PathSamples, table: RuleTable | None = None, max_feed_mm_s: float = 100.0,
           machine: Machine | None = None) -> FeedProfile:
    """The fuzzy advisor's :class:`FeedProfile` (method "fuzzy"); ``table`` defaults to rules/paper.toml
    (rules/machine.toml when a ``machine`` is given)."""
    return advise_details(samples, table, max_feed_mm_s, machine=machine).profile
