"""The program model: a whole G-code program as its original lines plus one row per motion.

:func:`fuzzyfeed.program.read.read_program` builds it; :mod:`fuzzyfeed.program.rewrite`
writes it back with changed F words. Every original line is kept (``lines``), with the modal
state in force after it (per-line arrays). Every line that moves the tool gives one *move* row
(per-move arrays, in mm, in the coordinate frame in force): its kind, start, end, the programmed
F in force, and for arcs the exact circle. A *cut* is a chain of feed moves (lines, arcs, NURBS
blocks) between rapids; ``cut`` numbers them from 0 (−1 for moves in no cut).

Positions a program does not determine are tracked as *unknown*: the machine's start point (it is
not assumed to be 0), after a change to offsets whose values the machine holds (G54-G59.3 not set
by G10 L2, the G92/G52 offsets at the start, tool length offsets, G10 L1/L20), a G28/G30/G53 move,
a probe (on the axes it moves), a drilling cycle in G91 or outside G17. The offsets the program
sets are followed as LinuxCNC follows them (:mod:`fuzzyfeed.program.frames`: polar words, G92,
G52, G92.1/.2/.3, G10 L2, changes of system, drilling cycles' retract). ``known`` is false for a
move from an unknown point (its length is not known); such a move is kept as written (kind KEPT,
or its own kind with ``known`` false) and never advised. The meanings of ``kind``, ``known``,
``feed_mode``, ``rotary`` and ``stops`` are unchanged by issue 40 (no kind or field added):
SYNCED is G33/G33.1, whose speed no F sets; G93/G95 moves have ``feed_mode`` 93/95.
``feed_mm_min`` is the F in force converted with the units in force when the F was read (the
units before its line's G20/G21: LinuxCNC's order of execution).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: File suffixes read as G-code.
GCODE_SUFFIXES = (".ngc", ".nc", ".gcode", ".gc", ".tap", ".cnc")
MM_PER_INCH = 25.4
#: Why a feed move without an F in force is refused (LinuxCNC refuses it too).
NO_FEED_RULE = ("feed move with no F in force (F = 0); the program must give an F word before its "
                "first feed move")

# move kinds
RAPID, LINE, ARC, NURBS, CYCLE, KEPT, HOME, SYNCED = range(8)
KIND_NAMES = ("rapid", "line", "arc", "nurbs", "cycle", "kept", "home", "synced")
#: Kinds whose feed is not an F word (rapids, homing, spindle-synchronised G33/G33.1): no F is
#: ever written on their lines.
NO_F_KINDS = (RAPID, HOME, SYNCED)
#: Kinds the advisor changes (their feed is advised per cut).
ADVISED_KINDS = (LINE, ARC, NURBS)
#: Plane codes: G17 (XY), G18 (XZ), G19 (YZ) -> (first axis, second axis, normal axis) indices,
#: as LinuxCNC orders them (G18: Z then X).
PLANE_AXES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}
#: Centre words of each axis (X: I, Y: J, Z: K).
CENTRE_LETTERS = "IJK"


@dataclass(frozen=True, eq=False)
class Rows:
    """The executed rows of a program whose lines run more than once or out of order (loops,
    subroutine calls): per row its line (0-based; −1 for a line of another file) and the feed
    state after it, and per move its row. The program's per-line arrays then hold the state
    after each line's last run."""

    line: np.ndarray            # (R,) source line of every row
    feed_mode: np.ndarray       # (R,) 93, 94, 95
    has_f: np.ndarray           # (R,) the row has an F word
    feed_value: np.ndarray      # (R,) F in force after the row (program units)
    feed_reset: np.ndarray      # (R,) F set to 0 on the row (G94/G95 given, or a change of mode)
    move_row: np.ndarray        # (M,) the row of every move
    feed_inch: np.ndarray | None = None   # (R,) an F on the row is read in inches (units before it)
    call_line: np.ndarray | None = None   # (R,) main-file line of the outermost call the row runs in, or -1


def lines_of_rows(values: np.ndarray, row_line: np.ndarray, n_lines: int, before=None) -> np.ndarray:
    """Per line, the value at the line's last row; a line that never runs takes the value of
    the line before it (``before``, or the first row's value, at the top of the file)."""
    values = np.asarray(values)
    last = np.full(n_lines, -1, dtype=np.int64)
    ok = row_line >= 0
    np.maximum.at(last, row_line[ok], np.flatnonzero(ok))
    ran = last >= 0
    idx = np.where(ran, np.arange(n_lines), -1)
    np.maximum.accumulate(idx, out=idx)
    src = np.where(idx >= 0, last[np.maximum(idx, 0)], -1)
    fill = values[0] if before is None else before
    out = np.where(src >= 0, values[np.maximum(src, 0)], fill)
    if before is not None:
        out = np.where(ran, out, before)
    return out.astype(values.dtype)


