"""The ``fuzzyfeed`` command line: one module per subcommand, each with ``register(subparsers)``.

Errors fuzzyfeed raises on purpose (and unreadable/unwritable files) print one line,
``fuzzyfeed: error: ...``, and exit with code 2; argparse does the same for bad arguments.
Plotting and dataframe libraries are imported inside the commands that need them, so
``fuzzyfeed --version`` and ``--help`` stay fast.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from fuzzyfeed import __version__
from fuzzyfeed.errors import FuzzyfeedError

#: Subcommand modules in the order ``--help`` lists them.
COMMANDS = ("shapes", "plot", "advise", "rules", "schedule", "compare")

DESCRIPTION = """\
Feedrate advice along NURBS tool paths.

Units: lengths in mm, curvature in 1/mm, time in s; feeds are given and written in mm/min
(F words, CSV column feed_mm_min), machine limits in mm/s, mm/s^2 and mm/s^3.
SHAPE is a shipped shape's name (see `fuzzyfeed shapes`) or a path to a shape file.
"""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="fuzzyfeed", description=DESCRIPTION,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"fuzzyfeed {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        importlib.import_module(f"fuzzyfeed.cli.{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    from fuzzyfeed.cli._common import shape_context

    try:
        with shape_context(args):
            result = args.run(args)
    except (FuzzyfeedError, OSError) as exc:
        message = str(exc) if isinstance(exc, FuzzyfeedError) or not exc.filename else (
            f"{exc.filename}: {exc.strerror}")
        print(f"fuzzyfeed: error: {message}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("fuzzyfeed: interrupted", file=sys.stderr)
        return 130
    return int(result or 0)
