"""A rewritten program checked by the controller's own interpreter (issue 40 item 5): LinuxCNC's
stand-alone ``rs274`` reads the program as written and as rewritten, with the same tool table, and
must accept the rewrite and give the same canonical moves apart from the feeds (a split move's
pieces on its line or arc, within 1 µm, covering it exactly; every other call identical). Where it
refuses or the moves differ, the lines whose rewrite is to blame keep their text: the rewrite is
tried on halves of the changed lines (a bisection, at most ``max_runs`` runs of rs274) and only
the lines it accepts are rewritten.

Tool table: the one the advice used (diameters in mm, written for rs274 in inches, as the
stand-alone rs274 reads them); without one, tools 1–999 of diameter 0 so that tool changes are
accepted (compensation then has no radius, as in fuzzyfeed's reading).
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.program.model import MM_PER_INCH, Program

#: Geometry tolerance of the comparison (mm in the canonical units; 1 µm).
TOL = 1e-3
#: rs274's time limit per run (s).
TIMEOUT_S = 300
_CALL = re.compile(r"^\s*\d+\s+N\S*\s+([A-Z_0-9]+)\((.*)\)\s*$")
_FEEDS = ("STRAIGHT_FEED", "ARC_FEED", "NURBS_FEED")


def rs274_path() -> str | None:
    """rs274 on PATH, or None."""
    return shutil.which("rs274")


@dataclass(frozen=True)
class Rs274Run:
    """rs274 on one program: accepted, its first error line (and the line it names), its calls."""

    ok: bool
    message: str
    calls: tuple[tuple[str, str], ...]


def run_rs274(program: Path, tools_mm: dict[int, float] | None, workdir: Path) -> Rs274Run:
    """``rs274 -t TABLE -g program`` in ``workdir`` (its own HOME and parameter file)."""
    binary = rs274_path()
    if binary is None:
        raise InputError("--verify-rs274: rs274 not found on PATH (LinuxCNC's interpreter; Debian "
                         "package linuxcnc-uspace)")
    workdir.mkdir(parents=True, exist_ok=True)
    table = workdir / "tools.tbl"
    if tools_mm:
        table.write_text("".join(f"T{t} P{t} D{d / MM_PER_INCH:.9f} Z0 ;\n" for t, d in sorted(tools_mm.items())))
    else:
        table.write_text("".join(f"T{t} P{t} D0 Z0 ;\n" for t in range(1, 1000)))
    out = workdir / "canon.out"
    try:
        done = subprocess.run([binary, "-t", str(table), "-g", str(program), str(out)], capture_output=True,
                              text=True, stdin=subprocess.DEVNULL, timeout=TIMEOUT_S, cwd=workdir,
                              env={**os.environ, "HOME": str(workdir)})
    except subprocess.TimeoutExpired:
        return Rs274Run(False, f"rs274: no answer within {TIMEOUT_S} s", ())
    said = [ln.strip() for ln in (done.stderr + done.stdout).splitlines()
            if ln.strip() and ln.strip() != "executing"]
    calls = []
    if out.exists():
        for line in out.read_text(errors="replace").splitlines():
            m = _CALL.match(line)
            if m:
                calls.append((m.group(1), m.group(2)))
    if done.returncode != 0:
        return Rs274Run(False, " / ".join(said[:2]) or f"rs274 exit {done.returncode}", tuple(calls))
    return Rs274Run(True, "", tuple(calls))


def _nums(args: str) -> np.ndarray:
    return np.array([float(a) for a in re.split(r"[,\s]+", args.strip()) if a], dtype=float)


def _sweep(start: np.ndarray, a: np.ndarray) -> float:
    """Signed sweep (rad) of an ARC_FEED from ``start`` (plane coordinates)."""
    c1, c2, rot = a[2], a[3], int(a[4])
    a0 = math.atan2(start[1] - c2, start[0] - c1)
    a1 = math.atan2(a[1] - c2, a[0] - c1)
    if rot > 0:
        s = (a1 - a0) % (2 * math.pi)
        return (s if s > 1e-12 else 2 * math.pi) + 2 * math.pi * (rot - 1)
    s = -((a0 - a1) % (2 * math.pi))
    return (s if s < -1e-12 else -2 * math.pi) - 2 * math.pi * (-rot - 1)


_PLANES = {"CANON_PLANE_XY": (0, 1, 2), "CANON_PLANE_XZ": (2, 0, 1), "CANON_PLANE_YZ": (1, 2, 0)}


def compare_moves(original, rewritten) -> str | None:
    """None when ``rewritten``'s calls are ``original``'s apart from SET_FEED_RATE values and feed
    moves split into pieces along the same line or arc (module docstring); else what differs."""
    a = [c for c in original if c[0] != "SET_FEED_RATE"]
    b = [c for c in rewritten if c[0] != "SET_FEED_RATE"]
    plane, pos, j = "CANON_PLANE_XY", None, 0
    for i, (name, args) in enumerate(a):
        if name == "SELECT_PLANE":
            plane = args.strip()
        if name not in _FEEDS or name == "NURBS_FEED" or pos is None:
            if j >= len(b) or b[j] != (name, args):
                got = f"{b[j][0]}({b[j][1]})" if j < len(b) else "the end"
                return f"call {i + 1}: {name}({args}) became {got}"
            j += 1
            if name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
                pos = _nums(args)[:3]
            elif name == "ARC_FEED":
                v, idx = _nums(args), _PLANES.get(plane, (0, 1, 2))
                pos = np.empty(3)
                pos[idx[0]], pos[idx[1]], pos[idx[2]] = v[0], v[1], v[5]
            elif name == "NURBS_FEED":
                pos = None
            continue
        v = _nums(args)
        if name == "STRAIGHT_FEED":
            target, length, here = v[:3], float(np.linalg.norm(v[:3] - pos)), pos
            d = (target - pos) / length if length > 0 else np.zeros(3)
            walked = 0.0
            while True:
                if j >= len(b) or b[j][0] != name:
                    return f"call {i + 1}: {name}({args}) is not followed by its pieces"
                w = _nums(b[j][1])
                p = w[:3]
                off = (p - pos) - np.dot(p - pos, d) * d
                if w.size != v.size or not np.array_equal(w[3:], v[3:]) or np.linalg.norm(off) > TOL:
                    return f"call {i + 1}: {name}({args}): piece {name}({b[j][1]}) is off the line"
                walked += float(np.linalg.norm(p - here))
                here = p
                j += 1
                if np.linalg.norm(p - target) <= TOL:
                    break
            if abs(walked - length) > TOL:
                return f"call {i + 1}: {name}({args}): pieces {walked:.6f} long, the move {length:.6f}"
            pos = target
            continue
        idx = _PLANES.get(plane, (0, 1, 2))
        here = np.array([pos[idx[0]], pos[idx[1]], pos[idx[2]]])
        sweep, swept = _sweep(here, v), 0.0
        while True:
            if j >= len(b) or b[j][0] != name:
                return f"call {i + 1}: {name}({args}) is not followed by its pieces"
            w = _nums(b[j][1])
            if (w.size != v.size or np.any(np.abs(w[2:4] - v[2:4]) > TOL) or np.sign(w[4]) != np.sign(v[4])
                    or not np.array_equal(w[6:], v[6:])):
                return f"call {i + 1}: {name}({args}): piece {name}({b[j][1]}) is off the arc"
            swept += _sweep(here, w)
            here = np.array([w[0], w[1], w[5]])
            j += 1
            if np.all(np.abs(w[[0, 1, 5]] - v[[0, 1, 5]]) <= TOL) and abs(abs(swept) - abs(sweep)) < 1e-3:
                break
        if abs(swept - sweep) > 1e-3:
            return f"call {i + 1}: {name}({args}): pieces sweep {swept:.6f} rad, the arc {sweep:.6f}"
        pos = np.empty(3)
        pos[idx[0]], pos[idx[1]], pos[idx[2]] = v[0], v[1], v[5]
    if j != len(b):
        return f"the rewritten program has {len(b) - j} more call(s): {b[j][0]}({b[j][1]}) ..."
    return None


@dataclass(frozen=True)
class Verification:
    """What rs274 said: ``status`` is ``accepted`` (the whole rewrite), ``kept`` (``kept_lines``,
    1-based, keep their text; ``message`` is what rs274 said of the full rewrite) or ``unchecked``
    (rs274 refuses the program as written: ``message``)."""

    status: str
    message: str
    kept_lines: tuple[int, ...]
    runs: int

    def __post_init__(self):
        if self.status not in ("accepted", "kept", "unchecked"):
            raise ValueError(f"status = {self.status!r}; must be accepted, kept or unchecked")

    def figures(self) -> dict[str, object]:
        """The columns a CSV row or a batch summary carries."""
        return {"rs274": self.status, "rs274_kept_lines": " ".join(str(v) for v in self.kept_lines)}

    def summary(self) -> str:
        if self.status == "accepted":
            return (f"rs274 accepts the rewritten program and gives the same moves apart from the feeds "
                    f"({self.runs} run(s))")
        if self.status == "unchecked":
            return f"not checked with rs274: it refuses the program as written ({self.message})"
        shown = ", ".join(str(v) for v in self.kept_lines[:12]) + (", ..." if len(self.kept_lines) > 12 else "")
        return (f"rs274: {len(self.kept_lines)} line(s) keep their text ({shown}): rewritten, {self.message}; "
                f"the rest is accepted with the same moves ({self.runs} run(s))")


def verified_rewrite(program: Program, piece_move: np.ndarray, piece_end: np.ndarray,
                     piece_feed_mm_min: np.ndarray, rewrite: Callable, tools_mm: dict[int, float] | None,
                     max_runs: int = 40) -> tuple[str, Verification]:
    """The rewritten text (``rewrite(program, move, end, feed)``) that rs274 accepts with the same
    moves, and what it said (module docstring)."""
    with tempfile.TemporaryDirectory(prefix="fuzzyfeed-rs274-") as tmp:
        scratch = Path(tmp)
        original = run_rs274(program.path.resolve(), tools_mm, scratch / "original")
        text = rewrite(program, piece_move, piece_end, piece_feed_mm_min)
        if not original.ok:
            return text, Verification("unchecked", original.message, (), 1)
        runs = [1]
        name = program.path.name

        def check(text: str) -> str | None:
            runs[0] += 1
            where = scratch / f"run{runs[0]}"
            where.mkdir()
            path = where / name
            path.write_text(text, newline="")
            run = run_rs274(path, tools_mm, where)
            return ("rs274 said: " + run.message) if not run.ok else compare_moves(original.calls, run.calls)

        said = check(text)
        if said is None:
            return text, Verification("accepted", "", (), runs[0])
        line_of = program.move_line[piece_move]

        def subset(lines: list[int]) -> str:
            keep = np.isin(line_of, lines)
            return rewrite(program, piece_move[keep], piece_end[keep], piece_feed_mm_min[keep])

        def good(lines: list[int]) -> list[int]:
            """The largest part of ``lines`` found whose rewrite rs274 accepts (checked)."""
            if not lines or runs[0] >= max_runs:
                return []
            if len(lines) == 1:
                return []                               # its rewrite was refused or changed
            half = len(lines) // 2
            parts = []
            for part in (lines[:half], lines[half:]):
                if runs[0] < max_runs and check(subset(part)) is None:
                    parts.append(part)
                else:
                    parts.append(good(part))
            both = parts[0] + parts[1]
            if not parts[0] or not parts[1]:
                return both
            if runs[0] < max_runs and check(subset(both)) is None:
                return both
            return max(parts, key=len)

        changed = sorted({int(v) for v in line_of if v >= 0})
        accepted = good(changed)
        taken = set(accepted)
        kept = tuple(v + 1 for v in changed if v not in taken)
        final = subset(accepted) if accepted else rewrite(program, piece_move[:0], piece_end[:0],
                                                          piece_feed_mm_min[:0])
        return final, Verification("kept", said, kept, runs[0])