@dataclass(frozen=True, eq=False)
class Program:
    """A read program (see the module docstring). Arrays are read-only in spirit; lengths:
    L = number of lines, M = number of moves."""

    path: Path
    lines: Sequence[str]             # the original lines (a LineStore when read: ~30 B a line)
    newline: str
    end_line: int                     # 0-based index of the line with M2/M30 (L if none)
    # per line (L)
    inch: np.ndarray                  # bool: G20 in force after the line
    absolute: np.ndarray              # bool: G90
    ij_absolute: np.ndarray           # bool: G90.1
    plane: np.ndarray                 # 17, 18, 19
    feed_mode: np.ndarray             # 93, 94, 95
    feed_value: np.ndarray            # programmed F in force (program units / min; 0 if none)
    tool: np.ndarray                  # T selected (−1 if none)
    work_offset: np.ndarray           # 54.0 … 59.3: the coordinate system in force
    length_offset: np.ndarray         # 43.0, 43.1, 43.2 or 49.0: tool length offset mode
    has_f: np.ndarray                 # bool: the line has an F word
    feed_reset: np.ndarray            # bool: F is set to 0 on the line (G94/G95, change of mode)
    # per move (M)
    move_line: np.ndarray             # 0-based line index (−1: a line of another file)
    kind: np.ndarray                  # RAPID, LINE, ...
    start: np.ndarray                 # (M, 3) mm
    end: np.ndarray                   # (M, 3) mm
    feed_mm_min: np.ndarray           # programmed feed in force (mm/min, NaN for rapids)
    cut: np.ndarray                   # cut number or −1
    centre: np.ndarray                # (M, 3) arc centre (plane coords; NaN if not an arc)
    turns: np.ndarray                 # signed: +n counter-clockwise (G3), −n clockwise (G2); 0 else
    arc_plane: np.ndarray             # plane code of an arc (0 else)
    no_split: np.ndarray              # bool: the move's line must stay one move (stop codes, P turns)
    has_z_words: bool = False         # the program names Z somewhere (its paths are 3-D)
    nurbs: dict = field(default_factory=dict)   # move index -> Nurbs (G5.2 block, in mm)
    nurbs_lines: dict = field(default_factory=dict)  # move index -> (first, last) line of the block
    rows: Rows | None = None          # executed rows, when lines run more than once or out of order
    rotary: np.ndarray | None = None  # (M,) bool: the move turns a rotary axis (A/B/C; U/V/W)
    known: np.ndarray | None = None   # (M,) bool: the move starts from a known point
    stops: np.ndarray | None = None   # (M,) bool: its line stops the program after it (M0/M1/M2/M30/M60)
    #: (M,) bool: a move of cutter compensation (G41/G42) whose tool diameter is not known, and
    #: the move that leaves it: its row is the programmed contour, not the tool centre's path
    #: (LinuxCNC offsets it), so it is not judged and its line is never split (the controller's
    #: entry and corner rules depend on the move as written)
    comp_unknown: np.ndarray | None = None
    #: G20 in force before the first line: a window of a program's lines read from the state before
    #: it (:mod:`fuzzyfeed.program.windows`); an F on the first line is read in those units
    inch_before: bool = False

    @property
    def n_cuts(self) -> int:
        return int(self.cut.max()) + 1 if self.cut.size else 0

    def cut_moves(self, k: int) -> np.ndarray:
        """Move indices of cut ``k`` in order."""
        return np.flatnonzero(self.cut == k)

    @property
    def scale(self) -> np.ndarray:
        """mm per program unit on every line (25.4 under G20)."""
        return np.where(self.inch, MM_PER_INCH, 1.0)

    def move_lengths(self) -> np.ndarray:
        """Length (mm) of every move: chord for lines and rapids, exact for arcs (helical
        included), the NURBS's arc length for G5.2 blocks."""
        out = np.empty(self.kind.size)
        block = 1 << 16        # by blocks: no (M, 3) temporaries (row by row the same floats)
        for lo in range(0, out.size, block):
            out[lo:lo + block] = np.linalg.norm(self.end[lo:lo + block] - self.start[lo:lo + block], axis=1)
        for m in np.flatnonzero(self.kind == ARC):
            out[m] = arc_geometry(self, m)["length"]
        for m, curve in self.nurbs.items():
            out[m] = curve.length
        return out


