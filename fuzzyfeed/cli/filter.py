"""``fuzzyfeed filter --machine M PROGRAM``: a LinuxCNC ``[FILTER]`` program. AXIS (and the other
LinuxCNC GUIs) run ``<filter> PROGRAM`` when a program is opened, load what it writes on standard
output, show ``FILTER_PROGRESS=N`` (percent) lines of standard error as progress, and show the
standard error as the error when the exit code is not 0. The advised program is what
``fuzzyfeed advise PROGRAM --machine M --gcode OUT`` writes: the cuts that break the machine's
contour tolerance as written get the advised F words, the others keep theirs; a program with no
cut comes back unchanged. INI lines::

    [FILTER]
    PROGRAM_EXTENSION = .ngc,.nc,.tap G-code with fuzzyfeed's advised feeds
    ngc = fuzzyfeed filter --machine /path/to/machine.toml
"""

from __future__ import annotations

import argparse
import sys

from fuzzyfeed.cli import COMMANDS

#: evaluate_program's stages and the progress reported when each starts
STAGES = {"as written": 10, "advice": 40, "advised run": 70, "uniform slowdown": 85}


def register(sub) -> None:
    p = sub.add_parser("filter", help=COMMANDS["filter"],
                       description="Advise PROGRAM for a machine and write the advised program on "
                                   "standard output, FILTER_PROGRESS=N lines on standard error: a "
                                   "LinuxCNC [FILTER] program (see the README).")
    p.add_argument("program", metavar="PROGRAM", help="the G-code program AXIS opens")
    p.add_argument("--machine", required=True, metavar="FILE", help="a machine file or a shipped machine's name")
    from fuzzyfeed.cli._program import add_program_arguments

    add_program_arguments(p)
    p.set_defaults(run=run)


def _progress(percent: int) -> None:
    print(f"FILTER_PROGRESS={percent}", file=sys.stderr, flush=True)


def run(args: argparse.Namespace) -> int:
    from fuzzyfeed.fuzzy.rule_reader import load_rule_table
    from fuzzyfeed.fuzzy.rules import DEFAULT_MACHINE_TABLE
    from fuzzyfeed.machine.description import load_machine
    from fuzzyfeed.program.read import read_program
    from fuzzyfeed.report.value import evaluate_program

    _progress(0)
    machine = load_machine(args.machine)
    tools = None
    if args.tool_table is not None:
        from fuzzyfeed.program.tools import read_tool_table

        tools = read_tool_table(args.tool_table, args.tool_units)
    program = read_program(args.program, tools=tools)
    if program.n_cuts == 0:          # nothing to advise: the program as it is
        from pathlib import Path

        sys.stdout.flush()
        sys.stdout.buffer.write(Path(args.program).read_bytes())
        sys.stdout.buffer.flush()
        _progress(100)
        return 0
    ev = evaluate_program(program, machine, load_rule_table(DEFAULT_MACHINE_TABLE), reference=False,
                          progress=lambda stage: _progress(STAGES.get(stage, 50)))
    sys.stdout.write(ev.text)
    sys.stdout.flush()
    _progress(100)
    return 0
