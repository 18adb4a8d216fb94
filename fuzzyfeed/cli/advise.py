"""``fuzzyfeed advise SHAPE -o OUT.csv``: the fuzzy advisor's feed (seed 002) for every sampled point."""

from __future__ import annotations

import argparse

import numpy as np

from fuzzyfeed.cli import COMMANDS
from fuzzyfeed.cli._common import (add_shape_argument, check_feed_mm_min, point_count, positive_float,
                                   table_from_args)
from fuzzyfeed.cli._program import add_program_arguments, refuse_program_arguments
from fuzzyfeed.cli._gcode import add_gcode_arguments, prepare_gcode
from fuzzyfeed.cli._machine import add_machine_arguments, machine_from_args
from fuzzyfeed.program.cuts import DEFAULT_STEP_MM
from fuzzyfeed.errors import InputError, MachineLimitsError
from fuzzyfeed.machine.limits import DEFAULT_FEED_MM_S
from fuzzyfeed.geometry.sampling import DEFAULT_POINTS, POINT_STEP_MM

#: Default maximum feed F (mm/min) when --feed-mm-min is not given: the machine default's feed.
DEFAULT_FEED_MM_MIN = DEFAULT_FEED_MM_S * 60.0


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


def compute(args: argparse.Namespace, shape=None):
    """Shape, rules and samples in, :class:`~fuzzyfeed.fuzzy.advisor.FuzzyAdvice` out (one call);
    ``shape``, if already loaded, is SHAPE's one path."""
    from fuzzyfeed.fuzzy.advisor import advise_details
    from fuzzyfeed.io.shapes import load_shape, sample_shape

    feed_mm_min = check_feed_mm_min(DEFAULT_FEED_MM_MIN if args.feed_mm_min is None else args.feed_mm_min)
    machine = machine_from_args(args)
    table = table_from_args(args, machine)
    shape = load_shape(args.shape) if shape is None else shape
    try:
        samples = sample_shape(shape, args.points, max_step_mm=POINT_STEP_MM)
        return shape, advise_details(samples, table, feed_mm_min / 60.0, machine=machine)
    except InputError as exc:  # the message names the user's file
        raise InputError(f"{args.shape}: {exc}") from None


def advice_columns(advice, rule_strengths: bool = False) -> dict[str, np.ndarray]:
    """The CSV columns of a fuzzy advice, units in the names (plus w_K_D per rule if asked)."""
    profile = advice.profile
    cols = dict(profile.samples.columns())
    if advice.machine is not None:
        ceiling = profile.max_feed_mm_s * 60.0
        cols["safe_feed_mm_min"] = np.minimum(advice.machine.safe_feed_mm_s * 60.0, ceiling)
        cols["safe_feed_ratio"] = advice.machine.safe_feed_ratio
        cols["safe_feed_ratio_near"] = advice.machine.safe_feed_ratio_near
    else:
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


def advice_provenance(args: argparse.Namespace, shape, advice) -> dict[str, str]:
    """Which table, F and tool path made this advice (CSV sidecar, G-code header)."""
    from fuzzyfeed.fuzzy.provenance import provenance

    source = str(shape.path) if getattr(shape, "path", None) else str(args.shape)
    if getattr(shape, "source", ""):
        source += f" ({shape.source})"
    return provenance(advice.table, advice.profile.max_feed_mm_s * 60.0, source,
                      len(advice.profile.samples))


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
        _filter_line(advice),
    ])


def _filter_line(advice) -> str:
    """Smoothness before and after the filter, and the feed at the curvature peaks against the
    controller's (issue 12: a filter must not speed up a corner)."""
    from fuzzyfeed.fuzzy.filters import curvature_peaks

    table = advice.table
    raw, pct = advice.controller_pct, advice.feed_pct
    size = f"{table.filter_mm:g} mm" if table.filter_mm else f"{table.filter_points} points"
    steps = (f"{np.abs(np.diff(raw)).max():.2f} % -> {np.abs(np.diff(pct)).max():.2f} %"
             if raw.size > 1 else "n/a")
    peaks = curvature_peaks(advice.features.curvature_1_mm)
    above = float((pct[peaks] - np.maximum(raw[peaks], table.feed_floor_pct)).max())
    corners = ("never above the controller at a curvature peak" if above <= 1e-9 else
               f"up to {above:.2f} % above the controller at a curvature peak")
    return f"{table.filter} filter over {size}: largest point-to-point change {steps}; {corners}"


def drawing_paths(args: argparse.Namespace) -> list | None:
    """Every path of SHAPE (a drawing's contours; the one path of any other file), read once; None
    when a FILE#SELECTOR picks one."""
    from fuzzyfeed.io.shapes import load_shapes, split_selector

    _, selector = split_selector(args.shape)
    return None if selector is not None else load_shapes(args.shape)


