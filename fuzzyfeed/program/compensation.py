"""Cutter radius compensation (G41/G42, G41.1/G42.1) as LinuxCNC's interpreter computes it: the
programmed moves in, the tool-centre moves out (``interp_convert.cc`` convert_straight_comp1/2,
convert_arc_comp1/2 and ``interp_queue.cc`` move_endpoint_and_flush).

The tool radius comes from G41.1/G42.1's D (a diameter), or for G41/G42 from the tool table: the
tool of the D word, else the tool in the spindle (the last M6). A negative radius swaps the side.
The first move after G41/G42 is the *entry*: a line (or arc) whose end is offset by the radius,
perpendicular to the move; it must be longer than the radius. Every later move is offset to its
side; at a convex corner (turning more than 0.05 rad away from the offset side) an arc of the tool
radius around the programmed corner is inserted (a rapid to its end for G0); at a concave corner
the previous move is cut back where the two offset moves meet (line-line, line-arc, arc-line,
arc-arc), refused where the tool cannot reach the corner without gouging. A move without XY motion
keeps the tool where it is (its XY end follows the corner cut-back). G40 ends compensation: the
next move goes from the compensated point to its programmed end. In G18 the same computation runs
on (Z, X), as LinuxCNC's does (a mill's tool: lathe tool orientations are not read).

Every output move belongs to the programmed move whose line made it (an inserted corner arc to the
line after the corner, as LinuxCNC runs it at that line's F). Lengths are in mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fuzzyfeed.program.model import ARC, LINE, RAPID

#: LinuxCNC's TOLERANCE_CONCAVE_CORNER (rad): a turn smaller than this needs no corner arc.
CONCAVE_CORNER_RAD = 0.05
#: TOLERANCE_EQUAL, and the arc-shortening allowance of the gouge check (mm; 0.001 in in inch).
_EQUAL = 1e-6
_GOUGE_MM = {False: 0.0254, True: 0.0254}


@dataclass
class _Move:
    kind: int                 # RAPID, LINE or ARC
    end: np.ndarray           # (3,) mm
    src: int                  # the programmed move it belongs to
    centre: tuple = (math.nan, math.nan)
    turn: int = 0             # signed turns (arcs)
    sweep: float = 0.0        # original sweep (rad) of a queued arc, for the gouge check
    direction: tuple = (0.0, 0.0)   # original direction of a queued line, for the gouge check


@dataclass(frozen=True)
class Compensated:
    """The moves of a program after compensation: per output move the programmed move it
    belongs to (``src``), its kind, start, end (mm), arc centre (XY; NaN else) and signed turns."""

    src: np.ndarray
    kind: np.ndarray
    start: np.ndarray
    end: np.ndarray
    centre: np.ndarray
    turns: np.ndarray


def _find_turn(x1, y1, cx, cy, turn, x2, y2) -> float:
    """LinuxCNC's find_turn: the signed sweep (rad) from (x1, y1) to (x2, y2) about (cx, cy)."""
    if turn == 0:
        return 0.0
    a = math.atan2(y1 - cy, x1 - cx)
    b = math.atan2(y2 - cy, x2 - cx)
    if turn > 0:
        if b <= a:
            b += 2 * math.pi
        return (b - a) + (turn - 1) * 2 * math.pi
    if a <= b:
        a += 2 * math.pi
    return (b - a) + (turn + 1) * 2 * math.pi


def _inside(side: int, turn: int) -> bool:
    """LinuxCNC's TOOL_INSIDE_ARC: left of a counter-clockwise arc or right of a clockwise one."""
    return (side > 0 and turn > 0) or (side < 0 and turn < 0)


