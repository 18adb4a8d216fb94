"""fuzzyfeed's machine model against LinuxCNC 2.9's own planner (issue 37).

For each public program of benchmarks/library (its first --lines lines, so LinuxCNC, which runs in
real time, takes seconds), as written and as advised (``evaluate_program``, what ``fuzzyfeed
advise P --machine M --gcode A`` writes): fuzzyfeed's predicted time and largest contour error
against LinuxCNC's planner (tests/linuxcnc_sim.py) — its time (``SimRun.motion_time_s``), and the
contour error of the machine's servo model (``following_errors``) on LinuxCNC's commanded joint
positions, measured against the programmed path as fuzzyfeed builds it (``program_path`` chains,
``windowed_distance`` over the whole path), split into the ticks on feed moves (in the part) and
on rapids (in the air).

    python benchmarks/bench_controllers.py [--machine linuxcnc-mill] [--lines 120] [--max-s 25] [--markdown FILE]
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
#: mm programs rs274 accepts, from eleven sources (not only LinuxCNC's examples)
PROGRAMS = ("cncjs/tball.gcode", "camotics/engrave.ngc", "camotics/wave.gcode", "ugs/electric_turtle.nc",
            "ugs/enclosure.nc", "linuxcnc/tort.ngc", "machinekit/splash.ngc", "gsender/demo.gcode",
            "pycut/pycut_small_kasten_op.nc",
            "pcb2gcode/Easy-SDR_outline.ngc", "fluidnc/arcs_arrows.nc",
            "led_floor/1084_btn_18bit_first.nc", "gsender/longmill-line_M0.nc", "ugs/headrough.nc")


def prefix(src: Path, lines: int, out: Path) -> Path:
    """The program's first ``lines`` lines after a known start (G21 G90, at the origin), without its
    M0/M1/M2/M30/M60 lines, then M2."""
    body = src.read_text(errors="replace").splitlines()[:lines]
    # program ends and operator pauses out (the harness would resume a pause, but its wait would
    # count in LinuxCNC's time and not in fuzzyfeed's)
    body = [l for l in body if not re.fullmatch(r"\s*(N\d+\s*)?(M0?[0-2]|M30|M60|%)\s*(\(.*\))?\s*", l, re.I)]
    out.write_text("G21 G90\nG0 X0 Y0 Z0\n" + "\n".join(body) + "\nM5\nM2\n")
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--machine", default="linuxcnc-mill")
    ap.add_argument("--lines", type=int, default=120)
    ap.add_argument("--max-s", type=float, default=25.0,
                    help="halve a program's lines until fuzzyfeed predicts its advised run within this")
    ap.add_argument("--markdown", default=None, metavar="FILE")
    args = ap.parse_args()
    reason = linuxcnc_sim.unavailable()
    if reason:
        print(f"bench_controllers: {reason}")
        return 1
    from fuzzyfeed.fuzzy.rule_reader import load_rule_table
    from fuzzyfeed.fuzzy.rules import DEFAULT_MACHINE_TABLE
    from fuzzyfeed.machine.description import load_machine
    from fuzzyfeed.program.read import read_program
    from fuzzyfeed.report.value import evaluate_program

    machine = load_machine(args.machine)
    table = load_rule_table(DEFAULT_MACHINE_TABLE)
    tol = machine.contour_tol_um
    rows, delays = [], 0
    head = (f"{'program [:lines]':<40} {'run':<8} {'ff s':>7} {'lcnc s':>7} {'t err':>7} {'ff um':>7} "
            f"{'part um':>8} {'air um':>7}")
    print(f"machine {machine.describe()}\n{head}")
    with tempfile.TemporaryDirectory() as tmp:
        for name in PROGRAMS:
            src = LIBRARY / name
            lines, ev = args.lines, None
            while lines >= 10:         # LinuxCNC runs in real time: the advised run within --max-s
                p = prefix(src, lines, Path(tmp) / (src.stem + ".ngc"))
                try:
                    ev = evaluate_program(read_program(p), machine, table, reference=False)
                except Exception as exc:   # a prefix fuzzyfeed cannot advise: named, not counted
                    print(f"{name:<34} skipped: {type(exc).__name__}: {exc}")
                    ev = None
                    break
                if ev.report.advised.time_s <= args.max_s:
                    break
                lines //= 2
            if ev is None:
                continue
            if ev.report.advised.time_s > args.max_s:
                print(f"{name:<40} skipped: its first {lines} lines advised take "
                      f"{ev.report.advised.time_s:.0f} s > --max-s {args.max_s:g}")
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
                part, air = linuxcnc_sim.servo_contour_um(run, machine, f)
                terr = row.time_s / run.motion_time_s - 1.0
                rows.append((f"{name} [:{lines}]", label, row.time_s, run.motion_time_s, terr, row.max_um, part, air))
                print(f"{name + f' [:{lines}]':<40} {label:<8} {row.time_s:7.2f} {run.motion_time_s:7.2f} {terr * 100:6.1f}% "
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
              f"`python benchmarks/bench_controllers.py --machine {args.machine} --lines {args.lines} --max-s {args.max_s:g}`", "",
              f"Machine: {machine.describe()}", "",
              "Each program's first lines ([:N]) after `G21 G90 G0 X0 Y0 Z0`, then M2. ff: fuzzyfeed's prediction "
              "(time, largest contour error of its own planner + servo); LinuxCNC: its planner's time (the "
              "servo periods with a move in progress: waits for M-codes and tool changes left out, as "
              "fuzzyfeed leaves them out), its "
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
