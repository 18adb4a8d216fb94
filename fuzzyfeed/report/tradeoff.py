"""Cycle time against contour error: seed 002's accuracy claim, reproduced in the simulator.

Seed 002 (§3, Tables 10-12 and the abstract) reports that its fuzzy feed gives 43 % less tracking
error than other schedules at the same cycle time, and needs 49 % less time at the same error. Here
every method runs through the one simulator with the same axis servo model
(:mod:`fuzzyfeed.machine.servo`), and the contour error is the distance of the tool from the curve.

:func:`claims_vs_constant` answers the claim against a constant feed exactly: the constant feed of
equal cycle time is F_c = L/T_fuzzy (its cycle time is L/F), and the constant feed of equal max
contour error is found by a safeguarded secant search on log F (the error grows monotonically with
the feed, ≈ F² on smooth paths). :func:`pareto_points` gives the families of the trade-off plot:
fuzzy, fuzzy-safe, SLW and constant at several command feeds F (one :func:`compare` per F), and the
SLW schedule under several contour tolerances ε. The SLW has no contour limit of its own; on a
curve of radius r the steady-state error of the first-order loop is ≈ v²/(2r·Kv²) = a_n/(2·Kv²),
so a contour tolerance ε is the centripetal-acceleration limit A = 2·Kv²·ε (the SLW's axis
acceleration limit, capped by the machine's).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from fuzzyfeed.report.compare import compare
from fuzzyfeed.errors import InputError
from fuzzyfeed.fuzzy.advisor import advise
from fuzzyfeed.fuzzy.rules import RuleTable
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.machine.profile import FeedProfile
from fuzzyfeed.geometry.sampling import PathSamples
from fuzzyfeed.machine.servo import ServoModel
from fuzzyfeed.machine.simulate import Metrics, simulate_profile
from fuzzyfeed.slw import schedule

#: Seed 002's headline figures (abstract): error reduction at equal time, time reduction at equal error.
PAPER_ERROR_REDUCTION_PCT = 43.0
PAPER_TIME_REDUCTION_PCT = 49.0


@dataclass(frozen=True)
class Point:
    """One run in the trade-off: a method family at one setting."""

    family: str
    setting: str
    cycle_time_s: float
    contour_err_max_um: float
    contour_err_mean_um: float
    violating_ticks: int


def _point(family: str, setting: str, m: Metrics) -> Point:
    return Point(family, setting, m.cycle_time_s, m.contour_err_max_um, m.contour_err_mean_um,
                 int(sum(count for count, _ in m.violations.values())))


def _limits_at(limits: MachineLimits, feed_mm_min: float) -> MachineLimits:
    return replace(limits, feed_mm_s=feed_mm_min / 60.0)


def pareto_points(samples: PathSamples, limits: MachineLimits, feeds_mm_min, tolerances_um=(),
                  servo: ServoModel | None = None, table: RuleTable | None = None,
                  progress=None) -> list[Point]:
    """Families ``fuzzy``, ``fuzzy-safe``, ``slw`` and ``constant`` at every feed of
    ``feeds_mm_min`` (the other limits as in ``limits``), and ``slw-tol`` at every contour
    tolerance of ``tolerances_um`` (A = min(machine A, 2·Kv²·ε), F from ``limits``; a tolerance
    the scheduler refuses to schedule is left out)."""
    servo = ServoModel() if servo is None else servo
    step = progress or (lambda _name: None)
    points: list[Point] = []
    for feed in feeds_mm_min:
        step(f"F = {feed:g}")
        result = compare(samples, _limits_at(limits, feed), table, servo=servo)
        for method in ("fuzzy", "fuzzy-safe", "slw", "constant"):
            points.append(_point(method, f"F={feed:g}", result.simulations[method].metrics))
    kv = min(servo.kv_1_s)
    for tol in tolerances_um:
        step(f"eps = {tol:g} um")
        acc = tuple(min(a, 2.0 * kv * kv * tol * 1e-3) for a in limits.axis_acc_mm_s2)
        machine = replace(limits, axis_acc_mm_s2=acc)
        try:
            traj = schedule(samples.curve, machine, planner="window", transition="cosine")
        except InputError:  # the scheduler refuses some low-acceleration paths: leave the point out
            continue
        m = traj.simulate(servo=servo).metrics
        points.append(_point("slw-tol", f"eps={tol:g}um", m))
    return points


@dataclass(frozen=True)
class Claim:
    """Fuzzy advice at one maximum feed against the constant feed, at equal time and equal error."""

    feed_mm_min: float
    fuzzy_time_s: float
    fuzzy_err_um: float
    equal_time_feed_mm_min: float        # constant feed with the fuzzy cycle time (L / T)
    equal_time_err_um: float             # its max contour error
    equal_err_feed_mm_min: float         # constant feed with the fuzzy max contour error
    equal_err_time_s: float              # its cycle time

    @property
    def error_reduction_pct(self) -> float:
        """How much less max contour error the fuzzy advice has than a constant feed of equal time."""
        return 100.0 * (1.0 - self.fuzzy_err_um / self.equal_time_err_um)

    @property
    def time_reduction_pct(self) -> float:
        """How much less time the fuzzy advice takes than a constant feed of equal max error."""
        return 100.0 * (1.0 - self.fuzzy_time_s / self.equal_err_time_s)


def _constant(samples: PathSamples, limits: MachineLimits, feed_mm_s: float, servo: ServoModel) -> Metrics:
    profile = FeedProfile(samples, np.full(len(samples), feed_mm_s), "constant", feed_mm_s)
    return simulate_profile(profile, limits, servo=servo).metrics


def equal_error_feed(samples: PathSamples, limits: MachineLimits, target_um: float, start_mm_s: float,
                     start_err_um: float, servo: ServoModel, rtol: float = 0.005,
                     max_runs: int = 12) -> tuple[float, Metrics]:
    """The constant feed (mm/s) whose max contour error is ``target_um``: secant steps on
    (log F, log error), kept inside a bracket by bisection; starts from a known (F, error)."""
    if not (target_um > 0 and start_err_um > 0):
        raise InputError(f"contour errors {target_um!r}, {start_err_um!r} µm; need both > 0")
    lo = hi = None  # (log F, log e - log target) with the sign known
    x0, y0 = math.log(start_mm_s), math.log(start_err_um / target_um)
    (lo, hi) = ((x0, y0), None) if y0 < 0 else (None, (x0, y0))
    x = x0 - y0 / 2.0  # error ≈ F²
    best = None
    for _ in range(max_runs):
        if lo is not None and hi is not None and not lo[0] < x < hi[0]:
            x = 0.5 * (lo[0] + hi[0])
        m = _constant(samples, limits, math.exp(x), servo)
        y = math.log(m.contour_err_max_um / target_um)
        best = (math.exp(x), m)
        if abs(y) <= rtol:
            break
        if y < 0:
            lo = (x, y)
        else:
            hi = (x, y)
        if lo is not None and hi is not None:
            x = lo[0] - lo[1] * (hi[0] - lo[0]) / (hi[1] - lo[1])
        else:
            x = x - y / 2.0
    assert best is not None
    return best


def claims_vs_constant(samples: PathSamples, limits: MachineLimits, feeds_mm_min,
                       servo: ServoModel | None = None, table: RuleTable | None = None) -> list[Claim]:
    """Seed 002's two claims for the fuzzy advice at each maximum feed, against a constant feed."""
    servo = ServoModel() if servo is None else servo
    out = []
    for feed in feeds_mm_min:
        machine = _limits_at(limits, feed)
        fuzzy = simulate_profile(advise(samples, table, max_feed_mm_s=machine.feed_mm_s), machine,
                                 servo=servo).metrics
        f_time = samples.length / fuzzy.cycle_time_s
        same_time = _constant(samples, machine, f_time, servo)
        f_err, same_err = equal_error_feed(samples, machine, fuzzy.contour_err_max_um, f_time,
                                           same_time.contour_err_max_um, servo)
        out.append(Claim(feed_mm_min=feed, fuzzy_time_s=fuzzy.cycle_time_s,
                         fuzzy_err_um=fuzzy.contour_err_max_um, equal_time_feed_mm_min=f_time * 60.0,
                         equal_time_err_um=same_time.contour_err_max_um,
                         equal_err_feed_mm_min=f_err * 60.0, equal_err_time_s=same_err.cycle_time_s))
    return out
