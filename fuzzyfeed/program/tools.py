"""A LinuxCNC tool table: the tool diameters cutter compensation needs.

One tool per line, words in any order: ``T`` tool number, ``P`` pocket, ``D`` diameter, ``X Y Z
A B C U V W`` offsets, ``I J Q`` lathe data, and a ``;`` comment to the end of the line (LinuxCNC's
``tool.tbl``). Values are in the machine's length units (``units``: "mm" or "inch"; LinuxCNC's
stand-alone ``rs274`` reads them as inches). Blank and comment-only lines are skipped; a line
without ``T``, a word that is not a number, a tool given twice or a diameter that is not finite
is one error naming the file and line.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

from fuzzyfeed.errors import PathFormatError

_WORD = re.compile(r"([A-Za-z])\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)")
_LETTERS = set("TPDXYZABCUVWIJQ")


def read_tool_table(path: str | os.PathLike, units: str = "mm") -> dict[int, float]:
    """Tool number -> diameter (mm) of a LinuxCNC tool table (see the module docstring)."""
    from fuzzyfeed.base.files import read_text

    if units not in ("mm", "inch"):
        raise PathFormatError(f"tool table units {units!r}; give mm or inch")
    scale = 25.4 if units == "inch" else 1.0
    path = Path(path)
    text = read_text(path, "tool table", PathFormatError)
    tools: dict[int, float] = {}
    for number, raw in enumerate(text.splitlines(), start=1):
        body = raw.split(";", 1)[0].strip()
        if not body:
            continue
        words = {}
        pos = 0
        for m in _WORD.finditer(body):
            if body[pos:m.start()].strip():
                break
            words[m.group(1).upper()] = m.group(2)
            pos = m.end()
        rest = body[pos:].strip()
        if rest or not words:
            raise PathFormatError(f"{path}:{number}: '{(rest or body)[:20]}' in {raw.strip()!r}: expected "
                                  "words like T1 P1 D6.0 Z0.5 (a letter and a number)")
        bad = set(words) - _LETTERS
        if bad:
            raise PathFormatError(f"{path}:{number}: {sorted(bad)[0]} is not a tool table word "
                                  "(T P D X Y Z A B C U V W I J Q)")
        if "T" not in words:
            raise PathFormatError(f"{path}:{number}: no T word in {raw.strip()!r}; every tool line needs "
                                  "its tool number")
        tool = float(words["T"])
        if tool != int(tool) or tool < 0:
            raise PathFormatError(f"{path}:{number}: T{words['T']}: a tool number is a whole number >= 0")
        diameter = float(words.get("D", "0"))
        if not math.isfinite(diameter) or abs(diameter) * scale > 1e6:
            raise PathFormatError(f"{path}:{number}: D{words['D']}: a diameter must be finite and "
                                  "within ±1 km")
        if int(tool) in tools:
            raise PathFormatError(f"{path}:{number}: tool T{int(tool)} is given twice")
        tools[int(tool)] = diameter * scale
    return tools
