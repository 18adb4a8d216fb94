"""Tune a machine table on a library of programs, and check it on programs it has not seen
(issue 32, item 5).

The library is split, seeded, into a tuning part and a held-out part. The table's shape stays
(:func:`~fuzzyfeed.fuzzy.machine_table.machine_table`: its levels of the near ratio and one
output term per level); what moves is the output's *safety* — the fraction of the safe feed the
advice asks for — in three bands of the near ratio (below 5 %, 5-35 %, from 35 %), blended in
log ratio between the bands' centres. Each band's safety is searched by bisection between 0.5 and
1, starting from the shipped table's: raised while every tuning program that breaks the tolerance as
written, advised and run on the machine (:func:`~fuzzyfeed.program.run.run_program`), still holds
it, lowered when one does not; a program over the tolerance even at 0.5 everywhere is set aside
(named, not a constraint). Both parts are then reported, before and after.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fuzzyfeed.fuzzy.machine_table import DEFAULT_LEVELS, DEFAULT_SAFETY, machine_table
from fuzzyfeed.fuzzy.rules import RuleTable
from fuzzyfeed.machine.description import Machine
from fuzzyfeed.program.feeds import advise_program
from fuzzyfeed.program.model import Program
from fuzzyfeed.program.read import parse_program
from fuzzyfeed.program.rewrite import rewrite_program
from fuzzyfeed.program.run import program_path, run_program
from fuzzyfeed.report.value import cuts_over

#: Centres (near ratio) of the three safety bands.
BAND_CENTRES = (0.02, 0.15, 0.6)
#: Safety searched between these bounds.
SAFETY_RANGE = (0.5, 1.0)
#: Bisection steps per band.
STEPS = 4


def split_library(names: list[str], holdout: float, seed: int) -> tuple[list[str], list[str]]:
    """(tuning, held-out) names: a seeded permutation of the sorted names, the first
    round(holdout × n) held out (at least one of each when there are two or more)."""
    ordered = sorted(names)
    rng = np.random.default_rng(seed)
    perm = [ordered[i] for i in rng.permutation(len(ordered))]
    k = int(round(holdout * len(perm)))
    if len(perm) >= 2:
        k = min(max(k, 1), len(perm) - 1)
    return sorted(perm[k:]), sorted(perm[:k])


def band_safety(levels, safeties: tuple[float, float, float]) -> list[float]:
    """Safety per level: the bands' values blended linearly in log ratio between their centres."""
    x = np.log(np.asarray(BAND_CENTRES))
    return [float(np.interp(math.log(c), x, safeties)) for c in levels]


def table_with(safeties: tuple[float, float, float], name: str, source: str) -> RuleTable:
    return machine_table(DEFAULT_LEVELS, band_safety(DEFAULT_LEVELS, safeties), name=name, source=source)


@dataclass(frozen=True)
class ProgramResult:
    name: str
    written_time_s: float
    written_max_um: float
    advised_time_s: float
    advised_max_um: float


def advised_run(program: Program, machine: Machine, table: RuleTable, over: list[int]):
    """The program with ``table``'s advice on the cuts ``over`` run on the machine."""
    if not over:
        return None
    pa = advise_program(program, table, cuts=over, machine=machine)
    text = rewrite_program(program, pa.piece_move, pa.piece_end, pa.piece_feed_mm_min)
    return run_program(program_path(parse_program(text, program.path), machine.chord_tol_mm), machine)


