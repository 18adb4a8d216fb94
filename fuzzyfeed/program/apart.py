"""The places the uniform slowdown sets apart (issue 36, item 3): where no feed factor holds the
tolerance, so that the factor is *found* for the rest of the program instead of left a bound.

A place is a commanded segment of a chain. It is set apart when its error with every F × the floor
factor (:data:`~fuzzyfeed.machine.floor_error.FLOOR`, 0.01: the limit reference's floor) is still
over the tolerance (:func:`~fuzzyfeed.machine.floor_error.floor_errors`): a feed move entered from
rapids, where the tool still lags the rapids' deceleration, A/Kv², whatever F is. The uniform
factor is then the largest one that holds the tolerance everywhere else; the places are listed
apart (line, where, error), like the errors in the air, never dropped silently.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.floor_error import FLOOR, floor_errors
from fuzzyfeed.machine.stream import WARMUP_TIME_CONSTANTS, warmup_ticks
from fuzzyfeed.program.run import ProgramPath, ProgramRun

#: The most servo periods the floor runs of one call of :func:`set_apart` may take (beyond, the
#: places are not measured and none is set apart: the search ends with a bound and says so).
APART_MAX_TICKS = 2e7


@dataclass(frozen=True)
class Apart:
    """A place set apart: the program line (0-based) of the move commanded there, the start of
    the segment (mm), its arc length along the feed moves end to end (mm, the value plot's s), its
    error with every F × :data:`FLOOR` (µm) and at the uniform factor (µm; NaN when no whole run
    was made at it)."""

    line: int
    xyz: tuple[float, float, float]
    s_mm: float
    floor_um: float
    factor_um: float = float("nan")

    def text(self) -> str:
        at = f"{self.factor_um:.1f} um at the factor, " if math.isfinite(self.factor_um) else ""
        return (f"line {self.line + 1} ({', '.join(f'{c:g}' for c in self.xyz)}), s = {self.s_mm:.1f} mm: "
                f"{at}{self.floor_um:.1f} um at F x {FLOOR:g}")


def no_places(path: ProgramPath) -> list[np.ndarray]:
    """Per chain, no segment set apart."""
    return [np.zeros(0, np.int64) for _ in path.chains]


def masked(seg_max_mm: np.ndarray, apart: np.ndarray) -> np.ndarray:
    """``seg_max_mm`` with the segments ``apart`` at 0 (a copy only when there are some)."""
    if apart.size == 0:
        return seg_max_mm
    out = seg_max_mm.copy()
    out[apart] = 0.0
    return out


def run_max_um(run: ProgramRun, apart: list[np.ndarray]) -> float:
    """Largest error in the part (µm) of ``run`` outside the places ``apart``."""
    if not any(a.size for a in apart):
        return run.max_um
    return max((float(masked(r.stream.seg_max_mm, a).max(initial=0.0)) for r, a in zip(run.runs, apart)),
               default=0.0) * 1e3


def hot_outside(run: ProgramRun, tol_mm: float, apart: list[np.ndarray]) -> list[np.ndarray]:
    """Per chain the segments of ``run`` over the tolerance, the places ``apart`` left out."""
    return [np.flatnonzero(masked(r.stream.seg_max_mm, a) > tol_mm) for r, a in zip(run.runs, apart)]


def set_apart(path: ProgramPath, machine: Machine, hot: list[np.ndarray], apart: list[np.ndarray],
              floor: list[np.ndarray], seen: list[np.ndarray], tol_mm: float) -> bool:
    """Measure the floor error of the ``hot`` segments not yet measured (``seen``) and add those
    over the tolerance to ``apart`` (sorted segment indices per chain; the lists are changed in
    place) with their floor errors (mm) to ``floor``; True when any was added. None is measured
    (False) when their floor runs would pass :data:`APART_MAX_TICKS` servo periods."""
    todo = [np.setdiff1d(h, s) for h, s in zip(hot, seen)]
    span = 2 * WARMUP_TIME_CONSTANTS * machine.servo.time_constant_s / machine.ts_s + warmup_ticks(machine)
    if sum(t.size for t in todo) * span > APART_MAX_TICKS:
        return False
    added = False
    for i, (chain, t) in enumerate(zip(path.chains, todo)):
        if t.size == 0:
            continue
        err = floor_errors(chain.motion, chain.seg_measured, machine, t)
        seen[i] = np.union1d(seen[i], t)
        new = err > tol_mm
        if new.any():
            seg = np.concatenate([apart[i], t[new]])
            val = np.concatenate([floor[i], err[new]])
            order = np.argsort(seg)
            apart[i], floor[i] = seg[order], val[order]
            added = True
    return added


def describe(path: ProgramPath, apart: list[np.ndarray], floor: list[np.ndarray],
             run: ProgramRun | None = None) -> tuple[Apart, ...]:
    """The places ``apart`` as :class:`Apart` rows, in path order (``run``: the whole run at the
    uniform factor, for the error there)."""
    if not any(a.size for a in apart):
        return ()
    out = []
    offset = 0.0
    for i, chain in enumerate(path.chains):
        pts = chain.motion.points
        lengths = np.linalg.norm(np.diff(pts, axis=0), axis=1) * chain.seg_measured
        a = apart[i]
        if a.size:
            before = np.concatenate([[0.0], np.cumsum(lengths)])[a]
            at = run.runs[i].stream.seg_max_mm[a] * 1e3 if run is not None else np.full(a.size, np.nan)
            for seg, s, f, e in zip(a.tolist(), before.tolist(), floor[i].tolist(), at.tolist()):
                out.append(Apart(line=int(path.program.move_line[chain.seg_move[seg]]),
                                 xyz=tuple(float(c) for c in pts[seg]), s_mm=offset + s,
                                 floor_um=f * 1e3, factor_um=e))
        offset += float(lengths.sum())
    return tuple(out)


def apart_lines(places: tuple[Apart, ...], shown: int | None = None) -> list[str]:
    """The places set apart as text, their errors left out of the uniform row: one line, then one
    per place (the ``shown`` largest at F × the floor, and the count of the others)."""
    if not places:
        return []
    out = [f"uniform: {len(places)} place(s) set apart, where even every F x {FLOOR:g} leaves the error over "
           "the tolerance (a feed move entered from rapids: the tool still lags them; no F changes it); "
           "its max leaves them out:"]
    order = sorted(places, key=lambda p: -p.floor_um)
    for p in order[:shown]:
        out.append("  " + p.text())
    if shown is not None and len(order) > shown:
        out.append(f"  and {len(order) - shown} more (the HTML report lists them all)")
    return out
