"""The fuzzy feedrate advisor of seed 002 (Lin, Lin & Wang 2021).

- :mod:`~fuzzyfeed.fuzzy.rules` — rule tables (TOML files in ``rules/``): variables, terms, grid, validation;
  read by :mod:`~fuzzyfeed.fuzzy.rule_reader`, written and edited by :mod:`~fuzzyfeed.fuzzy.rule_writer`.
- :mod:`~fuzzyfeed.fuzzy.features` — κ and the windowed, clipped, normalised Dκ (eq. 10).
- :mod:`~fuzzyfeed.fuzzy.engine` — exact vectorised Mamdani engine and per-rule firing strengths.
- :mod:`~fuzzyfeed.fuzzy.windows` — sliding windows in points or mm (extremes, means).
- :mod:`~fuzzyfeed.fuzzy.filters` — the feed filters: seed 002's mean, the default min-mean.
- :mod:`~fuzzyfeed.fuzzy.advisor` — features → engine → filter → :class:`FeedProfile`.
- :mod:`~fuzzyfeed.fuzzy.exchange` (+ ``fcl``, ``fll``, ``fis``) — export/import for other tools.
- :mod:`~fuzzyfeed.fuzzy.diff` — differences between two tables and where the feed changes.
- :mod:`~fuzzyfeed.fuzzy.provenance` — which table, F and path made an advice.
- :mod:`~fuzzyfeed.fuzzy.skfuzzy_ref` — the same controller in scikit-fuzzy (cross-check).

Imports :mod:`fuzzyfeed.machine` and below (layer 4), never the SLW scheduler. Importing this package loads neither numba's kernel nor scikit-fuzzy; both load on first use.
"""

from __future__ import annotations

from fuzzyfeed.fuzzy.advisor import FuzzyAdvice, advise, advise_details, average_filter
from fuzzyfeed.fuzzy.engine import FuzzyEngine, compile_table
from fuzzyfeed.fuzzy.features import Features, features
from fuzzyfeed.fuzzy.filters import smooth_feed
from fuzzyfeed.fuzzy.rule_reader import load_rule_table, parse_rule_table, resolve_rules_path
from fuzzyfeed.fuzzy.rule_writer import grid_text, save_rule_table
from fuzzyfeed.fuzzy.rules import RuleTable, Term, Variable

__all__ = [
    "Features",
    "FuzzyAdvice",
    "FuzzyEngine",
    "RuleTable",
    "Term",
    "Variable",
    "advise",
    "advise_details",
    "average_filter",
    "compile_table",
    "features",
    "grid_text",
    "load_rule_table",
    "parse_rule_table",
    "resolve_rules_path",
    "save_rule_table",
    "smooth_feed",
]
