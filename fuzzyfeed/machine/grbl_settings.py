"""A machine from GRBL's settings, as its ``$$`` command prints them (``$N=value``, optionally with a
``(comment)`` or ``; comment``; ``ok``, ``Grbl 1.1h [...]`` and ``[MSG:...]`` lines are skipped).

Read: ``$110``–``$112`` max rate (mm/min → mm/s), ``$120``–``$122`` acceleration (mm/s²), ``$11``
junction deviation (mm), ``$12`` arc tolerance (mm), ``$13`` report inches (GRBL keeps its
settings in mm whatever it reports: named, no conversion). GRBL's planner: each axis within its own
acceleration (a diagonal is faster), junction-deviation corners, a 16-block buffer (GRBL 1.1 on an
ATmega328p; named as assumed). Every other setting is named as ignored. A value that is not a
number, a setting given twice, or one of the eight missing: one
:class:`~fuzzyfeed.machine.imported.ImportSettingsError` line ``file:line: $N = value; rule``.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

from fuzzyfeed.errors import MachineLimitsError
from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.imported import Imported, ImportSettingsError, Setting
from fuzzyfeed.machine.servo import ServoModel

#: GRBL 1.1's planner buffer (BLOCK_BUFFER_SIZE on an ATmega328p)
GRBL_BLOCK_BUFFER = 16
_LINE = re.compile(r"^\$(\d+)\s*=\s*([^\s(;]*)\s*(?:\(.*\)|;.*)?$")
_SKIP = re.compile(r"^(ok|grbl\b.*|\[.*\]|>>>.*|\$\$|;.*|\(.*\)|\*\*\*\*.*)$", re.IGNORECASE)
_NAMES = {"110": "X max rate", "111": "Y max rate", "112": "Z max rate", "120": "X acceleration",
          "121": "Y acceleration", "122": "Z acceleration", "11": "junction deviation", "12": "arc tolerance"}


def read_grbl_settings(text: str, path: str | Path = "<grbl>", name: str | None = None) -> Imported:
    """The machine of a GRBL ``$$`` dump (see the module docstring)."""
    path = str(path)
    found: dict[str, tuple[int, str]] = {}
    for n, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or _SKIP.match(line):
            continue
        m = _LINE.match(line)
        if not m:
            raise ImportSettingsError(f"{path}:{n}: {line[:60]!r}; a $$ dump has lines $N=value")
        key, value = m.group(1), m.group(2)
        if key in found:
            raise ImportSettingsError(f"{path}:{n}: ${key} = {value} given twice (first at line "
                                      f"{found[key][0]}); a $$ dump gives each setting once")
        found[key] = (n, value)
    missing = [k for k in _NAMES if k not in found]
    if missing:
        raise ImportSettingsError(f"{path}: ${missing[0]} ({_NAMES[missing[0]]}) missing; a $$ dump of GRBL "
                                  f"prints ${', $'.join(_NAMES)} (it lacks ${', $'.join(missing)})")
    used: list[Setting] = []

    def number(key: str, zero_ok: bool = False) -> float:
        n, value = found[key]
        try:
            v = float(value)
        except ValueError:
            v = math.nan
        if not math.isfinite(v) or v < 0 or (v == 0 and not zero_ok):
            rule = "must be a finite number >= 0" if zero_ok else "must be a finite number > 0"
            raise ImportSettingsError(f"{path}:{n}: ${key} = {value!r} ({_NAMES.get(key, '')}); {rule}")
        return v

    def use(key: str, note: str) -> None:
        n, value = found[key]
        used.append(Setting(f"{path}:{n}", f"${key}", value, note))

    vel = tuple(number(k) / 60.0 for k in ("110", "111", "112"))
    acc = tuple(number(k) for k in ("120", "121", "122"))
    for k, v in zip(("110", "111", "112"), vel):
        use(k, f"{_NAMES[k]} {v:.6g} mm/s")
    for k, a in zip(("120", "121", "122"), acc):
        use(k, f"{_NAMES[k]} {a:.6g} mm/s^2")
    jd = number("11")
    use("11", f"junction deviation {jd:g} mm")
    arc = number("12")
    use("12", f"arcs as chords within {arc:g} mm")
    if "13" in found:
        inches = number("13", zero_ok=True)
        use("13", ("reports in inches; the settings are mm all the same (GRBL stores mm)" if inches
                   else "reports in mm"))
    assumed = [f"look-ahead {GRBL_BLOCK_BUFFER} moves (GRBL 1.1's planner buffer on an ATmega328p)",
               "servo Kv 30 1/s, no feed-forward (fuzzyfeed's default: GRBL drives steppers open loop; "
               "give the machine's own in the file if it has servos)",
               "interpolation period 0.001 s (fuzzyfeed's default)",
               "tangential jerk 20000 mm/s^3 (fuzzyfeed's SLW scheduler only; GRBL plans trapezoids)"]
    ignored = tuple(Setting(f"{path}:{n}", f"${k}", v, "not a setting fuzzyfeed models")
                    for k, (n, v) in sorted(found.items(), key=lambda kv: kv[1][0])
                    if k not in _NAMES and k != "13")
    try:
        machine = Machine(name=name or Path(path).stem, axis_vel_mm_s=vel, axis_acc_mm_s2=acc,  # type: ignore[arg-type]
                          jerk_mm_s3=20000.0, acceleration="axes", servo=ServoModel(), corner="junction-deviation",
                          corner_mm=jd, chord_tol_mm=arc, lookahead_moves=GRBL_BLOCK_BUFFER, ts_s=0.001,
                          source=f"GRBL $$ {Path(path).name}")
    except MachineLimitsError as exc:
        raise ImportSettingsError(f"{path}: {exc}") from None
    return Imported(machine=machine, used=tuple(used), ignored=ignored, assumed=tuple(assumed))
