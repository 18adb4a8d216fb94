"""``fuzzyfeed advise PROGRAM.ngc``'s own flags: ``--tool-table`` and ``--tool-units`` (the work is
the library's, :mod:`fuzzyfeed.advice.program`)."""

from __future__ import annotations

import argparse

from fuzzyfeed.advice.program import ADVICE_COLUMNS  # noqa: F401  (the CSV of a program's advice)


def add_program_arguments(parser: argparse.ArgumentParser) -> None:
    """``--tool-table`` and ``--tool-units`` (the tool diameters cutter compensation needs) and
    ``--verify-rs274``."""
    parser.add_argument("--tool-table", metavar="FILE", default=None,
                        help="G-code programs: a LinuxCNC tool table (T1 P1 D6.0 Z0.5 ...); with it "
                             "moves under G41/G42 are advised on the tool centre's path, LinuxCNC's "
                             "way (without it, the programmed contour, with a notice)")
    parser.add_argument("--tool-units", choices=("mm", "inch"), default="mm",
                        help="length units of the tool table's diameters, the machine's units "
                             "(default: %(default)s; LinuxCNC's stand-alone rs274 reads inch)")
    parser.add_argument("--verify-rs274", action="store_true",
                        help="G-code programs: read the rewritten program with LinuxCNC's rs274 (on "
                             "PATH) and the same tool table; lines whose rewrite it refuses or whose "
                             "moves it changes keep their text, and the summary names them")
