"""LinuxCNC's canonical machine calls (``rs274 -g``) of a program, and the comparison of an
original program's calls with a rewritten one's: the same calls in the same order except
SET_FEED_RATE values and split feed moves, the same rapids, the same feed-move geometry (1 µm)
and length, every feed > 0 and at most the original feed at the same place."""

from __future__ import annotations

import math
import os
import re
import subprocess
from pathlib import Path

import numpy as np

from test_gcode_export import rs274_binary

#: Geometry tolerance of the comparison (mm): 1 µm.
TOL_MM = 1e-3
_CALL = re.compile(r"^\s*\d+\s+N\S*\s+([A-Z_0-9]+)\((.*)\)\s*$")


def tool_table(directory: Path) -> Path:
    """A tool table with tools 1-20 (rs274 refuses T/M6/G43 H for tools it does not know)."""
    path = directory / "tools.tbl"
    path.write_text("".join(f"T{t} P{t} Z{0.5 + 0.1 * t:.3f} D6 ;end mill {t}\n" for t in range(1, 21)))
    return path


def canon(program: Path, workdir: Path, tools: Path | None = None) -> list[tuple[str, str]]:
    """(name, arguments) of every canonical call rs274 prints for ``program`` (exit 0 asserted),
    with the tool table ``tools`` (default :func:`tool_table`)."""
    out = workdir / (program.name + ".canon")
    table = tools if tools is not None else tool_table(workdir)
    done = subprocess.run([rs274_binary(), "-t", str(table), "-g", str(program), str(out)],
                          capture_output=True, text=True, stdin=subprocess.DEVNULL, timeout=300,
                          cwd=workdir, env={**os.environ, "HOME": str(workdir)})
    # rs274 keeps its parameter file in the working directory and maps the tool table into
    # $HOME/.tool.mmap, shared by every rs274 of that HOME: each run gets its own
    assert done.returncode == 0, f"rs274 rejected {program}: {done.stdout[-400:]} {done.stderr[-400:]}"
    calls = []
    for line in out.read_text().splitlines():
        m = _CALL.match(line)
        if m:
            calls.append((m.group(1), m.group(2)))
    assert calls and calls[-1][0] in ("PROGRAM_END", "ON_RESET"), f"{program}: no PROGRAM_END"
    return calls


def _nums(args: str) -> np.ndarray:
    return np.array([float(a) for a in re.split(r"[,\s]+", args.strip()) if a], dtype=float)


def _events(calls):
    """Calls without SET_FEED_RATE, each with the feed rate in force."""
    rate = 0.0
    out = []
    for name, args in calls:
        if name == "SET_FEED_RATE":
            rate = float(args)
            continue
        out.append((name, args, rate))
    return out


def _arc_sweep(start, a):
    """Signed sweep (rad) and length of an ARC_FEED from ``start`` (plane coords a1, a2, n)."""
    e1, e2, c1, c2, rot, n_end = a[0], a[1], a[2], a[3], int(a[4]), a[5]
    a0 = math.atan2(start[1] - c2, start[0] - c1)
    a1 = math.atan2(e2 - c2, e1 - c1)
    if rot > 0:
        sweep = (a1 - a0) % (2 * math.pi)
        sweep = sweep if sweep > 1e-12 else 2 * math.pi
        sweep += 2 * math.pi * (rot - 1)
    else:
        sweep = -((a0 - a1) % (2 * math.pi))
        sweep = sweep if sweep < -1e-12 else -2 * math.pi
        sweep -= 2 * math.pi * (-rot - 1)
    r = math.hypot(start[0] - c1, start[1] - c2)
    return sweep, math.hypot(abs(sweep) * r, n_end - start[2])


class Comparison:
    """Result of :func:`compare`: counts and the lowest ratio written feed / programmed feed."""

    def __init__(self):
        self.feed_moves = 0
        self.pieces = 0
        self.min_ratio = 1.0
        self.ratios = []


