"""``fuzzyfeed batch DIR_OR_GLOB... --out RESULTS_DIR [advise options]``: every program and drawing
of a library advised on Dask, each exactly as ``fuzzyfeed advise FILE -o OUT.csv --gcode OUT.ngc``
would: the advise options are made into one :class:`~fuzzyfeed.advice.options.AdviceOptions` here,
as ``advise`` makes them, and :func:`fuzzyfeed.batch.library.advise_library` does the rest."""

from __future__ import annotations

import argparse
import copy
import functools
import sys

from fuzzyfeed.cli import COMMANDS
from fuzzyfeed.cli._common import count_at_least

#: advise's arguments that name one file; batch makes them per file under RESULTS_DIR.
PER_FILE = frozenset({"help", "shape", "output", "gcode", "gcode_g52", "plot", "report"})
#: Where the batch parser keeps advise's options (apart from its own).
PREFIX = "advise__"


@functools.lru_cache(maxsize=1)
def advise_command() -> argparse.ArgumentParser:
    """The advise command's parser, as :mod:`fuzzyfeed.cli.advise` registers it (built once per
    process), whose options batch offers."""
    from fuzzyfeed.cli import ArgumentParser, advise

    parser = ArgumentParser(prog="fuzzyfeed")
    sub = parser.add_subparsers(dest="command")
    advise.register(sub)
    return sub.choices["advise"]


def forwarded_actions() -> list[argparse.Action]:
    """advise's options that batch passes to every file (all but those naming one file)."""
    return [a for a in advise_command()._actions if a.option_strings and a.dest not in PER_FILE]


def options_from_args(args: argparse.Namespace):
    """The batch's advise options as one :class:`~fuzzyfeed.advice.options.AdviceOptions`, made as
    ``fuzzyfeed advise`` makes its own (:func:`fuzzyfeed.cli.advise.options_from_args`)."""
    from fuzzyfeed.cli.advise import options_from_args as advise_options

    values = {a.dest: getattr(args, PREFIX + a.dest) for a in forwarded_actions()}
    return advise_options(argparse.Namespace(**values))


def register(sub) -> None:
    p = sub.add_parser(
        "batch", help=COMMANDS["batch"],
        description="Find every G-code program (.ngc, .nc, .gcode, .gc, .tap, .cnc) and DXF drawing "
                    "under DIR_OR_GLOB (folders searched recursively) and advise each exactly as "
                    "`fuzzyfeed advise FILE -o REL.csv --gcode REL` would, into RESULTS_DIR at the "
                    "same relative path REL: the advised program REL, REL.csv with its sidecar "
                    "(drawings: the CSV of every contour, no program), REL.png with --plots, the "
                    "value report REL.report.html with a machine and --reports html. "
                    "A refused or failing file is recorded with its reason and the batch goes on "
                    "(exit code 1 if any file failed). RESULTS_DIR/.manifest/ keeps the SHA-256 of "
                    "each input, of the options and the version: a rerun skips files whose three "
                    "are unchanged (--force redoes them). RESULTS_DIR/summary.csv and summary.html "
                    "summarise the run. Ctrl-C stops, keeping the finished files.")
    p.add_argument("inputs", nargs="+", metavar="DIR_OR_GLOB",
                   help="folders (searched recursively), glob patterns (quote them; ** reaches into "
                        "sub-folders) or files")
    p.add_argument("--out", required=True, metavar="RESULTS_DIR",
                   help="folder for the results (created; never one of the input folders)")
    p.add_argument("--workers", type=count_at_least(1, "workers", 4096), default=None, metavar="N",
                   help="worker processes of the local Dask cluster (default: one per core)")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT", default=None,
                   help="run on an existing Dask cluster instead (`dask scheduler` and `dask worker "
                        "tcp://HOST:PORT --nthreads 1` on each machine); its workers need the same "
                        "fuzzyfeed version and the inputs and RESULTS_DIR at the same paths")
    p.add_argument("--force", action="store_true", help="advise every file again, even unchanged ones")
    p.add_argument("--plots", action="store_true",
                   help="also draw each program's feed (advise --plot) as REL.png")
    p.add_argument("--reports", choices=("html", "csv"), default=None,
                   help="with a machine: also write each program's value report (advise --report) as "
                        "REL.report.html or REL.report.csv")
    group = p.add_argument_group("advise options, given to every file (see `fuzzyfeed advise --help`; "
                                 "--units, --points and --rule-strengths reach drawings only, --step-mm, "
                                 "--no-reference and the G-code options programs only)")
    for action in forwarded_actions():
        mine = copy.copy(action)
        mine.dest = PREFIX + action.dest
        group._add_action(mine)
    for action in advise_command()._actions:   # named per file by the batch: refused, not mistaken
        if action.option_strings and action.dest in PER_FILE - {"help"}:    # for --gcode-decimals
            p.add_argument(*action.option_strings, action=_PerFile, nargs=action.nargs, help=argparse.SUPPRESS)
    p.set_defaults(run=run)


class _PerFile(argparse.Action):
    """An advise option that names one output file: the batch names them for every file."""

    def __call__(self, parser, namespace, values, option_string=None):
        parser.error(f"{option_string}: the batch writes every file's results itself (REL.csv, the "
                     "advised program REL, REL.png with --plots, REL.report.html with --reports html) "
                     "under --out RESULTS_DIR; leave it out")


def run(args: argparse.Namespace) -> int:
    """The command: the batch, its failures one line each, the totals; exit 0 when every file was
    advised, 1 when some were not, 130 (143) when Ctrl-C (SIGTERM) stopped it."""
    from fuzzyfeed.batch.library import advise_library

    frame = advise_library(args.inputs, args.out, options_from_args(args), workers=args.workers,
                           scheduler=args.scheduler, force=args.force, plots=args.plots, reports=args.reports)
    failed = frame[frame["status"].isin(("refused", "failed"))]
    for row in failed.head(20).itertuples():
        print(f"{row.status}: {row.file}: {row.reason}")
    if len(failed) > 20:
        print(f"... and {len(failed) - 20} more (see summary.csv)")
    ok = frame[frame["status"] == "ok"]
    tally = ", ".join(f"{k} {v}" for k, v in frame["status"].value_counts().items())
    how = "as the machine runs them" if "contour_tol_um" in frame.columns else "feed moves, no acceleration"
    print(f"{len(frame)} files: {tally}; advised programs and drawings: {ok['time_written_s'].sum():.1f} s "
          f"as written, {ok['time_advised_s'].sum():.1f} s advised ({how})")
    print(f"wrote {' and '.join(frame.attrs['summary'])}")
    stopped = frame.attrs.get("interrupted")
    if stopped:
        print(f"fuzzyfeed: {stopped} stopped the batch; finished files are kept, run the same command "
              "again to go on", file=sys.stderr)
        return 143 if stopped == "SIGTERM" else 130
    return 1 if len(failed) or (frame["status"] != "ok").any() else 0
