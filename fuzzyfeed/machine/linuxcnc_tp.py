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
- A corner between moves is a blend arc (``blendComputeParameters``): tolerance
  T = min(P, L_in/4, L_out/4) (``tcFindBlendTolerance``, L the moves' lengths), radius
  R = T·sin θ/(1 − sin θ) (θ half the angle between −u_in and u_out), speed √(a_n·R) with
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


def linuxcnc_limits(unit: np.ndarray, length: np.ndarray, arc_radius_mm: np.ndarray,
                    machine: Machine) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """LinuxCNC 2.9's limits on a chain's polyline (see the module docstring): per segment the
    tangential acceleration (n,) and the speed cap of its move (n,) (inf on a line), and per inner
    vertex (n − 1,) the squared speed of its corner (inf inside an arc or on a straight junction:
    the segments' caps rule there)."""
    acc_axes = np.asarray(machine.axis_acc_mm_s2, dtype=float)
    vel_axes = np.asarray(machine.axis_vel_mm_s, dtype=float)
    n = length.size
    move, seg_r = moves(arc_radius_mm)
    last = move == move[-1]                                  # the chain's last move: parabolic end
    scale = np.where(last, PARABOLIC_SCALE, 1.0)
    acc = machine._along(acc_axes, unit, None) * scale
    cap = np.full(n, np.inf)
    arc = np.isfinite(seg_r)
    if arc.any():
        # the arc's plane from its chords' turn (a one-chord arc: the XY plane)
        normal = np.tile([0.0, 0.0, 1.0], (n, 1))
        if n > 1:
            inner = _plane_normal(unit[:-1], unit[1:])
            same = move[:-1] == move[1:]
            normal[:-1] = np.where(same[:, None], inner, normal[:-1])
            normal[1:] = np.where(same[:, None], inner, normal[1:])
        a_max = inscribed_bound(acc_axes, normal[arc])
        v_axes = inscribed_bound(vel_axes, normal[arc])
        r = seg_r[arc]
        v_ini = np.minimum(v_axes, np.sqrt(ACC_RATIO_NORMAL * a_max * r))
        a_o = a_max * scale[arc]
        a_n = v_ini ** 2 / r
        cut = a_n > ACC_RATIO_NORMAL * a_o
        ratio = np.where(cut, ACC_RATIO_TANGENTIAL, np.sqrt(np.clip(1.0 - (a_n / a_o) ** 2, 0.0, 1.0)))
        acc[arc] = a_o * ratio
        cap[arc] = np.where(cut, np.sqrt(ACC_RATIO_NORMAL * a_o * r), v_ini)
    w = np.full(max(n - 1, 0), np.inf)
    if n > 1:
        u_in, u_out = unit[:-1], unit[1:]
        corner = move[:-1] != move[1:]
        cos_in = np.einsum("ij,ij->i", u_in, u_out)
        # θ half the angle between −u_in and u_out: sin²θ = (1 + u_in·u_out)/2
        sin_t = np.sqrt(np.clip(0.5 * (1.0 + cos_in), 0.0, 1.0))
        move_len = np.bincount(move, weights=length)
        tol = np.minimum(machine.corner_mm, TOLERANCE_RATIO * np.minimum(move_len[move[:-1]], move_len[move[1:]]))
        with np.errstate(divide="ignore", invalid="ignore"):
            radius = tol * sin_t / (1.0 - sin_t)
        a_plane = inscribed_bound(acc_axes, _plane_normal(u_in, u_out))
        w_corner = ACC_RATIO_NORMAL * a_plane * radius
        w_corner = np.where(cos_in > 0.999999, np.inf, w_corner)          # straight on
        w_corner = np.where(cos_in < -0.999999, 0.0, w_corner)            # a reversal stops
        w = np.where(corner, w_corner, np.inf)
    return acc, cap, w