def why_nothing_to_advise(program: Program) -> str:
    """Why ``program`` has no cut: its moves counted by what keeps them from being advised (rapids,
    drilling cycles, rotary moves, feed moves in G93/G95, from unknown positions, or no move)."""
    kind = program.kind
    if kind.size == 0:
        return "no moves"
    feed_line = program.move_line
    mode = program.feed_mode[np.maximum(feed_line, 0)]
    rotary = program.rotary if program.rotary is not None else np.zeros(kind.size, bool)
    known = program.known if program.known is not None else np.ones(kind.size, bool)
    cut = np.isin(kind, ADVISED_KINDS)
    parts = [(np.isin(kind, (RAPID, HOME)), "rapid move(s)"),
             (kind == SYNCED, "spindle-synchronised move(s) (G33/G33.1), kept as written"),
             (kind == CYCLE, "drilling cycle(s), kept as written"),
             (cut & rotary, "move(s) turning a rotary axis (A/B/C), kept as written"),
             (cut & ~rotary & (mode != 94), "feed move(s) in G93/G95, kept as written"),
             (((kind == KEPT) | (cut & ~known)) & ~rotary & (mode == 94),
              "move(s) from a position the offsets leave unknown, kept as written")]
    said = [f"{int(sel.sum())} {what}" for sel, what in parts if sel.any()]
    return "; ".join(said) if said else "only moves of zero length"


def arc_geometry(program: Program, m: int) -> dict:
    """The exact circle of arc move ``m``: plane axes (a, b, n), centre (a, b), radius (mm),
    start angle, signed sweep (rad, + counter-clockwise), helical rise along n, length, curvature."""
    a, b, n = PLANE_AXES[int(program.arc_plane[m])]
    s, e, c = program.start[m], program.end[m], program.centre[m]
    r0 = float(np.hypot(s[a] - c[a], s[b] - c[b]))
    r1 = float(np.hypot(e[a] - c[a], e[b] - c[b]))
    a0 = float(np.arctan2(s[b] - c[b], s[a] - c[a]))
    a1 = float(np.arctan2(e[b] - c[b], e[a] - c[a]))
    turns = int(program.turns[m])
    if turns < 0:
        sweep = -((a0 - a1) % (2 * np.pi))
        sweep = sweep if sweep != 0 else -2 * np.pi
        sweep -= 2 * np.pi * (-turns - 1)
    else:
        sweep = (a1 - a0) % (2 * np.pi)
        sweep = sweep if sweep != 0 else 2 * np.pi
        sweep += 2 * np.pi * (turns - 1)
    rise = float(e[n] - s[n])
    r = 0.5 * (r0 + r1)
    planar = abs(sweep) * r
    length = float(np.hypot(planar, rise))
    pitch = rise / abs(sweep)                      # rise per radian
    kappa = r / (r * r + pitch * pitch)            # helix curvature (1/r when planar)
    return {"axes": (a, b, n), "centre": (float(c[a]), float(c[b])), "r0": r0, "r1": r1,
            "radius": r, "a0": a0, "sweep": float(sweep), "rise": rise, "length": length,
            "curvature": kappa}


def arc_points(program: Program, m: int, fractions: np.ndarray) -> np.ndarray:
    """Points (k, 3) mm at the given fractions (0..1) of arc move ``m``'s sweep: on the exact
    circle (radius blended linearly from start to end radius, as LinuxCNC does), helical along
    the plane's normal."""
    g = arc_geometry(program, m)
    a, b, n = g["axes"]
    f = np.asarray(fractions, dtype=float)
    ang = g["a0"] + g["sweep"] * f
    rad = g["r0"] + (g["r1"] - g["r0"]) * f
    out = np.empty((f.size, 3))
    out[:, a] = g["centre"][0] + rad * np.cos(ang)
    out[:, b] = g["centre"][1] + rad * np.sin(ang)
    out[:, n] = program.start[m, n] + g["rise"] * f
    out[f == 0] = program.start[m]
    out[f == 1] = program.end[m]
    return out


def move_end_tangents(program: Program, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit tangents (3,) of move ``m`` at its start and its end: a line's direction, an arc's
    exact tangent (d/df of :func:`arc_points`), a G5.2 block's C′ at its ends."""
    kind = int(program.kind[m])
    if kind == ARC:
        g = arc_geometry(program, m)
        a, b, n = g["axes"]
        out = []
        for f in (0.0, 1.0):
            ang = g["a0"] + g["sweep"] * f
            rad = g["r0"] + (g["r1"] - g["r0"]) * f
            d = np.zeros(3)
            d[a] = -rad * np.sin(ang) * g["sweep"] + (g["r1"] - g["r0"]) * np.cos(ang)
            d[b] = rad * np.cos(ang) * g["sweep"] + (g["r1"] - g["r0"]) * np.sin(ang)
            d[n] = g["rise"]
            out.append(d)
    elif kind == NURBS and int(m) in program.nurbs:
        curve = program.nurbs[int(m)]
        d1 = curve.evaluate(np.array(curve.domain, dtype=float), order=1)[1]
        out = [np.pad(row, (0, 3 - row.size)) for row in d1]
    else:
        d = program.end[m] - program.start[m]
        out = [d, d]
    unit = []
    for d in out:
        norm = float(np.linalg.norm(d))
        unit.append(d / norm if norm > 0 else np.zeros(3))
    return unit[0], unit[1]
