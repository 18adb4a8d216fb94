"""fuzzyfeed's machine model against LinuxCNC 2.9's own planner (issue 37).

For each public program of benchmarks/library (its first --lines lines, so LinuxCNC, which runs in
real time, takes seconds), as written and as advised (``evaluate_program``, what ``fuzzyfeed
advise P --machine M --gcode A`` writes): fuzzyfeed's predicted time and largest contour error
against LinuxCNC's planner (tests/linuxcnc_sim.py) — its time from first to last motion, and the
contour error of the machine's servo model (``following_errors``) on LinuxCNC's commanded joint
positions, measured against the programmed path as fuzzyfeed builds it (``program_path`` chains,
``windowed_distance`` over the whole path), split into the ticks on feed moves (in the part) and
on rapids (in the air).

    python benchmarks/bench_controllers.py [--machine linuxcnc-mill] [--lines 120] [--markdown FILE]
"""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

import linuxcnc_sim  # noqa: E402

LIBRARY = ROOT / "benchmarks" / "library" / "programs"
#: mm programs rs274 accepts, from ten sources (not only LinuxCNC's examples)
PROGRAMS = ("cncjs/tball.gcode", "camotics/engrave.ngc", "camotics/wave.gcode", "ugs/electric_turtle.nc",
            "ugs/enclosure.nc", "linuxcnc/tort.ngc", "machinekit/splash.ngc", "gsender/demo.gcode",
            "pycut/pycut_small_kasten_op.nc", "dxf2gcode/erin7.ngc", "fluidnc/arcs_arrows.nc",
            "led_floor/1084_btn_18bit_first.nc")


def prefix(src: Path, lines: int, out: Path) -> Path:
    """The program's first ``lines`` lines after a known start (G21 G90, at the origin), without its
    M0/M1/M2/M30/M60 lines, then M2."""
    body = src.read_text(errors="replace").splitlines()[:lines]
    # program ends and operator pauses out (the harness would resume a pause, but its wait would
    # count in LinuxCNC's time and not in fuzzyfeed's)
    body = [l for l in body if not re.fullmatch(r"\s*(N\d+\s*)?(M0?[0-2]|M30|M60|%)\s*(\(.*\))?\s*", l, re.I)]
    out.write_text("G21 G90\nG0 X0 Y0 Z0\n" + "\n".join(body) + "\nM5\nM2\n")
    return out


