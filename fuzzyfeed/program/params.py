"""LinuxCNC's parameters: numbered ``#1`` … ``#5601`` and named ``#<name>`` with their scoping, and
the read-only ones a program may read (``#<_metric>``, ``#<_feed>``, ``#5220`` …) from the modal
state of the lines executed so far. The parameters that depend on the machine (offsets, position,
probe results, I/O) are refused when read: fuzzyfeed does not know them.
"""

from __future__ import annotations

from fuzzyfeed.errors import PathFormatError

#: LinuxCNC's RS274NGC_MAX_PARAMETERS: numbered parameters are #1 … #5601.
MAX_PARAMETER = 5601
#: Call arguments #1 … #30 (INTERP_SUB_PARAMS) are local to a subroutine call.
SUB_PARAMS = 30


def _err(message: str) -> PathFormatError:
    return PathFormatError(message)


class Parameters:
    """Numbered and named parameters with LinuxCNC's scoping: #1 … #30 and names without a
    leading ``_`` belong to the current call level; #31 … #5601 and ``_`` names are global.
    ``system`` maps read-only names (``_metric``, ``_feed`` …) and system numbers to functions of
    no argument that give their value now (the reader's modal state)."""

    def __init__(self, system: dict | None = None):
        self.numbered = [0.0] * (MAX_PARAMETER + 1)
        self.frames: list[dict] = [{}]
        self.saved_args: list[list[float]] = []
        self.globals: dict[str, float] = {}
        self.system = system or {}
        self.return_value = 0.0
        self.value_returned = 0.0

    # numbered
    def get(self, index: int) -> float:
        if not 1 <= index <= MAX_PARAMETER:
            raise _err(f"parameter #{index} is out of range (#1 … #{MAX_PARAMETER})")
        fn = self.system.get(index)
        if fn is not None:
            return fn()
        return self.numbered[index]

    def set(self, index: int, value: float) -> None:
        if not 1 <= index <= MAX_PARAMETER:
            raise _err(f"parameter #{index} is out of range (#1 … #{MAX_PARAMETER})")
        if index in self.system:
            raise _err(f"parameter #{index} is read-only (or not supported: it depends on the "
                       "machine's offsets and position)")
        self.numbered[index] = value

    # named
    def get_named(self, name: str) -> float:
        value = self._find(name)
        if value is None:
            raise _err(f"named parameter #<{name}> is not defined")
        return value

    def exists(self, name: str) -> bool:
        return self._find(name) is not None

    def _find(self, name: str) -> float | None:
        if name.startswith("_"):
            if name == "_value":
                return self.return_value
            if name == "_value_returned":
                return self.value_returned
            fn = self.system.get(name)
            if fn is not None:
                return fn()
            return self.globals.get(name)
        return self.frames[-1].get(name)

    def set_named(self, name: str, value: float) -> None:
        if name.startswith("_"):
            if name in self.system or name in ("_value", "_value_returned"):
                raise _err(f"named parameter #<{name}> is read-only")
            self.globals[name] = value
        else:
            self.frames[-1][name] = value

    # call levels
    def enter(self, args: list[float]) -> None:
        """A subroutine call: #1 … #30 saved and set to ``args`` (0 for the rest), a new scope."""
        self.saved_args.append(self.numbered[1:SUB_PARAMS + 1])
        values = list(args) + [0.0] * (SUB_PARAMS - len(args))
        self.numbered[1:SUB_PARAMS + 1] = values
        self.frames.append({})

    def leave(self) -> None:
        self.numbered[1:SUB_PARAMS + 1] = self.saved_args.pop()
        self.frames.pop()

    @property
    def level(self) -> int:
        return len(self.frames) - 1


