"""A machine read from a controller's own settings (a LinuxCNC INI, a GRBL ``$$`` dump): the
:class:`~fuzzyfeed.machine.description.Machine`, every setting used and every one ignored (each
with why), and the machine file (TOML) that reproduces it.

The readers are :mod:`fuzzyfeed.machine.linuxcnc_ini` and :mod:`fuzzyfeed.machine.grbl_settings`;
``fuzzyfeed machines import`` writes :func:`machine_toml`.
"""

from __future__ import annotations

from dataclasses import dataclass

from fuzzyfeed.errors import MachineLimitsError
from fuzzyfeed.machine.description import Machine


class ImportSettingsError(MachineLimitsError):
    """A controller's settings file breaks a rule: ``file:line: KEY = value; rule``."""


@dataclass(frozen=True)
class Setting:
    """One setting of the source: where (``file:line``), its key as the controller names it, its
    value as written, and what fuzzyfeed did with it."""

    where: str
    key: str
    value: str
    note: str


@dataclass(frozen=True)
class Imported:
    """A machine and the account of its source: ``used`` and ``ignored`` settings, ``assumed``
    values fuzzyfeed needs that the source does not give (each named with the value taken)."""

    machine: Machine
    used: tuple[Setting, ...]
    ignored: tuple[Setting, ...]
    assumed: tuple[str, ...]

    def lines(self) -> list[str]:
        """The account, one line per setting."""
        out = [f"used     {s.where}: {s.key} = {s.value}  -> {s.note}" for s in self.used]
        out += [f"ignored  {s.where}: {s.key} = {s.value}  ({s.note})" for s in self.ignored]
        out += [f"assumed  {a}" for a in self.assumed]
        return out


def _axes(values) -> str:
    vals = [float(v) for v in values]
    if len(set(vals)) == 1:
        return repr(vals[0])
    return "[" + ", ".join(repr(v) for v in vals) + "]"


def _quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def machine_toml(imported: Imported) -> str:
    """The machine file of ``imported`` (every value with its unit in its key, the account of its
    source as comments); :func:`fuzzyfeed.machine.description.parse_machine` reads it back to the
    same :class:`Machine`."""
    m = imported.machine
    lines = [f"# fuzzyfeed machine imported by `fuzzyfeed machines import` from {m.source}"]
    lines += ["# " + line for line in imported.lines()]
    lines += [f"name = {_quote(m.name)}", f"source = {_quote(m.source)}", "", "[axes]",
              f"max_velocity_mm_s = {_axes(m.axis_vel_mm_s)}",
              f"max_acceleration_mm_s2 = {_axes(m.axis_acc_mm_s2)}",
              f"max_jerk_mm_s3 = {m.jerk_mm_s3!r}"]
    if m.path_acc_mm_s2 is not None:
        lines.append(f"path_acceleration_mm_s2 = {m.path_acc_mm_s2!r}")
    servo = m.servo
    lines += ["", "[servo]", f"kv_1_s = {_axes(servo.kv_1_s)}", f"feedforward = {_axes(servo.feedforward)}",
              "", "[controller]", f"acceleration = {_quote(m.acceleration)}", f"corner = {_quote(m.corner)}",
              ("path_tolerance_mm" if m.corner == "path-tolerance" else "junction_deviation_mm")
              + f" = {m.corner_mm!r}",
              f"chord_tolerance_mm = {m.chord_tol_mm!r}", f"lookahead_moves = {m.lookahead_moves}",
              f"period_s = {m.ts_s!r}", "", "[part]", f"contour_tolerance_um = {m.contour_tol_um!r}", ""]
    return "\n".join(lines)
