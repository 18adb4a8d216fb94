"""The exact, vectorised Mamdani engine of the fuzzy advisor (seed 002, section 2.7.1 C, eq. 11).

AND = min, implication = min (clip), aggregation = max, defuzzification = the centroid of the
aggregated piecewise-linear set, computed exactly (closed-form integrals between its kinks; no
output grid). Inputs outside a universe clip to its ends. Where no rule fires (all strengths 0,
impossible for a validated table, whose inputs are covered and whose grid is full) the output is
the table's ``feed_floor_pct`` — scikit-fuzzy would drop the output there.

The per-point loop is a numba kernel (``fuzzyfeed.fuzzy._kernel``, compiled once and cached on
disk) for large calls and its numpy form (``fuzzyfeed.fuzzy._centroid``, the same floats) for calls
below ``fuzzyfeed.geometry._kernels.COMPILED_MIN_POINTS`` points, so a small run never loads numba.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.base.checks import expect, finite_vector
from fuzzyfeed.geometry._kernels import use_compiled
from fuzzyfeed.errors import InputError
from fuzzyfeed.fuzzy.rules import RuleTable, Variable

#: Points per kernel call in :meth:`FuzzyEngine.feed_pct` (bounds temporary memory).
CHUNK_POINTS = 1 << 20


def _terms_array(var: Variable) -> np.ndarray:
    return np.array([t.trapezoid for t in var.terms], dtype=float).reshape(-1, 4)


def _limit_from_right(x: float, a: float, b: float, c: float, d: float) -> float:
    """lim μ(y) for y ↓ x (a vertical edge at x counts with its upper value)."""
    if x < a:
        return 0.0
    if x < b:
        return (x - a) / (b - a)
    if x < c:
        return 1.0
    if x < d:
        return (d - x) / (d - c)
    return 0.0


def _limit_from_left(x: float, a: float, b: float, c: float, d: float) -> float:
    """lim μ(y) for y ↑ x."""
    if x <= a:
        return 0.0
    if x <= b:
        return (x - a) / (b - a)
    if x <= c:
        return 1.0
    if x <= d:
        return (d - x) / (d - c)
    return 0.0


def membership(var: Variable, x: np.ndarray) -> np.ndarray:
    """μ of every term of ``var`` at ``x`` (clipped to the universe): array (N, n_terms)."""
    lo, hi = var.universe
    x = np.clip(np.asarray(x, dtype=float), lo, hi)
    out = np.empty((x.size, len(var.terms)))
    for j, term in enumerate(var.terms):
        a, b, c, d = term.trapezoid
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # subnormal widths
            rise = np.where(b > a, (x - a) / (b - a if b > a else 1.0), 1.0)
            fall = np.where(d > c, (d - x) / (d - c if d > c else 1.0), 1.0)
        mu = np.where(x < b, rise, np.where(x <= c, 1.0, fall))
        out[:, j] = np.where((x < a) | (x > d), 0.0, mu)
    return out


def check_finite(name: str, values: np.ndarray) -> np.ndarray:
    """Return ``values`` as a float array; NaN or infinity is an :class:`InputError` naming the index."""
    return np.ascontiguousarray(finite_vector(values, name, "controller inputs must be finite numbers"))


@dataclass(frozen=True, eq=False)
class FuzzyEngine:
    """A rule table compiled for fast evaluation. Build with :func:`compile_table`."""

    table: RuleTable
    k_terms: np.ndarray        # (n_k, 4) trapezoids of the curvature terms
    d_terms: np.ndarray        # (n_d, 4)
    o_terms: np.ndarray        # (n_o, 4)
    rule_k: np.ndarray         # (n_rules,) int64 index of the κ term
    rule_d: np.ndarray
    rule_o: np.ndarray
    grid_o: np.ndarray         # (n_k, n_d) output term of each rule, -1 = no rule
    x_int: np.ndarray          # sorted distinct output vertices: interval boundaries
    act_ptr: np.ndarray        # CSR: terms non-zero inside interval q are act_term[act_ptr[q]:act_ptr[q+1]]
    act_term: np.ndarray
    act_m0: np.ndarray         # their membership at the interval's left end (limit from inside)
    act_m1: np.ndarray         # ... and at its right end

    @property
    def rule_names(self) -> list[str]:
        return self.table.rule_names()

    def feed_pct(self, kappa: np.ndarray, dk: np.ndarray, compiled: bool | None = None) -> np.ndarray:
        """Defuzzified output (the table's feed unit, %) for each (κ, Dκ) pair; exact centroid.

        The compiled loop runs for large calls, the numpy form below ``COMPILED_MIN_POINTS``
        points (``compiled`` forces one form; both give the same floats)."""
        kappa = check_finite("curvature", np.atleast_1d(kappa))
        dk = check_finite("curvature_variation", np.atleast_1d(dk))
        if kappa.shape != dk.shape:
            raise InputError(f"curvature has {kappa.size} values, curvature_variation {dk.size}; "
                             "give one pair per point")
        no_fire = float(self.table.feed_floor_pct)
        if not (use_compiled(kappa.size) if compiled is None else compiled):
            from fuzzyfeed.fuzzy._centroid import centroid_numpy

            return centroid_numpy(self.clip_levels(kappa, dk), self.x_int, self.act_ptr, self.act_term,
                                  self.act_m0, self.act_m1, no_fire)
        from fuzzyfeed.fuzzy._kernel import centroid_kernel

        kernel = centroid_kernel()
        out = np.empty(kappa.size)
        (k_lo, k_hi), (d_lo, d_hi) = self.table.curvature.universe, self.table.curvature_variation.universe
        for start in range(0, kappa.size, CHUNK_POINTS):
            sl = slice(start, start + CHUNK_POINTS)
            kernel(kappa[sl], dk[sl], self.k_terms, self.d_terms, float(k_lo), float(k_hi),
                   float(d_lo), float(d_hi), self.grid_o, self.o_terms.shape[0], self.x_int, self.act_ptr,
                   self.act_term, self.act_m0, self.act_m1, no_fire, out[sl])
        return out

    def firing_strengths(self, kappa: np.ndarray, dk: np.ndarray) -> np.ndarray:
        """Strength min(μκ, μDκ) of every rule at every point: (N, n_rules), rules in the order
        of :attr:`rule_names` (row by row of the grid)."""
        kappa = check_finite("curvature", np.atleast_1d(kappa))
        dk = check_finite("curvature_variation", np.atleast_1d(dk))
        mk = membership(self.table.curvature, kappa)
        md = membership(self.table.curvature_variation, dk)
        return np.minimum(mk[:, self.rule_k], md[:, self.rule_d])

    def clip_levels(self, kappa: np.ndarray, dk: np.ndarray) -> np.ndarray:
        """Clip level of every output term (max strength of its rules): (N, n_out)."""
        w = self.firing_strengths(kappa, dk)
        h = np.zeros((w.shape[0], self.o_terms.shape[0]))
        for r, o in enumerate(self.rule_o):
            np.maximum(h[:, o], w[:, r], out=h[:, o])
        return h


def compile_table(table: RuleTable) -> FuzzyEngine:
    """Precompute the arrays the kernel needs: term trapezoids, rule indices, and the static cut of
    the output axis at every term vertex with each term's line inside each interval."""
    expect(table, RuleTable, "table", "a RuleTable (load_rule_table)")
    k, d, f = table.curvature, table.curvature_variation, table.feed
    rk, rd, ro = [], [], []
    for i in range(len(k.terms)):
        for j in range(len(d.terms)):
            rk.append(i)
            rd.append(j)
            ro.append(f.index(table.grid[i][j]))
    o_terms = _terms_array(f)
    x_int = np.sort(o_terms.ravel())            # the distinct breakpoints (np.unique would import numpy.ma)
    x_int = x_int[np.concatenate([[True], x_int[1:] != x_int[:-1]])]
    ptr, terms, m0s, m1s = [0], [], [], []
    for q in range(x_int.size - 1):
        x0, x1 = float(x_int[q]), float(x_int[q + 1])
        for o, (a, b, c, dd) in enumerate(o_terms):
            m0 = _limit_from_right(x0, a, b, c, dd)
            m1 = _limit_from_left(x1, a, b, c, dd)
            if max(m0, m1) > 0:
                terms.append(o)
                m0s.append(m0)
                m1s.append(m1)
        ptr.append(len(terms))
    as_int = lambda v: np.array(v, dtype=np.int64)  # noqa: E731
    return FuzzyEngine(table=table, k_terms=_terms_array(k), d_terms=_terms_array(d), o_terms=o_terms,
                       rule_k=as_int(rk), rule_d=as_int(rd), rule_o=as_int(ro),
                       grid_o=as_int(ro).reshape(len(k.terms), len(d.terms)), x_int=x_int,
                       act_ptr=as_int(ptr), act_term=as_int(terms), act_m0=np.array(m0s, dtype=float),
                       act_m1=np.array(m1s, dtype=float))


def feed_pct(table: RuleTable, kappa: np.ndarray, dk: np.ndarray) -> np.ndarray:
    """One-call form of :meth:`FuzzyEngine.feed_pct`."""
    return compile_table(table).feed_pct(kappa, dk)