class _Compensator:
    """LinuxCNC's compensation state: the tool point, the programmed point, the queue."""

    def __init__(self, fail, inch: bool):
        self.fail = fail
        self.out: list[_Move] = []
        self.queue: list[_Move] = []
        self.endpoint = (0.0, 0.0)
        self.endpoint_valid = False
        self.gouge = _GOUGE_MM[inch]

    # ----------------------------------------------------------------- queue
    def dequeue(self):
        self.endpoint_valid = False
        self.out.extend(self.queue)
        self.queue = []

    def set_endpoint(self, x, y):
        self.endpoint = (x, y)
        self.endpoint_valid = True

    def move_endpoint_and_flush(self, m: int, x: float, y: float):
        for q in self.queue:
            if q.kind == ARC:
                r1 = math.hypot(q.end[0] - q.centre[0], q.end[1] - q.centre[1])
                r2 = math.hypot(x - q.centre[0], y - q.centre[1])
                l2 = _find_turn(self.endpoint[0], self.endpoint[1], q.centre[0], q.centre[1], q.turn, x, y)
                if abs(r1 - r2) > 0.01:
                    self.fail(m, "cutter compensation made an arc with mismatched radii")
                if q.sweep != 0.0 and self.endpoint_valid and abs(l2) > abs(q.sweep) + self.gouge:
                    self.fail(m, "arc move in a concave corner cannot be reached by the tool without "
                                 "gouging (cutter compensation)")
            else:
                dx, dy = q.direction
                if self.endpoint_valid and dx * (x - self.endpoint[0]) + dy * (y - self.endpoint[1]) < 0:
                    self.fail(m, "straight move in a concave corner cannot be reached by the tool "
                                 "without gouging (cutter compensation)")
            q.end = np.array([x, y, q.end[2]])
        self.dequeue()
        self.set_endpoint(x, y)

    def enqueue(self, move: _Move):
        self.queue.append(move)

    # ----------------------------------------------------------------- moves
    def straight_first(self, m, kind, side, radius, current, p):
        cx, cy = current[:2]
        if math.hypot(p[0] - cx, p[1] - cy) <= radius:
            self.fail(m, "the cutter compensation entry move is not longer than the tool radius "
                         f"({radius:.4g} mm; LinuxCNC refuses it)")
        alpha = math.atan2(p[1] - cy, p[0] - cx) + (math.pi / 2 if side > 0 else -math.pi / 2)
        end = np.array([p[0] + radius * math.cos(alpha), p[1] + radius * math.sin(alpha), p[2]])
        self.set_endpoint(cx, cy)
        self.enqueue(_Move(kind, end, m, direction=(math.cos(alpha), math.sin(alpha))))
        return end

    def straight_next(self, m, kind, side, radius, current, programmed, p):
        cx, cy, cz = current
        opx, opy = programmed[:2]
        if p[1] == opy and p[0] == opx:                      # no XY motion
            end = np.array([cx, cy, p[2]])
            self.enqueue(_Move(kind, end, m, direction=(0.0, 0.0)))
            return end
        theta = math.atan2(cy - opy, cx - opx)
        alpha = math.atan2(p[1] - opy, p[0] - opx)
        if side > 0:
            if theta < alpha:
                theta += 2 * math.pi
            beta = (theta - alpha) - math.pi / 2
            gamma = math.pi / 2
        else:
            if alpha < theta:
                alpha += 2 * math.pi
            beta = (alpha - theta) - math.pi / 2
            gamma = -math.pi / 2
        end = np.array([p[0] + radius * math.cos(alpha + gamma), p[1] + radius * math.sin(alpha + gamma), p[2]])
        mid = (opx + radius * math.cos(alpha + gamma), opy + radius * math.sin(alpha + gamma))
        small = CONCAVE_CORNER_RAD
        front_arc = self.queue[0] if self.queue and self.queue[0].kind == ARC else None
        if beta < -small or beta > math.pi + small:
            concave = True
        elif beta > math.pi - small and front_arc is not None and (
                (side < 0 and front_arc.turn > 0) or (side > 0 and front_arc.turn < 0)):
            concave = True
        else:
            concave = False
        if not concave and beta > small:                     # convex: arc (or rapid) round the corner
            self.move_endpoint_and_flush(m, cx, cy)
            if kind == LINE:
                self.enqueue(_Move(ARC, np.array([mid[0], mid[1], cz]), m, centre=(opx, opy),
                                   turn=-1 if side > 0 else 1))
            else:
                self.enqueue(_Move(RAPID, np.array([mid[0], mid[1], cz]), m))
            self.dequeue()
            self.set_endpoint(*mid)
        elif concave:
            if front_arc is None:
                halfcorner = (beta + math.pi) / 2.0
                if halfcorner == 0.0:
                    self.fail(m, "a zero-degree inside corner is invalid for cutter compensation")
                retreat = radius / math.tan(halfcorner)
                mx = cx + retreat * math.cos(theta + gamma)
                my = cy + retreat * math.sin(theta + gamma)
                self.move_endpoint_and_flush(m, mx, my)
            else:
                mx, my = self._arc_to_line(m, front_arc, side, radius, programmed, p)
                self.move_endpoint_and_flush(m, mx, my)
        else:
            self.dequeue()
            self.set_endpoint(cx, cy)
        self.enqueue(_Move(kind, end, m, direction=(p[0] - opx, p[1] - opy)))
        return end

    def _arc_to_line(self, m, prev, side, radius, programmed, p):
        opx, opy = programmed[:2]
        oldrad = math.hypot(prev.centre[1] - prev.end[1], prev.centre[0] - prev.end[0])
        base_dir = math.atan2(p[1] - opy, p[0] - opx)
        theta = base_dir + math.pi / 2 if prev.turn > 0 else base_dir - math.pi / 2
        phi = math.atan2(prev.centre[1] - opy, prev.centre[0] - opx)
        inside = _inside(side, prev.turn)
        oldrad_uncomp = oldrad + radius if inside else oldrad - radius
        d = oldrad_uncomp * math.cos(theta - phi)
        d2 = d - radius if inside else d + radius
        ratio = d2 / oldrad
        if not -1.0 <= ratio <= 1.0:
            self.fail(m, "arc to straight motion makes a corner the compensated tool cannot fit in "
                         "without gouging")
        if inside:
            angle = (-math.acos(ratio) if prev.turn > 0 else math.acos(ratio)) + theta + math.pi
        else:
            angle = (math.acos(ratio) if prev.turn > 0 else -math.acos(ratio)) + theta + math.pi
        return prev.centre[0] + oldrad * math.cos(angle), prev.centre[1] + oldrad * math.sin(angle)

    def arc_first(self, m, side, radius, current, p, centre, turn):
        cx, cy = current[:2]
        if math.hypot(p[0] - cx, p[1] - cy) <= radius:
            self.fail(m, "the cutter compensation entry arc is not longer than the tool radius "
                         f"({radius:.4g} mm; LinuxCNC refuses it)")
        arc_radius = math.hypot(centre[0] - cx, centre[1] - cy)
        if arc_radius <= radius and _inside(side, turn):
            self.fail(m, f"tool radius {radius:.4g} mm is not less than the arc radius "
                         f"{arc_radius:.4g} mm (cutter compensation)")
        if _inside(side, turn):
            gamma = math.atan2(centre[1] - p[1], centre[0] - p[0])
        else:
            gamma = math.atan2(p[1] - centre[1], p[0] - centre[0])
        ex, ey = p[0] + radius * math.cos(gamma), p[1] + radius * math.sin(gamma)
        b_len = math.hypot(cy - ey, cx - ex) / 2.0
        ab = math.atan2(centre[1] - ey, centre[0] - ex)
        a_ang = math.atan2(cy - ey, cx - ex) - ab
        if abs(math.cos(a_ang)) < _EQUAL:
            self.fail(m, "tool radius not less than the arc radius (cutter compensation)")
        c_len = b_len / math.cos(a_ang)
        ncx, ncy = ex + c_len * math.cos(ab), ey + c_len * math.sin(ab)
        end = np.array([ex, ey, p[2]])
        self.enqueue(_Move(ARC, end, m, centre=(ncx, ncy), turn=turn,
                           sweep=_find_turn(cx, cy, ncx, ncy, turn, ex, ey)))
        return end

    def arc_next(self, m, side, radius, current, programmed, p, centre, turn):
        cx, cy, cz = current
        opx, opy = programmed[:2]
        ccx, ccy = centre
        arc_radius = math.hypot(ccx - p[0], ccy - p[1])
        theta = math.atan2(cy - opy, cx - opx)
        theta = theta - math.pi / 2 if side > 0 else theta + math.pi / 2
        delta = math.atan2(ccy - opy, ccx - opx)
        alpha = delta - math.pi / 2 if turn > 0 else delta + math.pi / 2
        beta = theta - alpha if side > 0 else alpha - theta
        if beta > 1.5 * math.pi:
            beta -= 2 * math.pi
        elif beta < -math.pi / 2:
            beta += 2 * math.pi
        if _inside(side, turn):
            gamma = math.atan2(ccy - p[1], ccx - p[0])
            if arc_radius <= radius:
                self.fail(m, f"tool radius {radius:.4g} mm is not less than the arc radius "
                             f"{arc_radius:.4g} mm (cutter compensation)")
        else:
            gamma = math.atan2(p[1] - ccy, p[0] - ccx)
            delta += math.pi
        end = np.array([p[0] + radius * math.cos(gamma), p[1] + radius * math.sin(gamma), p[2]])
        small = CONCAVE_CORNER_RAD
        sweep = _find_turn(opx, opy, ccx, ccy, turn, p[0], p[1])
        main = _Move(ARC, end, m, centre=(ccx, ccy), turn=turn, sweep=sweep)
        front_arc = self.queue[0] if self.queue and self.queue[0].kind == ARC else None
        if beta < -small or beta > math.pi + small or (abs(beta - math.pi) < small and not _inside(side, turn)):
            if front_arc is None:
                cy_ = arc_radius * math.sin(beta - math.pi / 2)
                if _inside(side, turn):
                    dist = arc_radius - radius
                    ratio = (cy_ + radius) / dist
                    if not -1.0 <= ratio <= 1.0:
                        self.fail(m, "arc move in a concave corner cannot be reached by the tool "
                                     "without gouging (cutter compensation)")
                    angle = theta + math.asin(ratio) if turn > 0 else theta - math.asin(ratio)
                else:
                    dist = arc_radius + radius
                    ratio = (cy_ - radius) / dist
                    if not -1.0 <= ratio <= 1.0:
                        self.fail(m, "arc move in a concave corner cannot be reached by the tool "
                                     "without gouging (cutter compensation)")
                    angle = theta + math.pi - math.asin(ratio) if turn > 0 else theta + math.pi + math.asin(ratio)
                mx, my = ccx + dist * math.cos(angle), ccy + dist * math.sin(angle)
            else:
                prev = front_arc
                oldrad = math.hypot(prev.centre[1] - prev.end[1], prev.centre[0] - prev.end[0])
                newrad = arc_radius - radius if _inside(side, turn) else arc_radius + radius
                arc_cc = math.hypot(prev.centre[1] - ccy, prev.centre[0] - ccx)
                if oldrad == 0 or arc_cc == 0:
                    self.fail(m, "arc to arc motion is invalid because the arcs have the same centre "
                                 "(cutter compensation)")
                a = (oldrad ** 2 + arc_cc ** 2 - newrad ** 2) / (2 * oldrad * arc_cc)
                if not -1.0 <= a <= 1.0:
                    self.fail(m, "arc to arc motion makes a corner the compensated tool cannot fit "
                                 "in without gouging")
                pullback = math.acos(a)
                cc_dir = math.atan2(ccy - prev.centre[1], ccx - prev.centre[0])
                if _inside(side, prev.turn):
                    direction = cc_dir + pullback if turn > 0 else cc_dir - pullback
                else:
                    direction = cc_dir - pullback if turn > 0 else cc_dir + pullback
                mx, my = prev.centre[0] + oldrad * math.cos(direction), prev.centre[1] + oldrad * math.sin(direction)
            self.move_endpoint_and_flush(m, mx, my)
            self.enqueue(main)
        elif beta > small:                                   # convex: corner arc, then the arc
            mx, my = opx + radius * math.cos(delta), opy + radius * math.sin(delta)
            self.dequeue()
            self.enqueue(_Move(ARC, np.array([mx, my, cz]), m, centre=(opx, opy),
                               turn=-1 if side > 0 else 1))
            self.dequeue()
            self.set_endpoint(mx, my)
            self.enqueue(main)
        else:
            self.dequeue()
            self.set_endpoint(cx, cy)
            self.enqueue(main)
        return end


