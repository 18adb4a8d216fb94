"""The shape of a machine table (inputs = "machine"): terms on the safe-feed ratio and the feed % it
gives, made from a list of levels so the shipped table, the tuner and the tests build it the same way.

Each level c (a ratio of the programmed feed) is a triangle on both inputs, peaking at c and reaching
the neighbouring levels (geometric steps: the centroid's error relative to the level is the same at
every level); the rule for (here ≈ any, near ≈ c) gives the output term centred at ``safety(c)``·c·100 %,
a narrow triangle. Where the near ratio reaches 1 the top term's centroid is above 100 % and the
advisor caps the feed at the programmed F: the machine follows within tolerance there, the feed
stays as written. The first input (here) has three terms and every row is the same by default —
the settling window already makes ``near ≤ here`` — so a user can make the approach zones (here
well above near) differ from the hot spots themselves by editing one row.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from fuzzyfeed.fuzzy.rules import FEED, MACHINE, SAFE, SAFE_NEAR, RuleTable, Term, Variable

#: Levels of the near ratio (fractions of the programmed feed) of the shipped table.
DEFAULT_LEVELS = (0.001, 0.0015, 0.0022, 0.0033, 0.005, 0.0075, 0.011, 0.016, 0.024, 0.035, 0.05, 0.075, 0.11, 0.16, 0.24, 0.35, 0.5, 0.7, 0.85, 1.0)
#: Output = safety × level × 100 % (below 1): the centroid's interpolation between two levels runs
#: up to ~4 % of the level above the straight line between them (geometric steps of 1.5).
DEFAULT_SAFETY = 0.93
#: The universe of both inputs (ratios above clip to its top).
RATIO_TOP = 1.5
#: The feed universe reaches above 100 % so the top term's centroid does; the advice is capped at F.
FEED_TOP_PCT = 110.0
#: Where the top level's term starts to rise, as a fraction of the top level.
TOP_RISE_FROM = 0.97
#: Rows: the ratio here (LOW, MID, OK).
HERE_TERMS = (("LOW", (0.0, 0.0, 0.5)), ("MID", (0.2, 0.6, 1.0)), ("OK", (0.8, 1.0, RATIO_TOP, RATIO_TOP)))


def _label(prefix: str, level: float) -> str:
    pct = level * 100
    text = (f"{pct:.2g}" if pct < 10 else f"{pct:.0f}").replace(".", "_")
    return f"{prefix}{text}"


def machine_table(levels: Sequence[float] = DEFAULT_LEVELS, safety: Sequence[float] | float = DEFAULT_SAFETY,
                  name: str = "machine", source: str = "", feed_floor_pct: float = 0.05) -> RuleTable:
    """A machine table with the near-ratio ``levels`` (increasing, the last 1.0) and the output
    ``safety`` factor per level (or one for all)."""
    lv = [float(x) for x in levels]
    sf = [float(safety)] * len(lv) if isinstance(safety, (int, float)) else [float(x) for x in safety]
    near_terms = []
    for i, c in enumerate(lv):
        left = lv[i - 1] if i else 0.0
        if i == len(lv) - 1:
            # the top term rises only over the last 3 %: below it the feed stays at the level under
            # it (slower, never faster than the ratio asks)
            near_terms.append(Term(_label("R", c), (max(left, TOP_RISE_FROM * c), c, RATIO_TOP, RATIO_TOP)))
        else:
            near_terms.append(Term(_label("R", c), (left, c, lv[i + 1]) if i else (0.0, 0.0, lv[1])))
    out_terms = []
    for i, (c, s) in enumerate(zip(lv, sf)):
        if i == len(lv) - 1:
            out_terms.append(Term("FULL", (100.0, 105.0, FEED_TOP_PCT)))
            continue
        centre = 100.0 * c * s
        half = 100.0 * 0.15 * (lv[i + 1] - c)
        out_terms.append(Term(_label("P", c), tuple(round(x, 4) for x in (max(centre - half, 0.0), centre,
                                                                           centre + half))))
    here = Variable(SAFE, (0.0, RATIO_TOP), tuple(Term(k, p) for k, p in HERE_TERMS))
    near = Variable(SAFE_NEAR, (0.0, RATIO_TOP), tuple(near_terms))
    feed = Variable(FEED, (0.0, FEED_TOP_PCT), tuple(out_terms))
    row = tuple(t.label for t in out_terms)
    return RuleTable(name=name, curvature=here, curvature_variation=near, feed=feed,
                     grid=tuple(row for _ in HERE_TERMS), feed_floor_pct=feed_floor_pct,
                     filter="none", source=source, inputs=MACHINE)


def ideal_pct(near_ratio, safety: float = DEFAULT_SAFETY):
    """The feed % the table approximates at a near ratio: safety × ratio × 100, 100 from ratio 1."""
    return [100.0 if r >= 1.0 else 100.0 * safety * r for r in near_ratio] if not isinstance(near_ratio, float) \
        else (100.0 if near_ratio >= 1.0 else 100.0 * safety * near_ratio)


__all__ = ["DEFAULT_LEVELS", "DEFAULT_SAFETY", "machine_table", "ideal_pct", "math"]
