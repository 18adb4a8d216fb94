"""A machine from a LinuxCNC INI (and, optionally, its HAL file's PID gains).

Read (units: [TRAJ] LINEAR_UNITS, mm or inch, converted to mm):

- [AXIS_x] MAX_VELOCITY, MAX_ACCELERATION of X, Y, Z, and the [JOINT_n] ones of the joints a
  ``trivkins`` machine maps to each axis ([KINS] KINEMATICS ``coordinates=``, else [TRAJ]
  COORDINATES letter by letter): an axis's limit is the smallest of them;
- an axis of [TRAJ] COORDINATES without a limit gets LinuxCNC's own default (1 unit/s, 1 unit/s²);
  X, Y or Z that the machine does not have (a lathe's Y) gets another axis's limits (named);
- [TRAJ] MAX_LINEAR_VELOCITY (or MAX_VELOCITY) caps every axis's velocity (fuzzyfeed has no
  path speed limit of its own); MAX_LINEAR_ACCELERATION (or MAX_ACCELERATION) is the limit along
  the path;
- [EMCMOT] SERVO_PERIOD (ns) the interpolation period;
- [RS274NGC] RS274NGC_STARTUP_CODE: G64 P<tol> the corner tolerance (path-tolerance corners);
- with a HAL file: ``setp <pid>.Pgain`` → Kv (1/s: LinuxCNC's PID P is output velocity per unit of
  following error), ``setp <pid>.FF1gain`` → velocity feed-forward, per joint (the value may be an
  INI reference such as ``[JOINT_0]P``; the joint is the one the reference or ``pid.N`` names).

Everything else is named as ignored. A value that is not a finite positive number, or none of X,
Y, Z: one :class:`~fuzzyfeed.machine.imported.ImportSettingsError` line
``file:line: [SECTION] KEY = value; rule``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

from fuzzyfeed.errors import MachineLimitsError
from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.imported import Imported, ImportSettingsError, Setting
from fuzzyfeed.machine.servo import ServoModel

AXES = "XYZ"
_UNITS = {"mm": 1.0, "metric": 1.0, "cm": 10.0, "in": 25.4, "inch": 25.4, "imperial": 25.4}
#: chords LinuxCNC never makes (it runs arcs exactly): fuzzyfeed's planner follows them within this
CHORD_TOL_MM = 0.001
#: LinuxCNC's limit of an axis or joint whose INI gives none (emccfg.h: 1 unit/s, 1 unit/s^2)
LINUXCNC_DEFAULT_LIMIT = 1.0


@dataclass(frozen=True)
class Entry:
    section: str
    key: str
    value: str
    line: int


def parse_ini(text: str) -> list[Entry]:
    """Every ``KEY = value`` of an INI with its section and line (LinuxCNC's format: ``[SECTION]``
    headers, ``#`` and ``;`` comment lines; a key may repeat)."""
    out, section = [], ""
    for n, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line[0] in "#;":
            continue
        if line.startswith("[") and "]" in line:
            section = line[1:line.index("]")].strip()
            continue
        if "=" in line:
            key, value = line.split("=", 1)
            out.append(Entry(section, key.strip(), value.strip(), n))
    return out


class _Ini:
    def __init__(self, entries: list[Entry], path: str):
        self.entries, self.path = entries, path
        self.used: dict[int, str] = {}

    def get(self, section: str, *keys: str) -> Entry | None:
        for key in keys:
            for e in self.entries:
                if e.section == section and e.key == key:
                    return e
        return None

    def where(self, e: Entry) -> str:
        return f"{self.path}:{e.line}"

    def number(self, e: Entry, rule: str = "must be a finite number > 0") -> float:
        try:
            v = float(e.value)
        except ValueError:
            v = math.nan
        if not (math.isfinite(v) and v > 0):
            raise ImportSettingsError(f"{self.where(e)}: [{e.section}] {e.key} = {e.value!r}; {rule}")
        return v

    def use(self, e: Entry, note: str) -> None:
        self.used[id(e)] = note


def _units_mm(ini: _Ini) -> float:
    e = ini.get("TRAJ", "LINEAR_UNITS")
    if e is None:
        return 1.0
    name = e.value.strip().lower()
    if name in _UNITS:
        ini.use(e, f"lengths in {name} ({_UNITS[name]:g} mm)")
        return _UNITS[name]
    try:
        per_mm = float(name)                  # old style: machine units per mm
    except ValueError:
        per_mm = math.nan
    if not (math.isfinite(per_mm) and per_mm > 0):
        raise ImportSettingsError(f"{ini.where(e)}: [TRAJ] LINEAR_UNITS = {e.value!r}; must be mm, "
                                  "inch (in, metric, imperial, cm) or units per mm")
    ini.use(e, f"{per_mm:g} units per mm")
    return 1.0 / per_mm


def _joint_axes(ini: _Ini) -> tuple[list[str], bool]:
    """Axis letter of each joint, and whether joints map to axes (trivkins)."""
    kins = ini.get("KINS", "KINEMATICS")
    coords = ini.get("TRAJ", "COORDINATES")
    letters = ""
    if kins is not None:
        words = kins.value.split()
        if not words or words[0] != "trivkins":
            return [], False
        for w in words[1:]:
            if w.lower().startswith("coordinates="):
                letters = w.split("=", 1)[1]
    if not letters and coords is not None:
        letters = coords.value
    return [c.upper() for c in letters if c.isalpha()], True


def read_linuxcnc_ini(text: str, path: str | Path = "<ini>", hal_text: str | None = None,
                      hal_path: str | Path = "<hal>", name: str | None = None) -> Imported:
    """The machine of a LinuxCNC INI (see the module docstring)."""
    ini = _Ini(parse_ini(text), str(path))
    assumed: list[str] = []
    scale = _units_mm(ini)
    letters, trivial = _joint_axes(ini)
    vel: list[float | None] = [None] * 3
    acc: list[float | None] = [None] * 3
    coords = ini.get("TRAJ", "COORDINATES")
    present = set(c.upper() for c in coords.value if c.isalpha()) if coords else set(letters) or set(AXES)
    if coords is not None:
        ini.use(coords, f"axes {''.join(sorted(present))}")
    for j, axis in enumerate(AXES):
        sources = [f"AXIS_{axis}"]
        if trivial:
            sources += [f"JOINT_{n}" for n, letter in enumerate(letters) if letter == axis]
        for section in sources:
            for key, store, unit in (("MAX_VELOCITY", vel, "mm/s"), ("MAX_ACCELERATION", acc, "mm/s^2")):
                e = ini.get(section, key)
                if e is None:
                    continue
                v = ini.number(e) * scale
                store[j] = v if store[j] is None else min(store[j], v)  # type: ignore[type-var]
                ini.use(e, f"{axis} {key.lower().replace('max_', 'max ')} {v:.6g} {unit} (the smallest of "
                        f"{', '.join('[' + s + ']' for s in sources)})")
    for j, axis in enumerate(AXES):
        for key, store, unit in (("MAX_VELOCITY", vel, "mm/s"), ("MAX_ACCELERATION", acc, "mm/s^2")):
            if store[j] is None and axis in present:
                store[j] = LINUXCNC_DEFAULT_LIMIT * scale
                assumed.append(f"{axis} {key.lower().replace('_', ' ')} {store[j]:.6g} {unit}: no [AXIS_{axis}] "
                               f"nor joint {key}, LinuxCNC's own default (1 unit/s, 1 unit/s^2) applies")
    known = [j for j in range(3) if vel[j] is not None and acc[j] is not None]
    if not known:
        raise ImportSettingsError(f"{path}: no [AXIS_X]/[AXIS_Y]/[AXIS_Z] nor trivkins [JOINT_n] "
                                  "MAX_VELOCITY and MAX_ACCELERATION; not a machine with X, Y or Z")
    for j in range(3):
        if vel[j] is None or acc[j] is None:
            k = known[0]
            vel[j], acc[j] = vel[k], acc[k]
            assumed.append(f"{AXES[j]}: not an axis of this machine (COORDINATES {''.join(sorted(present))}); "
                           f"given {AXES[k]}'s limits {vel[k]:.6g} mm/s, {acc[k]:.6g} mm/s^2 so that a "
                           f"machine file exists (a program moving {AXES[j]} is not for this machine)")
    e = ini.get("TRAJ", "MAX_LINEAR_VELOCITY", "MAX_VELOCITY")
    if e is not None:
        cap = ini.number(e) * scale
        capped = [min(v, cap) for v in vel]  # type: ignore[type-var]
        ini.use(e, f"caps every axis's velocity at {cap:.6g} mm/s (fuzzyfeed has no path speed limit; a "
                "diagonal may plan faster than LinuxCNC)" if capped != vel else
                f"{cap:.6g} mm/s, no axis is faster (fuzzyfeed has no path speed limit)")
        vel = capped
    path_acc = None
    e = ini.get("TRAJ", "MAX_LINEAR_ACCELERATION", "MAX_ACCELERATION")
    if e is not None:
        path_acc = ini.number(e) * scale
        ini.use(e, f"path acceleration {path_acc:.6g} mm/s^2")
    ts = 0.001
    e = ini.get("EMCMOT", "SERVO_PERIOD")
    if e is not None:
        ts = ini.number(e) * 1e-9
        ini.use(e, f"servo period {ts:g} s")
    else:
        assumed.append("servo period 0.001 s ([EMCMOT] SERVO_PERIOD not given; LinuxCNC's default is 1 ms)")
    corner_mm = _corner(ini, scale, assumed)
    servo, hal_settings = _servo(ini, hal_text, str(hal_path), assumed) if hal_text is not None else (None, ())
    if servo is None:
        assumed.append("servo Kv 30 1/s, no feed-forward (fuzzyfeed's default; give --hal FILE for the PID gains)")
        servo = ServoModel()
    assumed.append(f"arcs followed as chords within {CHORD_TOL_MM * 1e3:g} um (LinuxCNC runs arcs exactly)")
    assumed.append("tangential jerk 20000 mm/s^3 (fuzzyfeed's SLW scheduler only; LinuxCNC 2.9 plans trapezoids)")
    try:
        machine = Machine(name=name or Path(str(path)).stem, axis_vel_mm_s=tuple(vel), axis_acc_mm_s2=tuple(acc),  # type: ignore[arg-type]
                          jerk_mm_s3=20000.0, path_acc_mm_s2=path_acc, acceleration="path", servo=servo,
                          corner="path-tolerance", corner_mm=corner_mm, chord_tol_mm=CHORD_TOL_MM,
                          lookahead_moves=0, ts_s=ts, source=f"LinuxCNC INI {Path(str(path)).name}")
    except MachineLimitsError as exc:
        raise ImportSettingsError(f"{path}: {exc}") from None
    used = tuple(Setting(ini.where(e), f"[{e.section}] {e.key}", e.value, ini.used[id(e)])
                 for e in ini.entries if id(e) in ini.used)
    ignored = tuple(Setting(ini.where(e), f"[{e.section}] {e.key}", e.value, _why_ignored(e, trivial))
                    for e in ini.entries if id(e) not in ini.used)
    hal_ignored = tuple(Setting(h.where, h.key, h.value, h.note[9:]) for h in hal_settings if h.note.startswith("IGNORED: "))
    hal_used = tuple(h for h in hal_settings if not h.note.startswith("IGNORED: "))
    return Imported(machine=machine, used=used + hal_used, ignored=ignored + hal_ignored,
                    assumed=tuple(assumed))


_G64 = re.compile(r"G\s*64(?![\d.])\s*(?:P\s*([-+]?[\d.]+))?", re.IGNORECASE)
_G61 = re.compile(r"G\s*61(?:\.1)?(?![\d])", re.IGNORECASE)


def _corner(ini: _Ini, scale: float, assumed: list[str]) -> float:
    e = ini.get("RS274NGC", "RS274NGC_STARTUP_CODE")
    code = re.sub(r"\([^)]*\)", " ", e.value) if e is not None else ""
    g64 = list(_G64.finditer(code))
    if g64 and g64[-1].group(1) is not None:
        try:
            p = float(g64[-1].group(1))
        except ValueError:
            p = math.nan
        if not (math.isfinite(p) and p > 0):
            raise ImportSettingsError(f"{ini.where(e)}: [RS274NGC] RS274NGC_STARTUP_CODE = {e.value!r}; "
                                      f"G64 P must be a finite number > 0")
        units = scale
        if re.search(r"G\s*20(?![\d.])", code[:g64[-1].start()], re.IGNORECASE):
            units = 25.4
        elif re.search(r"G\s*21(?![\d.])", code[:g64[-1].start()], re.IGNORECASE):
            units = 1.0
        ini.use(e, f"corners blended within G64 P{g64[-1].group(1)} = {p * units:.6g} mm")
        return p * units
    if e is not None and _G61.search(code):
        ini.use(e, "G61 exact stop: no G64 tolerance")
        assumed.append("corner tolerance 0.001 mm (the startup code sets G61, exact stop; fuzzyfeed plans "
                       "blends only, this nearly stops at corners)")
        return 0.001
    why = "G64 without P" if g64 else "no G64 P in the startup code"
    assumed.append(f"corner tolerance 0.01 mm ({why}: LinuxCNC then blends as fast as the axes allow; "
                   "fuzzyfeed needs a tolerance and takes 0.01 mm, edit path_tolerance_mm in the file or give --junction-deviation-mm)")
    return 0.01


def _why_ignored(e: Entry, trivial: bool) -> str:
    if e.section.startswith("JOINT_") and e.key in ("MAX_VELOCITY", "MAX_ACCELERATION") and not trivial:
        return "joint limit of a non-trivkins machine: the axes' limits are used"
    if e.section.startswith(("AXIS_", "JOINT_")) and e.key in ("MAX_VELOCITY", "MAX_ACCELERATION"):
        return "not a joint or axis of X, Y or Z"
    return "not a setting fuzzyfeed models"


_SETP = re.compile(r"^\s*setp\s+(\S+)\.(Pgain|FF1gain)\s+(\S+)", re.IGNORECASE)
_REF = re.compile(r"^\[([^\]]+)\](\S+)$")


def _servo(ini: _Ini, hal_text: str, hal_path: str, assumed: list[str]) -> tuple[ServoModel | None, list[Setting]]:
    """Kv and feed-forward per axis from the HAL file's PID gains, and the HAL settings read."""
    letters, trivial = _joint_axes(ini)
    gains: dict[str, dict[int, float]] = {"Pgain": {}, "FF1gain": {}}
    settings = []
    for n, line in enumerate(hal_text.splitlines(), start=1):
        m = _SETP.match(line.split("#", 1)[0])
        if not m:
            continue
        comp, pin, value = m.group(1), m.group(2), m.group(3)
        where = f"{hal_path}:{n}"
        joint = None
        ref = _REF.match(value)
        if ref:
            section = ref.group(1)
            e = ini.get(section, ref.group(2))
            if e is None:
                raise ImportSettingsError(f"{where}: setp {comp}.{pin} {value}; the INI has no "
                                          f"[{section}] {ref.group(2)}")
            if section.startswith("JOINT_") and section[6:].isdigit():
                joint = int(section[6:])
            text_value = e.value
            ini.use(e, f"via {where}")
        else:
            text_value = value
        tail = comp.rsplit(".", 1)[-1]
        if joint is None and tail.isdigit():
            joint = int(tail)
        if joint is None and len(tail) == 1 and tail.upper() in AXES and tail.upper() in letters:
            joint = letters.index(tail.upper())
        try:
            v = float(text_value)
        except ValueError:
            v = math.nan
        rule = "must be a finite number > 0" if pin == "Pgain" else "must be a finite number in 0..1"
        if not math.isfinite(v) or v < 0 or (pin == "Pgain" and v == 0) or (pin == "FF1gain" and v > 1):
            raise ImportSettingsError(f"{where}: setp {comp}.{pin} {value} (= {text_value}); {rule}")
        if joint is None or not trivial or joint >= len(letters) or letters[joint] not in AXES:
            settings.append(Setting(where, f"setp {comp}.{pin}", value, "IGNORED: names no joint of X, Y or Z"))
            continue
        gains[pin][joint] = v
        settings.append(Setting(where, f"setp {comp}.{pin}", text_value,
                                f"{letters[joint]} " + ("Kv 1/s" if pin == "Pgain" else "velocity feed-forward")))
    if not gains["Pgain"]:
        assumed.append(f"servo: {hal_path} sets no Pgain of a joint of X, Y or Z")
        return None, settings
    kv, ff = [], []
    for axis in AXES:
        joints = [j for j, letter in enumerate(letters) if letter == axis and j in gains["Pgain"]]
        if not joints:
            other = min(gains["Pgain"].values())
            assumed.append(f"servo {axis}: no Pgain in {hal_path}; Kv {other:g} 1/s (the lowest given)")
            kv.append(other)
            ff.append(0.0)
            continue
        kv.append(min(gains["Pgain"][j] for j in joints))
        ff.append(min(gains["FF1gain"].get(j, 0.0) for j in joints))
    return ServoModel(kv_1_s=tuple(kv), feedforward=tuple(ff)), settings
