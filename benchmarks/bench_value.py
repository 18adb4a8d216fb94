"""Is the advice worth having? (issue 32) — a library of public programs run on a machine.

    python benchmarks/bench_value.py [--machine reference] [--programs DIR_OR_MANIFEST] [--split tune.json]
                                     [--workers 2] [--markdown] [--json OUT.json] [--limit N]

For every program of the library (benchmarks/library/MANIFEST.csv: public programs from many CAM
posts and hand-written sources; the programs fuzzyfeed reads) and every machine asked for, the
program is run four ways on the same controller and servo model — as written, advised (the
machine table, or --rules), every F times the one factor that just holds the tolerance (the
uniform slowdown) and the limit reference (feeds lowered piece by piece only where the run breaks
the tolerance) — and the time and the max/p99 contour error of each are printed, per program and
as medians. The uniform slowdown and the limit reference are the anchors, measured in the same run.

With --split FILE (written by ``fuzzyfeed tune``), only the held-out programs count in the
summary (the ones never used for tuning); otherwise every program is held out (the shipped table
was not tuned on the library).

The verdict lines check issue 32's targets: advised max error <= 1.2 x tolerance on >= 90 % of the
programs; over the programs that break the tolerance as written, median advised time <= 0.7 x the
uniform slowdown's and <= 1.5 x the limit reference's; programs that hold as written take <= 1.05 x
their time as written.
"""

from __future__ import annotations

import argparse
import csv
import json
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

HERE = Path(__file__).resolve().parent
#: A uniform slowdown whose run would pass this many servo periods is not simulated: its time is
#: then the planner's at the lowest factor tried, a lower bound (so adv/uniform is an upper bound).
UNIFORM_MAX_TICKS = 8e6
LIBRARY = HERE / "library"


def library_programs(spec: str | None) -> list[Path]:
    """The programs to run: a folder (recursively, by G-code suffix) or the library's manifest."""
    from fuzzyfeed.program.model import GCODE_SUFFIXES

    if spec and Path(spec).is_dir():
        return sorted(p for p in Path(spec).rglob("*") if p.suffix.lower() in GCODE_SUFFIXES)
    manifest = Path(spec) if spec else LIBRARY / "MANIFEST.csv"
    with open(manifest, newline="") as handle:
        rows = [r for r in csv.DictReader(handle) if r["kind"] == "program"]
    return [manifest.parent / r["file"] for r in rows]


def _key(path: Path) -> str:
    """A program's name in tune's split file: its path from the repository's root, when inside it."""
    try:
        return Path(path).resolve().relative_to(HERE.parent).as_posix()
    except ValueError:
        return str(path)


def run_one(path: str, machine_name: str, rules: str | None, reference: bool, max_written_s: float) -> dict:
    """One program on one machine: the value report's rows, or the one-line reason it was skipped."""
    from fuzzyfeed.errors import FuzzyfeedError
    from fuzzyfeed.fuzzy.rule_reader import load_rule_table
    from fuzzyfeed.fuzzy.rules import DEFAULT_MACHINE_TABLE
    from fuzzyfeed.machine.description import load_machine
    from fuzzyfeed.program.read import read_program
    from fuzzyfeed.report.value import evaluate_program

    t0 = time.process_time()
    out = {"program": path, "machine": machine_name}
    try:
        program = read_program(path)
        if program.n_cuts == 0:
            return {**out, "skipped": "no feed move to advise"}
        machine = load_machine(machine_name)
        from fuzzyfeed.machine.planner import plan_motion
        from fuzzyfeed.program.run import program_path

        planned = sum(plan_motion(c.motion, machine).time_s for c in program_path(program, machine.chord_tol_mm).chains)
        if planned > max_written_s:
            return {**out, "skipped": f"{planned:.0f} s as written, over --max-written-s {max_written_s:g} "
                                      "(the uniform slowdown would simulate hours)"}
        table = load_rule_table(rules or DEFAULT_MACHINE_TABLE)
        ev = evaluate_program(program, machine, table, reference=reference, max_ticks=UNIFORM_MAX_TICKS)
    except (FuzzyfeedError, OSError) as exc:
        return {**out, "skipped": " ".join(str(exc).split())[:160]}
    r = ev.report
    out.update(r.csv_row())
    out["program"] = path
    out["reference_converged"] = r.reference_converged
    out["cpu_s"] = time.process_time() - t0
    return out


