"""The cross-check: fuzzy advice against the SLW schedule on the same samples, all simulated alike.

Methods compared (each executed by :mod:`fuzzyfeed.machine.simulate` and measured the same way):

``fuzzy``       the advisor's feed (seed 002) with the user's maximum feed F;
``fuzzy-safe``  the jerk-limited SLW schedule under min(advice, machine): the advice as a feed
                cap per sample (:func:`fuzzyfeed.slw.schedule` with ``feed_cap``), so every
                machine limit holds, jerk included, and the feed never exceeds the advice;
``slw``         the jerk-limited look-ahead schedule (seed 000), its own time law;
``constant``    the command feed F everywhere (what a program without feed planning asks for; a
                program's own F words);
``bound``       the acceleration-limited time-optimal bound (phase-plane pass, no jerk limit) on
                its own adaptive grid (:func:`fuzzyfeed.slw.path_bound`), the same as
                ``fuzzyfeed schedule`` reports; its feed is shown at the samples.

This module imports both planners and the simulator; nothing imports it but the edges.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.base.checks import expect
from fuzzyfeed.fuzzy.advisor import advise
from fuzzyfeed.fuzzy.rules import RuleTable
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.machine.profile import FeedProfile
from fuzzyfeed.geometry.sampling import PathSamples
from fuzzyfeed.machine.servo import ServoModel
from fuzzyfeed.machine.simulate import Simulation, simulate_profile
from fuzzyfeed.slw import path_bound, schedule
from fuzzyfeed.slw.feed_cap import FeedCap

METHODS = ("fuzzy", "fuzzy-safe", "slw", "constant", "bound")


@dataclass(frozen=True, eq=False)
class CrossCheck:
    """Where the fuzzy advice asks for more than the SLW schedule allows, and where it is slower.

    Ratios are fuzzy / SLW feed at the samples (the SLW feed is 0 only at the path's ends, which
    are left out). ``over_*`` describe the stretch where the advice is above the schedule,
    ``under_*`` where it is below; ``time_*_s`` integrate ds/v over those stretches.
    """

    over_fraction: float         # share of the path length where advice > schedule
    over_max_ratio: float        # largest advice / schedule
    over_worst_s_mm: float       # where that happens
    under_fraction: float        # share of the path length where advice < schedule
    under_min_ratio: float       # smallest advice / schedule
    time_gained_s: float         # advice faster than the schedule (the machine cannot follow)
    time_lost_s: float           # advice slower than the schedule (conservative)
    cycle_time_delta_s: float    # simulated fuzzy cycle time − SLW cycle time

    def lines(self) -> list[str]:
        return [
            f"advice above the SLW schedule on {100 * self.over_fraction:.1f} % of the path, "
            f"worst x{self.over_max_ratio:.2f} at s = {self.over_worst_s_mm:.2f} mm "
            f"({self.time_gained_s:.3f} s the machine cannot deliver)",
            f"advice below the SLW schedule on {100 * self.under_fraction:.1f} % of the path, "
            f"down to x{self.under_min_ratio:.2f} ({self.time_lost_s:.3f} s lost to caution)",
            f"simulated cycle time fuzzy - SLW: {self.cycle_time_delta_s:+.3f} s",
        ]


@dataclass(frozen=True, eq=False)
class Comparison:
    """Every method's profile and simulation on one path under one set of limits."""

    name: str
    samples: PathSamples
    limits: MachineLimits
    profiles: dict[str, FeedProfile]
    simulations: dict[str, Simulation]
    cross_check: CrossCheck
    servo: ServoModel | None = None

    def rows(self) -> list[dict[str, object]]:
        """One metrics row per method (the CSV of ``fuzzyfeed compare``)."""
        return [{"shape": self.name, **self.simulations[m].metrics.row()} for m in self.simulations]


def _cross_check(samples: PathSamples, fuzzy: FeedProfile, slw: FeedProfile,
                 fuzzy_time_s: float, slw_time_s: float) -> CrossCheck:
    v_f, v_s = fuzzy.feed_mm_s, slw.feed_mm_s
    ds = np.diff(samples.s)
    # per segment: mean feeds, ratio, and the time each feed needs for the segment
    f_mid, s_mid = 0.5 * (v_f[:-1] + v_f[1:]), 0.5 * (v_s[:-1] + v_s[1:])
    inner = s_mid > 1e-9 * max(float(v_s.max()), 1.0)
    ratio = np.divide(f_mid, s_mid, out=np.ones_like(f_mid), where=inner)
    over = inner & (ratio > 1.0 + 1e-9)
    under = inner & (ratio < 1.0 - 1e-9)
    total = float(ds.sum())
    t_f = np.divide(ds, f_mid, out=np.zeros_like(ds), where=f_mid > 0)
    t_s = np.divide(ds, s_mid, out=np.zeros_like(ds), where=s_mid > 0)
    worst = int(np.argmax(np.where(inner, ratio, -np.inf)))
    return CrossCheck(
        over_fraction=float(ds[over].sum() / total), over_max_ratio=float(ratio[worst]),
        over_worst_s_mm=float(0.5 * (samples.s[worst] + samples.s[worst + 1])),
        under_fraction=float(ds[under].sum() / total),
        under_min_ratio=float(np.min(np.where(inner, ratio, np.inf))),
        time_gained_s=float(np.sum(t_s[over] - t_f[over])),
        time_lost_s=float(np.sum(t_f[under] - t_s[under])),
        cycle_time_delta_s=fuzzy_time_s - slw_time_s,
    )


