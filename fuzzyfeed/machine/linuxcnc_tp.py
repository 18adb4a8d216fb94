"""LinuxCNC 2.9's trajectory planner rules the GRBL-style plan leaves out, for ``corner =
"path-tolerance"`` machines (issue 37). Read from LinuxCNC 2.9 (commit f1270d6ed7, the Debian
``2.9.0~pre1`` build): ``src/emc/task/emccanon.cc``, ``src/emc/tp/tc.c``, ``tp.c``, ``blendmath.c``;
checked against its uspace sim (tests/test_linuxcnc_sim.py).

- A straight move's acceleration is the axes' alone (``getStraightAcceleration``:
  a = |d| / max_j(|d_j| / A_j)); [TRAJ] MAX_LINEAR_ACCELERATION does not limit it (``tp->aMax`` is
  set and never read), so the machine's path limit is not applied.
- A circular move (G2/G3): a_max = the smallest acceleration of its plane's axes, its speed limit
  v_ini = min(the plane's axes' velocity, √(a_n·r)) with a_n = a_max·√3/2 (``ARC_FEED``); the
  planner (``pmCircleActualMaxVel``, ``tcUpdateCircleAccRatio``) keeps part of a for the normal
  acceleration v²/r: with a_o the move's overall acceleration, if v_ini²/r > a_o·√3/2 the speed is
  capped at √(a_o·r·√3/2) and the tangential acceleration is a_o/2, otherwise it is
  a_o·√(1 − (v_ini²/(r·a_o))²) (``BLEND_ACC_RATIO_TANGENTIAL`` = 1/2, ``tcGetTangentialMaxAccel``).
- A move whose end condition stays a parabolic blend — under G64 the last move before the queue
  runs dry (the end of a chain: a stop code, the program's end) — runs at half its acceleration
  (``tcGetOverallMaxAccel``: "acceleration is scaled down by 1/2").
- A move lasts at least 1.02 servo periods (``tcClampVelocityByLength``, ``TP_MIN_SEGMENT_CYCLES``):
  speed ≤ L/(1.02·Ts).
- Between two arcs past a right angle the blend is parabolic (half acceleration on both moves,
  speed 2·√(a_t·T/cos θ), ``tpComputeBlendVelocity``) unless a kink is faster; a near-tangent
  junction (``tpSetupTangent``: the direction change at v/Ts + a within ARC_BLEND_KINK_RATIO of
  the axes' limits, doubled next to an arc) keeps its speed and loses that share of acceleration.
- Any other corner between moves is a blend arc (``blendComputeParameters``): tolerance
  T = min(P, L_in/4, L_out/4) (``tcFindBlendTolerance``, L the moves' lengths), reach along each
  move d = min(T·cos θ/(1 − sin θ), L_in/2, L_out/2), radius R = d·tan θ (θ half the angle
  between −u_in and u_out; R = T·sin θ/(1 − sin θ) on long moves), speed √(a_n·R) with
  a_n = √3/2 · the acceleration bound of the corner's plane (``calculateInscribedDiameter``:
  min_j A_j / |e_j projected on the plane|).
"""

from __future__ import annotations

import numpy as np

from fuzzyfeed.machine.description import Machine

#: blendmath.h: the share of an arc's acceleration kept tangential at its speed limit.
ACC_RATIO_TANGENTIAL = 0.5
#: blendmath.h: BLEND_ACC_RATIO_NORMAL = √(1 − 0.5²).
ACC_RATIO_NORMAL = float(np.sqrt(1.0 - ACC_RATIO_TANGENTIAL ** 2))
#: tc.c: a move ending in a parabolic blend keeps this share of its acceleration.
PARABOLIC_SCALE = 0.5
#: tc.c tcFindBlendTolerance: a blend consumes at most this share of a move's length as tolerance.
TOLERANCE_RATIO = 0.25
#: tc_types.h: a blend arc takes at most this share of a move's length.
BLEND_DIST_FRACTION = 0.5
#: tp_types.h: the fewest servo periods a move may last.
MIN_SEGMENT_CYCLES = 1.02
#: tp.c tpGetTangentKinkRatio: [TRAJ] ARC_BLEND_KINK_RATIO, 0.1 by default.
KINK_RATIO = 0.1


