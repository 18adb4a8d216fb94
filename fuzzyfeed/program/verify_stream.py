"""rs274's check of a rewrite, streamed (issue 36): rs274 writes its canonical calls to a pipe, and
the calls of the program as written and as rewritten are compared as they come (two rs274 runs
side by side), carrying only the plane, the position and the call count — nothing per call of
the program is held. The comparison is :func:`fuzzyfeed.program.verify.compare_moves`'s (that
function runs this one on lists), the bisection over the changed lines
:func:`fuzzyfeed.program.verify.verified_rewrite`'s, on ranges of the changed lines' indices
(:func:`check_rewrites`): the same runs, verdicts and kept lines, whether the program was read
whole or in windows (:mod:`fuzzyfeed.program.verify_windows`).
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import threading
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np

from fuzzyfeed.errors import InputError
from fuzzyfeed.program.model import MM_PER_INCH

#: Geometry tolerance of the comparison (mm in the canonical units; 1 µm).
TOL = 1e-3
#: rs274's time limit per run (s).
TIMEOUT_S = 300
_CALL = re.compile(r"^\s*\d+\s+N\S*\s+([A-Z_0-9]+)\((.*)\)\s*$")
_FEEDS = ("STRAIGHT_FEED", "ARC_FEED", "NURBS_FEED")
_PLANES = {"CANON_PLANE_XY": (0, 1, 2), "CANON_PLANE_XZ": (2, 0, 1), "CANON_PLANE_YZ": (1, 2, 0)}


def write_tool_table(tools_mm: dict[int, float] | None, path: Path) -> None:
    """The tool table rs274 reads (inches); without one, tools 1–999 of diameter 0."""
    if tools_mm:
        path.write_text("".join(f"T{t} P{t} D{d / MM_PER_INCH:.9f} Z0 ;\n" for t, d in sorted(tools_mm.items())))
    else:
        path.write_text("".join(f"T{t} P{t} D0 Z0 ;\n" for t in range(1, 1000)))


def rs274_path() -> str | None:
    """rs274 on PATH, or None."""
    return shutil.which("rs274")


class Rs274Process:
    """``rs274 -t TABLE -g program`` in ``workdir`` (its own HOME; nothing else there), its calls on
    a pipe: :meth:`calls` yields them as they come, :meth:`finish` reads the rest and says whether
    rs274 accepted the program (``(ok, message)``: its first two lines on stderr, or the time limit)."""

    def __init__(self, program: Path, tools_mm: dict[int, float] | None, workdir: Path):
        binary = rs274_path()
        if binary is None:
            raise InputError("--verify-rs274: rs274 not found on PATH (LinuxCNC's interpreter; Debian "
                             "package linuxcnc-uspace)")
        workdir.mkdir(parents=True, exist_ok=True)
        table = workdir / "tools.tbl"
        write_tool_table(tools_mm, table)
        self._err = open(workdir / "stderr.txt", "w+b")
        self.timed_out = False
        self.proc = subprocess.Popen([binary, "-t", str(table), "-g", str(program)], stdout=subprocess.PIPE,
                                     stderr=self._err, stdin=subprocess.DEVNULL, cwd=workdir,
                                     env={**os.environ, "HOME": str(workdir)}, errors="replace")
        self._timer = threading.Timer(TIMEOUT_S, self._kill)
        self._timer.daemon = True
        self._timer.start()

    def _kill(self) -> None:
        self.timed_out = True
        self.proc.kill()

    def calls(self) -> Iterator[tuple[str, str]]:
        """The canonical calls (name, arguments), as the file's lines would give them."""
        for line in self.proc.stdout:
            for part in line.splitlines():       # as str.splitlines splits a whole file
                m = _CALL.match(part)
                if m:
                    yield m.group(1), m.group(2)

    def finish(self) -> tuple[bool, str]:
        for _ in self.proc.stdout:
            pass
        rc = self.proc.wait()
        self._timer.cancel()
        self.proc.stdout.close()
        self._err.seek(0)
        err = self._err.read().decode(errors="replace")
        self._err.close()
        if self.timed_out:
            return False, f"rs274: no answer within {TIMEOUT_S} s"
        said = [ln.strip() for ln in err.splitlines() if ln.strip() and ln.strip() != "executing"]
        if rc != 0:
            return False, " / ".join(said[:2]) or f"rs274 exit {rc}"
        return True, ""

    def close(self) -> None:
        """Stop it (an error elsewhere): nothing left running."""
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        self._timer.cancel()
        for handle in (self.proc.stdout, self._err):
            if not handle.closed:
                handle.close()


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


