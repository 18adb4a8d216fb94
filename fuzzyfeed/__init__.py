"""fuzzyfeed: feedrate advice along NURBS tool paths.

A Mamdani fuzzy advisor (Lin, Lin & Wang 2021) and a jerk-limited sliding look-ahead window
scheduler share one NURBS sampling layer. Importing the package stays light: it imports no
third-party library (not even numpy), and the public names below load on first use.

The flow, one package per step (each package's docstring says what it may import):
``geometry`` → ``machine`` → ``fuzzy`` | ``slw`` → ``program`` → ``io`` → ``report`` → ``advice``
→ ``batch``, ``designer`` → ``cli``; ``base`` and ``errors`` serve them all.

In a notebook::

    import fuzzyfeed as ff
    result = ff.advise_file("part.ngc", machine="reference")   # an AdviceResult
    result.value                                                # as written / advised / uniform / reference
    result.plot()
    ff.advise_library(["library/"], "results/", ff.AdviceOptions(machine="reference"))
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

from fuzzyfeed.errors import FuzzyfeedError

#: Public names loaded on first use: name -> module that defines it.
_LAZY = {
    "Nurbs": "fuzzyfeed.geometry.nurbs",
    "PathSamples": "fuzzyfeed.geometry.sampling",
    "sample_by_arc_length": "fuzzyfeed.geometry.sampling",
    "sample_uniform_u": "fuzzyfeed.geometry.sampling",
    "load_shape": "fuzzyfeed.io.shapes",
    "sample_shape": "fuzzyfeed.io.shapes",
    "advise": "fuzzyfeed.fuzzy.advisor",
    "advise_details": "fuzzyfeed.fuzzy.advisor",
    "load_rule_table": "fuzzyfeed.fuzzy.rule_reader",
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
    # the advice pipeline (issue 39): one options value, one function per file and per library
    "Machine": "fuzzyfeed.machine.description",
    "load_machine": "fuzzyfeed.machine.description",
    "AdviceOptions": "fuzzyfeed.advice.options",
    "advise_file": "fuzzyfeed.advice.pipeline",
    "AdviceResult": "fuzzyfeed.advice.result",
    "advise_library": "fuzzyfeed.batch.library",
}


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'fuzzyfeed' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


__all__ = sorted(["FuzzyfeedError", "__version__", *_LAZY])
