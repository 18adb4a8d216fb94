"""What the designer draws, as numpy arrays: the advice on a path, the control surface on axes
spaced by the breakpoints, the surface seen in 3-D (projected quadrilaterals, far ones first),
and the membership functions with their breakpoints."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.fuzzy.rules import RuleTable, Variable
from fuzzyfeed.geometry.sampling import PathSamples


def path_advice(samples: PathSamples, table: RuleTable, max_feed_mm_s: float, machine=None):
    """The advice the path panel shows (:class:`~fuzzyfeed.fuzzy.advisor.FuzzyAdvice`); the one
    place the designer advises, through the advice pipeline's own
    :func:`~fuzzyfeed.advice.shape.advise_path` (what ``advise`` and ``advise_file`` do with a path):
    the edited table and the ``machine`` as one options value (a machine table reads its terms)."""
    from fuzzyfeed.advice.options import AdviceOptions
    from fuzzyfeed.advice.shape import advise_path

    return advise_path(samples, AdviceOptions(rules=table, machine=machine), max_feed_mm_s=max_feed_mm_s)


def path_on_machine(samples: PathSamples, feed_mm_s: np.ndarray, machine) -> tuple[float, float]:
    """(time in s, max contour error in µm) of the path's points run as G1 moves at the advised
    feeds (each segment at the slower of its ends') through the machine's planner and servo."""
    from fuzzyfeed.machine.planner import Motion
    from fuzzyfeed.machine.trace import trace_motion

    pts = np.asarray(samples.xyz, dtype=float)
    keep = np.concatenate([[True], np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-9])
    pts, feed = pts[keep], np.asarray(feed_mm_s, dtype=float)[keep]
    seg_feed = np.minimum(feed[:-1], feed[1:])
    motion = Motion(pts, seg_feed, np.zeros(seg_feed.size, bool), np.full(pts.shape[0], np.nan))
    tr = trace_motion(motion, machine)
    return tr.plan.time_s, tr.max_mm * 1e3


def breakpoint_axis(var: Variable) -> np.ndarray:
    """The sorted distinct breakpoints of ``var`` inside its universe, with the universe's ends:
    the values at the integer positions 0, 1, … of an axis where every interval between two
    breakpoints has the same width (so terms crowded near 0 stay readable)."""
    lo, hi = var.universe
    points = [p for t in var.terms for p in t.points if lo <= p <= hi]
    return np.unique(np.concatenate([[lo, hi], points]))


def axis_values(breaks: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` evenly spaced positions on the breakpoint axis and the values there."""
    pos = np.linspace(0.0, breaks.size - 1.0, n)
    return pos, np.interp(pos, np.arange(breaks.size), breaks)


@dataclass(frozen=True)
class Surface:
    """The controller's output (``z``, output unit) at positions ``pu`` × ``pv`` of the two
    breakpoint axes (values ``u``, ``v``); ``z[j, i]`` is at (u[i], v[j])."""

    pu: np.ndarray
    pv: np.ndarray
    u: np.ndarray
    v: np.ndarray
    z: np.ndarray
    u_breaks: np.ndarray
    v_breaks: np.ndarray


def control_surface(table: RuleTable, n: int = 41) -> Surface:
    """The exact Mamdani output over the two inputs' universes, ``n`` × ``n`` points."""
    from fuzzyfeed.fuzzy.engine import compile_table

    ub, vb = breakpoint_axis(table.variables[0]), breakpoint_axis(table.variables[1])
    pu, u = axis_values(ub, n)
    pv, v = axis_values(vb, n)
    uu, vv = np.meshgrid(u, v)
    z = compile_table(table).feed_pct(uu.ravel(), vv.ravel()).reshape(uu.shape)
    return Surface(pu, pv, u, v, z, ub, vb)


@dataclass(frozen=True)
class Projection:
    """Quadrilaterals of a surface seen from (azimuth, elevation): screen ``xs``/``ys`` (4 corners
    each), the mean output of each (for its colour), far ones first; and the box's edges."""

    xs: list[list[float]]
    ys: list[list[float]]
    z: np.ndarray
    edge_xs: list[list[float]]
    edge_ys: list[list[float]]
    label_x: list[float]
    label_y: list[float]


def project_surface(surface: Surface, z_range: tuple[float, float], azimuth_deg: float = -60.0,
                    elevation_deg: float = 30.0, step: int = 2) -> Projection:
    """Orthographic view of the surface in the unit box (both inputs on their breakpoint axes,
    the output over ``z_range``), every ``step``-th grid line; painter's order."""
    a, e = np.radians(azimuth_deg), np.radians(elevation_deg)
    toward = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    right = np.array([-np.sin(a), np.cos(a), 0.0])
    up = np.cross(toward, right)
    pu = surface.pu[::step] / max(surface.pu[-1], 1e-300)
    pv = surface.pv[::step] / max(surface.pv[-1], 1e-300)
    zz = surface.z[::step, ::step]
    lo, hi = z_range
    zn = (zz - lo) / (hi - lo) if hi > lo else np.zeros_like(zz)
    uu, vv = np.meshgrid(pu, pv)
    pts = np.stack([uu - 0.5, vv - 0.5, 0.8 * zn - 0.4], axis=-1)     # (nv, nu, 3)
    sx, sy, depth = pts @ right, pts @ up, pts @ toward
    corners = [(slice(None, -1), slice(None, -1)), (slice(None, -1), slice(1, None)),
               (slice(1, None), slice(1, None)), (slice(1, None), slice(None, -1))]
    qx = np.stack([sx[c] for c in corners], axis=-1).reshape(-1, 4)
    qy = np.stack([sy[c] for c in corners], axis=-1).reshape(-1, 4)
    qd = np.mean([depth[c] for c in corners], axis=0).ravel()
    qz = np.mean([zz[c] for c in corners], axis=0).ravel()
    order = np.argsort(qd)
    box = np.array([[-.5, -.5, -.4], [.5, -.5, -.4], [.5, .5, -.4], [-.5, .5, -.4], [-.5, -.5, -.4],
                    [-.5, -.5, .4]])
    ends = np.array([[0.0, -0.62, -0.4], [-0.62, 0.0, -0.4], [-0.56, -0.56, 0.45]])
    return Projection(xs=qx[order].tolist(), ys=qy[order].tolist(), z=qz[order],
                      edge_xs=[(box @ right).tolist()], edge_ys=[(box @ up).tolist()],
                      label_x=(ends @ right).tolist(), label_y=(ends @ up).tolist())


def membership_lines(var: Variable) -> tuple[list[list[float]], list[list[float]]]:
    """Each term as a polyline from its first to its last breakpoint (0 … 1 … 0); a shoulder at
    the universe's end stays at 1 out to it."""
    xs, ys = [], []
    for term in var.terms:
        p = list(term.points)
        y = [0.0, 1.0, 0.0] if len(p) == 3 else [0.0, 1.0, 1.0, 0.0]
        xs.append(p)
        ys.append(y)
    return xs, ys


def breakpoint_rows(var: Variable) -> dict[str, list]:
    """One row per breakpoint (x, its membership 0 or 1, the term, its index in the term): the
    draggable points of the membership plot."""
    rows: dict[str, list] = {"x": [], "y": [], "term": [], "index": []}
    for term in var.terms:
        n = len(term.points)
        for k, x in enumerate(term.points):
            rows["x"].append(float(x))
            rows["y"].append(0.0 if k in (0, n - 1) else 1.0)
            rows["term"].append(term.label)
            rows["index"].append(k)
    return rows