def summarise(rows: list[dict], held_out: set[str] | None) -> list[str]:
    ok = [r for r in rows if "skipped" not in r and (held_out is None or _key(r["program"]) in held_out)]
    lines = []
    by_machine: dict[str, list[dict]] = {}
    for r in ok:
        by_machine.setdefault(r["machine"], []).append(r)
    for machine, rs in by_machine.items():
        tol = rs[0]["contour_tol_um"]
        n = len(rs)
        within = sum(r["advised_max_um"] <= 1.2 * tol for r in rs)
        breaking = [r for r in rs if not r["holds_as_written"]]
        holding = [r for r in rs if r["holds_as_written"]]
        vs_uniform = [r["advised_time_s"] / r["uniform_time_s"] for r in breaking]
        vs_ref = [r["advised_time_s"] / r["reference_time_s"] for r in breaking
                  if r["reference_time_s"] == r["reference_time_s"]]
        vs_written_hold = [r["advised_time_s"] / r["written_time_s"] for r in holding]
        vs_written = [r["advised_time_s"] / r["written_time_s"] for r in breaking]
        med = (lambda xs: statistics.median(xs) if xs else float("nan"))
        lines.append(f"machine {machine!r} (tolerance {tol:g} um): {n} programs, {len(breaking)} break the "
                     f"tolerance as written, {len(holding)} hold it")
        lines.append(f"  advised max error <= 1.2 x tolerance: {within}/{n} = {100 * within / max(n, 1):.0f} % "
                     f"(goal >= 90 %)  {'ok' if within >= 0.9 * n else 'MISSED'}")
        lines.append(f"  over the {len(breaking)} that break it: median advised / uniform slowdown "
                     f"{med(vs_uniform):.3f} (goal <= 0.7)  {'ok' if med(vs_uniform) <= 0.7 else 'MISSED'}; "
                     f"median advised / limit reference {med(vs_ref):.3f} (goal <= 1.5)  "
                     f"{'ok' if med(vs_ref) <= 1.5 else 'MISSED'}; median advised / as written "
                     f"{med(vs_written):.3f}")
        if holding:
            worst = max(vs_written_hold)
            lines.append(f"  over the {len(holding)} that hold it: advised / as written at most {worst:.3f} "
                         f"(goal <= 1.05)  {'ok' if worst <= 1.05 else 'MISSED'}")
        bounded = sum(bool(r.get("uniform_is_bound")) for r in breaking)
        if bounded:
            lines.append(f"  ({bounded} uniform slowdowns past the tick budget are lower bounds: their "
                         "advised / uniform ratios are upper bounds)")
        lines.append(f"  median time (s): as written {med([r['written_time_s'] for r in rs]):.1f}, advised "
                     f"{med([r['advised_time_s'] for r in rs]):.1f}, uniform {med([r['uniform_time_s'] for r in rs]):.1f}, "
                     f"reference {med([r['reference_time_s'] for r in rs]):.1f}; median max error (um): as written "
                     f"{med([r['written_max_um'] for r in rs]):.1f}, advised {med([r['advised_max_um'] for r in rs]):.1f}")
    return lines


def _factor(c: float) -> str:
    return f"{c:.3f}" if c >= 0.01 else f"{c:.3g}"