def compare(original, rewritten) -> Comparison:
    """Assert that ``rewritten``'s calls equal ``original``'s except SET_FEED_RATE values and split
    feed moves (see the module docstring); returns what was compared."""
    a, b = _events(original), _events(rewritten)
    res = Comparison()
    plane = "CANON_PLANE_XY"
    pos = np.zeros(3)
    j = 0
    for name, args, rate in a:
        if name == "SELECT_PLANE":
            plane = args.strip()
        if name not in ("STRAIGHT_FEED", "ARC_FEED", "NURBS_FEED"):
            assert j < len(b), f"rewritten program ends early; expected {name}({args})"
            assert (b[j][0], b[j][1]) == (name, args), f"call {j}: {b[j][0]}({b[j][1]}) != {name}({args})"
            if name in ("STRAIGHT_TRAVERSE",):
                pos = _nums(args)[:3]
            j += 1
            continue
        res.feed_moves += 1
        if name == "NURBS_FEED":
            assert b[j][:2] == (name, args), f"call {j}: {b[j][:2]} != {name}({args})"
            assert 0 < b[j][2] <= rate + 1e-9, f"NURBS feed {b[j][2]} > programmed {rate}"
            res.ratios.append(b[j][2] / rate)
            j += 1
            pos = None  # rs274 does not print where a NURBS ends
            continue
        v = _nums(args)
        if pos is None and name == "STRAIGHT_FEED":
            # start unknown: the pieces must lie on the line from the first piece's end
            k = j
            while k < len(b) and b[k][0] == "STRAIGHT_FEED" and \
                    np.linalg.norm(_nums(b[k][1])[:3] - v[:3]) > TOL_MM:
                k += 1
            pos = _nums(b[j][1])[:3] if k > j else v[:3]
            if k > j:
                fb = b[j][2]
                assert 0 < fb <= rate + 1e-9
                res.ratios.append(fb / rate)
                res.pieces += 1
                j += 1
        if name == "STRAIGHT_FEED":
            target = v[:3]
            total = float(np.linalg.norm(target - pos))
            d = (target - pos) / total if total > 0 else np.zeros(3)
            length = 0.0
            here = pos.copy()
            while True:
                assert j < len(b) and b[j][0] == "STRAIGHT_FEED", \
                    f"expected a piece of STRAIGHT_FEED({args}), got {b[j][:2] if j < len(b) else 'end'}"
                w = _nums(b[j][1])
                assert np.array_equal(w[3:], v[3:]), f"rotary axes changed: {b[j][1]} vs {args}"
                p = w[:3]
                off = (p - pos) - np.dot(p - pos, d) * d
                assert np.linalg.norm(off) <= TOL_MM, f"piece end {p} is {np.linalg.norm(off)} mm off the line to {target}"
                fb = b[j][2]
                assert 0 < fb <= rate + 1e-9, f"feed {fb} > programmed {rate} on STRAIGHT_FEED({args})"
                res.ratios.append(fb / rate)
                length += float(np.linalg.norm(p - here))
                here = p
                res.pieces += 1
                j += 1
                if np.linalg.norm(p - target) <= TOL_MM:
                    break
            assert abs(length - total) <= TOL_MM, f"length {length} != {total}"
            pos = target
        else:  # ARC_FEED(first_end, second_end, first_axis, second_axis, rotation, axis_end, a, b, c, ...)
            idx = {"CANON_PLANE_XY": (0, 1, 2), "CANON_PLANE_XZ": (2, 0, 1), "CANON_PLANE_YZ": (1, 2, 0)}[plane]
            start = np.array([pos[idx[0]], pos[idx[1]], pos[idx[2]]])
            sweep, length_a = _arc_sweep(start, v)
            here = start
            swept, length = 0.0, 0.0
            while True:
                assert j < len(b) and b[j][0] == "ARC_FEED", \
                    f"expected a piece of ARC_FEED({args}), got {b[j][:2] if j < len(b) else 'end'}"
                w = _nums(b[j][1])
                assert np.all(np.abs(w[2:4] - v[2:4]) <= TOL_MM), f"arc centre moved: {b[j][1]} vs {args}"
                assert np.sign(w[4]) == np.sign(v[4]), f"arc direction changed: {b[j][1]} vs {args}"
                assert np.array_equal(w[6:], v[6:])
                s_k, l_k = _arc_sweep(here, w)
                fb = b[j][2]
                assert 0 < fb <= rate + 1e-9, f"feed {fb} > programmed {rate} on ARC_FEED({args})"
                res.ratios.append(fb / rate)
                swept += s_k
                length += l_k
                here = np.array([w[0], w[1], w[5]])
                res.pieces += 1
                j += 1
                if np.all(np.abs(w[[0, 1, 5]] - v[[0, 1, 5]]) <= TOL_MM) and abs(abs(swept) - abs(sweep)) < 1e-3:
                    break
            assert abs(swept - sweep) <= 1e-3, f"sweep {swept} != {sweep} for ARC_FEED({args})"
            assert abs(length - length_a) <= TOL_MM * 2, f"arc length {length} != {length_a}"
            end = np.empty(3)
            end[idx[0]], end[idx[1]], end[idx[2]] = v[0], v[1], v[5]
            pos = end
    assert j == len(b), f"rewritten program has {len(b) - j} extra calls: {b[j:j + 3]}"
    res.min_ratio = min(res.ratios) if res.ratios else 1.0
    return res