def linuxcnc_errors(run, machine, program_file: Path):
    """Largest contour error (um) of the servo on LinuxCNC's commands: in the part, in the air."""
    from fuzzyfeed.machine.contour import windowed_distance
    from fuzzyfeed.machine.servo import following_errors
    from fuzzyfeed.program.read import read_program
    from fuzzyfeed.program.run import program_path

    path = program_path(read_program(program_file), machine.chord_tol_mm)
    pts, rapid = [], []
    for chain in path.chains:
        p = chain.motion.points
        if pts and np.linalg.norm(p[0] - pts[-1]) > 0:      # a gap between chains: in the air
            rapid.append(True)
            pts.append(p[0])
        elif not pts:
            pts.append(p[0])
        pts.extend(p[1:])
        rapid.extend(chain.motion.rapid.tolist())
    pts, rapid = np.array(pts), np.array(rapid)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    actual = run.joints_mm - following_errors(machine.servo, run.joints_mm, run.ts_s)
    k = actual.shape[0]
    dist, nearest, _ = windowed_distance(pts, s, actual, np.full(k, -1.0), np.full(k, s[-1] + 1.0))
    # fuzzyfeed's split (machine/trace.py): a tick is in the part when it is commanded on a feed
    # move and the tool is nearest a feed segment; a tool still lagging on a rapid is in the air
    feed = np.isin(run.motion_type, (linuxcnc_sim.FEED, linuxcnc_sim.ARC))
    part = feed & ~rapid[nearest]
    air = (run.motion_type == linuxcnc_sim.TRAVERSE) | (feed & rapid[nearest])
    return (float(dist[part].max() * 1e3) if part.any() else 0.0,
            float(dist[air].max() * 1e3) if air.any() else 0.0)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--machine", default="linuxcnc-mill")
    ap.add_argument("--lines", type=int, default=120)
    ap.add_argument("--markdown", default=None, metavar="FILE")
    args = ap.parse_args()
    reason = linuxcnc_sim.unavailable()
    if reason:
        print(f"bench_controllers: {reason}")
        return 1
    from fuzzyfeed.fuzzy.rules import DEFAULT_MACHINE_TABLE, load_rule_table
    from fuzzyfeed.machine.description import load_machine
    from fuzzyfeed.program.read import read_program
    from fuzzyfeed.report.value import evaluate_program

    machine = load_machine(args.machine)
    table = load_rule_table(DEFAULT_MACHINE_TABLE)
    tol = machine.contour_tol_um
    rows, delays = [], 0
    head = (f"{'program':<34} {'run':<8} {'ff s':>7} {'lcnc s':>7} {'t err':>7} {'ff um':>7} "
            f"{'part um':>8} {'air um':>7}")
    print(f"machine {machine.describe()}\n{head}")
    with tempfile.TemporaryDirectory() as tmp:
        for name in PROGRAMS:
            src = LIBRARY / name
            p = prefix(src, args.lines, Path(tmp) / (src.stem + ".ngc"))
            try:
                ev = evaluate_program(read_program(p), machine, table, reference=False)
            except Exception as exc:   # a prefix fuzzyfeed cannot advise: named, not counted
                print(f"{name:<34} skipped: {type(exc).__name__}: {exc}")
                continue
            a = Path(tmp) / (src.stem + "_advised.ngc")
            a.write_text(ev.text)
            for label, f, row in (("written", p, ev.report.written), ("advised", a, ev.report.advised)):
                try:
                    run = linuxcnc_sim.run_program(machine, f, expected_s=row.time_s + 5).moving()
                except linuxcnc_sim.SimError as exc:
                    print(f"{name:<34} {label:<8} LinuxCNC: {str(exc)[:120]}")
                    continue
                delays += run.realtime_delays
                part, air = linuxcnc_errors(run, machine, f)
                terr = row.time_s / run.time_s - 1.0
                rows.append((name, label, row.time_s, run.time_s, terr, row.max_um, part, air))
                print(f"{name:<34} {label:<8} {row.time_s:7.2f} {run.time_s:7.2f} {terr * 100:6.1f}% "
                      f"{row.max_um:7.1f} {part:8.1f} {air:7.1f}", flush=True)
    lines = []
    for label in ("written", "advised"):
        r = [x for x in rows if x[1] == label]
        if not r:
            continue
        e = np.abs([x[4] for x in r])
        hold = sum(x[6] <= 1.2 * tol for x in r)
        lines.append(f"{label}: {len(r)} programs, time error median {np.median(e) * 100:.2f} %, worst "
                     f"{e.max() * 100:.2f} %; part error within 1.2 x {tol:g} um on {hold}/{len(r)}")
    lines.append(f"LinuxCNC 'Unexpected realtime delay' messages: {delays} (wall time only)")
    print("\n".join(lines))
    if args.markdown:
        md = ["# fuzzyfeed against LinuxCNC 2.9's planner (benchmarks/bench_controllers.py)", "",
              f"`python benchmarks/bench_controllers.py --machine {args.machine} --lines {args.lines}`", "",
              f"Machine: {machine.describe()}", "",
              "Each program's first lines after `G21 G90 G0 X0 Y0 Z0`, then M2. ff: fuzzyfeed's prediction "
              "(time, largest contour error of its own planner + servo); lcnc: LinuxCNC's planner, its "
              "commanded joints through the same servo model, contour error against the programmed path "
              "(ticks on feed moves = part, on rapids = air).", "",
              "| program | run | ff time s | LinuxCNC time s | time error | ff max um | LinuxCNC part um | LinuxCNC air um |",
              "|---|---|---|---|---|---|---|---|"]
        md += [f"| {n} | {l} | {a:.2f} | {b:.2f} | {c * 100:+.1f} % | {d:.1f} | {e:.1f} | {f:.1f} |"
               for n, l, a, b, c, d, e, f in rows]
        md += ["", *lines, ""]
        Path(args.markdown).write_text("\n".join(md))
        print(f"wrote {args.markdown}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
