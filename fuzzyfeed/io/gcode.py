"""G-code in one import: the program model and its reader, the writers, the cuts as shapes.

- :mod:`fuzzyfeed.program.model`: the program model (lines, modal state, moves, cuts).
- :mod:`fuzzyfeed.program.read`: the reader (whole programs, LinuxCNC dialect).
- :mod:`fuzzyfeed.program.rewrite`: the program written back with advised F words.
- :mod:`fuzzyfeed.program.write`: a feed profile as a ``G1`` program (shapes).
- :mod:`fuzzyfeed.program.g52`: a NURBS as LinuxCNC ``G5.2`` blocks.
- :mod:`fuzzyfeed.io.gcode_paths`: a program's cuts as shapes.
"""

from fuzzyfeed.program.g52 import (check_g52_curve, linuxcnc_knots, nurbs_gcode_program,
                                      write_gcode_nurbs)
from fuzzyfeed.program.read import parse_program, read_program
from fuzzyfeed.io.gcode_paths import (ARC_TOLERANCE_MM, NURBS_IMPORT_POINTS_PER_SPAN, load_gcode,
                                       load_gcode_shapes)
from fuzzyfeed.program.write import (DEFAULT_DECIMALS, DEFAULT_FEED_DECIMALS, GcodeProgram,
                                      gcode_program, quantise_feed_mm_min, segment_feeds_mm_s,
                                      write_gcode)
from fuzzyfeed.program.model import GCODE_SUFFIXES, MM_PER_INCH, Program
from fuzzyfeed.geometry.nurbs import bezier_segments, insert_knot

__all__ = ["ARC_TOLERANCE_MM", "DEFAULT_DECIMALS", "DEFAULT_FEED_DECIMALS", "GCODE_SUFFIXES",
           "MM_PER_INCH", "NURBS_IMPORT_POINTS_PER_SPAN", "GcodeProgram", "Program",
           "bezier_segments", "check_g52_curve", "gcode_program", "insert_knot", "linuxcnc_knots",
           "load_gcode", "load_gcode_shapes", "nurbs_gcode_program", "parse_program",
           "quantise_feed_mm_min", "read_program", "segment_feeds_mm_s", "write_gcode",
           "write_gcode_nurbs"]
