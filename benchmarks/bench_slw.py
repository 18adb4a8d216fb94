"""SLW scheduler benchmark: does it work wherever users go, and how near the jerk-limited floor?

Paths, each on two machines — EQUAL (the issue's: 6000 mm/min, 100 mm/s and 1000 mm/s² per axis,
10 000 mm/s³, 1 µm, 1 ms) and SLOW_Y (the same with Y at 50 mm/s and 250 mm/s²):
the shipped shapes; ``--random`` random NURBS of tests/slw_cases.py (degree 2-5, 2-D and 3-D,
random weights); the polylines of tests/slw_cases.py (rectangles, zig-zags, square passes,
CAM-style chains of 10³-10⁴ segments, blended within G64 P0.01); and every cut of the real
programs in benchmarks/library/programs of the main repository, or tests/programs/corpus when
that is absent (its first ``--max-cuts`` cuts, each at the program's own F words, capped at the command feed, as
``fuzzyfeed schedule`` runs it).

Per case, the schedule users get by default (``schedule``'s: the faster of the whole-path LP and the
seven-phase window; ``--planner window`` runs the window alone with seed 000's cosine and the
seven-phase transitions, ``--transition``): failure or not; the
worst ratio to every limit measured by the one simulator from the interpolated positions (feed,
axis velocity, axis acceleration, chord error; the profile's jerk); the cycle time over the
jerk-limited floor (fuzzyfeed.slw.floor.jerk_floor: the acceleration-limited bound, and every
leg between full stops at least its seven-phase rest-to-rest time), printed beside the floor;
the CPU time of ``schedule``. Anchor in the same run: the bound against toppra 0.6 on infinity
(DESIGN §6: 4.9008 s).

Run: python benchmarks/bench_slw.py [--random N] [--planner optimal|window] [--transition both|seven-phase|cosine]
``--corner-bound NAME ...`` prints, for the named cases only, a proven lower bound on the cycle time
of any jerk-limited schedule through the path's true corners (:func:`corner_chain_bound`) beside
the floor and the SLW time: where it is above the floor, no scheduler can reach the floor there.
Last line: median_ratio_to_floor=M worst_ratio_to_floor=W worst_compute_s=C failed=F over_limit=V
(of the planner, or with ``--planner window`` of the first transition, over every case).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import slw_cases  # noqa: E402

from fuzzyfeed.cli._limits import program_feed_limits  # noqa: E402
from fuzzyfeed.io.shapes import load_shape, load_shapes, shape_names  # noqa: E402
from fuzzyfeed.machine.limits import MachineLimits  # noqa: E402
from fuzzyfeed.slw import measure, path_bound, schedule  # noqa: E402
from fuzzyfeed.slw.floor import jerk_floor, legs_s  # noqa: E402
from fuzzyfeed.slw.warm import warm_kernels  # noqa: E402

LIMITS = ("feed", "axis_vel", "axis_acc", "chord", "jerk")
EQUAL = MachineLimits()
SLOW_Y = MachineLimits(axis_vel_mm_s=(100, 50, 100), axis_acc_mm_s2=(1000, 250, 1000))
MACHINES = {"equal": EQUAL, "slow-y": SLOW_Y}
#: Over a limit: a tick above it by more than this (the summary prints two decimals of a per cent).
OVER = 1 + 5e-5
#: Diagnostic only (not the floor): the jerk at which a jerk-bound seven-phase change of feed takes
#: as long as the cosine's, 2·√(Δv/J') = π·√(Δv/(2J)) ⇔ J' = 8J/π² (profile.py). The floor under
#: J' (cosine cases, column ``/cosJ``) shows how much of a cosine's gap the transition's shape
#: alone makes on the jerk side (an acceleration-bound cosine, π/2 x Δv/A, costs more still).
COSINE_JERK = 8.0 / np.pi ** 2
LIBRARY = Path("/work/main/benchmarks/library/programs")


def toppra_bound(curve, limits: MachineLimits, grid_points: int = 4000) -> float | None:
    """toppra 0.6 on the same path (a spline through arc-length samples of x, y, z, s; per-axis
    velocity/acceleration limits, the command feed as the velocity limit of s). None if absent."""
    try:
        import toppra as ta
        import toppra.algorithm as algo
        import toppra.constraint as constraint
    except ImportError:
        return None
    from fuzzyfeed.geometry.sampling import sample_by_arc_length

    ta.setup_logging("WARNING")
    smp = sample_by_arc_length(curve, n=4 * grid_points)
    path = ta.SplineInterpolator(smp.s, np.column_stack([smp.xyz, smp.s]))
    vel = np.array([[-v, v] for v in limits.axis_vel_mm_s] + [[-limits.feed_mm_s, limits.feed_mm_s]])
    acc = np.array([[-a, a] for a in limits.axis_acc_mm_s2] + [[-1e12, 1e12]])
    inst = algo.TOPPRA([constraint.JointVelocityConstraint(vel), constraint.JointAccelerationConstraint(acc)],
                       path, gridpoints=np.linspace(0.0, smp.s[-1], grid_points),
                       parametrizer="ParametrizeConstAccel")
    traj = inst.compute_trajectory(0, 0)
    return None if traj is None else float(traj.duration)


def _max_distance(T: float, c1: float, c2: float, F: float, A: float, J: float, n: int = 40) -> float:
    """An upper bound on the distance any motion with |j| ≤ J, |a| ≤ A, 0 ≤ v ≤ F can cover in T
    seconds from v(0) ≤ c1 to v(T) ≤ c2 (accelerations at both ends free): an LP on n time steps
    h in which each step's jerk integrals are only bounded (|Δa| ≤ Jh, |Δv − h·a| ≤ Jh²/2,
    |Δs − h·v − h²a/2| ≤ Jh³/6) and the limits hold at the steps — a superset of the motions."""
    from scipy.optimize import linprog
    from scipy.sparse import lil_matrix

    h, nv = T / n, n + 1
    size = 2 * nv + 2 * n  # v_0…v_n, a_0…a_n, Δv − h·a per step, Δs − h·v − h²a/2 per step
    a_ub, b_ub = lil_matrix((2 * n, size)), np.full(2 * n, J * h)
    a_eq = lil_matrix((n, size))
    cost = np.zeros(size)
    for k in range(n):
        a_ub[2 * k, nv + k + 1], a_ub[2 * k, nv + k] = 1.0, -1.0
        a_ub[2 * k + 1, nv + k + 1], a_ub[2 * k + 1, nv + k] = -1.0, 1.0
        a_eq[k, k + 1], a_eq[k, k], a_eq[k, nv + k], a_eq[k, 2 * nv + k] = 1.0, -1.0, -h, -1.0
        cost[k] -= h
        cost[nv + k] -= h * h / 2.0
        cost[2 * nv + n + k] -= 1.0
    bounds = ([(0.0, F)] * nv + [(-A, A)] * nv + [(-J * h * h / 2.0, J * h * h / 2.0)] * n
              + [(-J * h ** 3 / 6.0, J * h ** 3 / 6.0)] * n)
    bounds[0], bounds[n] = (0.0, min(c1, F)), (0.0, min(c2, F))
    res = linprog(cost, A_ub=a_ub.tocsr(), b_ub=b_ub, A_eq=a_eq.tocsr(), b_eq=np.zeros(n), bounds=bounds,
                  method="highs")
    return -res.fun


def corner_chain_bound(curve, limits: MachineLimits) -> float:
    """A proven lower bound (s) on the cycle time of any schedule with tangential |j| ≤ J,
    |a| ≤ ‖A_j‖₂ and v ≤ F that passes each true corner no faster than the corner rule allows
    (fuzzyfeed.slw.preprocess.corners without its 10 % margin: cap/0.9 + J·Ts²/2). The path is cut
    at its corners and every gap is run alone with free accelerations at its ends (a relaxation);
    per gap, the least T whose :func:`_max_distance` covers the gap (bisection, from below)."""
    from fuzzyfeed.slw.preprocess import corners

    s_c, cap = corners(curve, limits)
    F, J = limits.feed_mm_s, limits.jerk_mm_s3
    A = float(np.linalg.norm(limits.axis_acc_mm_s2[:curve.dim]))
    s = np.concatenate([[0.0], s_c, [curve.length]])
    v = np.concatenate([[0.0], cap / 0.9 + J * limits.ts_s ** 2 / 2.0, [0.0]])
    total = 0.0
    for g, c1, c2 in zip(np.diff(s), v[:-1], v[1:]):
        lo, hi = 0.0, max(g / F, 1e-4)
        while _max_distance(hi, c1, c2, F, A, J) < g:
            lo, hi = hi, 2.0 * hi
        for _ in range(22):
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if _max_distance(mid, c1, c2, F, A, J) >= g else (mid, hi)
        total += lo
    return total


def run_case(name: str, curve, limits: MachineLimits, transition: str, cap=None, keep_curve: bool = False) -> dict:
    """One case; ``transition`` "optimal" runs ``schedule(planner="optimal")``: the faster of the LP's
    and the window's seven-phase schedule (its CPU time includes both)."""
    t0 = time.process_time()
    try:
        if transition == "optimal":
            traj = schedule(curve, limits, feed_cap=cap, planner="optimal", transition="seven-phase")
        else:
            traj = schedule(curve, limits, transition=transition, feed_cap=cap, planner="window")
    except Exception as exc:  # noqa: BLE001 - a benchmark reports every failure
        return {"name": name, "fail": f"{type(exc).__name__}: {exc}"[:240], "cpu": time.process_time() - t0}
    cpu = time.process_time() - t0
    bound = path_bound(traj.curve, limits, feed_cap=cap, halve=False)  # the path followed
    floor = jerk_floor(traj.curve, limits, bound)
    old = max(bound.time_s, legs_s(traj.curve, limits))  # the floor before the corner chain
    cos_floor = None
    if transition == "cosine":  # diagnostic: the floor at the cosine's equivalent jerk (COSINE_JERK)
        from dataclasses import replace

        cos_floor = jerk_floor(traj.curve, replace(limits, jerk_mm_s3=COSINE_JERK * limits.jerk_mm_s3), bound)
    m = measure(traj)
    return {"name": name, "length": traj.curve.length, "cpu": cpu, "time": traj.cycle_time_s,
            "bound": bound.time_s, "floor": floor, "ratio": traj.cycle_time_s / floor,
            "ratio_old": traj.cycle_time_s / old,
            "ratio_cos": None if cos_floor is None else traj.cycle_time_s / cos_floor,
            "worst": max(m[k] for k in LIMITS), "limit": max(LIMITS, key=lambda k: m[k]),
            "crit": traj.n_critical, **({"curve": traj.curve} if keep_curve else {})}