def compensate(kind: np.ndarray, start: np.ndarray, end: np.ndarray, centre: np.ndarray,
               turns: np.ndarray, side: np.ndarray, radius_mm: np.ndarray, plane: np.ndarray, inch: bool,
               fail, resets: np.ndarray | None = None) -> Compensated:
    """The moves after compensation (see the module docstring). Per programmed move: ``side``
    +1 (G41, left), −1 (G42, right) or 0 (off), ``radius_mm`` the tool radius (used where side
    ≠ 0), ``plane`` 17 or 18 (XZ: the algorithm runs on (Z, X) as LinuxCNC's does);
    ``fail(move, message)`` raises the caller's one-line error; ``resets`` (M, 3) marks the axes
    whose frame changed (G43, G5x, ...) since the move before: a move that follows a compensated
    one starts where the tool is but for those axes, which take the program's start."""
    comp = _Compensator(fail, inch)
    current = None
    programmed = None
    first = True
    axes = np.array([0, 1, 2])
    order: list[tuple[_Move, bool]] = []          # every output move and whether it follows on

    def flush_out():
        for mv in comp.out:                          # back from plane coordinates to X, Y, Z
            xyz = np.empty(3)
            xyz[axes] = mv.end
            mv.end = xyz
            c = np.full(3, math.nan)
            if mv.kind == ARC:
                c[axes[0]], c[axes[1]] = mv.centre
            mv.centre = tuple(c)
            order.append((mv, True))
        comp.out = []

    for m in range(kind.size):
        s = int(side[m])
        if s == 0:
            follows = not first
            if not first:                                   # G40: flush, the tool stays where it is
                comp.move_endpoint_and_flush(m, current[0], current[1])
                comp.dequeue()
                flush_out()
                first = True
            order.append((_Move(int(kind[m]), end[m].copy(), m, centre=tuple(centre[m]),
                                turn=int(turns[m])), follows))
            continue
        if first:
            axes = np.array([2, 0, 1]) if int(plane[m]) == 18 else np.array([0, 1, 2])
        p = end[m][axes]
        r = float(radius_mm[m])
        if r < 0:
            r, s = -r, -s
        here = start[m][axes] if current is None or first else current
        if kind[m] in (RAPID, LINE):
            if first:
                new = comp.straight_first(m, int(kind[m]), s, r, here, p)
            else:
                new = comp.straight_next(m, int(kind[m]), s, r, here, programmed, p)
        elif kind[m] == ARC:
            c = (float(centre[m, axes[0]]), float(centre[m, axes[1]]))
            if first:
                new = comp.arc_first(m, s, r, here, p, c, int(turns[m]))
            else:
                new = comp.arc_next(m, s, r, here, programmed, p, c, int(turns[m]))
        else:
            fail(m, "only G0, G1, G2 and G3 moves can run under cutter compensation (LinuxCNC refuses "
                    "the others)")
        first = False
        current = new
        programmed = p.copy()
        flush_out()
    comp.dequeue()
    flush_out()
    n = len(order)
    out_start = np.empty((n, 3))
    prev = start[0] if kind.size else np.zeros(3)
    for k, (mv, follows) in enumerate(order):
        # a compensated move starts where the last one ended; others where the program put them
        out_start[k] = prev if follows else start[mv.src]
        if follows and resets is not None:
            out_start[k] = np.where(resets[mv.src], start[mv.src], prev)
        prev = mv.end
    moves = [mv for mv, _ in order]
    return Compensated(src=np.array([mv.src for mv in moves], dtype=np.int64),
                       kind=np.array([mv.kind for mv in moves], dtype=np.int8),
                       start=out_start, end=np.array([mv.end for mv in moves]).reshape(n, 3),
                       centre=np.array([mv.centre for mv in moves], dtype=float).reshape(n, 3),
                       turns=np.array([mv.turn for mv in moves], dtype=np.int64))


