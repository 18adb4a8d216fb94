"""The controller's inputs in the machine's own terms (issue 32): a machine table's two inputs.

At every sample:

- **safe feed** v_safe: the largest feed at which the machine holds its contour tolerance there —
  on a curve the steady-state servo error r·(1 − |G(jv/r)|) (:func:`~fuzzyfeed.machine.safe_feed.curve_safe_feed`),
  at a junction of two moves the error of a corner of the turn the path makes there (measured at
  a scale of a few tolerances) run through the machine's own planner and servo, or, where
  junctions follow closely, of the curvature their turns make
  (:func:`~fuzzyfeed.machine.safe_feed.junction_safe_feed`); the smaller (a true corner's blend
  curvature is the corner's, not a curve's: it counts as a corner only);
  and where the path starts behind a rapid, the error of a cut's entry (the rapid brakes at full
  acceleration into it);
- ``safe_feed_ratio`` = v_safe / F, F the programmed feed there (the ceiling), clipped at
  :data:`RATIO_TOP`: 1 or more means the machine follows within tolerance at F;
- ``safe_feed_ratio_near`` = the lowest ratio of the hot spots whose *settling distance* reaches
  the sample: a spot j reaches v_safe_j·t_settle + margin either side of it, t_settle the time the
  servo needs to forget the lag the planner's braking leaves
  (:func:`~fuzzyfeed.machine.safe_feed.settle_time_s`). Before a slow spot the feed must already be
  low long enough for the braking lag to decay, and after it the tool must come round before the
  machine accelerates again.

Both are dimensionless: scaling the feed, the servo gain and the acceleration together (F → cF,
Kv → cKv, A → c²A, tolerance fixed) leaves them unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.fuzzy.windows import centred_bounds, range_min
from fuzzyfeed.geometry.sampling import PathSamples
from fuzzyfeed.machine.description import Machine
from fuzzyfeed.machine.safe_feed import corner_safe_feed, curve_safe_feed, junction_safe_feed, settle_time_s

#: Ratios above this are clipped: the machine follows well within tolerance.
RATIO_TOP = 1.5
#: Added to every hot spot's settling distance (mm): one sampling step of a program's cut.
NEAR_MARGIN_MM = 0.25
#: Levels of safe feed the settling windows are computed at (geometric, per path).
NEAR_LEVELS = 24
#: A junction that turns more than this (rad) in a point sequence counts as a corner.
CORNER_MIN_RAD = np.radians(1.0)


@dataclass(frozen=True, eq=False)
class MachineFeatures:
    """Per sample: the safe feed (mm/s), the lowest safe feed whose settling distance reaches it,
    and both over the ceiling (the controller's two inputs)."""

    safe_feed_mm_s: np.ndarray
    safe_near_mm_s: np.ndarray
    safe_feed_ratio: np.ndarray
    safe_feed_ratio_near: np.ndarray


def vertex_turn_angles(samples: PathSamples) -> np.ndarray:
    """Turn angle (rad) at every sample of a point sequence: the angle between the segments
    arriving and leaving (0 at the ends and inside a NURBS, whose samples are no junctions)."""
    n = len(samples)
    out = np.zeros(n)
    if samples.curve is not None and np.isfinite(samples.d1).all():
        return out
    xyz = samples.xyz
    d = np.diff(xyz, axis=0)
    norm = np.linalg.norm(d, axis=1)
    ok = norm > 0
    d[ok] /= norm[ok, None]
    if n > 2:
        cos = np.clip(np.einsum("ij,ij->i", d[:-1], d[1:]), -1.0, 1.0)
        out[1:-1] = np.where(ok[:-1] & ok[1:], np.arccos(cos), 0.0)
    return out


def entry_turns(samples: PathSamples, entry_direction, machine: Machine) -> np.ndarray:
    """The angles (rad) between a rapid's direction and where the path goes over the first stretch
    the rapid's braking lag covers (a·τ², the tool's lag when the rapid stops): the chords from the
    path's start to its points within that stretch (longer than the tolerance). A plunge of a few µm
    before an XY move, or a small circle entered from above, turns the tool through all of them.
    Empty without a rapid."""
    none = np.zeros(0)
    if entry_direction is None:
        return none
    d = np.asarray(entry_direction, dtype=float)
    if d.shape != (3,) or not np.isfinite(d).all():
        return none
    tau = machine.servo.time_constant_s
    reach = min(max(machine.tangential_acc_mm_s2 * tau * tau, machine.contour_tol_mm), float(samples.s[-1]))
    if reach <= 0:
        return none
    s = np.asarray(samples.s, dtype=float)
    within = np.flatnonzero(s <= reach)
    far = np.array([np.interp(reach, s, samples.xyz[:, k]) for k in range(3)])
    pts = np.vstack([samples.xyz[within], far[None, :]])
    chords = pts - samples.xyz[0]
    norms = np.linalg.norm(chords, axis=1)
    ok = norms > machine.contour_tol_mm
    return np.arccos(np.clip(chords[ok] @ d / norms[ok], -1.0, 1.0))


def entry_safe_feed(samples: PathSamples, entry_direction, machine: Machine) -> float:
    """The safe feed at a cut's entry: the slowest the entry table gives over the range of turns
    the path makes within the rapid's braking lag (:func:`entry_turns`), inf without a rapid."""
    from fuzzyfeed.machine.safe_feed import CORNER_ANGLES_DEG

    turns = entry_turns(samples, entry_direction, machine)
    if turns.size == 0:
        return float("inf")
    lo, hi = float(turns.min()), float(turns.max())
    table = np.radians(CORNER_ANGLES_DEG)
    probe = np.concatenate([[lo, hi], table[(table > lo) & (table < hi)]])
    return float(corner_safe_feed(machine, probe, rapid_lead=True).min())


def machine_features(samples: PathSamples, ceiling_mm_s: np.ndarray, machine: Machine,
                     turn_angle: np.ndarray | None = None, corner: np.ndarray | None = None,
                     entry_direction=None) -> MachineFeatures:
    """The machine inputs of every sample (module docstring). ``ceiling_mm_s`` (N,) is the feed
    the advice is a fraction of; ``turn_angle`` (N,) the turn at junctions (default: from the points
    of a point sequence, none on a NURBS); ``corner`` (N,) which junctions are true corners (their
    curvature is the blend's; default: every junction turning more than 1°); ``entry_direction``
    the unit direction of a rapid that ends at the path's first point (None or NaNs: none)."""
    kappa = np.asarray(samples.curvature, dtype=float)
    turn = vertex_turn_angles(samples) if turn_angle is None else np.asarray(turn_angle, dtype=float)
    is_corner = (turn > CORNER_MIN_RAD) if corner is None else np.asarray(corner, dtype=bool)
    ceiling = np.asarray(ceiling_mm_s, dtype=float)
    v_curve = curve_safe_feed(machine, np.where(is_corner, 0.0, kappa))
    v_safe = np.minimum(v_curve, junction_safe_feed(machine, turn, samples.xyz, samples.s))
    v_safe[0] = min(v_safe[0], entry_safe_feed(samples, entry_direction, machine))
    near = settling_min(v_safe, np.asarray(samples.s, dtype=float), settle_time_s(machine), ceiling)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.clip(v_safe / ceiling, 0.0, RATIO_TOP)
        ratio_near = np.clip(near / ceiling, 0.0, RATIO_TOP)
    return MachineFeatures(safe_feed_mm_s=v_safe, safe_near_mm_s=near,
                           safe_feed_ratio=np.nan_to_num(ratio, nan=RATIO_TOP, posinf=RATIO_TOP),
                           safe_feed_ratio_near=np.nan_to_num(ratio_near, nan=RATIO_TOP, posinf=RATIO_TOP))


def hot_spots(v_safe: np.ndarray, ceiling: np.ndarray) -> np.ndarray:
    """Where a spot is hot: slower than the feed either side of it (at a junction the machine
    leaves at the next move's F, not at the F of the move that ends there); and that feed."""
    around = ceiling.copy()
    if ceiling.size > 1:
        around[:-1] = np.maximum(around[:-1], ceiling[1:])
        around[1:] = np.maximum(around[1:], ceiling[:-1])
    return v_safe < around, around


def settling_min(v_safe: np.ndarray, s: np.ndarray, settle_s: float, ceiling: np.ndarray,
                 levels: tuple[float, float] | None = None,
                 span: tuple[float, float] | None = None) -> np.ndarray:
    """near_i = min over spots j with |s_i − s_j| ≤ v_safe_j·settle_s + margin of v_safe_j.

    Computed per level of safe feed (geometric levels between the slowest spot and the ceiling):
    the spots at or below a level, each reaching at most the level's distance, give a windowed
    minimum; the minimum over levels is ≤ the exact value's window (a spot reaches at most one
    level's distance further than its own), never above it. On a piece of a path (the advice in
    pieces): ``levels`` = the whole path's (slowest hot spot, fastest feed around a hot spot) and
    ``span`` its first and last s."""
    out = v_safe.copy()
    hot, around = hot_spots(v_safe, ceiling)
    if not hot.any() or s.size < 2:
        return out
    lo_v, hi_v = (float(v_safe[hot].min()), float(np.max(around[hot]))) if levels is None else levels
    levels = np.geomspace(max(lo_v, 1e-9), max(hi_v, lo_v * (1 + 1e-9)), NEAR_LEVELS)
    n = s.size
    below = 0.0
    for level in levels:
        pick = hot & (v_safe <= level) & (v_safe > below)
        below = level
        if not pick.any():
            continue
        masked = np.where(pick, v_safe, np.inf)
        lo, hi = centred_bounds(n, s=s, half_mm=level * settle_s + NEAR_MARGIN_MM, symmetric=False, span=span)
        out = np.minimum(out, range_min(masked, lo, hi))
    return out
