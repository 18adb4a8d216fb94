"""The command feed and machine-limit flags of the subcommands that schedule (see :mod:`._machine`)."""

from __future__ import annotations

import argparse

from fuzzyfeed.cli._common import positive_float
from fuzzyfeed.cli._machine import add_machine_arguments, machine_from_args
from fuzzyfeed.machine.limits import DEFAULT_CHORD_TOL_MM, DEFAULT_FEED_MM_S, MachineLimits


def add_limit_arguments(parser: argparse.ArgumentParser) -> None:
    """Add --feed-mm-min and the machine flags (``--machine`` and one flag per field, servo too)."""
    g = parser.add_argument_group("command feed")
    g.add_argument("--feed-mm-min", type=positive_float, default=DEFAULT_FEED_MM_S * 60.0, metavar="F",
                   help="command feed in mm/min (default: %(default)g)")
    add_machine_arguments(parser)


def add_approach_argument(parser: argparse.ArgumentParser, transition: str = "cosine") -> None:
    """``--approach`` (the SLW scheduler's short-block profile) and ``--transition`` (the shape of
    its feed changes, default ``transition``: schedule's is seven-phase, compare's seed 000's
    cosine), the same on schedule and compare."""
    parser.add_argument("--approach", type=int, choices=(1, 2), default=2,
                        help="SLW short blocks (seed 000 Table 1, types 2-3): 2 rises to a peak "
                             "between the two transitions (faster); 1 cruises at the higher end feed "
                             "(the paper's choice, smoother) (default: %(default)s)")
    parser.add_argument("--transition", choices=("cosine", "seven-phase"), default=transition,
                        help="SLW feed changes: cosine (seed 000's; with --approach 1 the paper's "
                             "scheduler) or seven-phase (trapezoidal acceleration, jerk J all through "
                             "its ramps; faster on most paths) (default: %(default)s)")


def limits_from_args(args: argparse.Namespace) -> MachineLimits:
    """The validated :class:`MachineLimits` of the parsed flags: the command feed, and the machine's
    limits (its file and flags; without any, the defaults of MachineLimits)."""
    machine = machine_from_args(args)
    if machine is not None:
        # without a machine file the SLW keeps its own chord error default (1 um)
        own = getattr(args, "machine", None) or getattr(args, "chord_tol_mm", None)
        return machine.limits(args.feed_mm_min / 60.0, None if own else DEFAULT_CHORD_TOL_MM)
    return MachineLimits(feed_mm_s=args.feed_mm_min / 60.0)


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
