"""The axis servo flags (contour error): gains, feed-forward, an optional second-order loop."""

from __future__ import annotations

import argparse
import math

from fuzzyfeed.cli._common import positive_float
from fuzzyfeed.machine.servo import DEFAULT_KV_1_S, ServoModel


def _fraction(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value) or not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"{text!r} must be a fraction between 0 and 1")
    return value


def _per_axis(kind):
    def parse(text: str) -> float | tuple[float, ...]:
        parts = [p.strip() for p in text.split(",")]
        if len(parts) not in (1, 3):
            raise argparse.ArgumentTypeError(f"{text!r}: give one number for all axes or three as X,Y,Z")
        values = tuple(kind(p) for p in parts)
        return values[0] if len(values) == 1 else values
    return parse


def add_servo_arguments(parser: argparse.ArgumentParser) -> None:
    """Add --servo-kv-1-s | --servo-kv-m-min-mm | --servo-natural-freq-hz, --servo-damping, --servo-ff."""
    g = parser.add_argument_group(
        "axis servo (contour error)",
        "Each axis follows its set-points through a position loop x' = Kv (x_cmd - x) + ff x'_cmd "
        "(or a second-order loop); the contour error is the distance of the actual position from "
        "the path at every tick. Given, these replace the machine file's [servo].")
    gain = g.add_mutually_exclusive_group()
    gain.add_argument("--servo-kv-1-s", type=_per_axis(positive_float), default=None, metavar="KV",
                      help=f"position-loop gain in 1/s, one value or X,Y,Z (default: {DEFAULT_KV_1_S:g})")
    gain.add_argument("--servo-kv-m-min-mm", type=_per_axis(positive_float), default=None, metavar="KV",
                      help="the same gain in Heidenhain's unit, m/min per mm of following error "
                           "(1 m/min/mm = 16.67 1/s)")
    gain.add_argument("--servo-natural-freq-hz", type=_per_axis(positive_float), default=None, metavar="FN",
                      help="a second-order loop of this natural frequency in Hz (gain 2 pi FN / (2 damping))")
    g.add_argument("--servo-damping", type=_per_axis(positive_float), default=None, metavar="ZETA",
                   help="damping ratio of the second-order loop (default: 0.7)")
    g.add_argument("--servo-ff", type=_per_axis(_fraction), default=None, metavar="FF",
                   help="velocity feed-forward fraction 0..1, one value or X,Y,Z (default: 0)")


def servo_flags_given(args: argparse.Namespace) -> bool:
    return any(getattr(args, n, None) is not None for n in
               ("servo_kv_1_s", "servo_kv_m_min_mm", "servo_natural_freq_hz", "servo_damping", "servo_ff"))


def servo_from_args(args: argparse.Namespace, machine=None) -> ServoModel:
    """The validated :class:`ServoModel` of parsed servo flags; without any, the ``machine``'s
    servo (or the default loop)."""
    if not servo_flags_given(args) and machine is not None:
        return machine.servo
    ff = 0.0 if args.servo_ff is None else args.servo_ff
    damping = 0.7 if args.servo_damping is None else args.servo_damping
    if args.servo_natural_freq_hz is not None:
        return ServoModel(natural_freq_hz=args.servo_natural_freq_hz, damping=damping, feedforward=ff)
    if args.servo_damping is not None:
        from fuzzyfeed.errors import MachineLimitsError
        raise MachineLimitsError("--servo-damping: belongs to a second-order loop; give "
                                 "--servo-natural-freq-hz with it")
    if args.servo_kv_m_min_mm is not None:
        return ServoModel.from_kv_m_min_mm(args.servo_kv_m_min_mm, feedforward=ff)
    return ServoModel(kv_1_s=args.servo_kv_1_s, feedforward=ff)
