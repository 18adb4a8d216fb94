"""Tune a rule table's output terms for cycle time under a contour tolerance (seed 002's future work).

Seed 002 (§4) proposes learning the controller's parameters from the machine. Here the rule grid
and the input terms stay; the feed terms are moved. They are kept a triangular partition of the
feed universe (each term's feet on its neighbours' peaks, shoulders at both ends, as in
rules/paper.toml), so the parameters are the gaps between consecutive peaks, and the search runs
on log-gaps (every candidate is a valid, ordered partition). Objective: the summed cycle time of
the advice over a set of shapes, each simulated by the one simulator with the servo model, plus a
penalty proportional to how far any constraint is exceeded:

- max contour error ≤ the tolerance (µm), and
- every machine limit the simulator counts — feed, chord error, axial velocity and acceleration —
  except the jerk (a feed given per sample is not jerk-limited; only the SLW schedule is).

The minimiser is scipy's Nelder–Mead on that penalised objective; the result is the best feasible
candidate seen (or, if none was feasible, the least infeasible one, reported as such).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.fuzzy.advisor import advise
from fuzzyfeed.fuzzy.rules import RuleTable, Term, Variable
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.machine.profile import FeedProfile
from fuzzyfeed.geometry.sampling import PathSamples
from fuzzyfeed.machine.servo import ServoModel
from fuzzyfeed.machine.simulate import Metrics, simulate_profile

#: Relative weight of a constraint excess against the cycle time.
PENALTY = 20.0


def partition_feed(feed: Variable, gaps: np.ndarray) -> Variable:
    """The feed variable with its terms replaced by the triangular partition of the given gaps
    (len(terms) − 1 positive gaps, scaled to span the universe)."""
    lo, hi = feed.universe
    gaps = np.asarray(gaps, dtype=float)
    if gaps.shape != (len(feed.terms) - 1,) or not np.all(np.isfinite(gaps)) or np.any(gaps <= 0):
        raise InputError(f"gaps = {gaps!r}; need {len(feed.terms) - 1} finite values > 0")
    peaks = lo + (hi - lo) * np.concatenate([[0.0], np.cumsum(gaps) / gaps.sum()])
    peaks[-1] = hi
    terms = []
    for i, term in enumerate(feed.terms):
        a = peaks[max(i - 1, 0)]
        c = peaks[min(i + 1, len(peaks) - 1)]
        terms.append(Term(term.label, (float(a), float(peaks[i]), float(c))))
    return replace(feed, terms=tuple(terms))


def peaks_of(feed: Variable) -> np.ndarray:
    """Peak (membership 1) of every feed term: the middle of its top."""
    return np.array([0.5 * (t.trapezoid[1] + t.trapezoid[2]) for t in feed.terms])


@dataclass(frozen=True, eq=False)
class TuneResult:
    """The tuned table, the metrics per shape before and after, and the search's bookkeeping."""

    table: RuleTable
    before: dict[str, Metrics]
    after: dict[str, Metrics]
    feasible: bool
    evaluations: int

    def lines(self, tol_um: float) -> list[str]:
        out = []
        for name in self.after:
            b, a = self.before[name], self.after[name]
            out.append(f"{name}: cycle {b.cycle_time_s:.3f} -> {a.cycle_time_s:.3f} s, max contour error "
                       f"{b.contour_err_max_um:.4g} -> {a.contour_err_max_um:.4g} um (tolerance {tol_um:g}), "
                       f"worst limit ratio {_worst(b):.3f} -> {_worst(a):.3f}")
        t0 = sum(m.cycle_time_s for m in self.before.values())
        t1 = sum(m.cycle_time_s for m in self.after.values())
        out.append(f"total cycle time {t0:.3f} -> {t1:.3f} s ({100 * (t1 / t0 - 1):+.1f} %), "
                   f"{'feasible' if self.feasible else 'NOT feasible (least infeasible found)'}, "
                   f"{self.evaluations} evaluations")
        return out


def _worst(m: Metrics) -> float:
    """Largest value/limit ratio over the constrained limits (all but the jerk)."""
    return max(worst for name, (_, worst) in m.violations.items() if name != "jerk")


def excess(m: Metrics, tol_um: float) -> float:
    """How far ``m`` is outside the constraints (0 when it meets all of them)."""
    over = max(0.0, m.contour_err_max_um / tol_um - 1.0)
    over += sum(max(0.0, worst - 1.0 - 1e-3) for name, (_, worst) in m.violations.items() if name != "jerk")
    return over