# --- parity of the reader's moves with rs274's (issue 40) -------------------------------------

#: Marker comment put before every line of a program run through rs274: its COMMENT call names
#: the line the following calls come from (rs274 prints only the last comment of a line, so the
#: marker stands on a line of its own).
_MARK = "FFLINE "
_PLANE_IDX = {"CANON_PLANE_XY": (0, 1, 2), "CANON_PLANE_XZ": (2, 0, 1), "CANON_PLANE_YZ": (1, 2, 0)}
_MOTION = ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "ARC_FEED", "NURBS_FEED", "STRAIGHT_PROBE", "RIGID_TAP")


def marked(text: str, base: int = 0) -> str:
    """``text`` with a comment line ``(FFLINE k)`` before every line k (0-based, plus ``base``) but
    '%' lines."""
    out = []
    for k, line in enumerate(text.split("\n")):
        if line.strip() != "%":
            out.append(f"({_MARK}{k + base})")
        out.append(line)
    return "\n".join(out)


def rs274_calls(text: str, workdir: Path, table: str, var: str | None = None, mark: bool = True):
    """(calls, "") of rs274 on ``text`` (marked, see :func:`marked`, unless already) with tool
    table ``table`` and parameter file ``var``; (None, rs274's first message) when it refuses."""
    workdir.mkdir(parents=True, exist_ok=True)
    (workdir / "p.ngc").write_text(marked(text) if mark else text)
    (workdir / "t.tbl").write_text(table)
    args = [rs274_binary(), "-t", "t.tbl", "-g", "p.ngc", "p.out"]
    if var is not None:
        (workdir / "p.var").write_text(var)
        args[1:1] = ["-v", "p.var"]
    done = subprocess.run(args, capture_output=True, text=True, stdin=subprocess.DEVNULL, timeout=120,
                          cwd=workdir, env={**os.environ, "HOME": str(workdir)})
    if done.returncode:
        said = [ln for ln in done.stdout.splitlines() if ln.strip() and ln.strip() != "executing"]
        return None, said[0] if said else f"exit {done.returncode}"
    calls = []
    for line in (workdir / "p.out").read_text().splitlines():
        m = _CALL.match(line)
        if m:
            calls.append((m.group(1), m.group(2)))
    return calls, ""


class Event:
    """One motion call of rs274: where it ends and what moved it, in mm, in the frame in force."""

    __slots__ = ("name", "line", "group", "end", "disp", "feed", "per_rev", "synced", "plane",
                 "centre", "turns")

    def __repr__(self):
        return f"{self.name}(line {self.line}, end {np.round(self.end, 4).tolist()})"


