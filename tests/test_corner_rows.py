"""The corner table read row by row (issue 36: a program's advice computes only the rows its turns
need): the same feeds as the whole table read at once, and the rows the same numbers."""

from __future__ import annotations

import math

import numpy as np

from fuzzyfeed.machine import safe_feed
from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.servo import ServoModel


def _from_whole_table(machine, phi, tol, rapid_lead):
    """corner_safe_feed as it read the whole table before (independent of the row cache)."""
    angles, speeds = safe_feed._corner_grid(machine)
    err = np.vstack([safe_feed._corner_errors(float(a), speeds, machine, rapid_lead) for a in angles])
    err = np.maximum.accumulate(err, axis=1)
    logv = np.log(speeds)
    per = np.empty(angles.size)
    for i, e in enumerate(err):
        if e[-1] <= tol:
            per[i] = np.inf
        elif e[0] > tol:
            per[i] = speeds[0]
        else:
            j = int(np.argmax(e > tol))
            f = (tol - e[j - 1]) / (e[j] - e[j - 1]) if e[j] > e[j - 1] else 0.0
            per[i] = math.exp(logv[j - 1] + f * (logv[j] - logv[j - 1]))
    p = np.clip(np.abs(phi), 0.0, math.pi)
    k = np.clip(np.searchsorted(angles, p, side="right"), 1, angles.size - 1)
    out = np.minimum(per[k - 1], per[k])
    return err, (out if rapid_lead else np.where(p <= 0.0, np.inf, out))


def test_rows_read_lazily_give_the_whole_tables_feeds():
    machine = Machine(servo=ServoModel(kv_1_s=23.0), contour_tol_um=17.0)   # a machine no other test caches
    rng = np.random.default_rng(36)
    phi = np.concatenate([[0.0, 1e-4, math.pi], rng.uniform(0.0, 0.4, 6)])     # turns in a few rows only
    for rapid_lead in (False, True):
        lazy = safe_feed.corner_safe_feed(machine, phi, rapid_lead=rapid_lead)
        info = safe_feed._corner_error_row.cache_info()
        err, whole = _from_whole_table(machine, phi, machine.contour_tol_mm, rapid_lead)
        np.testing.assert_array_equal(lazy, whole)
        assert np.isfinite(lazy).any()
        angles, _, table = safe_feed.corner_error_table(machine, rapid_lead)
        np.testing.assert_array_equal(table, err)
        assert safe_feed._corner_error_row.cache_info().misses > info.misses    # the table filled the rest
