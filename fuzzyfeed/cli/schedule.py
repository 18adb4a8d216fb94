"""``fuzzyfeed schedule SHAPE -o TRAJ.csv``: the jerk-limited scheduler's timed trajectory (the whole-path
LP beside seed 000's sliding look-ahead window)."""

from __future__ import annotations

import argparse
import sys

import numpy as np

from fuzzyfeed.cli import COMMANDS
from fuzzyfeed.cli._common import add_shape_argument
from fuzzyfeed.cli._gcode import add_gcode_arguments, prepare_gcode
from fuzzyfeed.cli._limits import (add_approach_argument, add_limit_arguments, check_schedule_work,
                                    limits_from_args, program_feed_limits, schedule_error)
from fuzzyfeed.errors import InputError


def register(sub) -> None:
    p = sub.add_parser(
        "schedule", help=COMMANDS["schedule"],
        description="Preprocess SHAPE (feed limits, critical points, blocks), schedule the "
                    "jerk-limited feed (by default the faster of a whole-path time-optimal LP and the "
                    "sliding look-ahead window; --planner window --transition cosine --approach 1 is "
                    "seed 000's scheduler), interpolate at the servo period and write one CSV row per "
                    "period: t_s, u, x_mm, y_mm, z_mm, s_mm, "
                    "feed_mm_s, feed_mm_min, acc_mm_s2, jerk_mm_s3. Prints the cycle time, the "
                    "critical points and blocks, the worst chord error, accelerations and jerk "
                    "(measured from the positions) and the ratio to the acceleration-limited "
                    "time-optimal bound. A cut of a G-code program runs at the program's F "
                    "words, each capped by --feed-mm-min.")
    add_shape_argument(p)
    p.add_argument("-o", "--output", required=True, metavar="TRAJ.csv", help="CSV file to write (atomically)")
    add_limit_arguments(p)
    add_approach_argument(p, transition="seven-phase")
    p.add_argument("--planner", choices=("optimal", "window"), default="optimal",
                   help="optimal: the jerk-limited time-optimal feed over the whole path (linear "
                        "programs in bounded pieces) and the sliding look-ahead window, both checked "
                        "tick by tick, the faster kept; a path over the LP's work budget (over 40 000 "
                        "grid points, its pieces' overlaps counted: any path over ~10 m, and shorter "
                        "dense ones) keeps the window, and the summary says why. window: the window "
                        "alone (seed 000), faster to compute (default: %(default)s)")
    p.add_argument("--plot", metavar="FIG.png", default=None,
                   help="also draw feed, acceleration and jerk against time (and the feed against "
                        "arc length with the limit and the bound)")
    add_gcode_arguments(p)  # G-code: the scheduled feed at the shape's 2000 seed-002 samples
    p.set_defaults(run=run)


def compute(args: argparse.Namespace):
    """Shape, trajectory, measurements and bound for parsed arguments."""
    from fuzzyfeed.io.shapes import load_shape
    from fuzzyfeed.slw import measure, path_bound, schedule

    shape = load_shape(args.shape)
    limits, cap, note = program_feed_limits(shape, limits_from_args(args))
    check_schedule_work(args.shape, shape.curve.length, limits)
    try:  # a progress bar on a terminal (tqdm.auto), none in a pipe or a log
        traj = schedule(shape.curve, limits, progress=True if sys.stderr.isatty() else None,
                        approach=args.approach, feed_cap=cap, transition=args.transition,
                        planner=args.planner)
    except InputError as exc:  # the message names the user's file (and the slowest limit)
        raise InputError(schedule_error(args.shape, exc, shape.curve.length, limits)) from None
    bound = path_bound(traj.curve, limits, feed_cap=cap)  # of the path followed (a polyline: blended)
    return shape, traj, measure(traj), bound, note, cap


def summary(shape_name: str, traj, m: dict, bound, feed_note: str | None = None) -> str:
    bound_s = bound.time_s
    lim = traj.limits
    lines = [
        f"{shape_name}: length {traj.s_mm[-1]:.3f} mm, {traj.t_s.size} servo periods of {lim.ts_s:g} s",
        f"cycle time        {traj.cycle_time_s:.4f} s  (time-optimal bound {bound_s:.4f} s, "
        f"ratio {traj.cycle_time_s / bound_s:.4f})",
        f"bound grid        {bound.s_mm.size} points, time changes {100 * bound.grid_change:.3f} % "
        "when the grid is halved",
        f"critical points   {traj.n_critical}" + (f"   blocks {traj.n_blocks}" if traj.n_blocks else ""),
        "planner           " + ("look-ahead window" if traj.n_blocks else "whole-path LP")
        + (f" ({traj.planner_note})" if traj.planner_note else ""),
        f"max feed          {m['feed'] * lim.feed_mm_min:.1f} mm/min ({100 * m['feed']:.2f} % of command)",
        f"max chord error   {1000 * m['chord'] * lim.chord_tol_mm:.4f} um ({100 * m['chord']:.2f} % of limit)",
        f"max axis velocity {100 * m['axis_vel']:.2f} % of limit",
        f"max axis acc      {100 * m['axis_acc']:.2f} % of limit (from positions)",
        f"max tangential    acc {np.abs(traj.acc_mm_s2).max():.1f} mm/s^2, "
        f"jerk {np.abs(traj.jerk_mm_s3).max():.1f} mm/s^3 ({100 * m['jerk']:.2f} % of limit)",
        f"terminal error    {1000 * m['terminal_error_mm']:.3g} um",
    ]
    if feed_note is not None:
        lines.insert(1, feed_note)
    if traj.polyline_fit is not None:
        lines.append(f"path followed     {traj.polyline_fit.describe()}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    from fuzzyfeed.io.csv import write_columns
    from fuzzyfeed.io.shapes import sample_shape

    shape, traj, m, bound_profile, feed_note, cap = compute(args)
    samples = sample_shape(shape)

    def segment_feeds():
        """F of each segment = its length / the scheduled time between its ends, so the program
        at its F words takes the schedule's time (up to the F rounding)."""
        t = traj.time_at(samples.s)
        dt = np.diff(t)
        ds = np.diff(samples.s)
        with np.errstate(divide="ignore", invalid="ignore"):
            seg = np.where(dt > 0, ds / dt * 60.0, np.nan)
        if np.isnan(seg).any():   # two samples passed within one servo period: neighbour's feed
            ok = ~np.isnan(seg)
            seg = np.interp(np.arange(seg.size), np.flatnonzero(ok), seg[ok])
        return seg

    lim = traj.limits
    if not traj.n_blocks:
        how = "the whole-path LP"
    else:
        how = (f"the look-ahead window of seed 000, {args.transition} transitions"
               + ("" if args.planner == "window" else "; the LP's schedule not kept"))
    notes = (f"jerk-limited schedule ({how}): F = {lim.feed_mm_min:g} mm/min, cycle time "
             f"{traj.cycle_time_s:.4f} s",)
    gcode = prepare_gcode(args, lambda: traj.feed_at(samples), shape, notes, segment_feeds)
    write_columns(args.output, traj.columns())
    print(summary(shape.name, traj, m, bound_profile, feed_note))
    print(f"wrote {args.output}")
    if args.plot:
        from fuzzyfeed.report.plot import plot_schedule

        plot_schedule(traj, bound_profile, title=shape.name, output=args.plot, feed_cap=cap)
        print(f"wrote {args.plot}")
    for path in gcode.write():
        print(f"wrote {path}")
    return 0
