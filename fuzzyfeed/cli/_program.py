"""``fuzzyfeed advise PROGRAM.ngc``: advise every cut of a whole G-code program and write the
same program back with the advised F words (``--gcode``), see :mod:`fuzzyfeed.program.feeds`
and :mod:`fuzzyfeed.program.rewrite`. ``PROGRAM.ngc#N`` advises cut N only (the other cuts keep
their feeds)."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from fuzzyfeed.errors import ExportError, MachineLimitsError


def add_program_arguments(parser: argparse.ArgumentParser) -> None:
    """``--tool-table`` and ``--tool-units``: the tool diameters cutter compensation needs."""
    parser.add_argument("--tool-table", metavar="FILE", default=None,
                        help="G-code programs: a LinuxCNC tool table (T1 P1 D6.0 Z0.5 ...); with it "
                             "moves under G41/G42 are advised on the tool centre's path, LinuxCNC's "
                             "way (without it, the programmed contour, with a notice)")
    parser.add_argument("--tool-units", choices=("mm", "inch"), default="mm",
                        help="length units of the tool table's diameters, the machine's units "
                             "(default: %(default)s; LinuxCNC's stand-alone rs274 reads inch)")


def refuse_program_arguments(args: argparse.Namespace) -> None:
    """Refuse the program-only flags for a shape."""
    if args.tool_table is not None:
        raise ExportError("--tool-table applies to G-code programs only (cutter compensation)")


def is_program(spec: str) -> bool:
    """True when SHAPE names a G-code file (with or without #N)."""
    from fuzzyfeed.program.model import GCODE_SUFFIXES
    from fuzzyfeed.io.shapes import split_selector

    base, _ = split_selector(spec)
    return Path(str(base)).suffix.lower() in GCODE_SUFFIXES


def _combined_advice(pa):
    """One FuzzyAdvice over all advised cuts end to end (for the plot): arc length runs on."""
    from fuzzyfeed.fuzzy.advisor import FuzzyAdvice
    from fuzzyfeed.fuzzy.features import Features
    from fuzzyfeed.machine.profile import FeedProfile
    from fuzzyfeed.geometry.sampling import PathSamples

    parts = {k: [] for k in ("xyz", "s", "tangent", "k", "wmax", "dk", "raw", "pct", "feed")}
    offset = 0.0
    for cs, adv, ceil in zip(pa.cuts, pa.advice, pa.ceiling_mm_min):
        sm = cs.samples
        parts["xyz"].append(sm.xyz)
        parts["s"].append(sm.s + offset)
        offset += sm.length
        parts["tangent"].append(sm.tangent)
        parts["k"].append(sm.curvature)
        parts["wmax"].append(adv.features.window_max_1_mm)
        parts["dk"].append(adv.features.curvature_variation)
        parts["raw"].append(adv.controller_pct)
        parts["pct"].append(adv.feed_pct)
        parts["feed"].append(adv.feed_pct / 100.0 * ceil / 60.0)
    cat = {k: np.concatenate(v) for k, v in parts.items()}
    nan = np.full_like(cat["xyz"], np.nan)
    s = cat["s"]
    samples = PathSamples(u=s / max(s[-1], 1e-300), xyz=cat["xyz"], s=s, tangent=cat["tangent"],
                          curvature=cat["k"], d1=nan, d2=nan, dim=3)
    f_max = float(np.max(np.concatenate(pa.ceiling_mm_min))) / 60.0
    profile = FeedProfile(samples=samples, feed_mm_s=cat["feed"], method="fuzzy", max_feed_mm_s=f_max)
    feats = Features(curvature_1_mm=cat["k"], window_max_1_mm=cat["wmax"], curvature_variation=cat["dk"])
    return FuzzyAdvice(profile=profile, features=feats, controller_pct=cat["raw"],
                       feed_pct=cat["pct"], table=pa.table)


def run_program(args: argparse.Namespace) -> dict:
    """``advise PROGRAM``: writes the outputs, prints the summary and returns its figures (see
    :func:`fuzzyfeed.cli.advise.advise_file`)."""
    from fuzzyfeed.cli._common import check_feed_mm_min, table_from_args
    from fuzzyfeed.program.cuts import DEFAULT_STEP_MM
    from fuzzyfeed.base.atomic import atomic_write
    from fuzzyfeed.io.csv import write_columns
    from fuzzyfeed.program.read import read_program
    from fuzzyfeed.program.rewrite import rewrite_program
    from fuzzyfeed.io.points import pick_by_index
    from fuzzyfeed.io.shapes import resolve_shape_path, split_selector
    from fuzzyfeed.program.feeds import (DEFAULT_PROGRAM_FEED_STEP_MM_MIN, advice_columns,
                                        advise_program, program_times)

    cap = None if args.feed_mm_min is None else check_feed_mm_min(args.feed_mm_min)
    if args.gcode_g52:
        raise ExportError("--gcode-g52 writes a NURBS shape; a G-code program is written back "
                          "with --gcode OUT.ngc")
    if args.line_numbers or args.g52_whole:
        flag = "--line-numbers" if args.line_numbers else "--g52-whole"
        raise ExportError(f"{flag}: a program written back keeps its own lines and words; "
                          "leave the flag out")
    if args.rule_strengths:
        raise ExportError("--rule-strengths is for shapes; a program's CSV has one row per sample "
                          "of every cut")
    if args.points != _default_points():
        raise MachineLimitsError("--points is for shapes; a program is sampled every --step-mm "
                                 "along its cuts")
    outputs = [p for p in (args.output, args.gcode, args.plot) if p]
    if len(set(outputs)) != len(outputs):
        raise ExportError(f"output files must differ: {', '.join(outputs)}")
    base, selector = split_selector(args.shape)
    path = resolve_shape_path(base)
    from fuzzyfeed.cli._machine import machine_from_args

    machine = machine_from_args(args)
    table = table_from_args(args, machine)
    tools = None
    if args.tool_table is not None:
        from fuzzyfeed.program.tools import read_tool_table

        tools = read_tool_table(args.tool_table, args.tool_units)
    from fuzzyfeed.base.memory import fix_mmap_threshold

    fix_mmap_threshold()               # large programs: freed columns go back to the system
    program = read_program(path, tools=tools)
    if program.n_cuts == 0:            # nothing to advise: the program as it is, and one notice
        return _pass_through(args, path, program)
    cuts = None
    if selector is not None and program.n_cuts:
        described = [f"{k + 1} (line {int(program.move_line[program.cut_moves(k)[0]]) + 1})"
                     for k in range(program.n_cuts)]
        cuts = [pick_by_index(program.path, selector, described)]
    step = args.feed_step_mm_min or DEFAULT_PROGRAM_FEED_STEP_MM_MIN
    if machine is not None:
        return _run_on_machine(args, program, machine, table, cuts, cap, step)
    if args.report is not None or args.no_reference:
        flag = "--report" if args.report is not None else "--no-reference"
        raise MachineLimitsError(f"{flag}: the value report needs a machine (--machine FILE, or a "
                                 "machine flag such as --contour-tol-um)")
    if not args.plot:       # in pieces: memory bounded by a piece, outputs written as they come
        return _run_streamed(args, path, program, table, cuts, cap, step)
    pa = advise_program(program, table, cuts=cuts, step_mm=args.step_mm or DEFAULT_STEP_MM,
                        cap_mm_min=cap, feed_step_mm_min=step)
    text = rewrite_program(program, pa.piece_move, pa.piece_end, pa.piece_feed_mm_min) if args.gcode else None
    columns = advice_columns(pa)
    write_columns(args.output, columns)
    from fuzzyfeed.fuzzy.provenance import provenance
    from fuzzyfeed.io.csv import write_metadata

    feed_note = "the program's own F" + (f", capped at {cap:g} mm/min" if cap else "")
    record = provenance(table, cap or 0.0, str(path), len(columns["s_mm"]))
    record["F_mm_min"] = feed_note
    write_metadata(args.output, list(columns), record)
    if args.plot:
        from fuzzyfeed.report.plot import plot_fuzzy_advice

        plot_fuzzy_advice(_combined_advice(pa), f"{path.name}: {len(pa.cuts)} cut(s) end to end", args.plot)
    if text is not None:
        with atomic_write(args.gcode, "w", newline="") as handle:
            handle.write(text)
    t_prog, t_adv = program_times(pa)
    fr = np.concatenate([a.feed_pct for a in pa.advice])
    n_split = int(np.sum(np.diff(pa.piece_move) == 0))
    print(f"{path.name}: {len(program.lines)} lines, {program.kind.size} moves, {program.n_cuts} "
          f"cut(s), {len(pa.cuts)} advised; rules {table.name!r}; F from the program"
          + (f", capped at {cap:g} mm/min" if cap else ""))
    print(f"advised fraction of the programmed F  min {fr.min():.2f} %  mean {fr.mean():.2f} %  "
          f"max {fr.max():.2f} %   (F rounded down to {step:g} mm/min steps)")
    print(f"feed moves of the advised cuts: {t_prog:.3f} s at the programmed F, {t_adv:.3f} s at "
          f"the advised F (no acceleration); {n_split} split points")
    print(f"wrote {args.output}" + (f" and {args.plot}" if args.plot else ""))
    if text is not None:
        print(f"wrote {args.gcode}")
    return {"cuts": program.n_cuts, "cuts_advised": len(pa.cuts), "time_written_s": t_prog,
            "time_advised_s": t_adv, "feed_pct_min": float(fr.min()), "feed_pct_mean": float(fr.mean())}


def _run_streamed(args: argparse.Namespace, path: Path, program, table, cuts, cap, step) -> dict:
    """``advise PROGRAM`` without a machine or a plot: the advice in pieces
    (:mod:`fuzzyfeed.program.stream`), the CSV written piece by piece, the program after."""
    from fuzzyfeed.base.atomic import atomic_write
    from fuzzyfeed.fuzzy.provenance import provenance
    from fuzzyfeed.io.csv import ColumnStream, write_metadata
    from fuzzyfeed.program.cuts import DEFAULT_STEP_MM
    from fuzzyfeed.program.feeds import pieces_times
    from fuzzyfeed.program.rewrite import rewrite_chunks
    from fuzzyfeed.program.stream import stream_program_advice

    pm, pe, pf = [], [], []
    count, total, lo, hi = 0, 0.0, np.inf, -np.inf
    with atomic_write(args.output, "w", newline="") as handle:
        out = ColumnStream(handle, args.output)
        for piece in stream_program_advice(program, table, cuts=cuts, step_mm=args.step_mm or DEFAULT_STEP_MM,
                                           cap_mm_min=cap, feed_step_mm_min=step):
            out.write(piece.columns)
            fr = piece.columns["feed_pct"]
            count, total = count + fr.size, total + float(fr.sum())
            lo, hi = min(lo, float(fr.min())), max(hi, float(fr.max()))
            pm.append(piece.piece_move)
            pe.append(piece.piece_end)
            pf.append(piece.piece_feed_mm_min)
    names = out.names
    piece_move, piece_end, piece_feed = np.concatenate(pm), np.concatenate(pe), np.concatenate(pf)
    feed_note = "the program's own F" + (f", capped at {cap:g} mm/min" if cap else "")
    record = provenance(table, cap or 0.0, str(path), out.rows)
    record["F_mm_min"] = feed_note
    write_metadata(args.output, names, record)
    if args.gcode:
        with atomic_write(args.gcode, "w", newline="") as handle:
            for chunk in rewrite_chunks(program, piece_move, piece_end, piece_feed):
                handle.write(chunk)
    t_prog, t_adv = pieces_times(program, piece_move, piece_end, piece_feed)
    mean = total / count
    n_advised = program.n_cuts if cuts is None else len(cuts)
    n_split = int(np.sum(np.diff(piece_move) == 0))
    print(f"{path.name}: {len(program.lines)} lines, {program.kind.size} moves, {program.n_cuts} "
          f"cut(s), {n_advised} advised; rules {table.name!r}; F from the program"
          + (f", capped at {cap:g} mm/min" if cap else ""))
    print(f"advised fraction of the programmed F  min {lo:.2f} %  mean {mean:.2f} %  "
          f"max {hi:.2f} %   (F rounded down to {step:g} mm/min steps)")
    print(f"feed moves of the advised cuts: {t_prog:.3f} s at the programmed F, {t_adv:.3f} s at "
          f"the advised F (no acceleration); {n_split} split points")
    print(f"wrote {args.output}")
    if args.gcode:
        print(f"wrote {args.gcode}")
    return {"cuts": program.n_cuts, "cuts_advised": n_advised, "time_written_s": t_prog,
            "time_advised_s": t_adv, "feed_pct_min": lo, "feed_pct_mean": mean}


#: The CSV columns of a program's advice (fuzzyfeed.program.feeds.advice_columns), written as
#: a header alone when a program has nothing to advise.
ADVICE_COLUMNS = ("cut", "source_line", "u", "x_mm", "y_mm", "z_mm", "s_mm", "curvature_1_mm",
                  "curvature_window_max_1_mm", "curvature_variation", "feed_pct_controller", "feed_pct",
                  "programmed_feed_mm_min", "feed_mm_min")


def _pass_through(args: argparse.Namespace, path: Path, program) -> dict:
    """A program with no cut: --gcode gets its bytes unchanged, the CSV its header, one notice;
    the figures of no cut advised."""
    import warnings

    from fuzzyfeed.base.atomic import atomic_write
    from fuzzyfeed.errors import FuzzyfeedNotice
    from fuzzyfeed.io.csv import write_columns
    from fuzzyfeed.program.model import why_nothing_to_advise

    warnings.warn(f"{path}: nothing to advise ({why_nothing_to_advise(program)}); the program is "
                  "written back unchanged", FuzzyfeedNotice, stacklevel=2)
    from fuzzyfeed.io.csv import write_metadata

    reason = why_nothing_to_advise(program)
    write_columns(args.output, {name: np.zeros(0) for name in ADVICE_COLUMNS})
    write_metadata(args.output, list(ADVICE_COLUMNS), {"source": str(path), "generator": "fuzzyfeed",
                                                       "advice": f"nothing to advise: {reason}"})
    if args.gcode:
        with atomic_write(args.gcode, "wb") as handle:
            handle.write(path.read_bytes())
    print(f"wrote {args.output}" + (f" and {args.gcode}" if args.gcode else ""))
    return {"cuts": 0, "cuts_advised": 0, "time_written_s": 0.0, "time_advised_s": 0.0}


def _default_points() -> int:
    from fuzzyfeed.geometry.sampling import DEFAULT_POINTS
    return DEFAULT_POINTS


def _run_on_machine(args: argparse.Namespace, program, machine, table, cuts, cap, step) -> dict:
    """``advise PROGRAM`` with a machine: the program run as written, the cuts that break the
    tolerance advised, the value report printed (and written with --report); returns the figures
    (times as the machine runs the program) with the value report's row."""
    import sys

    from fuzzyfeed.base.atomic import atomic_write
    from fuzzyfeed.program.cuts import DEFAULT_STEP_MM
    from fuzzyfeed.fuzzy.provenance import provenance
    from fuzzyfeed.io.csv import write_columns, write_metadata
    from fuzzyfeed.report.value import evaluate_program

    if program.n_cuts == 0:
        from fuzzyfeed.errors import PathFormatError
        raise PathFormatError(f"{program.path}: no feed move (G1, G2/G3 or G5.2) in G94 found; nothing to advise")
    tty = sys.stderr.isatty()

    def progress(stage: str) -> None:
        if tty:
            print(f"fuzzyfeed: {program.path.name}: {stage} ...", file=sys.stderr, flush=True)

    ev = evaluate_program(program, machine, table, cap_mm_min=cap, feed_step_mm_min=step,
                          step_mm=args.step_mm or DEFAULT_STEP_MM, cuts=cuts,
                          reference=not args.no_reference, progress=progress)
    columns = ev.columns()
    write_columns(args.output, columns)
    record = provenance(table, cap or 0.0, str(program.path), len(columns["s_mm"]))
    record["F_mm_min"] = "the program's own F" + (f", capped at {cap:g} mm/min" if cap else "")
    record["machine"] = machine.describe()
    write_metadata(args.output, list(columns), record)
    if args.gcode:
        with atomic_write(args.gcode, "w", newline="") as handle:
            handle.write(ev.text)
    if args.plot:
        from fuzzyfeed.report.value_files import plot_value

        plot_value(ev.report, args.plot)
    if args.report:
        from fuzzyfeed.report.value_files import write_value_report

        write_value_report([ev.report], args.report)
    left = program.n_cuts - len(ev.advised_cuts)
    print(f"{program.path.name}: {len(program.lines)} lines, {program.n_cuts} cut(s); {machine.describe()}")
    print(f"advised {len(ev.advised_cuts)} cut(s) that break the tolerance as written; {left} left as written")
    print("\n".join(ev.report.lines()))
    written = [p for p in (args.output, args.gcode, args.plot, args.report) if p]
    print("wrote " + ", ".join(written))
    r = ev.report
    row = {k: v for k, v in r.csv_row().items() if k not in ("program", "written_time_s", "advised_time_s")}
    return {"cuts": program.n_cuts, "cuts_advised": len(ev.advised_cuts), "time_written_s": r.written.time_s,
            "time_advised_s": r.advised.time_s, "feed_pct_min": float(columns["feed_pct"].min()),
            "feed_pct_mean": float(columns["feed_pct"].mean()), **row}