def canon_events(calls) -> list[Event]:
    """The motion calls of a marked program's listing, each with its source line (the marker
    before it), its end point and displacement in mm in the frame in force (positions are
    printed in the units then in force; a change of G5x, G92/G52 or tool length offset moves the
    frame, not the tool; a RIGID_TAP comes back where it started), and the feed in mm/min as LinuxCNC's canonical layer converts it: with
    the units in force when SET_FEED_RATE is called (issue 37)."""
    unit, feed, per_rev, synced, line, group, changed = 1.0, 0.0, False, False, -1, -1, -2
    plane = "CANON_PLANE_XY"
    here = np.zeros(3)
    offsets = {"g5x": np.zeros(3), "g92": np.zeros(3), "tool": np.zeros(3)}
    out = []
    for name, args in calls:
        if name == "COMMENT" and args.startswith('"' + _MARK):
            line, group = int(args[len(_MARK) + 1:-1]), group + 1
        elif name == "CHANGE_TOOL":
            changed = group
        elif name == "USE_LENGTH_UNITS":
            unit = 25.4 if "INCHES" in args else 1.0
        elif name == "SET_FEED_RATE":
            feed = float(args) * unit
        elif name == "SET_FEED_MODE":
            per_rev = _nums(args)[1] == 1
        elif name == "START_SPEED_FEED_SYNC":
            synced = True
        elif name == "STOP_SPEED_FEED_SYNCH":
            synced = False
        elif name == "SELECT_PLANE":
            plane = args.strip()
        elif name in ("SET_G5X_OFFSET", "SET_G92_OFFSET", "USE_TOOL_LENGTH_OFFSET"):
            v = _nums(args)
            key = {"SET_G5X_OFFSET": "g5x", "SET_G92_OFFSET": "g92", "USE_TOOL_LENGTH_OFFSET": "tool"}[name]
            new = (v[1:4] if key == "g5x" else v[:3]) * unit
            if not (key == "tool" and changed == group):
                # (rs274 keeps its coordinates when G43 stands on the line of the M6: seen with
                # Debian's 2.9.0~pre1, T4 M6 G43 then G0 X0 keeps Z)
                here = here - (new - offsets[key])
            offsets[key] = new
        elif name in _MOTION:
            e = Event()
            e.name, e.line, e.group, e.feed, e.per_rev, e.synced, e.plane = \
                name, line, group, feed, per_rev, synced, plane
            e.centre, e.turns = None, 0
            v = _nums(args) if name != "NURBS_FEED" else None
            if name == "ARC_FEED":
                a, b, n = _PLANE_IDX[plane]
                end = here.copy()
                end[a], end[b], end[n] = v[0] * unit, v[1] * unit, v[5] * unit
                e.centre, e.turns = np.array([v[2], v[3]]) * unit, int(v[4])
            elif name == "NURBS_FEED":
                end = np.full(3, np.nan)              # rs274 does not print where it ends
            else:
                end = v[:3] * unit
            e.end, e.disp = end, end - here
            if name != "RIGID_TAP":
                here = end
            out.append(e)
    return out


