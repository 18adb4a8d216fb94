"""``fuzzyfeed advise SHAPE -o OUT.csv``: the fuzzy advisor's feed (seed 002) for every sampled point."""

from __future__ import annotations

import argparse

from fuzzyfeed.advice.options import AdviceOptions
from fuzzyfeed.advice.shape import DEFAULT_FEED_MM_MIN
from fuzzyfeed.cli import COMMANDS
from fuzzyfeed.cli._common import add_shape_argument, point_count, positive_float
from fuzzyfeed.cli._gcode import add_gcode_arguments
from fuzzyfeed.cli._machine import add_machine_arguments, machine_from_args
from fuzzyfeed.cli._program import add_program_arguments
from fuzzyfeed.geometry.sampling import DEFAULT_POINTS
from fuzzyfeed.program.cuts import DEFAULT_STEP_MM


def register(sub) -> None:
    p = sub.add_parser(
        "advise", help=COMMANDS["advise"],
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
                    "row per sample with cut, source_line and programmed_feed_mm_min. "
                    "With a machine (--machine FILE or any machine flag) the advice reads the "
                    "machine's terms (rules/machine.toml: the feed that holds --contour-tol-um "
                    "on this machine over the programmed F); a program is run as written through "
                    "the machine's planner and servo, the cuts that break the tolerance are advised, "
                    "the others keep their feeds, and the value report is printed (--report).")
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
    p.add_argument("--filter", choices=("corner-mean", "min-mean", "mean", "none"), default=None,
                   help="smoothing of the controller's feed: corner-mean (the paper table's) "
                        "averages but never lifts a curvature peak above the controller, min-mean "
                        "never exceeds the controller anywhere (slowest), mean is seed 002's "
                        "average filter, none keeps the controller's output (the machine table's) "
                        "(default: the rule table's)")
    p.add_argument("--window-mm", type=positive_float, default=None, metavar="L",
                   help="look-ahead WS as a length: Dk at a point is the largest curvature within "
                        "the next L mm of path, whatever the sampling (default: the table's "
                        "window, 30 points in the paper's; on a point sequence or a program, "
                        "whose points are the file's, the stretch 30 points cover at 0.25 mm: "
                        "7.25 mm)")
    p.add_argument("--filter-mm", type=positive_float, default=None, metavar="L",
                   help="filter window M as a length of L mm centred on each point (default: the "
                        "table's, 21 points in the paper's; 5 mm on a point sequence or a program)")
    p.add_argument("--rule-strengths", action="store_true",
                   help="add one column per rule with its firing strength, named "
                        "w_<curvature term>_<curvature_variation term> (e.g. w_VS_M)")
    p.add_argument("--plot", metavar="FIG.png", default=None,
                   help="also draw feed and curvature against arc length and the path coloured by feed "
                        "(a program on a machine: where the feed drops along the path)")
    p.add_argument("--report", metavar="FILE.html", default=None,
                   help="G-code programs on a machine: write the value report, time and max/p99 contour "
                        "error as written, advised, uniformly slowed down and the limit reference "
                        "(.html with plots, or .csv: one row)")
    p.add_argument("--no-reference", action="store_true",
                   help="G-code programs on a machine: leave out the limit reference (the slowest "
                        "part of the value report)")
    add_gcode_arguments(p)
    add_machine_arguments(p)
    add_program_arguments(p)
    p.set_defaults(run=run, csv_sidecar=True)


def options_from_args(args: argparse.Namespace) -> AdviceOptions:
    """The advise flags (output files apart) as one :class:`AdviceOptions` value: the only place
    the command's Namespace becomes the library's options (the machine flags make the machine)."""
    return AdviceOptions(
        rules=args.rules, machine=machine_from_args(args), feed_mm_min=args.feed_mm_min,
        feed_step_mm_min=args.feed_step_mm_min, step_mm=args.step_mm, points=args.points,
        filter=args.filter, window_mm=args.window_mm, filter_mm=args.filter_mm,
        rule_strengths=args.rule_strengths, reference=not args.no_reference, units=args.units,
        point_tolerance=args.point_tolerance, path_tolerance=args.path_tolerance,
        tool_table=args.tool_table, tool_units=args.tool_units, safe_z_mm=args.safe_z_mm,
        plunge_feed_mm_min=args.plunge_feed_mm_min, line_numbers=args.line_numbers,
        gcode_decimals=args.gcode_decimals, g52_whole=args.g52_whole,
        verify_rs274=args.verify_rs274)


def run(args: argparse.Namespace) -> int:
    """The command: the options made once, the file advised (:func:`fuzzyfeed.advice.pipeline.
    advise_file`), its outputs written in the command's transaction, the summary printed."""
    from fuzzyfeed.advice.pipeline import advise_file

    result = advise_file(args.shape, options_from_args(args))
    wrote = result.write(csv=args.output, gcode=args.gcode, gcode_g52=args.gcode_g52, plot=args.plot,
                         report=args.report)
    for line in (*result.summary(), *wrote):
        print(line)
    return 0
