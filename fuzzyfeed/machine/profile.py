"""FeedProfile: the one value every planner returns and every consumer (simulator, exporters) takes."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.base.checks import expect, float_array
from fuzzyfeed.errors import InputError
from fuzzyfeed.geometry.sampling import PathSamples

MM_S_PER_MM_MIN = 1.0 / 60.0


@dataclass(frozen=True, eq=False)
class FeedProfile:
    """A feed for every sampled point of a path.

    ``feed_mm_s`` has one finite value ≥ 0 per row of ``samples`` (0 only where a planner stops,
    such as the SLW profile's start and end at rest). ``method`` names the planner ("fuzzy",
    "slw", "constant", "bound", ...); ``max_feed_mm_s`` is the user's maximum feed the
    percentages refer to.
    """

    samples: PathSamples
    feed_mm_s: np.ndarray
    method: str
    max_feed_mm_s: float

    def __post_init__(self) -> None:
        expect(self.samples, PathSamples, "samples", "PathSamples")
        expect(self.max_feed_mm_s, (int, float, np.integer, np.floating), "max_feed_mm_s", "a number of mm/s")
        feed = np.array(float_array(self.feed_mm_s, "feed_mm_s"), dtype=float)
        if feed.shape != (len(self.samples),):
            raise InputError(f"feed_mm_s: shape {feed.shape}, expected ({len(self.samples)},), "
                             "one feed per sample")
        bad = ~np.isfinite(feed) | (feed < 0)
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(f"feed_mm_s[{i}] = {feed[i]}; a feed must be finite and >= 0")
        if not np.isfinite(self.max_feed_mm_s) or self.max_feed_mm_s <= 0:
            raise InputError(f"max_feed_mm_s = {self.max_feed_mm_s}; must be finite and > 0")
        feed.flags.writeable = False
        object.__setattr__(self, "feed_mm_s", feed)

    @property
    def feed_mm_min(self) -> np.ndarray:
        return self.feed_mm_s * 60.0

    @property
    def feed_pct(self) -> np.ndarray:
        return 100.0 * self.feed_mm_s / self.max_feed_mm_s

    def travel_time_s(self) -> float:
        """Time to run the samples at these feeds, trapezoidal in 1/v over arc length.

        A zero feed at a segment's end is handled by using the segment's mean feed (v_a + v_b)/2,
        which is exact for a feed linear in time and finite for a stop at one end.
        """
        ds = np.diff(np.asarray(self.samples.s, dtype=float))
        bad = ~np.isfinite(ds) | (ds < 0)
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(f"samples.s[{i + 1}] = {self.samples.s[i + 1]} after {self.samples.s[i]}; "
                             "arc lengths must be finite and non-decreasing")
        v = self.feed_mm_s
        mean = 0.5 * (v[:-1] + v[1:])
        if np.any((mean <= 0) & (ds > 0)):
            raise InputError(f"{self.method}: the feed is 0 along a segment; the path is never completed")
        return float(np.sum(np.divide(ds, mean, out=np.zeros_like(ds), where=ds > 0)))
