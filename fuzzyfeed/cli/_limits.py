"""The machine-limit flags, the same on every subcommand that takes limits."""

from __future__ import annotations

import argparse

from fuzzyfeed.cli._common import positive_float
from fuzzyfeed.machine.limits import (DEFAULT_AXIS_ACC_MM_S2, DEFAULT_AXIS_VEL_MM_S, DEFAULT_CHORD_TOL_MM,
                              DEFAULT_FEED_MM_S, DEFAULT_JERK_MM_S3, DEFAULT_TS_S, MachineLimits)


def axis_values(text: str) -> float | tuple[float, ...]:
    """argparse type: one positive number for all axes, or three comma-separated (x,y,z)."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) not in (1, 3):
        raise argparse.ArgumentTypeError(f"{text!r}: give one number for all axes or three as X,Y,Z")
    values = tuple(positive_float(p) for p in parts)
    return values[0] if len(values) == 1 else values


def add_limit_arguments(parser: argparse.ArgumentParser) -> None:
    """Add --feed-mm-min, --axis-vel-mm-s, --axis-acc-mm-s2, --jerk-mm-s3, --chord-tol-mm, --ts-s."""
    g = parser.add_argument_group("machine limits")
    g.add_argument("--feed-mm-min", type=positive_float, default=DEFAULT_FEED_MM_S * 60.0, metavar="F",
                   help="command feed in mm/min (default: %(default)g)")
    g.add_argument("--axis-vel-mm-s", type=axis_values, default=DEFAULT_AXIS_VEL_MM_S, metavar="V",
                   help="axis velocity limit in mm/s, one value or X,Y,Z (default: %(default)g)")
    g.add_argument("--axis-acc-mm-s2", type=axis_values, default=DEFAULT_AXIS_ACC_MM_S2, metavar="A",
                   help="axis acceleration limit in mm/s^2, one value or X,Y,Z (default: %(default)g)")
    g.add_argument("--jerk-mm-s3", type=positive_float, default=DEFAULT_JERK_MM_S3, metavar="J",
                   help="tangential jerk limit in mm/s^3 (default: %(default)g)")
    g.add_argument("--chord-tol-mm", type=positive_float, default=DEFAULT_CHORD_TOL_MM, metavar="D",
                   help="chord error tolerance in mm (default: %(default)g)")
    g.add_argument("--ts-s", type=positive_float, default=DEFAULT_TS_S, metavar="T",
                   help="servo (interpolation) period in s (default: %(default)g)")


def add_approach_argument(parser: argparse.ArgumentParser) -> None:
    """``--approach`` (the SLW scheduler's short-block profile) and ``--transition`` (the shape of
    its feed changes), the same on schedule and compare."""
    parser.add_argument("--approach", type=int, choices=(1, 2), default=2,
                        help="SLW short blocks (seed 000 Table 1, types 2-3): 2 rises to a peak "
                             "between the two transitions (faster); 1 cruises at the higher end feed "
                             "(the paper's choice, smoother) (default: %(default)s)")
    parser.add_argument("--transition", choices=("seven-phase", "cosine"), default="seven-phase",
                        help="SLW feed changes: seven-phase (trapezoidal acceleration, jerk J all "
                             "through its ramps; faster) or cosine (seed 000's; with --approach 1 the "
                             "paper's scheduler) (default: %(default)s)")


def limits_from_args(args: argparse.Namespace) -> MachineLimits:
    """The validated :class:`MachineLimits` of parsed limit flags (MachineLimitsError if invalid)."""
    return MachineLimits(feed_mm_s=args.feed_mm_min / 60.0, axis_vel_mm_s=args.axis_vel_mm_s,
                         axis_acc_mm_s2=args.axis_acc_mm_s2, jerk_mm_s3=args.jerk_mm_s3,
                         chord_tol_mm=args.chord_tol_mm, ts_s=args.ts_s)


def program_feed_limits(shape, limits: MachineLimits):
    """A cut of a G-code program runs at the program's own F words (DESIGN, "Feeds in a
    program": the F a program has at a place is the ceiling there), each capped by
    ``--feed-mm-min``. Returns (limits with that command feed: the highest of them; the feed cap
    as (s_mm, feed_mm_s) or None; one line saying so, or None). Other shapes run at
    ``--feed-mm-min`` unchanged."""
    from dataclasses import replace

    import numpy as np

    from fuzzyfeed.errors import PathFormatError
    from fuzzyfeed.program.model import NO_FEED_RULE

    if shape.programmed_feed is None:
        return limits, None, None
    s, f_mm_min = (np.asarray(a, dtype=float) for a in shape.programmed_feed)
    if not (f_mm_min > 0).all():
        raise PathFormatError(f"{shape.source}: {NO_FEED_RULE}")
    capped = np.minimum(f_mm_min, limits.feed_mm_min)
    low, high = float(capped.min()), float(capped.max())
    words = f"F{low:g}" if low == high else f"F{low:g}-F{high:g}"
    note = f"feed              the program's {words} mm/min"
    if f_mm_min.max() > limits.feed_mm_min:
        note += f" (F words above --feed-mm-min {limits.feed_mm_min:g} capped to it)"
    return replace(limits, feed_mm_s=high / 60.0), (s, capped / 60.0), note
