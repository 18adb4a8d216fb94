"""The same controller built with scikit-fuzzy's ``control`` API: the cross-check of the engine.

scikit-fuzzy samples every membership function on a universe grid. The input grids here hold
``input_points`` evenly spaced values plus every term breakpoint, so the inputs' memberships are
exact (scikit-fuzzy interpolates linearly between grid values); the output grid is
``output_points`` evenly spaced values plus the output terms' vertices. scikit-fuzzy adds the clip
crossings itself, so its remaining error is the crossings of two clipped terms between grid values.
Inputs are clipped to the universes first (as the engine does). Feed terms that no rule uses are
left out (they change nothing, and scikit-fuzzy 0.5's array mode fails on them). scikit-fuzzy is imported inside
the functions.
"""

from __future__ import annotations

import warnings

import numpy as np

from fuzzyfeed.fuzzy.rules import DK, FEED, KAPPA, RuleTable, Variable


def _universe(var: Variable, points: int) -> np.ndarray:
    lo, hi = var.universe
    extra = [x for t in var.terms for x in t.points]
    return np.union1d(np.linspace(lo, hi, points), np.clip(extra, lo, hi))


def _add_terms(fvar, var: Variable, used: set[str] | None = None) -> None:
    import skfuzzy as fuzz

    for term in var.terms:
        if used is not None and term.label not in used:
            continue
        if len(term.points) == 3:
            fvar[term.label] = fuzz.trimf(fvar.universe, list(term.points))
        else:
            fvar[term.label] = fuzz.trapmf(fvar.universe, list(term.points))


def build_control_system(table: RuleTable, input_points: int = 1001, output_points: int = 1001):
    """A ``skfuzzy.control.ControlSystem`` with the table's terms and rules (min/min/max, centroid)."""
    from skfuzzy import control as ctrl

    kappa = ctrl.Antecedent(_universe(table.curvature, input_points), KAPPA)
    dk = ctrl.Antecedent(_universe(table.curvature_variation, input_points), DK)
    feed = ctrl.Consequent(_universe(table.feed, output_points), FEED, defuzzify_method="centroid")
    _add_terms(kappa, table.curvature)
    _add_terms(dk, table.curvature_variation)
    # feed terms no rule uses change nothing, and scikit-fuzzy 0.5's array mode fails on them
    _add_terms(feed, table.feed, used={f for _, _, f in table.rules})
    rules = [ctrl.Rule(kappa[k] & dk[d], feed[f], label=f"R{n + 1}")
             for n, (k, d, f) in enumerate(table.rules)]
    return ctrl.ControlSystem(rules)


def skfuzzy_feed_pct(table: RuleTable, kappa: np.ndarray, dk: np.ndarray, *, array: bool = True,
                     input_points: int = 1001, output_points: int = 1001, system=None) -> np.ndarray:
    """scikit-fuzzy's centroid for each (κ, Dκ): one ``compute()`` on arrays (``array=True``) or a
    per-point loop (``array=False``)."""
    from skfuzzy import control as ctrl

    system = system or build_control_system(table, input_points, output_points)
    kappa = np.clip(np.asarray(kappa, dtype=float), *table.curvature.universe)
    dk = np.clip(np.asarray(dk, dtype=float), *table.curvature_variation.universe)
    with warnings.catch_warnings():
        # scikit-fuzzy 0.5 calls np.maximum(a, b, out) positionally (deprecated in numpy 2)
        warnings.simplefilter("ignore", DeprecationWarning)
        if array:
            sim = ctrl.ControlSystemSimulation(system, cache=False)
            sim.input[KAPPA] = kappa
            sim.input[DK] = dk
            sim.compute()
            return np.asarray(sim.output[FEED], dtype=float).reshape(kappa.shape)
        sim = ctrl.ControlSystemSimulation(system, cache=False)
        out = np.empty(kappa.size)
        for i, (x, y) in enumerate(zip(kappa.ravel(), dk.ravel())):
            sim.input[KAPPA] = float(x)
            sim.input[DK] = float(y)
            sim.compute()
            out[i] = sim.output[FEED]
        return out.reshape(kappa.shape)
