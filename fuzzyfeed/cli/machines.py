"""``fuzzyfeed machines``: the shipped machine files, a machine file checked, and a machine file
imported from what a controller's user already has — a LinuxCNC INI (``--hal FILE`` for its PID
gains) or GRBL's ``$$`` settings (:mod:`fuzzyfeed.machine.linuxcnc_ini`,
:mod:`fuzzyfeed.machine.grbl_settings`). The import prints every setting used, every one ignored
and every value assumed, and writes the machine file (TOML) with -o."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from fuzzyfeed.cli import COMMANDS


def register(sub) -> None:
    p = sub.add_parser("machines", help=COMMANDS["machines"],
                       description="List the shipped machine files, check one, or import one from a "
                                   "LinuxCNC INI or a GRBL $$ dump.")
    actions = p.add_subparsers(dest="machines_action", metavar="ACTION")
    actions.add_parser("list", help="the shipped machine files (the default)")
    check = actions.add_parser("check", help="read a machine file and describe it")
    check.add_argument("file", metavar="FILE")
    imp = actions.add_parser("import", help="a machine file from a LinuxCNC INI or a GRBL $$ dump",
                             description="Write a fuzzyfeed machine file from a LinuxCNC INI ([JOINT_n]/"
                                         "[AXIS_x] limits, [TRAJ], [EMCMOT] SERVO_PERIOD, G64 P of "
                                         "RS274NGC_STARTUP_CODE; --hal: PID Pgain -> Kv, FF1gain -> "
                                         "feed-forward) or from GRBL's $$ output ($110-$112, $120-$122, "
                                         "$11, $12, $13). Every setting used, ignored or assumed is named.")
    imp.add_argument("settings", metavar="FILE", help="a LinuxCNC INI (*.ini) or a text file with GRBL's $$ output")
    imp.add_argument("--hal", metavar="FILE", default=None, help="LinuxCNC: the HAL file setting the PID gains")
    imp.add_argument("--name", default=None, help="the machine's name (default: the file's stem)")
    imp.add_argument("-o", "--output", required=True, metavar="OUT.toml", help="the machine file to write ('-': stdout)")
    p.set_defaults(run=run)


def _is_ini(path: Path, text: str) -> bool:
    if path.suffix.lower() == ".ini":
        return True
    if re.search(r"^\s*\$\d+\s*=", text, re.MULTILINE):
        return False
    return bool(re.search(r"^\s*\[[A-Za-z_0-9]+\]\s*$", text, re.MULTILINE))


def import_settings(settings: str, hal: str | None = None, name: str | None = None):
    """The :class:`~fuzzyfeed.machine.imported.Imported` machine of a settings file."""
    from fuzzyfeed.base.files import read_text
    from fuzzyfeed.machine.imported import ImportSettingsError

    path = Path(settings)
    text = read_text(path, "settings", ImportSettingsError, latin1=True)
    if _is_ini(path, text):
        from fuzzyfeed.machine.linuxcnc_ini import read_linuxcnc_ini

        hal_text = read_text(Path(hal), "HAL file", ImportSettingsError) if hal else None
        return read_linuxcnc_ini(text, path, hal_text=hal_text, hal_path=hal or "<hal>", name=name)
    if hal:
        raise ImportSettingsError(f"--hal {hal}: a HAL file goes with a LinuxCNC INI; {settings} is not one")
    if not re.search(r"^\s*\$\d+\s*=", text, re.MULTILINE):
        raise ImportSettingsError(f"{settings}: neither a LinuxCNC INI ([SECTION] headers) nor GRBL $$ "
                                  "output ($N=value lines)")
    from fuzzyfeed.machine.grbl_settings import read_grbl_settings

    return read_grbl_settings(text, path, name=name)


def run(args: argparse.Namespace) -> int:
    action = args.machines_action or "list"
    if action == "list":
        from fuzzyfeed.machine.description import load_machine, machine_names

        for name in machine_names():
            print(load_machine(name).describe())
        return 0
    if action == "check":
        from fuzzyfeed.machine.description import load_machine

        print(load_machine(args.file).describe())
        return 0
    from fuzzyfeed.base.atomic import atomic_write
    from fuzzyfeed.machine.imported import machine_toml

    imported = import_settings(args.settings, args.hal, args.name)
    text = machine_toml(imported)
    for line in imported.lines():
        print(line)
    print(imported.machine.describe())
    with atomic_write(args.output, "w") as handle:
        handle.write(text)
    print(f"wrote {args.output}")
    return 0
