"""``fuzzyfeed tune``: move a rule table's feed terms to cut cycle time under a contour tolerance."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from fuzzyfeed.cli._common import count_at_least, point_count, positive_float
from fuzzyfeed.cli._limits import add_limit_arguments, limits_from_args
from fuzzyfeed.cli._machine import machine_from_args
from fuzzyfeed.cli._servo import servo_from_args

DESCRIPTION = """\
Tune the output (feed) terms of a rule table (seed 002's future work): keep the rule grid and the
input terms, move the feed terms (kept a triangular partition of the feed universe) to minimise the
summed cycle time of the advice on SHAPES at the command feed F, subject to a max contour error
(servo model, see the servo flags) and every machine limit but the jerk (a feed given per sample is
not jerk-limited). Nelder-Mead on the simulated cycle times; each evaluation simulates every shape.
The tuned table is written to a new TOML file (an existing file is not overwritten). Exit code 1
when no candidate met the constraints (the least infeasible table is written, and said so).
"""


#: argparse type of --evaluations: Nelder-Mead's simplex needs at least 3.
evaluation_count = count_at_least(3, "evaluations")


def register(sub) -> None:
    p = sub.add_parser("tune", help="tune a rule table's feed terms for cycle time under a contour tolerance",
                       description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("shapes", nargs="+", metavar="SHAPE", help="shapes to tune on (names or files)")
    p.add_argument("--rules", metavar="FILE", default=None,
                   help="rule table to start from (default: the paper's table, rules/paper.toml)")
    p.add_argument("--evaluations", type=evaluation_count, default=120, metavar="N",
                   help="simulation rounds (all shapes each) the search may use (default: %(default)s)")
    p.add_argument("--points", type=point_count, default=2000,
                   help="sample points per shape, uniform in u (default: %(default)s)")
    p.add_argument("--name", default=None, help="name of the tuned table (default: <table>-tuned)")
    add_limit_arguments(p)
    p.add_argument("-o", "--output", required=True, metavar="TUNED.toml", help="new rule-table file to write")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from fuzzyfeed.errors import InputError
    from fuzzyfeed.fuzzy.rules import load_rule_table, save_rule_table
    from fuzzyfeed.fuzzy.tune import tune_output_terms
    from fuzzyfeed.io.shapes import load_shape, sample_shape

    out = Path(args.output)
    if out.exists():
        raise InputError(f"{out}: file exists; tune writes a new file (remove it or choose another name)")
    limits = limits_from_args(args)
    machine = machine_from_args(args)
    servo = servo_from_args(args, machine)
    if machine is None or (args.contour_tol_um is None and not args.machine):
        raise InputError("--contour-tol-um: missing; tune needs the contour tolerance (a flag or a "
                         "--machine file's [part] contour_tolerance_um)")
    args.contour_tol_um = machine.contour_tol_um
    table = load_rule_table(args.rules)
    shapes = {}
    for spec in args.shapes:
        shape = load_shape(spec)
        shapes[shape.name] = sample_shape(shape, args.points)
    with tqdm(total=args.evaluations, desc="tuning", unit="eval", disable=not sys.stderr.isatty(),
              leave=False) as bar:
        result = tune_output_terms(table, shapes, limits, args.contour_tol_um, servo=servo,
                                   max_evaluations=args.evaluations, name=args.name,
                                   progress=lambda: bar.update(1))
    print(f"tuning {table.name!r} on {', '.join(shapes)}: F = {limits.feed_mm_min:g} mm/min, contour "
          f"tolerance {args.contour_tol_um:g} um, servo {servo.describe()}")
    for line in result.lines(args.contour_tol_um):
        print(f"  {line}")
    print("  feed terms (peak %): " + ", ".join(f"{t.label} {t.points[1]:.1f}" for t in result.table.feed.terms))
    save_rule_table(result.table, out)
    print(f"wrote {out}")
    return 0 if result.feasible else 1
