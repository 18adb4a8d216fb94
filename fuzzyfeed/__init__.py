"""fuzzyfeed: feedrate advice along NURBS tool paths.

A Mamdani fuzzy advisor (Lin, Lin & Wang 2021) and a jerk-limited sliding look-ahead window
scheduler share one NURBS sampling layer. Importing the package stays light: no plotting or
dataframe library is imported here, and the names below other than the core's load on first use.

The flow, one package per step (each package's docstring says what it may import):
``geometry`` → ``machine`` → ``fuzzy`` | ``slw`` → ``program`` → ``io`` → ``report`` → ``batch``,
``designer`` → ``cli``; ``base`` and ``errors`` serve them all.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

from fuzzyfeed.errors import FuzzyfeedError
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.geometry.sampling import PathSamples, sample_by_arc_length, sample_uniform_u

#: Public names loaded on first use: name -> module that defines it.
_LAZY = {
    "load_shape": "fuzzyfeed.io.shapes",
    "sample_shape": "fuzzyfeed.io.shapes",
    "advise": "fuzzyfeed.fuzzy.advisor",
    "advise_details": "fuzzyfeed.fuzzy.advisor",
    "load_rule_table": "fuzzyfeed.fuzzy.rules",
    "RuleTable": "fuzzyfeed.fuzzy.rules",
    "MachineLimits": "fuzzyfeed.machine.limits",
    "ServoModel": "fuzzyfeed.machine.servo",
    "FeedProfile": "fuzzyfeed.machine.profile",
    "simulate_profile": "fuzzyfeed.machine.simulate",
    "schedule": "fuzzyfeed.slw",
    "time_optimal_bound": "fuzzyfeed.slw",
    "read_program": "fuzzyfeed.program.read",
    "advise_program": "fuzzyfeed.program.feeds",
    "compare": "fuzzyfeed.report.compare",
}


def _batch_api(paths, out, **options):
    """``fuzzyfeed.batch(paths, out, ...)``: the batch command's Python face,
    :func:`fuzzyfeed.cli.batch.batch` (the package :mod:`fuzzyfeed.batch` is callable and lands here,
    so the engine never imports the command line it serves)."""
    from fuzzyfeed.cli.batch import batch

    return batch(paths, out, **options)


def __getattr__(name: str):
    if name == "batch":      # the package, callable: fuzzyfeed.batch(paths, out, ...)
        return importlib.import_module("fuzzyfeed.batch")
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'fuzzyfeed' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY) | {"batch"})


__all__ = sorted([
    "FuzzyfeedError",
    "Nurbs",
    "PathSamples",
    "__version__",
    "batch",
    "sample_by_arc_length",
    "sample_uniform_u",
    *_LAZY,
])