def evaluate(table: RuleTable, shapes: dict[str, PathSamples], limits: MachineLimits,
             servo: ServoModel) -> dict[str, Metrics]:
    """Simulate the advice of ``table`` at the command feed of ``limits`` on every shape, started
    from and stopped at rest (:func:`from_rest`)."""
    return {name: simulate_profile(from_rest(advise(samples, table, max_feed_mm_s=limits.feed_mm_s),
                                             limits), limits, servo=servo).metrics
            for name, samples in shapes.items()}


def from_rest(profile: FeedProfile, limits: MachineLimits) -> FeedProfile:
    """The advice capped by v ≤ √(2·a·d) with d the distance from the start or to the end and
    a = half the smallest axis acceleration: the machine starts from rest and stops at rest within
    its limits whatever the table asks there (the simulator counts the jump from rest), so the
    tuning judges the table where it acts, not the path's two ends."""
    s = np.asarray(profile.samples.s, dtype=float)
    a = 0.5 * float(np.min(limits.axis_acc_mm_s2))
    ramp = np.sqrt(2.0 * a * np.minimum(s - s[0], s[-1] - s))
    return FeedProfile(profile.samples, np.minimum(profile.feed_mm_s, ramp), profile.method,
                       profile.max_feed_mm_s)


def tune_output_terms(table: RuleTable, shapes: dict[str, PathSamples], limits: MachineLimits,
                      contour_tol_um: float, servo: ServoModel | None = None, max_evaluations: int = 120,
                      name: str | None = None, progress=None) -> TuneResult:
    """Move ``table``'s feed terms to minimise the summed cycle time of the advice on ``shapes``
    (at the command feed of ``limits``) under ``contour_tol_um`` and the machine limits."""
    from scipy.optimize import minimize

    if not (isinstance(contour_tol_um, (int, float)) and math.isfinite(contour_tol_um) and contour_tol_um > 0):
        raise InputError(f"contour tolerance = {contour_tol_um!r} um; must be a finite number > 0")
    if not shapes:
        raise InputError("no shapes to tune on")
    servo = ServoModel() if servo is None else servo
    step = progress or (lambda: None)
    before = evaluate(table, shapes, limits, servo)
    peaks = peaks_of(table.feed)
    start_gaps = np.maximum(np.diff(peaks), 1e-3 * (table.feed.universe[1] - table.feed.universe[0]))
    label = name or f"{table.name}-tuned"
    source = (f"{table.name} with its feed terms tuned by fuzzyfeed (fuzzyfeed.fuzzy.tune): shapes "
              f"{', '.join(shapes)}, F = {limits.feed_mm_min:g} mm/min, contour tolerance "
              f"{contour_tol_um:g} um, servo {servo.describe()}")
    best: dict[str, object] = {"key": (math.inf, math.inf), "table": table, "metrics": before}
    count = [0]

    def candidate(z: np.ndarray) -> RuleTable:
        gaps = np.exp(np.clip(z, -20, 20))
        return replace(table, feed=partition_feed(table.feed, gaps), name=label, source=source)

    def objective(z: np.ndarray) -> float:
        count[0] += 1
        step()
        cand = candidate(z)
        metrics = evaluate(cand, shapes, limits, servo)
        total = sum(m.cycle_time_s for m in metrics.values())
        over = sum(excess(m, contour_tol_um) for m in metrics.values())
        key = (over, total) if over > 0 else (0.0, total)
        if key < best["key"]:  # type: ignore[operator]
            best.update(key=key, table=cand, metrics=metrics)
        return total * (1.0 + PENALTY * over)

    z0 = np.log(start_gaps)
    simplex = np.vstack([z0] + [z0 + 0.5 * np.eye(z0.size)[i] for i in range(z0.size)])
    minimize(objective, z0, method="Nelder-Mead",
             options={"maxfev": max_evaluations, "initial_simplex": simplex, "xatol": 1e-3, "fatol": 1e-4})
    over, _ = best["key"]  # type: ignore[misc]
    return TuneResult(table=best["table"], before=before, after=best["metrics"],  # type: ignore[arg-type]
                      feasible=over == 0.0, evaluations=count[0])