def table(rows: list[dict], markdown: bool) -> str:
    head = ["program", "machine", "written s", "written max um", "advised s", "advised max um", "advised p99 um",
            "uniform x", "uniform s", "reference s", "reference max um", "adv/uniform", "adv/ref"]
    body = []
    for r in rows:
        if "skipped" in r:
            continue
        body.append([Path(r["program"]).name, r["machine"], f"{r['written_time_s']:.1f}", f"{r['written_max_um']:.1f}",
                     f"{r['advised_time_s']:.1f}", f"{r['advised_max_um']:.1f}", f"{r['advised_p99_um']:.1f}",
                     ("<" if r.get("uniform_is_bound") else "") + _factor(r["uniform_factor"]),
                     (">=" if r.get("uniform_is_bound") else "") + f"{r['uniform_time_s']:.1f}",
                     f"{r['reference_time_s']:.1f}",
                     f"{r['reference_max_um']:.1f}", f"{r['advised_time_s'] / r['uniform_time_s']:.2f}",
                     f"{r['advised_time_s'] / r['reference_time_s']:.2f}"])
    if markdown:
        return "\n".join(["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
                         + ["| " + " | ".join(b) + " |" for b in body])
    widths = [max(len(h), *(len(b[i]) for b in body)) if body else len(h) for i, h in enumerate(head)]
    return "\n".join(["  ".join(h.rjust(w) for h, w in zip(head, widths))]
                     + ["  ".join(c.rjust(w) for c, w in zip(b, widths)) for b in body])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--machine", action="append", default=None,
                        help="shipped machine name or file (repeat; default: reference)")
    parser.add_argument("--programs", default=None, help="a folder of programs or a MANIFEST.csv (default: the library)")
    parser.add_argument("--rules", default=None, help="rule table (default: the machine table)")
    parser.add_argument("--split", default=None, help="tune's split file: summarise the held-out programs only")
    parser.add_argument("--held-out-only", action="store_true",
                        help="with --split: run the held-out programs only (the others are not simulated)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--limit", type=int, default=None, help="the first N programs only")
    parser.add_argument("--no-reference", action="store_true")
    parser.add_argument("--max-written-s", type=float, default=900.0,
                        help="leave out programs that take longer as written (default: %(default)g s)")
    parser.add_argument("--markdown", action="store_true")
    parser.add_argument("--json", default=None, help="also write every row as JSON")
    args = parser.parse_args()
    programs = library_programs(args.programs)[: args.limit]
    machines = args.machine or ["reference"]
    held_out = None
    if args.split:
        held_out = set(json.loads(Path(args.split).read_text())["held_out"])
        if args.held_out_only:
            programs = [p for p in programs if _key(p) in held_out]
    elif args.held_out_only:
        parser.error("--held-out-only needs --split")
    t0 = time.time()
    rows = []
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        futures = [pool.submit(run_one, str(p), m, args.rules, not args.no_reference, args.max_written_s)
                   for p in programs for m in machines]
        for done, fut in enumerate(as_completed(futures), start=1):
            row = fut.result()
            rows.append(row)
            tag = row.get("skipped") or (f"{row['advised_time_s']:.1f} s, {row['advised_max_um']:.1f} um "
                                         f"(written {row['written_time_s']:.1f} s, {row['written_max_um']:.1f} um)")
            print(f"[{done}/{len(futures)}] {Path(row['program']).name} on {row['machine']}: {tag}",
                  file=sys.stderr, flush=True)
    rows.sort(key=lambda r: (r["machine"], Path(r["program"]).name))
    print(table(rows, args.markdown))
    skipped = [r for r in rows if "skipped" in r]
    print(f"\n{len(rows) - len(skipped)} runs, {len(skipped)} skipped (programs fuzzyfeed refuses or without "
          f"feed moves), {time.time() - t0:.0f} s wall")
    for r in skipped:
        print(f"  skipped {Path(r['program']).name}: {r['skipped']}")
    print()
    print("\n".join(summarise(rows, held_out)))
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
