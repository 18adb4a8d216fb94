"""Which filter smooths the fuzzy controller's feed without giving back its slow-down at corners?

    python benchmarks/filter_choice.py [--points 2000] [--rules paper]

For every shipped shape (sampled uniform in u, seed 002's 2000 points) and candidate filter, prints:
- ``max_step``: smoothness, the largest point-to-point change of the feed (% of F);
- ``peak_excess``: the largest (filtered − controller) feed at a curvature peak (% of F; > 0 means
  the filter raised the feed where the controller slowed down most);
- ``kept``: the smallest share of the controller's slow-down (100 − feed) kept at a peak (%);
- ``time``: travel time at the filtered feeds over the time at the controller's own feeds (floor held; the cost
  of smoothing; the average filter is cheaper because it raises the corners' feed).
Curvature peaks: local maxima of κ with prominence ≥ 10 % of the shape's largest κ.
Candidates: the controller itself (none), seed 002's centred mean, the mean capped by the controller
(min(mean, controller)), and fuzzyfeed's min-mean (erosion then mean) for M = 11, 21, 31.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np
from scipy.signal import find_peaks

from fuzzyfeed.fuzzy.advisor import advise_details
from fuzzyfeed.fuzzy.filters import smooth_feed
from fuzzyfeed.fuzzy.rules import load_rule_table
from fuzzyfeed.io.shapes import load_shape, sample_shape

SHAPES = ("infinity", "trident", "trident2", "butterfly", "wm")


def candidates(raw: np.ndarray) -> dict[str, np.ndarray]:
    out = {"none": raw}
    for m in (11, 21, 31):
        out[f"mean M={m}"] = smooth_feed(raw, "mean", m)
    out["capped-mean M=21"] = np.minimum(out["mean M=21"], raw)
    for m in (11, 21, 31):
        out[f"min-mean M={m}"] = smooth_feed(raw, "min-mean", m)
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--points", type=int, default=2000)
    ap.add_argument("--rules", default=None)
    args = ap.parse_args(argv)
    table = load_rule_table(args.rules)
    print(f"{'shape':<10} {'filter':<18} {'max_step':>9} {'peak_excess':>12} {'kept':>7} {'time':>7}")
    worst: dict[str, list[float]] = {}
    for name in SHAPES:
        samples = sample_shape(load_shape(name), args.points)
        advice = advise_details(samples, replace(table, filter="mean", filter_points=1))
        raw = advice.controller_pct
        k = samples.curvature
        peaks, _ = find_peaks(np.concatenate([[-np.inf], k, [-np.inf]]), prominence=0.1 * k.max())
        peaks = peaks - 1
        ds = np.diff(samples.s)
        held = np.clip(raw, table.feed_floor_pct, 100.0)
        t_raw = float(np.sum(ds / (0.5 * (held[1:] + held[:-1]))))
        for label, f in candidates(raw).items():
            f = np.clip(f, table.feed_floor_pct, 100.0)
            step = float(np.abs(np.diff(f)).max())
            excess = float((f[peaks] - raw[peaks]).max())
            kept = float(((100 - f[peaks]) / (100 - raw[peaks])).min() * 100)
            t = float(np.sum(ds / (0.5 * (f[1:] + f[:-1])))) / t_raw
            worst.setdefault(label, []).append(excess)
            print(f"{name:<10} {label:<18} {step:9.3f} {excess:12.3f} {kept:6.1f}% {t:7.3f}")
    print("worst peak_excess over the shapes: " +
          "  ".join(f"{label}: {max(v):.3f}" for label, v in worst.items()))


if __name__ == "__main__":
    main()
