"""Advise a whole library of programs and drawings on Dask, on one machine or a cluster (layer 8).

Imports the report layer and everything below it, never the command line: the per-file work is
handed in (``plan``, ``task``; see :mod:`fuzzyfeed.batch.run`), and ``fuzzyfeed batch`` hands in
the advise command's own. ``discover`` finds the inputs, ``manifest`` keeps each file's key
(input, options and version digests) and status, ``work`` runs a chunk of files on a worker,
``cluster`` starts or reaches the Dask cluster, ``run`` drives a run, ``summary`` writes
``summary.csv`` and ``summary.html``.

The package is also the function of its name: ``fuzzyfeed.batch(paths, out, workers=2,
feed_step_mm_min=100)`` returns the summary as a DataFrame (:func:`fuzzyfeed.cli.batch.batch`,
reached through the public API in :mod:`fuzzyfeed`).
"""

from __future__ import annotations

import sys
import types


class _CallablePackage(types.ModuleType):
    """``fuzzyfeed.batch`` is a package and, called, the batch API."""

    def __call__(self, paths, out, **options):
        import fuzzyfeed

        return fuzzyfeed._batch_api(paths, out, **options)


sys.modules[__name__].__class__ = _CallablePackage
