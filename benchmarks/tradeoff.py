"""Seed 002's accuracy claim in the simulator: cycle time against contour error.

    python benchmarks/tradeoff.py [--markdown] [--pareto] [--kv 30] [--ff 0] [--feeds 750,1500,3000,6000]

For the paper's three shapes (infinity, trident, butterfly; seed 002 Tables 7-9) and every maximum
feed F, the fuzzy advice (rules/paper.toml) is simulated with the axis servo model (first-order
position loop, Kv = 30 1/s, no feed-forward unless told otherwise) on the default machine, and
compared with a constant feed (a) of the same cycle time, (b) of the same max contour error. The
paper claims 43 % less error at equal time and 49 % less time at equal error. With --pareto it
also prints the trade-off points: fuzzy, fuzzy-safe, SLW and constant at each F, and the SLW under
contour tolerances ε (axis acceleration 2·Kv²·ε).
"""

from __future__ import annotations

import argparse
import statistics

from fuzzyfeed.io.shapes import load_shape, sample_shape
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.machine.servo import ServoModel
from fuzzyfeed.report.tradeoff import (PAPER_ERROR_REDUCTION_PCT, PAPER_TIME_REDUCTION_PCT, claims_vs_constant,
                                pareto_points)

SHAPES = ("infinity", "trident", "butterfly")


def _table(header: list[str], rows: list[list[str]], markdown: bool) -> str:
    if markdown:
        return "\n".join(["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
                         + ["| " + " | ".join(r) + " |" for r in rows])
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    return "\n".join(["  ".join(h.rjust(w) for h, w in zip(header, widths))]
                     + ["  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in rows])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--markdown", action="store_true")
    parser.add_argument("--pareto", action="store_true", help="also print the trade-off points")
    parser.add_argument("--kv", type=float, default=30.0, help="position-loop gain, 1/s (default 30)")
    parser.add_argument("--ff", type=float, default=0.0, help="velocity feed-forward fraction (default 0)")
    parser.add_argument("--feeds", default="750,1500,3000,6000", help="maximum feeds F in mm/min")
    parser.add_argument("--tolerances", default="10,30,100,300", help="SLW contour tolerances in µm (--pareto)")
    parser.add_argument("--points", type=int, default=2000)
    args = parser.parse_args()
    feeds = [float(f) for f in args.feeds.split(",")]
    servo = ServoModel(kv_1_s=args.kv, feedforward=args.ff)
    limits = MachineLimits()
    header = ["shape", "F (mm/min)", "fuzzy time (s)", "fuzzy max contour err (µm)",
              "constant, same time: err (µm)", "error reduction", "constant, same err: time (s)",
              "time reduction"]
    rows, err_red, time_red, pareto = [], [], [], []
    for name in SHAPES:
        samples = sample_shape(load_shape(name), args.points)
        for c in claims_vs_constant(samples, limits, feeds, servo=servo):
            err_red.append(c.error_reduction_pct)
            time_red.append(c.time_reduction_pct)
            rows.append([name, f"{c.feed_mm_min:g}", f"{c.fuzzy_time_s:.3f}", f"{c.fuzzy_err_um:.4g}",
                         f"{c.equal_time_err_um:.4g} (F = {c.equal_time_feed_mm_min:.0f})",
                         f"{c.error_reduction_pct:.1f} %",
                         f"{c.equal_err_time_s:.3f} (F = {c.equal_err_feed_mm_min:.0f})",
                         f"{c.time_reduction_pct:.1f} %"])
        if args.pareto:
            tolerances = [float(t) for t in args.tolerances.split(",")]
            for p in pareto_points(samples, limits, feeds, tolerances, servo=servo):
                pareto.append([name, p.family, p.setting, f"{p.cycle_time_s:.3f}", f"{p.contour_err_max_um:.4g}",
                               f"{p.contour_err_mean_um:.4g}", str(p.violating_ticks)])
    print(f"servo: {servo.describe()}; machine: {MachineLimits().as_dict()}")
    print(_table(header, rows, args.markdown))
    print()
    print(f"error reduction at equal cycle time: median {statistics.median(err_red):.1f} % "
          f"(range {min(err_red):.1f} to {max(err_red):.1f} %), paper {PAPER_ERROR_REDUCTION_PCT:g} %")
    print(f"time reduction at equal max contour error: median {statistics.median(time_red):.1f} % "
          f"(range {min(time_red):.1f} to {max(time_red):.1f} %), paper {PAPER_TIME_REDUCTION_PCT:g} %")
    if pareto:
        print()
        print(_table(["shape", "family", "setting", "cycle time (s)", "max contour err (µm)",
                      "mean contour err (µm)", "violating ticks"], pareto, args.markdown))


if __name__ == "__main__":
    main()
