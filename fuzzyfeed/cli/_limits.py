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
    """``--approach`` (the SLW scheduler's short-block profile), the same on schedule and compare."""
    parser.add_argument("--approach", type=int, choices=(1, 2), default=2,
                        help="SLW short blocks (seed 000 Table 1, types 2-3): 2 rises to a peak "
                             "between the two transitions (faster); 1 cruises at the higher end feed "
                             "(the paper's choice, smoother) (default: %(default)s)")


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


def slowest_limit(length_mm: float, limits: MachineLimits) -> tuple[str, float]:
    """The flag whose limit alone makes a rest-to-rest run over ``length_mm`` longest, and that
    time (s): L / min(F, |V|) at the feed or the axes' velocities, 2·√(L / |A|) at the axes'
    accelerations together, (32·L / J)^(1/3) at the tangential jerk J (the bang-bang jerk
    profile). Each is a lower bound on any schedule's time."""
    import numpy as np

    vel = min(limits.feed_mm_s, float(np.linalg.norm(limits.axis_vel_mm_s)))
    bounds = {
        "--feed-mm-min" if limits.feed_mm_s <= vel else "--axis-vel-mm-s": length_mm / vel,
        "--axis-acc-mm-s2": 2.0 * float(np.sqrt(length_mm / np.linalg.norm(limits.axis_acc_mm_s2))),
        "--jerk-mm-s3": float(np.cbrt(32.0 * length_mm / limits.jerk_mm_s3)),
    }
    flag = max(bounds, key=bounds.get)
    return flag, bounds[flag]


def check_schedule_work(where: str, length_mm: float, limits: MachineLimits) -> None:
    """Refuse, before any work, limits under which the path needs more servo periods than the
    scheduler's budget whatever it does (see :func:`slowest_limit`), naming the flag."""
    from fuzzyfeed.errors import MachineLimitsError
    from fuzzyfeed.slw.trajectory import MAX_TICKS

    flag, time_s = slowest_limit(length_mm, limits)
    if time_s / limits.ts_s > MAX_TICKS:
        value = {"--feed-mm-min": f"{limits.feed_mm_min:g} mm/min", "--jerk-mm-s3": f"{limits.jerk_mm_s3:g} mm/s^3",
                 "--axis-vel-mm-s": f"{limits.axis_vel_mm_s} mm/s",
                 "--axis-acc-mm-s2": f"{limits.axis_acc_mm_s2} mm/s^2"}[flag]
        raise MachineLimitsError(f"{flag} {value}: the path of {length_mm:.6g} mm needs at least "
                                 f"{time_s:.4g} s = {time_s / limits.ts_s:.4g} servo periods at this "
                                 f"limit (more than {MAX_TICKS:.0e}); raise {flag}")


def schedule_error(where: str, exc: Exception, length_mm: float, limits: MachineLimits) -> str:
    """The scheduler's one-line refusal prefixed with the file and, when it ran out of servo
    periods, the flag whose limit is slowest on this path."""
    text = f"{where}: {exc}"
    if "servo periods" in str(exc):
        flag, time_s = slowest_limit(length_mm, limits)
        text += f" (the slowest limit here is {flag}: at least {time_s:.4g} s alone)"
    return text