class ModalState:
    """The modal state the read-only parameters report, updated from every executed line."""

    def __init__(self, where: str = "the program"):
        self.metric, self.absolute, self.feed, self.rpm = 1.0, 1.0, 0.0, 0.0
        self.motion, self.plane, self.coord, self.feed_mode, self.tool, self.next_tool = 800.0, 170.0, 540.0, 940.0, 0.0, 0.0
        self.where = where
        self.probe: dict | None = None     # the target words of the last G38.x (absolute) line
        self.probe_said = False

    def update(self, letters, values) -> None:
        if any(k == 6 and round(v * 10) in (382, 383, 384, 385) for k, v in zip(letters, values)):
            absolute = self.absolute == 1.0 and not any(k == 6 and round(v * 10) == 910
                                                        for k, v in zip(letters, values))
            self.probe = {chr(97 + k): v for k, v in zip(letters, values) if k in (23, 24, 25)} \
                if absolute else {}
        for k, value in zip(letters, values):
            letter = chr(97 + k)
            if letter == "g":
                g = round(value * 10)
                if g in (200, 210):
                    self.metric = 1.0 if g == 210 else 0.0
                elif g in (900, 910):
                    self.absolute = 1.0 if g == 900 else 0.0
                elif g in (170, 180, 190):
                    self.plane = float(g)
                elif g in (930, 940, 950):
                    self.feed_mode = float(g)
                elif 540 <= g <= 593:
                    self.coord = float(g)
                elif g in (0, 10, 20, 30, 800) or 730 <= g <= 890:
                    self.motion = float(g)
            elif letter == "f":
                self.feed = value
            elif letter == "s":
                self.rpm = abs(value)
            elif letter == "t":
                self.next_tool = value
            elif letter == "m" and round(value) == 6:
                self.tool = self.next_tool

    def system(self, params: Parameters) -> dict:
        coord_number = lambda: {540: 1, 550: 2, 560: 3, 570: 4, 580: 5, 590: 6, 591: 7, 592: 8,
                                593: 9}.get(int(self.coord), 1)
        out = {
            "_metric": lambda: self.metric, "_imperial": lambda: 1.0 - self.metric,
            "_absolute": lambda: self.absolute, "_incremental": lambda: 1.0 - self.absolute,
            "_feed": lambda: self.feed, "_rpm": lambda: self.rpm, "_motion_mode": lambda: self.motion,
            "_plane": lambda: self.plane, "_coord_system": lambda: self.coord,
            "_inverse_time": lambda: 1.0 if self.feed_mode == 930 else 0.0,
            "_units_per_minute": lambda: 1.0 if self.feed_mode == 940 else 0.0,
            "_units_per_rev": lambda: 1.0 if self.feed_mode == 950 else 0.0,
            "_call_level": lambda: float(params.level), "_vmajor": lambda: 2.0, "_vminor": lambda: 9.0,
            "_current_tool": lambda: self.tool, "_selected_tool": lambda: self.next_tool,
            5220: lambda: float(coord_number()), 5400: lambda: self.tool,
        }
        for k, axis in ((5061, "x"), (5062, "y"), (5063, "z")):
            out[k] = self._probe_value(k, axis)
        out[5070] = self._probe_value(5070, None)
        unsupported = ([5064 + k for k in range(6)] + [5161 + k for k in range(230)] + [5399]
                       + [5401 + k for k in range(28)])    # probe, offsets, M66, tool data, position
        for k in unsupported:
            if k not in out:
                out[k] = _unsupported(k)
        for name in ("_x", "_y", "_z", "_a", "_b", "_c", "_u", "_v", "_w", "_abs_x", "_abs_y",
                     "_abs_z", "_abs_a", "_abs_b", "_abs_c", "_tool_offset", "_retract_r_plane",
                     "_retract_old_z", "_ccomp", "_line", "_spindle_on", "_spindle_cw", "_mist",
                     "_flood", "_speed_override", "_feed_override", "_adaptive_feed", "_feed_hold",
                     "_current_pocket", "_selected_pocket", "_task", "_metric_machine",
                     "_remap_level", "_spindle_rpm_mode", "_spindle_css_mode", "_ijk_absolute_mode",
                     "_lathe_diameter_mode", "_lathe_radius_mode"):
            out.setdefault(name, _unsupported(name))
        return out


    def _probe_value(self, number: int, axis: str | None):
        """#5061–#5063 (where the probe tripped) read as the last G38.x's target in X, Y, Z, and
        #5070 (tripped) as 1, with one notice: the machine measures them; the advice follows the
        path the program takes when the probe trips at its target."""
        def value() -> float:
            if self.probe is None or (axis is not None and axis not in self.probe):
                return _unsupported(number)()
            if not self.probe_said:
                import warnings

                from fuzzyfeed.errors import FuzzyfeedNotice

                warnings.warn(f"{self.where}: probe results (#5061-#5063, #5070) read as the probe's "
                              "target (the machine measures them); the advice follows the path the "
                              "program takes then", FuzzyfeedNotice, stacklevel=2)
                self.probe_said = True
            return 1.0 if axis is None else float(self.probe[axis])
        return value


def _unsupported(key):
    what = f"#{key}" if isinstance(key, int) else f"#<{key}>"

    def fail():
        raise PathFormatError(f"system parameter {what} is not supported (it depends on the "
                              "machine: offsets, position, probe or I/O)")
    return fail
