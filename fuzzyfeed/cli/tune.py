"""``fuzzyfeed tune``: move a rule table's feed terms to cut cycle time under a contour tolerance."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from fuzzyfeed.cli import COMMANDS
from fuzzyfeed.cli._common import count_at_least, point_count, positive_float
from fuzzyfeed.cli._limits import add_limit_arguments, limits_from_args
from fuzzyfeed.cli._machine import machine_from_args
from fuzzyfeed.cli._servo import servo_from_args

DESCRIPTION = """\
Programs (a folder of G-code files, searched recursively, or files): tune the machine table on a
machine (--machine, machine flags; default the reference machine): the library is split, seeded
(--holdout, --seed), the output's safety in three bands of the near ratio is raised as far as every
tuning program still holds the contour tolerance, and both parts are reported before and after.

Shapes: tune the output (feed) terms of a rule table (seed 002's future work): keep the rule grid and the
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
    p = sub.add_parser("tune", help=COMMANDS["tune"],
                       description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("shapes", nargs="+", metavar="SHAPE|PROGRAMS",
                   help="shapes to tune a paper table on (names or files), or G-code programs and folders "
                        "of them (searched recursively) to tune the machine table on, on a machine")
    p.add_argument("--rules", metavar="FILE", default=None,
                   help="rule table to start from (default: the paper's table, rules/paper.toml)")
    p.add_argument("--evaluations", type=evaluation_count, default=120, metavar="N",
                   help="simulation rounds (all shapes each) the search may use (default: %(default)s)")
    p.add_argument("--points", type=point_count, default=2000,
                   help="sample points per shape, uniform in u (default: %(default)s)")
    p.add_argument("--name", default=None, help="name of the tuned table (default: <table>-tuned)")
    add_limit_arguments(p)
    p.add_argument("-o", "--output", required=True, metavar="TUNED.toml", help="new rule-table file to write")
    g = p.add_argument_group("a library of programs")
    g.add_argument("--holdout", type=_fraction, default=0.3, metavar="FRACTION",
                   help="part of the programs kept out of the tuning and reported apart (default: %(default)s)")
    g.add_argument("--seed", type=int, default=1, help="seed of the split (default: %(default)s)")
    g.add_argument("--max-written-s", type=positive_float, default=None, metavar="S",
                   help="leave out programs that take longer than S seconds as written on the machine "
                        "(each tuning round runs every program)")
    g.add_argument("--split-out", metavar="SPLIT.json", default=None,
                   help="also write the split (tuning and held-out programs) and every program's "
                        "result as JSON (benchmarks/bench_value.py --split reads it)")
    p.set_defaults(run=run)


def _fraction(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0.0 <= value < 1.0:
        raise argparse.ArgumentTypeError(f"{text!r} must be a fraction from 0 to below 1")
    return value


def _is_library(specs: list[str]) -> bool:
    from fuzzyfeed.program.model import GCODE_SUFFIXES

    return any(Path(s).is_dir() or Path(s.split("#")[0]).suffix.lower() in GCODE_SUFFIXES for s in specs)


def run_library(args: argparse.Namespace, out: Path) -> int:
    """Tune the machine table on programs (module :mod:`fuzzyfeed.report.tune_programs`)."""
    import json
    import shlex

    from tqdm import tqdm

    from fuzzyfeed.base.atomic import atomic_write
    from fuzzyfeed.errors import FuzzyfeedError, InputError
    from fuzzyfeed.fuzzy.rule_writer import save_rule_table
    from fuzzyfeed.program.read import read_program
    from fuzzyfeed.report.tune_programs import library_files, split_record, tune_on_programs

    if args.rules is not None:
        raise InputError("--rules: a library of programs tunes the machine table's safety; leave --rules out")
    machine = machine_from_args(args, always=True)
    files = library_files(args.shapes)
    root = Path(*Path(files[0]).resolve().parts[:1]) if files else Path(".")
    programs, skipped = {}, []
    for f in files:
        try:
            prog = read_program(f)
        except (FuzzyfeedError, OSError) as exc:
            skipped.append(f"{f}: {' '.join(str(exc).split())[:120]}")
            continue
        if not prog.n_cuts:
            skipped.append(f"{f}: no feed move to advise")
            continue
        if args.max_written_s is not None:
            from fuzzyfeed.machine.plan_windows import planned_time
            from fuzzyfeed.program.run import program_path

            # each chain's planned time window by window (bit for bit plan_motion's), no whole plan
            planned = sum(planned_time(c.motion, machine) for c in program_path(prog, machine.chord_tol_mm).chains)
            if planned > args.max_written_s:
                skipped.append(f"{f}: {planned:.0f} s as written, over --max-written-s {args.max_written_s:g}")
                continue
        programs[str(f)] = prog
    del root
    if len(programs) < 2:
        raise InputError(f"{' '.join(args.shapes)}: {len(programs)} program(s) fuzzyfeed can advise; tuning "
                         "on a library needs at least 2")
    command = "fuzzyfeed tune " + " ".join(shlex.quote(a) for a in sys.argv[2:]) if sys.argv[1:2] == ["tune"] \
        else "fuzzyfeed tune (library)"
    name = args.name or out.stem
    source = (f"machine table tuned for machine {machine.name!r} ({machine.contour_tol_um:g} um) on "
              f"{len(programs)} programs less the share {args.holdout:g} held out (seed {args.seed}; the "
              f"split file lists both parts): {command}")
    bar = tqdm(desc="tuning", unit="round", disable=not sys.stderr.isatty(), leave=False)
    with bar:
        result = tune_on_programs(programs, machine, args.holdout, args.seed, name=name, source=source,
                                  progress=lambda: bar.update(1))
    print(f"tuning the machine table on {len(result.tuning)} programs, {len(result.held_out)} held out; "
          f"{machine.describe()}")
    for line in result.lines(machine.contour_tol_um):
        print(f"  {line}")
    for line in skipped:
        print(f"  skipped {line}")
    save_rule_table(result.table, out)
    if args.split_out:
        with atomic_write(args.split_out, "w") as handle:
            json.dump(split_record(result, machine, args.holdout, args.seed, command), handle, indent=1)
    print(f"wrote {out}" + (f" and {args.split_out}" if args.split_out else ""))
    return 0


def run(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from fuzzyfeed.errors import InputError
    from fuzzyfeed.fuzzy.rule_reader import load_rule_table
    from fuzzyfeed.fuzzy.rule_writer import save_rule_table
    from fuzzyfeed.fuzzy.tune import tune_output_terms
    from fuzzyfeed.io.shapes import load_shape, sample_shape

    out = Path(args.output)
    if out.exists():
        raise InputError(f"{out}: file exists; tune writes a new file (remove it or choose another name)")
    if _is_library(args.shapes):
        return run_library(args, out)
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