def comp_per_line(comp_code: np.ndarray, comp_given: np.ndarray, d_col: np.ndarray, loaded: np.ndarray,
                  plane: np.ndarray, scale: np.ndarray, tools: dict | None, fail):
    """Per line of a program: the compensation side in force (+1 G41, −1 G42, 0 G40) and the tool
    radius (mm; NaN when no diameter is known: G41/G42 without a tool table or with a tool not in
    it). ``comp_code`` is the modal code × 10 in force, ``comp_given`` the lines that give one,
    ``loaded`` the tool in the spindle; ``fail(line, message)`` raises the one-line error."""
    n = comp_code.size
    side = np.where(np.isin(comp_code, [410, 411]), 1, np.where(np.isin(comp_code, [420, 421]), -1, 0))
    radius = np.full(n, np.nan)
    for i in np.flatnonzero(comp_given & (side != 0)):
        code = int(comp_code[i])
        if plane[i] not in (17, 18):
            fail(i, f"G{code / 10:g} in the G{int(plane[i])} plane: cutter compensation works in G17 (XY) "
                    "and G18 (XZ) only (LinuxCNC refuses the others)")
        if i > 0 and side[i - 1] != 0:
            fail(i, f"G{code / 10:g} while cutter compensation is on: turn it off with G40 first "
                    "(LinuxCNC refuses it)")
        d = d_col[i]
        if code in (411, 421):
            if np.isnan(d):
                fail(i, f"G{code / 10:g} with no D word: G41.1/G42.1 take the tool diameter as D")
            radius[i] = d * scale[i] / 2.0
            continue
        if not np.isnan(d):
            if d != round(d) or d < 0:
                fail(i, f"G{code / 10:g} D{d:g}: D is a tool number (a whole number >= 0)")
            tool = int(d)
        else:
            tool = int(loaded[i])
        if tools is not None and tool in tools:
            radius[i] = tools[tool] / 2.0
        elif tools is not None and not np.isnan(d):
            fail(i, f"G{code / 10:g} D{tool}: tool {tool} is not in the tool table")
    # the radius set where compensation turns on holds until G40
    start = comp_given & (side != 0)
    idx = np.where(start, np.arange(n), -1)
    np.maximum.accumulate(idx, out=idx)
    radius = np.where((side != 0) & (idx >= 0), radius[np.maximum(idx, 0)], np.nan)
    return side, radius