class _Peek:
    """The rewritten calls (SET_FEED_RATE left out) one at a time: ``cur`` (None at the end), ``j``
    its index."""

    def __init__(self, calls: Iterable):
        self._it = (c for c in calls if c[0] != "SET_FEED_RATE")
        self.j = 0
        self.cur = next(self._it, None)

    def take(self):
        c = self.cur
        self.cur = next(self._it, None)
        self.j += 1
        return c

    def rest(self) -> int:
        n = 0
        while self.cur is not None:
            self.take()
            n += 1
        return n


def _arc_end(v: np.ndarray, plane: str) -> np.ndarray:
    idx = _PLANES.get(plane, (0, 1, 2))
    pos = np.empty(3)
    pos[idx[0]], pos[idx[1]], pos[idx[2]] = v[0], v[1], v[5]
    return pos


def compare_call_streams(original: Iterable, rewritten: Iterable) -> str | None:
    """None when the ``rewritten`` calls are the ``original`` ones apart from SET_FEED_RATE values
    and feed moves split into pieces along the same line or arc (within :data:`TOL`); else what
    differs (the first difference). Both are consumed once, in order."""
    b = _Peek(rewritten)
    plane, pos = "CANON_PLANE_XY", None
    for i, (name, args) in enumerate(c for c in original if c[0] != "SET_FEED_RATE"):
        if name == "SELECT_PLANE":
            plane = args.strip()
        if name not in _FEEDS or name == "NURBS_FEED" or pos is None:
            if b.cur is None or b.cur != (name, args):
                got = f"{b.cur[0]}({b.cur[1]})" if b.cur is not None else "the end"
                return f"call {i + 1}: {name}({args}) became {got}"
            b.take()
            if name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
                pos = _nums(args)[:3]
            elif name == "ARC_FEED":
                pos = _arc_end(_nums(args), plane)
            elif name == "NURBS_FEED":
                pos = None
            continue
        v = _nums(args)
        if b.cur == (name, args):
            # the move unchanged: one piece ending on its end, which the loops below accept as is
            b.take()
            pos = v[:3] if name == "STRAIGHT_FEED" else _arc_end(v, plane)
            continue
        if name == "STRAIGHT_FEED":
            target, length, here = v[:3], float(np.linalg.norm(v[:3] - pos)), pos
            d = (target - pos) / length if length > 0 else np.zeros(3)
            walked = 0.0
            while True:
                if b.cur is None or b.cur[0] != name:
                    return f"call {i + 1}: {name}({args}) is not followed by its pieces"
                w = _nums(b.cur[1])
                p = w[:3]
                off = (p - pos) - np.dot(p - pos, d) * d
                if w.size != v.size or not np.array_equal(w[3:], v[3:]) or np.linalg.norm(off) > TOL:
                    return f"call {i + 1}: {name}({args}): piece {name}({b.cur[1]}) is off the line"
                walked += float(np.linalg.norm(p - here))
                here = p
                b.take()
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
            if b.cur is None or b.cur[0] != name:
                return f"call {i + 1}: {name}({args}) is not followed by its pieces"
            w = _nums(b.cur[1])
            if (w.size != v.size or np.any(np.abs(w[2:4] - v[2:4]) > TOL) or np.sign(w[4]) != np.sign(v[4])
                    or not np.array_equal(w[6:], v[6:])):
                return f"call {i + 1}: {name}({args}): piece {name}({b.cur[1]}) is off the arc"
            swept += _sweep(here, w)
            here = np.array([w[0], w[1], w[5]])
            b.take()
            if np.all(np.abs(w[[0, 1, 5]] - v[[0, 1, 5]]) <= TOL) and abs(abs(swept) - abs(sweep)) < 1e-3:
                break
        if abs(swept - sweep) > 1e-3:
            return f"call {i + 1}: {name}({args}): pieces sweep {swept:.6f} rad, the arc {sweep:.6f}"
        pos = _arc_end(v, plane)
    if b.cur is not None:
        first = b.cur
        return f"the rewritten program has {b.rest()} more call(s): {first[0]}({first[1]}) ..."
    return None


