"""Which rule table, maximum feed F and tool path made an advice: recorded next to every CSV
(a CSVW ``-metadata.json`` sidecar) and in the G-code header, so an edited table is never
mistaken for the paper's.

The table is identified by its name (its file's name unless the file sets one), its file and a
digest of what it computes (terms, grid and settings; not its name, source or comments), so two
files with the same name but different cells have different digests.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from fuzzyfeed.fuzzy.rule_writer import table_to_toml
from fuzzyfeed.fuzzy.rules import RuleTable


def table_digest(t: RuleTable) -> str:
    """First 12 hex digits of the SHA-256 of the table's canonical TOML without name and source."""
    from dataclasses import replace

    text = table_to_toml(replace(t, source=""), with_name=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:12]


def provenance(table: RuleTable, max_feed_mm_min: float, source: str | Path | None = None,
               points: int | None = None) -> dict[str, str]:
    """The record of one advice, as ordered text fields (for a CSV sidecar or G-code comments).

    ``source``: the tool path's file or shipped name (and its own source line, if any).
    """
    from fuzzyfeed import __version__

    ws = f"{table.window_mm:g} mm" if table.window_mm else f"{table.window_points} points"
    m = f"{table.filter_mm:g} mm" if table.filter_mm else f"{table.filter_points} points"
    out = {
        "rules": table.name,
        "rules_file": str(table.path) if table.path is not None else "",
        "rules_digest": table_digest(table),
        "rules_source": table.source,
        "F_mm_min": f"{float(max_feed_mm_min):g}",
        "window": ws,
        "filter": f"{table.filter} over {m}",
        "source": "" if source is None else str(source),
        "generator": f"fuzzyfeed {__version__}",
    }
    if points is not None:
        out["points"] = str(int(points))
    return out


def provenance_lines(record: dict[str, str]) -> list[str]:
    """``key: value`` lines safe inside a G-code ``( … )`` comment (no parentheses, one line each)."""
    def clean(v: str) -> str:
        return " ".join(v.replace("(", "[").replace(")", "]").split())
    return [f"{k}: {clean(v)}" for k, v in record.items() if v != ""]