def line(r: dict) -> str:
    if "fail" in r:
        return f"{r['name']:<34} FAILED after {r['cpu']:.2f} s: {r['fail']}"
    return (f"{r['name']:<34} {r['length']:9.1f} {r['time']:9.3f} {r['bound']:9.3f} {r['floor']:9.3f} "
            f"{r['ratio']:7.4f} {r['ratio_old']:7.4f} {r['worst']:8.5f} {r['limit']:>8} {r['crit']:6d} {r['cpu']:7.2f}"
            + ("" if r.get("ratio_cos") is None else f" {r['ratio_cos']:7.4f}"))


HEADER = (f"{'path / machine / transition':<34} {'length mm':>9} {'SLW s':>9} {'bound s':>9} {'floor s':>9} "
          f"{'/floor':>7} {'/old':>7} {'worst':>8} {'limit':>8} {'crit':>6} {'cpu s':>7} {'/cosJ':>7}")


def cases(n_random: int, max_cuts: int, programs: tuple[str, str] | None = None, builtin_only: bool = False,
          first_cut: int = 1):
    """(name, curve, limits, feed cap or None) of every benchmark case; with ``programs`` = (first,
    end), only the programs whose path in the library is in [first, end) ("" = no end); with
    ``builtin_only``, every case but the programs."""
    if programs is not None:
        yield from _program_cases(max_cuts, programs, first_cut)
        return
    for name in shape_names():
        for mname, lim in MACHINES.items():
            yield f"{name}/{mname}", load_shape(name).curve, lim, None
    for name, curve, _ in slw_cases.polyline_cases()[:4]:  # the default-machine ones, both machines
        for mname, lim in MACHINES.items():
            yield f"{name.split('/')[0]}/{mname}", curve, lim, None
    for mname, lim in MACHINES.items():
        yield f"cam10000/{mname}", slw_cases.cam_polyline(10_000), lim, None
    # the issue's two reports: a random cubic with a near-cusp (the chords' jerk 13.8 x J), and the
    # case of it found here (tests/test_slw_schedule.py)
    for mname, lim in MACHINES.items():
        yield f"cusp-cubic/{mname}", slw_cases.cusp_cubic(), lim, None
    for seed in range(n_random):
        curve, _ = slw_cases.random_nurbs(seed)
        for mname, lim in MACHINES.items():
            yield f"nurbs{seed} p{curve.degree} {curve.dim}-D/{mname}", curve, lim, None
    if not builtin_only:
        yield from _program_cases(max_cuts, ("", ""), first_cut)