def parity(program, events_a: list[Event], events_b: list[Event], tol_mm: float = TOL_MM) -> dict:
    """Compare the reader's moves with rs274's motion calls of the same program run twice, with
    two parameter files and tool tables (A: offsets and home positions 0; B: other values; the
    same tool diameters). A coordinate or displacement that is the same in both runs is set by the
    program; one that differs depends on the machine's state. Checked per move, in order:

    - a RAPID, LINE, ARC, SYNCED or KEPT move is one call (STRAIGHT_TRAVERSE, STRAIGHT_FEED or
      ARC_FEED, STRAIGHT_PROBE / RIGID_TAP for KEPT / SYNCED), of the matching kind; SYNCED exactly
      the spindle-synchronised calls;
    - HOME, CYCLE and NURBS moves stand for all calls of their line's run;
    - the move is ``known`` (placed) exactly when rs274's displacement is the same in A and B, and
      then equals it within ``tol_mm`` plus rs274's print resolution (4 decimals); every end
      coordinate the program sets (same in A and B) equals the reader's; arcs have rs274's centre
      (relative to the start) and turns;
    - the feed of a LINE or ARC in G94 is rs274's, converted as the canonical layer converts it;
      a move in G95 or G93 has that feed mode in the program's arrays.

    Returns counts; raises AssertionError naming the first difference."""
    from fuzzyfeed.program.model import ARC, CYCLE, HOME, KEPT, LINE, NURBS, RAPID, SYNCED

    assert len(events_a) == len(events_b), f"rs274 runs differ in length: {len(events_a)} {len(events_b)}"
    kinds = {RAPID: ("STRAIGHT_TRAVERSE",), LINE: ("STRAIGHT_FEED",), ARC: ("ARC_FEED",),
             SYNCED: ("STRAIGHT_FEED", "RIGID_TAP"),
             KEPT: ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "ARC_FEED", "STRAIGHT_PROBE")}
    j = 0
    probed = ever_probed = False
    stats = {"moves": 0, "placed": 0, "not_placed": 0, "calls": len(events_a), "feeds": 0, "empty_calls": 0}
    lines = program.rows.line if program.rows is not None else None
    for m in range(program.kind.size):
        kind = int(program.kind[m])
        where = f"move {m} (line {int(program.move_line[m]) + 1}: {_line_text(program, m)!r})"
        assert j < len(events_a), f"{where}: rs274 has no more motion calls"
        a, b = events_a[j], events_b[j]
        while (a.name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED") and a.line != int(program.move_line[m])
               and not a.synced and np.all(np.abs(a.disp) < 1e-6) and np.all(np.abs(b.disp) < 1e-2)
               and j + 1 < len(events_a)):
            # G0/G1 with no axis words (``G00 S12000``): rs274 moves to where the tool is; no move
            stats["empty_calls"] += 1
            j += 1
            a, b = events_a[j], events_b[j]
        stats["moves"] += 1
        if kind in (HOME, CYCLE, NURBS):
            g = a.group
            while j < len(events_a) and events_a[j].group == g:
                j += 1
            continue
        assert a.name in kinds[kind], f"{where}: {a.name} in rs274 for a {kind} move ({a})"
        assert (kind == SYNCED) == (a.synced or a.name == "RIGID_TAP"), \
            f"{where}: kind {kind}, rs274 synchronised {a.synced}"
        res = 5e-5 * 25.4 * 2 + tol_mm     # both ends printed to 4 decimals (inch the coarser)
        determined = bool(np.all(np.abs(a.disp - b.disp) <= res))
        known = bool(program.known[m]) if program.known is not None else True
        if a.name == "STRAIGHT_PROBE":
            probed = ever_probed = True                 # stand-alone rs274 ends a probe at its target; a machine
        elif known:                        # where the probe trips: unknown until the program sets it
            probed = False
        if (np.isnan(a.disp).any() or (probed and not known) or (kind == KEPT and not determined)
                or a.name == "RIGID_TAP"):
            # after a NURBS_FEED rs274 does not say where the tool is: only the ends are compared
            same = np.abs(a.end - b.end) <= res
            if known and a.name != "RIGID_TAP":
                assert np.all(np.abs(program.end[m] - a.end)[same] <= res), \
                    f"{where}: end {program.end[m]} != rs274's {a.end}"
            stats["placed" if known else "not_placed"] += 1
            j += 1
            continue
        assert known == determined, (f"{where}: reader {'places' if known else 'does not place'} it, "
                                     f"rs274's displacement {a.disp} / {b.disp} with other offsets")
        if known:
            stats["placed"] += 1
            d = program.end[m] - program.start[m]
            assert np.all(np.abs(d - a.disp) <= res), f"{where}: displacement {d} != rs274's {a.disp}"
            same = (np.abs(a.end - b.end) <= res) & (not ever_probed)   # a probe's end is the machine's
            assert np.all(np.abs(program.end[m] - a.end)[same] <= res), \
                f"{where}: end {program.end[m]} != rs274's {a.end}"
            if kind == ARC:
                ax, bx, _ = _PLANE_IDX[a.plane]
                c = program.centre[m][[ax, bx]] - program.start[m][[ax, bx]]
                ca = a.centre - (a.end - a.disp)[[ax, bx]]
                assert np.all(np.abs(c - ca) <= res), f"{where}: centre {c} != rs274's {ca}"
                assert int(program.turns[m]) == a.turns, f"{where}: turns {program.turns[m]} != {a.turns}"
        else:
            stats["not_placed"] += 1
        if kind in (LINE, ARC):
            mode = int(program.feed_mode[program.move_line[m]]) if lines is None else \
                int(program.rows.feed_mode[program.rows.move_row[m]])
            if a.per_rev:
                assert mode == 95, f"{where}: feed per revolution in rs274, mode G{mode} in the reader"
            elif mode == 94:
                stats["feeds"] += 1
                assert abs(program.feed_mm_min[m] - a.feed) <= 5e-5 * 25.4 + 1e-9 * a.feed, \
                    f"{where}: feed {program.feed_mm_min[m]} mm/min != rs274's {a.feed}"
        j += 1
    while j < len(events_a) and np.all(np.abs(events_a[j].disp) < 1e-6) and not events_a[j].synced:
        stats["empty_calls"] += 1
        j += 1
    assert j == len(events_a), f"rs274 has {len(events_a) - j} more motion calls: {events_a[j:j + 3]}"
    return stats


def _line_text(program, m) -> str:
    li = int(program.move_line[m])
    return program.lines[li].strip()[:60] if 0 <= li < len(program.lines) else "another file"


def var_file(seed: int) -> str:
    """A parameter file for rs274 with offsets and home positions all different from 0 (seeded):
    G28/G30 homes, G54-G59.3 offsets (no rotation), G92 offsets (enabled); G54 selected."""
    import random

    rng = random.Random(seed)
    params = {}
    for base in (5161, 5181):
        for k in range(9):
            params[base + k] = rng.uniform(-50, 50)
    params[5210] = 1
    for k in range(9):
        params[5211 + k] = rng.uniform(-20, 20)
    params[5220] = 1
    for system in range(9):
        for k in range(9):
            params[5221 + 20 * system + k] = rng.uniform(-100, 100)
        params[5230 + 20 * system] = 0.0
    return "".join(f"{k}\t{v:.6f}\n" for k, v in sorted(params.items()))