@dataclass(frozen=True, eq=False)
class TuneResult:
    table: RuleTable
    safeties: tuple[float, float, float]
    tuning: list[str]
    held_out: list[str]
    before: dict[str, ProgramResult]
    after: dict[str, ProgramResult]
    set_aside: list[str]
    evaluations: int

    def lines(self, tol_um: float) -> list[str]:
        out = [f"safety per band (near ratio ~{BAND_CENTRES[0]:g} / ~{BAND_CENTRES[1]:g} / ~{BAND_CENTRES[2]:g}): "
               + " / ".join(f"{s:.3f}" for s in self.safeties) + f" ({self.evaluations} rounds)"]
        for label, names in (("tuning", self.tuning), ("held out", self.held_out)):
            rows = [(self.before[n], self.after[n]) for n in names]
            t0 = sum(b.advised_time_s for b, _ in rows)
            t1 = sum(a.advised_time_s for _, a in rows)
            held = sum(a.advised_max_um <= tol_um for _, a in rows)
            out.append(f"{label}: {len(names)} programs, advised time {t0:.1f} s -> {t1:.1f} s, "
                       f"{held}/{len(names)} within {tol_um:g} um after tuning")
            for b, a in rows:
                out.append(f"  {a.name}: as written {a.written_time_s:.1f} s {a.written_max_um:.1f} um; "
                           f"advised {b.advised_time_s:.1f} s {b.advised_max_um:.1f} um -> "
                           f"{a.advised_time_s:.1f} s {a.advised_max_um:.1f} um")
        if self.set_aside:
            out.append("set aside (over the tolerance even before tuning): " + ", ".join(self.set_aside))
        return out


def tune_on_programs(programs: dict[str, Program], machine: Machine, holdout: float = 0.3, seed: int = 1,
                     name: str = "machine-tuned", source: str = "", progress=None) -> TuneResult:
    """Tune the machine table's safety bands on the tuning part of ``programs`` (module docstring)."""
    step = progress or (lambda: None)
    tol = machine.contour_tol_um
    tuning, held_out = split_library(list(programs), holdout, seed)
    written = {n: run_program(program_path(p, machine.chord_tol_mm), machine) for n, p in programs.items()}
    over = {n: cuts_over(written[n], tol) for n in programs}

    def evaluate(safeties, names) -> dict[str, ProgramResult]:
        table = table_with(safeties, name, source)
        out = {}
        for n in names:
            w = written[n]
            run = advised_run(programs[n], machine, table, over[n])
            a = w if run is None else run
            out[n] = ProgramResult(n, w.time_s, w.max_um, a.time_s, a.max_um)
        step()
        return out

    start = (DEFAULT_SAFETY,) * 3
    before = evaluate(start, list(programs))
    # programs over the tolerance even at the lowest safety are set aside (no table fixes them)
    failing = [n for n in tuning if over[n] and before[n].advised_max_um > tol]
    floor = evaluate((SAFETY_RANGE[0],) * 3, failing) if failing else {}
    set_aside = [n for n in failing if floor[n].advised_max_um > tol]
    judged = [n for n in tuning if n not in set_aside and over[n]]
    best = list(start)
    rounds = 2 if failing else 1
    for band in range(3):
        lo, hi = SAFETY_RANGE
        trial_value = best[band]
        for _ in range(STEPS + 1):
            trial = list(best)
            trial[band] = trial_value
            res = evaluate(tuple(trial), judged)
            rounds += 1
            if all(r.advised_max_um <= tol for r in res.values()):
                lo = trial_value
                best = trial
            else:
                hi = trial_value
            trial_value = 0.5 * (lo + hi)
        if lo == SAFETY_RANGE[0] and best[band] != lo:
            best[band] = lo          # nothing held above the floor: the floor
    safeties = tuple(best)
    after = evaluate(safeties, list(programs))
    table = table_with(safeties, name, source)
    return TuneResult(table=table, safeties=safeties, tuning=tuning, held_out=held_out, before=before,
                      after=after, set_aside=set_aside, evaluations=rounds + 1)


def split_record(result: TuneResult, machine: Machine, holdout: float, seed: int, command: str) -> dict:
    """The split and the results as a JSON-ready dict (``bench_value --split`` reads ``held_out``)."""
    return {"command": command, "machine": machine.name, "contour_tol_um": machine.contour_tol_um,
            "holdout": holdout, "seed": seed, "safeties": list(result.safeties),
            "tuning": result.tuning, "held_out": result.held_out, "set_aside": result.set_aside,
            "results": {n: {"before": vars(result.before[n]), "after": vars(result.after[n])}
                        for n in result.before}}


def library_files(paths: list[str]) -> list[Path]:
    """Every G-code file under the folders and files given (recursively, by suffix)."""
    from fuzzyfeed.program.model import GCODE_SUFFIXES

    out: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            out += sorted(f for f in p.rglob("*") if f.suffix.lower() in GCODE_SUFFIXES and f.is_file())
        else:
            out.append(p)
    return out
