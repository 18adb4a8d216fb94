"""The ``fuzzyfeed`` command line: one module per subcommand, each with ``register(subparsers)``.

Errors fuzzyfeed raises on purpose (and unreadable/unwritable files) print one line,
``fuzzyfeed: error: ...``, and exit with code 2; argparse does the same for bad arguments (one
line, no usage block). Every command runs inside one output transaction
(:class:`fuzzyfeed.base.outputs.OutputSet`): its output flags are checked before any work, and its
files appear together at the end or not at all (error, Ctrl-C, SIGTERM, SIGHUP).
Only the subcommand named on the command line is built in full (its module imported, its
arguments registered); the others are listed by name and help line. Plotting, dataframe and
compiled-kernel libraries are imported inside the commands that need them, so ``fuzzyfeed
--version`` and ``--help`` stay fast and each command loads only what it uses.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import sys
from collections.abc import Iterable

from fuzzyfeed import __version__
from fuzzyfeed.errors import FuzzyfeedError

#: Subcommands (module ``fuzzyfeed.cli.<name>``) in the order ``--help`` lists them, with their help line.
COMMANDS = {
    "shapes": "list the shipped shapes",
    "plot": "draw a shape coloured by curvature to PNG",
    "advise": "advise the feed along a shape, a drawing or a G-code program (fuzzy controller, seed 002)",
    "batch": "advise every program and drawing of a library on Dask (one machine or a cluster)",
    "rules": "show, check, edit or draw a fuzzy rule table",
    "design": "edit a rule table interactively in the browser",
    "schedule": "schedule a jerk-limited feed with the SLW look-ahead (seed 000)",
    "compare": "compare fuzzy advice, SLW schedule, constant feed and the bound",
    "tune": "tune a rule table's feed terms for cycle time under a contour tolerance",
    "machines": "list or check machine files; import one from a LinuxCNC INI or GRBL $$ settings",
    "filter": "a LinuxCNC [FILTER] program: the advised program on stdout, progress on stderr",
}

DESCRIPTION = """\
Feedrate advice along NURBS tool paths.

Units: lengths in mm, curvature in 1/mm, time in s; feeds are given and written in mm/min
(F words, CSV column feed_mm_min), machine limits in mm/s, mm/s^2 and mm/s^3.
SHAPE is a shipped shape's name (see `fuzzyfeed shapes`) or a path to a shape file.
"""


#: Arguments that name output files (attribute, flag) and input files (attribute, name in messages).
OUTPUT_ARGS = (("output", "-o"), ("plot", "--plot"), ("gcode", "--gcode"), ("gcode_g52", "--gcode-g52"),
               ("report", "--report"), ("split_out", "--split-out"))
INPUT_ARGS = (("shape", "SHAPE"), ("rules", "--rules"), ("table", "TABLE"), ("tables", "TABLE"),
              ("machine", "--machine"), ("tool_table", "--tool-table"), ("settings", "FILE"), ("hal", "--hal"),
              ("program", "PROGRAM"))


class ArgumentParser(argparse.ArgumentParser):
    """argparse with one-line errors: ``fuzzyfeed: error: <message>`` and exit code 2, no usage."""

    def error(self, message: str):
        message = " ".join(str(message).split())
        command = self.prog.split(" ", 1)[1] + ": " if " " in self.prog else ""
        self.exit(2, f"fuzzyfeed: error: {command}{message}\n")


def build_parser(full: Iterable[str] = tuple(COMMANDS)) -> argparse.ArgumentParser:
    """The parser with the subcommands named in ``full`` built in full (default: all) and the others
    by name and help line only, which is all ``fuzzyfeed --help`` shows."""
    parser = ArgumentParser(prog="fuzzyfeed", description=DESCRIPTION,
                            formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"fuzzyfeed {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, help_line in COMMANDS.items():
        if name in full:
            importlib.import_module(f"fuzzyfeed.cli.{name}").register(sub)
        else:
            sub.add_parser(name, help=help_line)
    return parser


def _command(argv: list[str]) -> list[str]:
    """The subcommand the command line names (its first word that is not an option), if known."""
    first = next((word for word in argv if not word.startswith("-")), None)
    return [first] if first in COMMANDS else []


def _outputs_and_inputs(args: argparse.Namespace) -> tuple[list, list]:
    outputs = [(flag, getattr(args, attr)) for attr, flag in OUTPUT_ARGS if getattr(args, attr, None) is not None]
    if getattr(args, "csv_sidecar", False) and getattr(args, "output", None):
        from fuzzyfeed.io.csv import metadata_path

        sidecar = metadata_path(args.output)
        if sidecar is not None:  # the CSV's provenance sidecar is part of the same transaction
            outputs.append(("-o (its sidecar)", sidecar))
    inputs = []
    for attr, label in INPUT_ARGS:
        value = getattr(args, attr, None)
        for item in value if isinstance(value, list) else [value]:
            if item:
                inputs.append((label, item))
    return outputs, inputs


def _error_line(exc: BaseException, args: argparse.Namespace) -> str:
    if isinstance(exc, FuzzyfeedError):
        message = str(exc)
    elif isinstance(exc, OSError):
        message = f"{exc.filename}: {exc.strerror}" if exc.filename else (exc.strerror or str(exc))
    else:  # MemoryError, RecursionError: an input too big or too deep that no check caught
        what = getattr(args, "shape", None) or getattr(args, "rules", None) or getattr(args, "command", "")
        kind = "too large to process (out of memory)" if isinstance(exc, MemoryError) else \
            "too deeply nested to process"
        message = f"{what}: {kind}"
    return "fuzzyfeed: error: " + " ".join(message.split())


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(_command(argv))
    args = parser.parse_args(argv)          # --version and --help end here
    from fuzzyfeed.base.outputs import OutputSet, Terminated
    from fuzzyfeed.cli._common import shape_context

    try:
        outputs, inputs = _outputs_and_inputs(args)
        transaction = OutputSet(outputs, inputs, stdout=sys.stdout)
        # with an output on standard output, the command's own messages go to stderr
        quiet = contextlib.redirect_stdout(sys.stderr) if any(p == "-" for _, p in outputs) else \
            contextlib.nullcontext()
        with transaction, quiet, shape_context(args):
            result = args.run(args)
    except (FuzzyfeedError, OSError, MemoryError, RecursionError) as exc:
        print(_error_line(exc, args), file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("fuzzyfeed: interrupted; no output written", file=sys.stderr)
        return 130
    except Terminated as exc:
        print(f"fuzzyfeed: terminated by {exc.signal_name}; no output written", file=sys.stderr)
        return int(exc.code)
    return int(result or 0)
