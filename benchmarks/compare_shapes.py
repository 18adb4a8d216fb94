"""The comparison table of the README: every method on infinity, trident, butterfly and WM.

    python benchmarks/compare_shapes.py [--markdown] [--feed-mm-min 6000] [--points 2000]

Uses the default machine (F = 6000 mm/min, 100 mm/s and 1000 mm/s² per axis, 10 000 mm/s³,
1 µm chord tolerance, Ts = 1 ms) unless told otherwise; prints one table (Markdown with
--markdown) with, per shape and method: cycle time, ratio to the time-optimal bound, max chord
error, max contour error (axis servo: first-order loop, Kv = 30 1/s, no feed-forward), max feed
fluctuation, max tangential acceleration and jerk, and the number of servo ticks that break a
machine limit.
"""

from __future__ import annotations

import argparse

from fuzzyfeed.report.compare import compare
from fuzzyfeed.io.shapes import load_shape, sample_shape
from fuzzyfeed.machine.limits import MachineLimits

SHAPES = ("infinity", "trident", "butterfly", "wm")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--markdown", action="store_true")
    parser.add_argument("--feed-mm-min", type=float, default=6000.0)
    parser.add_argument("--points", type=int, default=2000)
    args = parser.parse_args()
    limits = MachineLimits.from_feed_mm_min(args.feed_mm_min)
    header = ["shape", "method", "cycle time (s)", "/ bound", "chord err max (µm)", "contour err max (µm)", "fluct max (%)",
              "acc max (mm/s²)", "jerk max (mm/s³)", "violating ticks"]
    rows = []
    for name in SHAPES:
        shape = load_shape(name)
        result = compare(sample_shape(shape, args.points), limits, name=name)
        for r in result.rows():
            violating = sum(v for k, v in r.items() if k.startswith("violations_"))
            rows.append([name, r["method"], f"{r['cycle_time_s']:.3f}", f"{r['ratio_to_bound']:.3f}",
                         f"{r['chord_err_max_um']:.3g}", f"{r['contour_err_max_um']:.4g}",
                         f"{r['feed_fluct_max_pct']:.2g}",
                         f"{r['tan_acc_max_mm_s2']:.4g}", f"{r['tan_jerk_max_mm_s3']:.4g}", str(violating)])
        if not args.markdown:
            print("; ".join(result.cross_check.lines()))
    if args.markdown:
        print("| " + " | ".join(header) + " |")
        print("|" + "---|" * len(header))
        for row in rows:
            print("| " + " | ".join(row) + " |")
    else:
        widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
        print("  ".join(h.rjust(w) for h, w in zip(header, widths)))
        for row in rows:
            print("  ".join(c.rjust(w) for c, w in zip(row, widths)))


if __name__ == "__main__":
    main()
