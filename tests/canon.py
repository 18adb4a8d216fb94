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
