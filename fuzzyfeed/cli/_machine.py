"""The machine flags, the same on every subcommand: ``--machine FILE`` and one flag per field.

A machine is *given* when ``--machine`` or any of its flags is: the file's values (or the
defaults of :class:`~fuzzyfeed.machine.description.Machine` when only flags are given) with every
flag given replacing its field. Without any, ``machine_from_args`` returns None and each command
behaves as without a machine.
"""

from __future__ import annotations

import argparse

from fuzzyfeed.cli._common import positive_float

#: args attribute -> Machine field, for the flags that override a machine file.
MACHINE_FLAGS = {
    "axis_vel_mm_s": "axis_vel_mm_s",
    "axis_acc_mm_s2": "axis_acc_mm_s2",
    "jerk_mm_s3": "jerk_mm_s3",
    "path_acc_mm_s2": "path_acc_mm_s2",
    "chord_tol_mm": "chord_tol_mm",
    "ts_s": "ts_s",
    "junction_deviation_mm": "corner_mm",
    "lookahead_moves": "lookahead_moves",
    "contour_tol_um": "contour_tol_um",
}
SERVO_FLAGS = ("servo_kv_1_s", "servo_kv_m_min_mm", "servo_natural_freq_hz", "servo_damping", "servo_ff")


def axis_values(text: str) -> float | tuple[float, ...]:
    """argparse type: one positive number for all axes, or three comma-separated (x,y,z)."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) not in (1, 3):
        raise argparse.ArgumentTypeError(f"{text!r}: give one number for all axes or three as X,Y,Z")
    values = tuple(positive_float(p) for p in parts)
    return values[0] if len(values) == 1 else values


def _lookahead(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 0 or value == 1:
        raise argparse.ArgumentTypeError(f"{value}: give at least 2 moves, or 0 for an unlimited look-ahead")
    return value


def add_machine_arguments(parser: argparse.ArgumentParser, tolerance_required: bool = False) -> None:
    """``--machine`` and the flags that override its fields (plus the servo flags)."""
    from fuzzyfeed.cli._servo import add_servo_arguments
    from fuzzyfeed.machine.description import Machine
    from fuzzyfeed.machine.limits import DEFAULT_CHORD_TOL_MM, MachineLimits

    d = Machine()
    lim = MachineLimits()
    g = parser.add_argument_group(
        "machine",
        "A machine file (--machine; shipped: reference, hobby-router, linuxcnc-mill, production-vmc) "
        "and flags that replace its fields. Defaults below are the reference machine's (issue 32).")
    g.add_argument("--machine", metavar="FILE", default=None,
                   help="machine description (TOML: axes, servo, controller corners and look-ahead, "
                        "contour tolerance): a shipped name or a file")
    g.add_argument("--axis-vel-mm-s", type=axis_values, default=None, metavar="V",
                   help=f"axis velocity limit in mm/s, one value or X,Y,Z (default: {lim.axis_vel_mm_s[0]:g})")
    g.add_argument("--axis-acc-mm-s2", type=axis_values, default=None, metavar="A",
                   help=f"axis acceleration limit in mm/s^2, one value or X,Y,Z (default: {lim.axis_acc_mm_s2[0]:g})")
    g.add_argument("--path-acc-mm-s2", type=positive_float, default=None, metavar="A",
                   help="the controller's acceleration limit along the path in mm/s^2, LinuxCNC's "
                        "[TRAJ] MAX_ACCELERATION (default: the slowest axis's)")
    g.add_argument("--jerk-mm-s3", type=positive_float, default=None, metavar="J",
                   help=f"tangential jerk limit in mm/s^3 (default: {lim.jerk_mm_s3:g})")
    g.add_argument("--chord-tol-mm", type=positive_float, default=None, metavar="D",
                   help=f"chord tolerance in mm: the SLW's chord error, and arcs followed as chords "
                        f"(default: {DEFAULT_CHORD_TOL_MM:g}; with a machine {d.chord_tol_mm:g})")
    g.add_argument("--ts-s", type=positive_float, default=None, metavar="T",
                   help=f"servo (interpolation) period in s (default: {lim.ts_s:g})")
    g.add_argument("--junction-deviation-mm", type=positive_float, default=None, metavar="D",
                   help="the controller's corner setting in mm: GRBL's junction deviation $11 (or the "
                        f"path tolerance G64 P of a machine file with corner = 'path-tolerance') "
                        f"(default: {d.corner_mm:g})")
    g.add_argument("--lookahead-moves", type=_lookahead, default=None, metavar="N",
                   help="the planner's buffer in moves, 0 for unlimited (GRBL: 16) (default: 0)")
    g.add_argument("--contour-tol-um", type=positive_float, default=None, metavar="EPS",
                   required=tolerance_required,
                   help="the contour tolerance the part must hold, in um"
                        + ("" if tolerance_required else f" (default: {d.contour_tol_um:g})"))
    add_servo_arguments(parser)


def machine_given(args: argparse.Namespace) -> bool:
    """Whether ``--machine`` or any machine or servo flag was given."""
    names = ("machine", *MACHINE_FLAGS, *SERVO_FLAGS)
    return any(getattr(args, n, None) is not None for n in names)


def machine_from_args(args: argparse.Namespace, always: bool = False):
    """The :class:`Machine` of the parsed flags, or None when none was given (unless ``always``)."""
    from dataclasses import replace

    from fuzzyfeed.cli._servo import servo_flags_given, servo_from_args
    from fuzzyfeed.machine.description import Machine, load_machine

    if not always and not machine_given(args):
        return None
    machine = load_machine(args.machine) if getattr(args, "machine", None) else Machine()
    changes = {field: getattr(args, flag) for flag, field in MACHINE_FLAGS.items()
               if getattr(args, flag, None) is not None}
    if servo_flags_given(args):
        changes["servo"] = servo_from_args(args)
    return replace(machine, **changes) if changes else machine
