"""``fuzzyfeed advise SHAPE -o OUT.csv``: the fuzzy advisor's feed (seed 002) for every sampled point."""

from __future__ import annotations

import argparse

import numpy as np

from fuzzyfeed.cli._common import add_shape_argument, check_feed_mm_min, point_count, positive_float
from fuzzyfeed.cli._gcode import add_gcode_arguments, prepare_gcode
from fuzzyfeed.cuts import DEFAULT_STEP_MM
from fuzzyfeed.errors import MachineLimitsError
from fuzzyfeed.limits import DEFAULT_FEED_MM_S
from fuzzyfeed.sampling import DEFAULT_POINTS

#: Default maximum feed F (mm/min) when --feed-mm-min is not given: the machine default's feed.
DEFAULT_FEED_MM_MIN = DEFAULT_FEED_MM_S * 60.0


def register(sub) -> None:
    p = sub.add_parser(
        "advise", help="advise the feed along a shape with the fuzzy controller (seed 002)",
        description="Sample SHAPE, compute curvature and the windowed curvature variation, run the "
                    "Mamdani rule table (exact centroid) and the average filter, and write one CSV "
                    "row per point: u, x_mm, y_mm, z_mm, s_mm, curvature_1_mm, curvature_window_max_1_mm "
                    "(Dk before normalisation), curvature_variation (the normalised Dk fed to the "
                    "controller), feed_pct_controller (before the filter), feed_pct, feed_mm_min. "
                    "Prints min/mean/max feed and the time at the advised feeds. "
                    "A G-code program (.ngc, .nc, ...) is advised cut by cut under its own F and, "
                    "with --gcode, written back whole: every line kept, only F words changed or "
                    "inserted, moves split only where the feed changes; G93/G95 moves, drilling "
                    "cycles and moves from unknown positions keep their F. The CSV then has one "
                    "row per sample with cut, source_line and programmed_feed_mm_min.")
    add_shape_argument(p)
    p.add_argument("-o", "--output", required=True, metavar="OUT.csv", help="CSV file to write (atomically)")
    p.add_argument("--rules", metavar="FILE", default=None,
                   help="rule table: a shipped name (see `fuzzyfeed rules show`) or a .toml file "
                        "(default: paper, seed 002's table)")
    p.add_argument("--feed-mm-min", type=float, default=None, metavar="F",
                   help="maximum feed F in mm/min; feed %% refers to it (shapes: "
                        f"default: {DEFAULT_FEED_MM_MIN:g}). For a G-code program the program's own F is "
                        "the ceiling at every move; F, if given, only caps it")
    p.add_argument("--step-mm", type=positive_float, default=None, metavar="MM",
                   help="G-code programs: largest distance between the advisor's samples along a "
                        f"cut, arcs also every 10 degrees (default: {DEFAULT_STEP_MM:g})")
    p.add_argument("--points", type=point_count, default=DEFAULT_POINTS, metavar="N",
                   help="sample points, uniform in the parameter as in seed 002 (default: %(default)s; "
                        "point-sequence shapes use their own points)")
    p.add_argument("--rule-strengths", action="store_true",
                   help="add one column per rule with its firing strength, named "
                        "w_<curvature term>_<curvature_variation term> (e.g. w_VS_M)")
    p.add_argument("--plot", metavar="FIG.png", default=None,
                   help="also draw feed and curvature against arc length and the path coloured by feed")
    add_gcode_arguments(p)
    p.set_defaults(run=run)


def compute(args: argparse.Namespace):
    """Shape, rules and samples in, :class:`~fuzzyfeed.fuzzy.advisor.FuzzyAdvice` out (one call)."""
    from fuzzyfeed.fuzzy.advisor import advise_details
    from fuzzyfeed.fuzzy.rules import load_rule_table
    from fuzzyfeed.io.shapes import load_shape, sample_shape

    feed_mm_min = check_feed_mm_min(DEFAULT_FEED_MM_MIN if args.feed_mm_min is None else args.feed_mm_min)
    table = load_rule_table(args.rules)
    shape = load_shape(args.shape)
    samples = sample_shape(shape, args.points)
    return shape, advise_details(samples, table, feed_mm_min / 60.0)


def advice_columns(advice, rule_strengths: bool = False) -> dict[str, np.ndarray]:
    """The CSV columns of a fuzzy advice, units in the names (plus w_K_D per rule if asked)."""
    profile = advice.profile
    cols = dict(profile.samples.columns())
    cols["curvature_window_max_1_mm"] = advice.features.window_max_1_mm
    cols["curvature_variation"] = advice.features.curvature_variation
    cols["feed_pct_controller"] = advice.controller_pct
    cols["feed_pct"] = profile.feed_pct
    cols["feed_mm_min"] = profile.feed_mm_min
    if rule_strengths:
        _, w = advice.rule_strengths()
        for n, (k, d, _) in enumerate(advice.table.rules):
            cols[f"w_{k}_{d}"] = w[:, n]
    return cols


def summary(shape_name: str, advice) -> str:
    p = advice.profile
    f = p.feed_mm_min
    pct = p.feed_pct
    t = p.travel_time_s()
    t_const = p.samples.length / p.max_feed_mm_s
    return "\n".join([
        f"{shape_name}: {len(p.samples)} points, length {p.samples.length:.3f} mm, rules "
        f"{advice.table.name!r}, F = {p.max_feed_mm_s * 60:g} mm/min",
        f"feed mm/min  min {f.min():.1f}  mean {f.mean():.1f}  max {f.max():.1f}   "
        f"(% of F: {pct.min():.2f} / {pct.mean():.2f} / {pct.max():.2f})",
        f"time at the advised feeds {t:.4f} s  (at constant F: {t_const:.4f} s)",
    ])


def run(args: argparse.Namespace) -> int:
    from fuzzyfeed.cli._program import is_program, run_program
    from fuzzyfeed.io.csv import write_columns

    if is_program(args.shape):
        return run_program(args)
    if args.step_mm is not None:
        raise MachineLimitsError("--step-mm applies to G-code programs only; shapes take --points")
    shape, advice = compute(args)
    notes = (f"rules {advice.table.name!r}; F = {advice.profile.max_feed_mm_s * 60:g} mm/min "
             "(feed % refers to it)",)
    gcode = prepare_gcode(args, advice.profile, shape, notes)  # checked before any file is written
    write_columns(args.output, advice_columns(advice, args.rule_strengths))
    if args.plot:
        from fuzzyfeed.plot import plot_fuzzy_advice

        plot_fuzzy_advice(advice, shape.name, args.plot)
    print(summary(shape.name, advice))
    print(f"wrote {args.output}" + (f" and {args.plot}" if args.plot else ""))
    for path in gcode.write():
        print(f"wrote {path}")
    return 0