def run_paths(args: argparse.Namespace, shapes: list) -> dict:
    """Advise every path of a file, as a program runs them: one CSV (column ``path``, 1-based, then
    the one-path columns) and one summary line per path; returns the figures (see :func:`advise_file`)."""
    from fuzzyfeed.errors import ExportError
    from fuzzyfeed.fuzzy.advisor import advise_details
    from fuzzyfeed.io.csv import write_columns
    from fuzzyfeed.io.shapes import sample_shape

    for flag in ("gcode", "gcode_g52", "plot"):
        if getattr(args, flag, None):
            option = "--" + flag.replace("_", "-")
            raise ExportError(f"{option}: {args.shape} holds {len(shapes)} paths; {option} writes "
                              f"one path, pick it with {args.shape}#path=N")
    feed_mm_min = check_feed_mm_min(DEFAULT_FEED_MM_MIN if args.feed_mm_min is None else args.feed_mm_min)
    machine = machine_from_args(args)
    table = table_from_args(args, machine)
    parts, lines, times = [], [], np.zeros((len(shapes), 2))
    for number, shape in enumerate(shapes, start=1):
        advice = advise_details(sample_shape(shape, args.points, max_step_mm=POINT_STEP_MM), table,
                                feed_mm_min / 60.0, machine=machine)
        cols = advice_columns(advice, args.rule_strengths)
        parts.append({"path": np.full(len(advice.profile.samples), number), **cols})
        p = advice.profile
        lines.append(f"path {number} {shape.name}: {len(p.samples)} points, length "
                     f"{p.samples.length:.3f} mm, feed mm/min min {p.feed_mm_min.min():.1f} mean "
                     f"{p.feed_mm_min.mean():.1f} max {p.feed_mm_min.max():.1f}, time "
                     f"{p.travel_time_s():.4f} s")
        times[number - 1] = p.samples.length / p.max_feed_mm_s, p.travel_time_s()
    columns = {name: np.concatenate([part[name] for part in parts]) for name in parts[0]}
    write_columns(args.output, columns)
    from fuzzyfeed.fuzzy.provenance import provenance
    from fuzzyfeed.io.csv import write_metadata

    write_metadata(args.output, list(columns),
                   provenance(table, feed_mm_min, f"{args.shape} ({len(shapes)} paths)", columns["path"].size))
    print(f"{args.shape}: {len(shapes)} paths, rules {table.name!r}, F = {feed_mm_min:g} mm/min")
    print("\n".join(lines))
    print(f"wrote {args.output}")
    return _figures(len(shapes), times.sum(axis=0), columns["feed_pct"])


def _figures(paths: int, times_s, feed_pct: np.ndarray) -> dict:
    """The summary figures :func:`advise_file` returns for a shape or drawing (time as written:
    every path at the constant F)."""
    return {"cuts": paths, "cuts_advised": paths, "time_written_s": float(times_s[0]),
            "time_advised_s": float(times_s[1]), "feed_pct_min": float(feed_pct.min()),
            "feed_pct_mean": float(feed_pct.mean())}


def run(args: argparse.Namespace) -> int:
    advise_file(args)
    return 0


def advise_file(args: argparse.Namespace) -> dict:
    """What ``fuzzyfeed advise`` does with parsed ``args`` (outputs written, summary printed),
    returning its figures: ``cuts`` (paths of a drawing), ``cuts_advised``, ``time_written_s``
    (a program at its own F, a shape at constant F), ``time_advised_s``, ``feed_pct_min``,
    ``feed_pct_mean``; a program on a machine: the times as the machine runs it and the value
    report's row (``written_max_um``, ``advised_max_um``, ...). ``fuzzyfeed batch`` calls it once
    per file."""
    from fuzzyfeed.cli._program import is_program, run_program
    from fuzzyfeed.io.csv import write_columns, write_metadata

    if is_program(args.shape):
        return run_program(args)
    if args.step_mm is not None:
        raise MachineLimitsError("--step-mm applies to G-code programs only; shapes take --points")
    if args.report is not None or args.no_reference:
        flag = "--report" if args.report is not None else "--no-reference"
        raise MachineLimitsError(f"{flag}: the value report runs a G-code program on a machine; "
                                 f"{args.shape} is not a program")
    refuse_program_arguments(args)
    shapes = drawing_paths(args)
    if shapes is not None and len(shapes) > 1:
        return run_paths(args, shapes)
    shape, advice = compute(args, shapes[0] if shapes else None)
    notes = (f"rules {advice.table.name!r}; F = {advice.profile.max_feed_mm_s * 60:g} mm/min "
             "(feed % refers to it)",)
    gcode = prepare_gcode(args, advice.profile, shape, notes)  # checked before any file is written
    columns = advice_columns(advice, args.rule_strengths)
    write_columns(args.output, columns)
    meta = write_metadata(args.output, list(columns), advice_provenance(args, shape, advice))
    if args.plot:
        from fuzzyfeed.report.plot import plot_fuzzy_advice

        plot_fuzzy_advice(advice, shape.name, args.plot)
    print(summary(shape.name, advice))
    print(f"wrote {args.output}" + (f" ({meta}: rules, F, source)" if meta else "")
          + (f" and {args.plot}" if args.plot else ""))
    for path in gcode.write():
        print(f"wrote {path}")
    p = advice.profile
    return _figures(1, (p.samples.length / p.max_feed_mm_s, p.travel_time_s()), p.feed_pct)