def _program_cases(max_cuts: int, programs: tuple[str, str], first_cut: int = 1):
    first, end = programs
    folder = LIBRARY if LIBRARY.is_dir() else ROOT / "tests" / "programs" / "corpus"
    for path in sorted(p for ext in ("ngc", "nc", "gcode") for p in folder.rglob(f"*.{ext}")):
        rel = str(path.relative_to(folder))
        if rel < first or (end and rel >= end):
            continue
        try:
            shapes = load_shapes(path)
        except Exception as exc:  # noqa: BLE001 - a program the reader refuses is not a case
            print(f"# {path.relative_to(folder)}: not read ({type(exc).__name__}: {str(exc)[:80]})")
            continue
        for i, shape in enumerate(shapes[:max_cuts], start=1):
            if i < first_cut:
                continue
            for mname, lim in MACHINES.items():
                try:
                    lim_f, cap, _ = program_feed_limits(shape, lim)
                except Exception as exc:  # noqa: BLE001
                    print(f"# {path.name}#{i}: {exc}")
                    continue
                yield f"{path.relative_to(folder)}#{i}/{mname}", shape.curve, lim_f, cap


def summary(results: list[dict], label: str) -> tuple[float, float, float, int, int]:
    ok = [r for r in results if "fail" not in r]
    fails = [r for r in results if "fail" in r]
    over = [r for r in ok if r["worst"] > OVER]
    ratios = np.array([r["ratio"] for r in ok])
    worst = max(ok, key=lambda r: r["ratio"])
    slow = max(results, key=lambda r: r["cpu"])
    print(f"{label}: {len(results)} cases, failed {len(fails)}, over a limit {len(over)} "
          f"{[r['name'] for r in over][:6]}; ratio to the jerk-limited floor: median {np.median(ratios):.4f}, "
          f"90th percentile {np.percentile(ratios, 90):.4f}, worst {worst['ratio']:.4f} ({worst['name']}: "
          f"{worst['time']:.3f} s against a floor of {worst['floor']:.3f} s); compute worst {slow['cpu']:.2f} s "
          f"({slow['name']}), total {sum(r['cpu'] for r in results):.1f} s; against the floor without the corner "
          f"chain: median {np.median([r['ratio_old'] for r in ok]):.4f}, worst {max(r['ratio_old'] for r in ok):.4f}")
    cos = [r["ratio_cos"] for r in ok if r.get("ratio_cos") is not None]
    if cos:
        print(f"{label} (diagnostic, not the floor): against the floor at the cosine's equivalent jerk "
              f"8J/pi^2: median {np.median(cos):.4f}, 90th percentile {np.percentile(cos, 90):.4f}, "
              f"worst {max(cos):.4f}")
    return float(np.median(ratios)), float(worst["ratio"]), float(slow["cpu"]), len(fails), len(over)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--random", type=int, default=110, help="random NURBS, each on both machines "
                                                              "(default: %(default)s)")
    ap.add_argument("--transition", choices=("both", "seven-phase", "cosine"), default="both")
    ap.add_argument("--planner", choices=("optimal", "window"), default="optimal", help="optimal (schedule's "
                    "default): the faster of the whole-path LP and the seven-phase window, once per case; "
                    "window: the window alone with each --transition (default: %(default)s)")
    ap.add_argument("--max-cuts", type=int, default=2, help="cuts of each program (default: %(default)s)")
    ap.add_argument("--first-cut", type=int, default=1, help="the programs' cuts from this one (1 = the first) "
                    "up to --max-cuts: a run split by cut")
    ap.add_argument("--corner-bound", nargs="+", metavar="NAME", help="only these cases (path/machine, as "
                    "printed): the proven corner-chain lower bound beside the floor and the SLW time")
    ap.add_argument("--programs", nargs=2, metavar=("FIRST", "END"), help="only the programs whose path "
                    "in the library is in [FIRST, END) ('' for no end), no other case: a run split across "
                    "processes (the summary is then of those cases only)")
    ap.add_argument("--builtin-only", action="store_true", help="every case but the programs (the other part "
                    "of a run split with --programs)")
    ap.add_argument("--machine", choices=tuple(MACHINES), help="only the cases on this machine")
    ap.add_argument("--program", nargs="+", metavar="PATH", help="only these programs (paths in the library, "
                    "as printed before '#'), no other case")
    args = ap.parse_args()
    if args.corner_bound:
        wanted = set(args.corner_bound)
        for name, curve, lim, cap in cases(args.random, args.max_cuts):
            if name not in wanted:
                continue
            r = run_case(name, curve, lim, "cosine", cap, keep_curve=True)
            lb = corner_chain_bound(r["curve"], lim)
            print(f"{name}: SLW {r['time']:.3f} s, floor {r['floor']:.3f} s ({r['ratio']:.4f}); proven corner-chain "
                  f"bound {lb:.3f} s = {lb / r['floor']:.4f} x the floor; SLW / bound {r['time'] / lb:.4f}", flush=True)
            wanted.discard(name)
            if not wanted:
                break
        return
    transitions = ("cosine", "seven-phase") if args.transition == "both" else (args.transition,)
    if args.planner == "optimal":
        transitions = ("optimal",)
    warm_kernels()  # every compiled kernel loaded (or compiled once) outside the timed cases
    print(f"machines: equal {EQUAL}\n          slow-y {SLOW_Y}")
    print(HEADER)
    print("-" * len(HEADER))
    results: dict[str, list[dict]] = {t: [] for t in transitions}
    if args.program:
        chosen = (c for p in args.program for c in _program_cases(args.max_cuts, (p, p + "\x7f"), args.first_cut)
                  if c[0].split("#")[0] == p)
    else:
        chosen = cases(args.random, args.max_cuts, args.programs and tuple(args.programs), args.builtin_only,
                       args.first_cut)
    for name, curve, lim, cap in chosen:
        if args.machine and not name.endswith(f"/{args.machine}"):
            continue
        for t in transitions:
            r = run_case(f"{name}/{t}", curve, lim, t, cap)
            results[t].append(r)
            print(line(r), flush=True)
    print()
    inf = load_shape("infinity").curve
    ours = path_bound(inf, EQUAL)
    theirs = toppra_bound(inf, EQUAL)
    print(f"bound on infinity: ours {ours.time_s:.4f} s | toppra 0.6 "
          f"{'not installed' if theirs is None else f'{theirs:.4f} s'} | DESIGN §6 anchor 4.9008 s")
    figures = {t: summary(rs, t) for t, rs in results.items()}
    if len(transitions) == 2:
        pairs = [(a, b) for a, b in zip(results["seven-phase"], results["cosine"])
                 if "fail" not in a and "fail" not in b]
        slower = [(a["name"], a["time"] / b["time"]) for a, b in pairs if a["time"] > b["time"] * (1 + 1e-3)]
        costlier = [(a["name"], a["cpu"], b["cpu"]) for a, b in pairs if a["cpu"] > 1.5 * b["cpu"] + 0.2]
        print(f"seven-phase against cosine on the same {len(pairs)} cases: median time ratio "
              f"{np.median([a['time'] / b['time'] for a, b in pairs]):.4f}; slower by > 0.1 % on "
              f"{len(slower)} {[(n, round(x, 4)) for n, x in slower[:6]]}; compute > 1.5 x + 0.2 s on "
              f"{len(costlier)} {[(n, round(x, 2), round(y, 2)) for n, x, y in costlier[:6]]}")
    med, worst, cpu, fails, over = figures[transitions[0]]
    print(f"median_ratio_to_floor={med:.4f} worst_ratio_to_floor={worst:.4f} worst_compute_s={cpu:.2f} "
          f"failed={fails} over_limit={over}")


if __name__ == "__main__":
    main()
