"""The one shape value every reader returns: a named tool path (NURBS in mm) and its origin.

Readers (:mod:`fuzzyfeed.io.points`, :mod:`fuzzyfeed.io.dxf`, :mod:`fuzzyfeed.io.gcode_paths`)
import only this module; :mod:`fuzzyfeed.io.shapes` is the one dispatcher that imports them.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fuzzyfeed.geometry.nurbs import Nurbs


@dataclass(frozen=True, eq=False)
class Shape:
    """A named tool path: the NURBS in mm plus where it came from."""

    name: str
    curve: Nurbs
    source: str = ""
    notes: str = ""
    path: Path | None = None
    #: For paths imported as point sequences (G-code/CSV/DXF polylines): the points, (N, 2|3) mm.
    #: ``curve`` is then the degree-1 NURBS through them (chord-length knots).
    polyline: np.ndarray | None = None
    #: For a cut of a G-code program: the F in force along it, as (s_mm, feed_mm_min) — arc length
    #: along ``curve`` and the feed from there on; an arc length given twice is a step (the next
    #: move's F). The program's F is the ceiling of every feed there (DESIGN, "Feeds in a program").
    programmed_feed: tuple[np.ndarray, np.ndarray] | None = None