def inscribed_bound(bounds: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """``calculateInscribedDiameter``: per plane of unit normal ``normal`` (N, 3), the largest value
    every direction in the plane allows, min_j B_j / |e_j − n_j n| (axes with B_j = 0 skipped)."""
    n = np.asarray(normal, dtype=float)
    b = np.asarray(bounds, dtype=float)
    proj = np.sqrt(np.clip(1.0 - n * n, 0.0, 1.0))          # |e_j − n_j n| = √(1 − n_j²)
    with np.errstate(divide="ignore"):
        extent = np.where(b[None, :] > 0, b[None, :] / np.maximum(proj, 1e-12), np.inf)
    return extent.min(axis=1)


def _plane_normal(u_in: np.ndarray, u_out: np.ndarray) -> np.ndarray:
    """Unit normal of the plane of two directions (N, 3); the XY plane's where they are parallel."""
    c = np.cross(u_in, u_out)
    norm = np.linalg.norm(c, axis=1)
    return np.where(norm[:, None] > 1e-12, c / np.maximum(norm, 1e-300)[:, None], [0.0, 0.0, 1.0])


def moves(arc_radius_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per segment (n,): the index of the program move it belongs to (a move boundary is an inner
    vertex of NaN radius), and the radius of the arc it is a chord of (NaN on a line)."""
    r = np.asarray(arc_radius_mm, dtype=float)
    boundary = ~np.isfinite(r[1:-1])
    move = np.concatenate([[0], np.cumsum(boundary)])
    seg_r = np.where(np.isfinite(r[1:]), r[1:], r[:-1])
    return move, seg_r


def linuxcnc_limits(unit: np.ndarray, length: np.ndarray, arc_radius_mm: np.ndarray, nominal: np.ndarray,
                    machine: Machine) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """LinuxCNC 2.9's limits on a chain's polyline (see the module docstring): per segment the
    tangential acceleration (n,) and the speed cap of its move (n,) (inf on a line), and per inner
    vertex (n − 1,) the squared speed of its corner (inf inside an arc or on a straight junction:
    the segments' caps rule there) and the length its blend arc takes from each of the two moves
    (0 where there is none: the moves can change speed only on what is left of them).
    ``nominal`` (n,): each segment's requested speed."""
    acc_axes = np.asarray(machine.axis_acc_mm_s2, dtype=float)
    vel_axes = np.asarray(machine.axis_vel_mm_s, dtype=float)
    n = length.size
    move, seg_r = moves(arc_radius_mm)
    n_moves = int(move[-1]) + 1
    arc = np.isfinite(seg_r)
    # the arc's plane from its chords' turn (a one-chord arc: the XY plane)
    normal = np.tile([0.0, 0.0, 1.0], (n, 1))
    if n > 1:
        inner = _plane_normal(unit[:-1], unit[1:])
        same = (move[:-1] == move[1:])[:, None]
        normal[:-1] = np.where(same, inner, normal[:-1])
        normal[1:] = np.where(same, inner, normal[1:])
    a_full = machine._along(acc_axes, unit, None)           # tc->maxaccel of a line
    a_arc = inscribed_bound(acc_axes, normal)              # ... of an arc (ARC_FEED)
    a_full = np.where(arc, a_arc, a_full)
    halve = np.zeros(n_moves, bool)
    halve[-1] = True                                       # the chain's last move: parabolic end
    kink = np.zeros(n_moves)
    w = np.full(max(n - 1, 0), np.inf)
    trim = np.zeros(max(n - 1, 0))
    if n > 1:
        # at a move's end LinuxCNC turns from the arc's tangent, not its chord's: the chord turned
        # by half its angle δ = asin(c/2r) about the arc's normal (a one-chord arc kept as is)
        one = arc & (np.bincount(move, minlength=n_moves)[move] == 1)
        half = np.where(arc & ~one, np.arcsin(np.clip(length / (2.0 * np.where(arc, seg_r, 1.0)), 0.0, 1.0)), 0.0)
        side = np.cross(normal, unit) * np.sin(half)[:, None]
        along = unit * np.cos(half)[:, None]
        u_in, u_out = (along + side)[:-1], (along - side)[1:]
        corner = move[:-1] != move[1:]
        m_in, m_out = move[:-1], move[1:]
        cos_in = np.einsum("ij,ij->i", u_in, u_out)
        sin_t = np.sqrt(np.clip(0.5 * (1.0 + cos_in), 0.0, 1.0))   # θ: half the angle of −u_in, u_out
        cos_t = np.sqrt(np.clip(0.5 * (1.0 - cos_in), 0.0, 1.0))
        move_len = np.bincount(move, weights=length)
        tol = np.minimum(machine.corner_mm, TOLERANCE_RATIO * np.minimum(move_len[m_in], move_len[m_out]))
        with np.errstate(divide="ignore", invalid="ignore"):
            # blendComputeParameters: the blend reaches along each move at most d_tol (the
            # tolerance) and half the move (BLEND_DIST_FRACTION), its radius R = tan θ · d
            d_tol = cos_t * tol / (1.0 - sin_t)
            d_geom = np.minimum(d_tol, BLEND_DIST_FRACTION * np.minimum(move_len[m_in], move_len[m_out]))
            radius = sin_t / cos_t * d_geom
        a_plane = inscribed_bound(acc_axes, _plane_normal(u_in, u_out))
        w_arc = ACC_RATIO_NORMAL * a_plane * radius                     # blend arc
        # tpSetupTangent: the acceleration a direction change takes at once, against the axes
        v_max = np.minimum(nominal[:-1], nominal[1:])
        a_inst = v_max / machine.ts_s + a_full[1:]
        scale_max = np.max(np.abs(a_inst[:, None] * (u_out - u_in)) / acc_axes[None, :], axis=1)
        with_arc = arc[:-1] | arc[1:]
        scale_max = np.where(with_arc, scale_max / ACC_RATIO_TANGENTIAL, scale_max)
        tangent = corner & (scale_max < KINK_RATIO)
        # between two arcs no blend arc is made past a right angle (tpCreateArcArcBlend fails on
        # arcs_arrows.nc's cusps; a line and an arc blend there): the better of a parabolic blend
        # (half acceleration on both moves, tpChooseBestBlend) and a kink at reduced speed
        fails = corner & ~tangent & arc[:-1] & arc[1:] & (cos_in < 0.0)
        a_t = 0.5 * a_full[:-1] * np.where(arc[:-1], ACC_RATIO_TANGENTIAL, 1.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            v_par = np.minimum(v_max, 2.0 * np.sqrt(a_t * tol / np.maximum(cos_t, 1e-9)))
            kink_vel = v_max * KINK_RATIO / scale_max
        parabolic = fails & (sin_t * v_par / 2.0 >= kink_vel)
        kinked = fails & ~parabolic
        np.maximum.at(kink, m_in[tangent], scale_max[tangent])
        np.maximum.at(kink, m_out[tangent], scale_max[tangent])
        np.maximum.at(kink, m_in[kinked], KINK_RATIO)
        np.maximum.at(kink, m_out[kinked], KINK_RATIO)
        halve[m_in[parabolic]] = True
        halve[m_out[parabolic]] = True
        w_corner = np.where(parabolic, v_par ** 2, np.where(kinked, kink_vel ** 2, w_arc))
        w_corner = np.where(tangent | (cos_in > 0.999999), np.inf, w_corner)   # straight on
        w_corner = np.where(cos_in < -0.999999, 0.0, w_corner)               # a reversal stops
        w = np.where(corner, w_corner, np.inf)
        # the blend arc's reach into each move (blendComputeParameters: R_plan, d_plan)
        with np.errstate(divide="ignore", invalid="ignore"):
            a_n = ACC_RATIO_NORMAL * a_plane
            v_plan = np.minimum(np.sqrt(w_arc), np.maximum(nominal[:-1], nominal[1:]))
            a_par = 0.5 * a_plane
            t_blend = np.minimum(np.sqrt(2.0 * a_par * d_geom), v_plan) / a_par
            phi = np.arccos(np.clip(cos_in, -1.0, 1.0))
            r_blend = np.minimum(t_blend * v_plan / phi, radius)
            d_plan = np.maximum(v_plan ** 2 / a_n, r_blend) * cos_t / sin_t
        blended = corner & np.isfinite(w_corner) & (w_corner > 0) & ~parabolic & ~kinked
        trim = np.where(blended & np.isfinite(d_plan), d_plan, 0.0)
    scale = (1.0 - kink[move]) * np.where(halve[move], PARABOLIC_SCALE, 1.0)
    acc = a_full * scale
    # tcClampVelocityByLength, tpComputeOptimalVelocity: a move lasts at least
    # TP_MIN_SEGMENT_CYCLES servo periods
    cap = (np.bincount(move, weights=length, minlength=n_moves) / (MIN_SEGMENT_CYCLES * machine.ts_s))[move]
    if arc.any():
        a_max = a_arc[arc]
        v_axes = inscribed_bound(vel_axes, normal[arc])
        r = seg_r[arc]
        v_ini = np.minimum(v_axes, np.sqrt(ACC_RATIO_NORMAL * a_max * r))
        a_o = acc[arc]
        a_n = v_ini ** 2 / r
        cut = a_n > ACC_RATIO_NORMAL * a_o
        ratio = np.where(cut, ACC_RATIO_TANGENTIAL, np.sqrt(np.clip(1.0 - (a_n / a_o) ** 2, 0.0, 1.0)))
        acc[arc] = a_o * ratio
        cap[arc] = np.minimum(cap[arc], np.where(cut, np.sqrt(ACC_RATIO_NORMAL * a_o * r), v_ini))
    return acc, cap, w, trim
