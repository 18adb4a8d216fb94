"""fuzzyfeed: feedrate advice along NURBS tool paths.

A Mamdani fuzzy advisor (Lin, Lin & Wang 2021) and a jerk-limited sliding look-ahead window
scheduler share one NURBS sampling layer. Importing the package stays light: no plotting or
dataframe library is imported here.
"""

from __future__ import annotations

__version__ = "0.1.0"

from fuzzyfeed.errors import FuzzyfeedError
from fuzzyfeed.nurbs import Nurbs
from fuzzyfeed.sampling import PathSamples, sample_by_arc_length, sample_uniform_u


__all__ = [
    "FuzzyfeedError",
    "Nurbs",
    "PathSamples",
    "__version__",
    "sample_by_arc_length",
    "sample_uniform_u",
]