def compare(samples: PathSamples, limits: MachineLimits, table: RuleTable | None = None,
            name: str = "path", progress=None, servo: ServoModel | None = None,
            approach: int = 2, feed_cap=None, transition: str = "cosine") -> Comparison:
    """Run every method of :data:`METHODS` on ``samples`` and simulate each (DESIGN §3).

    ``servo`` is the axis model every method's contour error is measured with (default
    ``ServoModel()``: first order, Kv = 30 1/s, no feed-forward).
    The fuzzy advisor's maximum feed is the command feed F of ``limits``; ``approach`` is the SLW
    scheduler's (seed 000 Table 1) for ``slw`` and ``fuzzy-safe``, ``transition`` the shape of its
    feed changes (seed 000's ``"cosine"`` or ``"seven-phase"``). ``progress``, if given, is
    called with the name of each step as it starts (the CLI hooks a progress bar on it).
    ``feed_cap`` (optional, (s_mm, feed_mm_s) along the path, a repeated s a step) is the F a
    program has at each place: every method runs under it — the advice as a fraction of it,
    the constant feed as it — as ``fuzzyfeed advise PROGRAM`` and a controller run it.
    """
    expect(samples, PathSamples, "samples", "PathSamples")
    expect(limits, MachineLimits, "limits", "MachineLimits")
    curve = samples.curve
    step = progress or (lambda _name: None)
    step("slw")
    ceiling = np.full(len(samples), limits.feed_mm_s)
    if feed_cap is not None:
        ceiling = np.minimum(FeedCap(*feed_cap, samples.length)(samples.s), limits.feed_mm_s)
    # the SLW method of seed 000: the look-ahead window alone
    trajectory = schedule(curve, limits, approach=approach, feed_cap=feed_cap, transition=transition,
                          planner="window")
    slw_profile = trajectory.feed_at(samples)
    step("bound")
    # on the path the machine follows: a polyline blended within the path tolerance, as schedule
    bound = path_bound(trajectory.curve, limits, halve=False, feed_cap=feed_cap)
    bound_profile, bound_time = bound.profile_at(samples, limits), bound.time_s
    step("fuzzy")
    fuzzy = advise(samples, table, max_feed_mm_s=limits.feed_mm_s)
    if feed_cap is not None:   # the advised fraction of the F in force
        fuzzy = FeedProfile(samples, fuzzy.feed_mm_s / limits.feed_mm_s * ceiling, "fuzzy", limits.feed_mm_s)
    step("fuzzy-safe")
    safe_trajectory = schedule(curve, limits, approach=approach, feed_cap=fuzzy, transition=transition,
                               planner="window")
    safe_at = safe_trajectory.feed_at(samples)
    safe = FeedProfile(samples, safe_at.feed_mm_s, "fuzzy-safe", limits.feed_mm_s)
    constant = FeedProfile(samples, ceiling, "constant", limits.feed_mm_s)
    profiles = {"fuzzy": fuzzy, "fuzzy-safe": safe, "slw": slw_profile, "constant": constant,
                "bound": bound_profile}
    sims: dict[str, Simulation] = {}
    for method in METHODS:
        step(f"simulate {method}")
        if method == "slw":
            sims[method] = trajectory.simulate("slw", bound_time_s=bound_time, servo=servo)
        elif method == "fuzzy-safe":
            sims[method] = safe_trajectory.simulate("fuzzy-safe", bound_time_s=bound_time, servo=servo)
        else:
            sims[method] = simulate_profile(profiles[method], limits, bound_time_s=bound_time, servo=servo)
    check = _cross_check(samples, fuzzy, slw_profile, sims["fuzzy"].metrics.cycle_time_s,
                         sims["slw"].metrics.cycle_time_s)
    return Comparison(name=name, samples=samples, limits=limits, profiles=profiles,
                      simulations=sims, cross_check=check, servo=servo)
