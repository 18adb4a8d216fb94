"""``fuzzyfeed compare SHAPE``: fuzzy, fuzzy-safe, SLW, constant feed and the bound, side by side."""

from __future__ import annotations

import argparse
import sys

from fuzzyfeed.cli import COMMANDS
from fuzzyfeed.cli._common import add_shape_argument, point_count
from fuzzyfeed.cli._limits import (add_approach_argument, add_limit_arguments, check_schedule_work,
                                    limits_from_args, program_feed_limits)
from fuzzyfeed.cli._machine import machine_from_args
from fuzzyfeed.cli._servo import servo_from_args

DESCRIPTION = """\
Simulate every method on the same samples with the same interpolator at Ts and print one metric
table: fuzzy (the advice at the command feed F), fuzzy-safe (the jerk-limited SLW schedule
under min(advice, machine): every limit held), slw (the jerk-limited look-ahead schedule), constant (F everywhere) and bound (the
acceleration-limited time-optimal bound, no jerk limit). A cut of a G-code program runs every row
under the program's F words, each capped by F (the advice a fraction of them, the constant row the
program as written). Violations count servo ticks over a limit.
The contour error is the distance of the tool from the curve when each axis follows its set-points
through a position loop (default Kv = 30 1/s, no feed-forward; see the servo flags).
"""


def register(sub) -> None:
    p = sub.add_parser("compare", help=COMMANDS["compare"],
                       description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_shape_argument(p)
    p.add_argument("--rules", metavar="FILE", default=None,
                   help="rule table file (default: the paper's table, rules/paper.toml)")
    p.add_argument("--points", type=point_count, default=2000,
                   help="sample points, uniform in u (default: %(default)s, as in seed 002)")
    add_limit_arguments(p)
    add_approach_argument(p)
    p.add_argument("-o", "--output", required=True, metavar="REPORT.csv",
                   help="CSV with one row per method (column method) and one column per metric")
    p.add_argument("--plot", metavar="FIG.png", default=None,
                   help="figure: feeds, acceleration, jerk, chord and contour error, path coloured by the advice")
    p.set_defaults(run=run)


METRIC_COLUMNS = (("cycle_time_s", "cycle (s)", "{:.4f}"), ("ratio_to_bound", "/bound", "{:.3f}"),
                  ("chord_err_max_um", "chord max (um)", "{:.3g}"),
                  ("contour_err_max_um", "contour max (um)", "{:.4g}"),
                  ("contour_err_mean_um", "contour mean (um)", "{:.4g}"),
                  ("contour_err_rms_um", "contour rms (um)", "{:.4g}"),
                  ("feed_fluct_max_pct", "fluct max (%)", "{:.2g}"),
                  ("tan_acc_max_mm_s2", "acc max (mm/s2)", "{:.4g}"),
                  ("tan_jerk_max_mm_s3", "jerk max (mm/s3)", "{:.4g}"))


def format_table(rows: list[dict]) -> str:
    header = f"{'method':<11}" + "".join(f"{title:>18}" for _, title, _ in METRIC_COLUMNS) + \
        f"{'violations (worst ratio)':>34}"
    lines = [header, "-" * len(header)]
    for row in rows:
        counts = {k[len("violations_"):]: v for k, v in row.items() if k.startswith("violations_")}
        bad = [(name, row[f"worst_ratio_{name}"]) for name, c in counts.items() if c]
        worst = max(bad, key=lambda x: x[1]) if bad else None
        summary = f"{sum(counts.values())} ({worst[0]} x{worst[1]:.2f})" if worst else "0"
        lines.append(f"{row['method']:<11}" + "".join(f"{fmt.format(row[key]):>18}" for key, _, fmt in
                                                    METRIC_COLUMNS) + f"{summary:>34}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    import numpy as np
    from tqdm import tqdm

    from fuzzyfeed.report.compare import METHODS, compare
    from fuzzyfeed.fuzzy.rule_reader import load_rule_table
    from fuzzyfeed.io.csv import write_columns
    from fuzzyfeed.io.shapes import load_shape, sample_shape
    from fuzzyfeed.geometry.sampling import POINT_STEP_MM

    servo = servo_from_args(args, machine_from_args(args))
    table = load_rule_table(args.rules)
    shape = load_shape(args.shape)
    limits, cap, feed_note = program_feed_limits(shape, limits_from_args(args))
    check_schedule_work(args.shape, shape.curve.length, limits)
    # a point sequence is sampled inside its long segments too: the fuzzy and bound rows execute a
    # feed given per sample, which must see a long line between two corners, not only its ends
    samples = sample_shape(shape, args.points, max_step_mm=POINT_STEP_MM)
    steps = 4 + len(METHODS)
    with tqdm(total=steps, desc=f"compare {shape.name}", unit="step", disable=not sys.stderr.isatty(),
              leave=False) as bar:
        def progress(name: str) -> None:
            bar.set_postfix_str(name)
            bar.update(1)

        result = compare(samples, limits, table, name=shape.name, progress=progress, servo=servo,
                         approach=args.approach, feed_cap=cap,
                         transition=args.transition)
    rows = result.rows()
    columns = {key: np.array([row[key] for row in rows]) for key in rows[0]}
    write_columns(args.output, columns, allow_nan=("ratio_to_bound",))
    print(f"{shape.name}: {len(samples)} samples, {samples.length:.3f} mm; F = {limits.feed_mm_min:g} mm/min, "
          f"Ts = {limits.ts_s:g} s, chord tolerance {limits.chord_tol_mm * 1e3:g} um; servo {servo.describe()}")
    if feed_note is not None:
        print(" ".join(feed_note.split()))
    print(format_table(rows))
    for line in result.cross_check.lines():
        print(f"  {line}")
    print(f"wrote {args.output}")
    if args.plot:
        from fuzzyfeed.report.plot_compare import plot_comparison

        plot_comparison(result, args.plot)
        print(f"wrote {args.plot}")
    return 0
