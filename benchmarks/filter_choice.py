"""Which filter smooths the fuzzy controller's feed without giving back its slow-down at corners?

    python benchmarks/filter_choice.py [--points 2000] [--rules paper]

For every shipped shape (sampled uniform in u, seed 002's 2000 points) and candidate filter, prints:
- ``max_step``: smoothness, the largest point-to-point change of the feed (% of F);
- ``kink_cut``: how many times smaller the largest second difference (kink) is than the
  controller's own (the team's bar for the average filter: at least 10 ×);
- ``reversals``: pairs of feed extrema (prominence ≥ 5 % of F) closer than half a window M — an
  up-and-down the filter should have smoothed away (the controller alone has dozens);
- ``peak_excess``: the largest (filtered − controller) feed at a curvature peak (% of F; > 0 means
  the filter raised the feed where the controller slowed down most); curvature peaks: every sample
  whose κ is at least its neighbours';
- ``kept``: the smallest share of the controller's slow-down (100 − feed) kept at a peak (%);
- ``time``: travel time at the filtered feeds over the time at the controller's own feeds (floor
  held): the cost of smoothing (the average is cheaper because it raises the corners' feed).
The rule for fuzzyfeed's default, printed on the last line: no excess at any peak, no reversal and a
kink cut of at least 10 on every shape, a worst-case max_step no larger than seed 002's average
(M = 21), and among those the least time on the worst shape.
Candidates: the controller itself (none), seed 002's centred mean, the mean capped by the controller
(min(mean, controller)), fuzzyfeed's corner-mean with its cap rising 10 to 40 % of F per half
window ("corner-mean/10"), and min-mean (see fuzzyfeed/fuzzy/filters.py), for M = 11, 21, 31.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np
from scipy.signal import find_peaks

from fuzzyfeed.fuzzy.advisor import advise_details
from fuzzyfeed.fuzzy.filters import curvature_peaks, smooth_feed
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.io.shapes import load_shape, sample_shape

SHAPES = ("infinity", "trident", "trident2", "butterfly", "wm")


def candidates(raw: np.ndarray, kappa: np.ndarray) -> dict[str, np.ndarray]:
    out = {"none": raw}
    for m in (11, 21, 31):
        out[f"mean M={m}"] = smooth_feed(raw, "mean", m)
    out["capped-mean M=21"] = np.minimum(out["mean M=21"], raw)
    for m in (11, 21, 31):
        for rise in (10.0, 20.0, 25.0, 30.0, 40.0):
            out[f"corner-mean/{rise:g} M={m}"] = smooth_feed(raw, "corner-mean", m, curvature=kappa,
                                                            rise_pct=rise)
    for m in (11, 21, 31):
        out[f"min-mean M={m}"] = smooth_feed(raw, "min-mean", m)
    return out


def _reversals(f: np.ndarray, m: int) -> int:
    ext = np.sort(np.concatenate([find_peaks(f, prominence=5.0)[0], find_peaks(-f, prominence=5.0)[0]]))
    return int((np.diff(ext) < m // 2).sum())


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--points", type=int, default=2000)
    ap.add_argument("--rules", default=None)
    args = ap.parse_args(argv)
    table = load_rule_table(args.rules)
    print(f"{'shape':<10} {'filter':<24} {'max_step':>9} {'kink_cut':>8} {'reversals':>9} "
          f"{'peak_excess':>12} {'kept':>7} {'time':>7}")
    worst: dict[str, list[tuple[float, float, int, float, float]]] = {}
    for name in SHAPES:
        samples = sample_shape(load_shape(name), args.points)
        advice = advise_details(samples, replace(table, filter="mean", filter_points=1))
        raw = advice.controller_pct
        k = samples.curvature
        peaks = curvature_peaks(k)
        ds = np.diff(samples.s)
        held = np.clip(raw, table.feed_floor_pct, 100.0)
        t_raw = float(np.sum(ds / (0.5 * (held[1:] + held[:-1]))))
        for label, f in candidates(raw, k).items():
            m = int(label.split("M=")[1]) if "M=" in label else 1
            f = np.clip(f, table.feed_floor_pct, 100.0)
            step = float(np.abs(np.diff(f)).max())
            rev = _reversals(f, m) if m > 1 else -1
            excess = float((f[peaks] - held[peaks]).max())
            kept = float(((100 - f[peaks]) / (100 - held[peaks])).min() * 100)
            t = float(np.sum(ds / (0.5 * (f[1:] + f[:-1])))) / t_raw
            kink = float(np.abs(np.diff(held, 2)).max() / max(np.abs(np.diff(f, 2)).max(), 1e-300))
            worst.setdefault(label, []).append((excess, step, rev, t, kink))
            print(f"{name:<10} {label:<24} {step:9.3f} {kink:8.1f} {rev:9d} {excess:12.3f} "
                  f"{kept:6.1f}% {t:7.3f}")
    print("worst over the shapes:        peak_excess max_step kink_cut reversals  time")
    for label, v in worst.items():
        print(f"  {label:<26} {max(x[0] for x in v):10.3f} {max(x[1] for x in v):8.3f} "
              f"{min(x[4] for x in v):8.1f} {max(x[2] for x in v):9d} {max(x[3] for x in v):6.3f}")
    paper_step = max(x[1] for x in worst["mean M=21"])
    ok = {label: max(x[3] for x in v) for label, v in worst.items() if label != "none"
          and max(x[0] for x in v) <= 0 and max(x[2] for x in v) == 0
          and max(x[1] for x in v) <= paper_step and min(x[4] for x in v) >= 10.0}
    best = min(ok, key=ok.get)
    print(f"choice={best.replace(' ', '_')} worst_time={ok[best]:.3f} "
          f"worst_max_step={max(x[1] for x in worst[best]):.3f} (mean M=21: {paper_step:.3f})")


if __name__ == "__main__":
    main()
