"""The ``fuzzyfeed`` command line: one module per subcommand, each with ``register(subparsers)``.

Errors fuzzyfeed raises on purpose (and unreadable/unwritable files) print one line,
``fuzzyfeed: error: ...``, and exit with code 2; argparse does the same for bad arguments (one
line, no usage block). Every command runs inside one output transaction
(:class:`fuzzyfeed.base.outputs.OutputSet`): its output flags are checked before any work, and its
files appear together at the end or not at all (error, Ctrl-C, SIGTERM, SIGHUP).
Plotting and dataframe libraries are imported inside the commands that need them, so
``fuzzyfeed --version`` and ``--help`` stay fast.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import sys

from fuzzyfeed import __version__
from fuzzyfeed.errors import FuzzyfeedError

#: Subcommand modules in the order ``--help`` lists them.
COMMANDS = ("shapes", "plot", "advise", "batch", "rules", "design", "schedule", "compare", "tune")

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
              ("machine", "--machine"), ("tool_table", "--tool-table"))


class ArgumentParser(argparse.ArgumentParser):
    """argparse with one-line errors: ``fuzzyfeed: error: <message>`` and exit code 2, no usage."""

    def error(self, message: str):
        message = " ".join(str(message).split())
        command = self.prog.split(" ", 1)[1] + ": " if " " in self.prog else ""
        self.exit(2, f"fuzzyfeed: error: {command}{message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = ArgumentParser(prog="fuzzyfeed", description=DESCRIPTION,
                            formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"fuzzyfeed {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        importlib.import_module(f"fuzzyfeed.cli.{name}").register(sub)
    return parser


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
    from fuzzyfeed.base.outputs import OutputSet, Terminated

    parser = build_parser()
    args = parser.parse_args(argv)
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