def check_pair(original: Path, rewritten: Path, tools_mm: dict[int, float] | None,
               where: Path) -> tuple[bool, str, str | None]:
    """rs274 on ``original`` and ``rewritten`` side by side (in ``where/original`` and ``where``),
    their calls compared as they come: (the original accepted, what rs274 said of it, what is wrong
    with the rewrite: None, ``"rs274 said: ..."`` or the comparison's first difference)."""
    runs = []
    try:
        runs.append(Rs274Process(original, tools_mm, where / "original"))
        runs.append(Rs274Process(rewritten, tools_mm, where))
        differs = compare_call_streams(runs[0].calls(), runs[1].calls())
        ok_a, said_a = runs[0].finish()
        ok_b, said_b = runs[1].finish()
    finally:
        for run in runs:
            run.close()
    if not ok_b:
        return ok_a, said_a, "rs274 said: " + said_b
    return ok_a, said_a, differs


# ---- the bisection over the changed lines, on ranges of their indices --------------------------

Ranges = list  # [(lo, hi), ...]: indices lo..hi-1 of the sorted changed lines, increasing


def count(sel: Ranges) -> int:
    return sum(hi - lo for lo, hi in sel)


def _cat(a: Ranges, b: Ranges) -> Ranges:
    out = list(a)
    for lo, hi in b:
        if out and out[-1][1] == lo:
            out[-1] = (out[-1][0], hi)
        else:
            out.append((lo, hi))
    return out


def _split(sel: Ranges, k: int) -> tuple[Ranges, Ranges]:
    """The first ``k`` indices of ``sel`` and the rest."""
    first, rest = [], []
    for lo, hi in sel:
        if k <= 0:
            rest.append((lo, hi))
        elif hi - lo <= k:
            first.append((lo, hi))
            k -= hi - lo
        else:
            first.append((lo, lo + k))
            rest.append((lo + k, hi))
            k = 0
    return first, rest


def selected(sel: Ranges, n: int) -> np.ndarray:
    """Bool over the ``n`` changed lines' indices: in ``sel``."""
    keep = np.zeros(n, dtype=bool)
    for lo, hi in sel:
        keep[lo:hi] = True
    return keep


def check_rewrites(original: Path, first: Path, write_subset: Callable[[Ranges, Path], None], n_changed: int,
                   tools_mm: dict[int, float] | None, scratch: Path, max_runs: int = 40):
    """rs274's verdict on the rewrite ``first`` of ``original`` (already written) and, where it
    refuses it or the moves differ, the largest part of the ``n_changed`` changed lines found by
    bisection whose rewrite it accepts (``write_subset(ranges, path)`` writes the rewrite of those
    lines only): ``(status, message, accepted ranges, runs)``, status ``accepted``, ``kept`` or
    ``unchecked`` (:class:`~fuzzyfeed.program.verify.Verification`)."""
    runs = [1]
    name = first.name
    ok, said_original, said = check_pair(original, first, tools_mm, scratch / "run2")
    if not ok:
        return "unchecked", said_original, None, 1
    runs[0] = 2
    if said is None:
        return "accepted", "", [(0, n_changed)], runs[0]

    def check(sel: Ranges) -> str | None:
        runs[0] += 1
        where = scratch / f"run{runs[0]}"
        where.mkdir()
        path = where / name
        write_subset(sel, path)
        return check_pair(original, path, tools_mm, where)[2]

    def good(sel: Ranges) -> Ranges:
        """The largest part of ``sel`` found whose rewrite rs274 accepts (checked)."""
        n = count(sel)
        if not n or runs[0] >= max_runs:
            return []
        if n == 1:
            return []                               # its rewrite was refused or changed
        parts = []
        for part in _split(sel, n // 2):
            if runs[0] < max_runs and check(part) is None:
                parts.append(part)
            else:
                parts.append(good(part))
        both = _cat(parts[0], parts[1])
        if not parts[0] or not parts[1]:
            return both
        if runs[0] < max_runs and check(both) is None:
            return both
        return max(parts, key=count)

    accepted = good([(0, n_changed)] if n_changed else [])
    return "kept", said, accepted, runs[0]
