"""``fuzzyfeed batch DIR_OR_GLOB... --out RESULTS_DIR [advise options]``: every program and drawing
of a library advised on Dask, each exactly as ``fuzzyfeed advise FILE -o OUT.csv --gcode OUT.ngc``
would (the advise command's own parser and work, see :func:`advise_task`), results under
RESULTS_DIR at the same relative paths; and :func:`batch`, the same from Python
(``fuzzyfeed.batch(paths, out, ...)``)."""

from __future__ import annotations

import argparse
import contextlib
import copy
import functools
import io
import os
import sys

from fuzzyfeed.cli._common import count_at_least
from fuzzyfeed.errors import BatchError, FuzzyfeedError

#: advise's arguments that name one file; batch makes them per file under RESULTS_DIR.
PER_FILE = frozenset({"help", "shape", "output", "gcode", "gcode_g52", "plot", "report"})
#: advise options that apply to drawings only (a program refuses them): not given to programs.
DRAWING_ONLY = frozenset({"units", "points", "rule_strengths"})
#: Where the batch parser keeps advise's options (apart from its own).
PREFIX = "advise__"


class _RaisingParser(argparse.ArgumentParser):
    """advise's parser for the batch: a bad option raises one BatchError line instead of exiting."""

    def error(self, message):
        raise BatchError(" ".join(str(message).split()))


@functools.lru_cache(maxsize=1)
def advise_parser() -> argparse.ArgumentParser:
    """A ``fuzzyfeed`` parser holding only the advise command, as :mod:`fuzzyfeed.cli.advise`
    registers it (built once per process)."""
    from fuzzyfeed.cli import advise

    parser = _RaisingParser(prog="fuzzyfeed")
    advise.register(parser.add_subparsers(dest="command"))
    return parser


def _advise_command() -> argparse.ArgumentParser:
    return next(a for a in advise_parser()._actions
                if isinstance(a, argparse._SubParsersAction)).choices["advise"]


@functools.lru_cache(maxsize=1)
def _program_only() -> frozenset[str]:
    """advise options that apply to programs only: ``--step-mm``, ``--no-reference`` (the value
    report) and the G-code export group (a drawing gets its CSV, no program)."""
    from fuzzyfeed.cli._gcode import add_gcode_arguments

    scratch = argparse.ArgumentParser()
    add_gcode_arguments(scratch)
    return frozenset({"step_mm", "no_reference"} | {a.dest for a in scratch._actions if a.dest != "help"}
                     - PER_FILE)


def forwarded_actions() -> list[argparse.Action]:
    """advise's options that batch passes to every file (all but those naming one file)."""
    return [a for a in _advise_command()._actions if a.option_strings and a.dest not in PER_FILE]


def _text(value) -> str:
    """A value as advise reads it back: floats exactly (repr), one value per axis as X,Y,Z."""
    if isinstance(value, (tuple, list)):
        return ",".join(map(_text, value))
    return repr(value) if isinstance(value, float) else os.fspath(value) if isinstance(value, os.PathLike) \
        else str(value)


def _tokens(action: argparse.Action, value) -> list[str]:
    """Command-line words that give ``action`` the value ``value`` (none for its default)."""
    flag = max(action.option_strings, key=len)
    if isinstance(action, (argparse._StoreTrueAction, argparse._StoreFalseAction, argparse._StoreConstAction)):
        return [] if value is None or bool(value) == bool(action.default) else [flag]
    if value is None or (value == action.default and type(value) is type(action.default)):
        return []
    if isinstance(action, argparse._CountAction):
        return [flag] * int(value)
    if isinstance(action, argparse._AppendAction):
        return [w for item in value for w in (flag, _text(item))]
    if isinstance(action, argparse._StoreAction):
        if action.nargs is None or action.nargs == "?":
            return [flag, _text(value)]
        return [flag, *map(_text, value)]
    raise BatchError(f"{flag}: an option batch cannot pass on ({type(action).__name__})")


def advise_options(values: dict) -> dict:
    """advise's arguments for option ``values`` (dest -> value, e.g. ``feed_step_mm_min=100``), for
    programs and for drawings, checked by advise's own parser: words that give exactly these values
    (``"program"``, ``"drawing"``), and the machine they describe (``"machine"``, None without).
    An unknown option or a bad value is one BatchError line."""
    actions = {a.dest: a for a in forwarded_actions()}
    unknown = sorted(set(values) - set(actions))
    if unknown:
        raise BatchError(f"{unknown[0]}: not an advise option; they are: {', '.join(sorted(actions))}")
    words = [w for dest, value in values.items() for w in _tokens(actions[dest], value)]
    parsed = advise_parser().parse_args(["advise", "SHAPE", "-o", "OUT.csv", *words])
    canonical = {dest: _tokens(action, getattr(parsed, dest)) for dest, action in actions.items()}
    again = advise_parser().parse_args(["advise", "SHAPE", "-o", "OUT.csv", *(w for v in canonical.values() for w in v)])
    if any(getattr(again, d) != getattr(parsed, d) for d in actions):   # the words must say the same
        raise BatchError(f"advise options {words}: cannot be passed on unchanged")
    program_only = _program_only()
    return {"program": [w for d, ws in canonical.items() if d not in DRAWING_ONLY for w in ws],
            "drawing": [w for d, ws in canonical.items() if d not in program_only for w in ws],
            "machine": _machine(parsed)}


def _machine(parsed: argparse.Namespace):
    """The machine the options describe (its file read and checked now: a bad one is refused before
    the batch starts), or None."""
    from fuzzyfeed.cli._machine import machine_from_args

    return machine_from_args(parsed)


def output_paths(out_dir: str, rel: str, kind: str, plots: bool, reports: str | None = None) -> dict[str, str]:
    """A file's results (flag -> path): ``REL.csv`` (and its sidecar), the advised program at
    ``REL`` itself, ``REL.png`` with ``plots`` and the value report ``REL.report.html`` (or
    ``.csv``) with ``reports`` (programs)."""
    base = os.path.join(out_dir, *rel.split("/"))
    paths = {"-o": base + ".csv"}
    if kind == "program":
        paths["--gcode"] = base
        if plots:
            paths["--plot"] = base + ".png"
        if reports:
            paths["--report"] = f"{base}.report.{reports}"
    return paths


def advise_task(job, finish) -> dict:
    """One file on a worker: ``fuzzyfeed advise *job.argv`` as the command runs it (same parser,
    same output transaction and shape context, the same error line), its manifest entry committed
    with its results (``finish``). Output and notices are kept off the worker's terminal."""
    from fuzzyfeed.base.outputs import OutputPathError, OutputSet
    from fuzzyfeed.cli import _error_line, _outputs_and_inputs
    from fuzzyfeed.cli._common import shape_context
    from fuzzyfeed.cli.advise import advise_file

    args = advise_parser().parse_args(["advise", *job.argv])
    err = io.StringIO()
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            outputs, inputs = _outputs_and_inputs(args)
            with OutputSet([*outputs, ("manifest entry", job.entry)], inputs):
                with shape_context(args):
                    figures = advise_file(args)
                finish(figures, _notes(err))
    except (FuzzyfeedError, OSError, MemoryError, RecursionError) as exc:
        status = "refused" if isinstance(exc, FuzzyfeedError) and not isinstance(exc, OutputPathError) \
            else "failed"
        return {"status": status, "reason": _error_line(exc, args).removeprefix("fuzzyfeed: error: "),
                "notes": _notes(err)}
    return {"status": "ok"}


def _notes(err: io.StringIO) -> str:
    lines = [ln.removeprefix("fuzzyfeed: notice: ").strip() for ln in err.getvalue().splitlines()]
    return " | ".join(ln for ln in lines if ln)


def batch(paths, out, *, workers: int | None = None, scheduler: str | None = None, force: bool = False,
          plots: bool = False, reports: str | None = None, progress: bool | None = None, echo=print,
          **options):
    """Advise every program and drawing under ``paths`` (folders searched recursively, globs, files)
    into the folder ``out`` on Dask and return the summary as a pandas DataFrame (one row per file:
    status, reason, cuts, time as written and advised, feed %, ...; also ``out/summary.csv`` and
    ``out/summary.html``).

    ``options`` are advise's, by their Python names (``rules="my.toml"``, ``feed_step_mm_min=100``,
    ``step_mm=0.5``; see ``fuzzyfeed advise --help``). ``workers`` local worker processes (default:
    one per core) or an existing cluster at ``scheduler`` (``"tcp://HOST:PORT"``); ``force`` redoes
    files whose input, options and version are unchanged since the last run; ``plots`` adds a PNG per
    program, ``reports`` (``"html"`` or ``"csv"``, with a machine) its value report. A refused or
    failed file is a row with its reason, not an exception."""
    from fuzzyfeed.batch.discover import find_sources
    from fuzzyfeed.batch.run import run_batch
    from fuzzyfeed.io.csv import metadata_path
    from fuzzyfeed.program.model import GCODE_SUFFIXES

    specs = [os.fspath(paths)] if isinstance(paths, (str, os.PathLike)) else [os.fspath(p) for p in paths]
    if workers is not None and scheduler is not None:
        raise BatchError("--workers: sizes a local cluster; an existing one (--scheduler) has its own workers")
    if reports not in (None, "html", "csv"):
        raise BatchError(f"--reports {reports}: give html or csv")
    out = os.fspath(out)
    words = advise_options(options)
    if reports and words["machine"] is None:
        raise BatchError(f"--reports {reports}: the value report needs a machine (--machine FILE, or a "
                         "machine flag such as --contour-tol-um)")
    sources = find_sources(specs, out, GCODE_SUFFIXES)

    def plan(src):
        files = output_paths(out, src.rel, src.kind, plots, reports)
        argv = [src.path, *(w for flag, path in files.items() for w in (flag, path)), *words[src.kind]]
        written = [*files.values(), metadata_path(files["-o"])]
        return argv, written

    key = [*words["program"], "|", *words["drawing"], *(["--plots"] if plots else []),
           *([f"--reports={reports}"] if reports else [])]
    return run_batch(sources, out, plan, advise_task, key, workers=workers, scheduler=scheduler,
                     force=force, progress=progress, echo=echo)


def register(sub) -> None:
    p = sub.add_parser(
        "batch", help="advise every program and drawing of a library on Dask (one machine or a cluster)",
        description="Find every G-code program (.ngc, .nc, .gcode, .gc, .tap, .cnc) and DXF drawing "
                    "under DIR_OR_GLOB (folders searched recursively) and advise each exactly as "
                    "`fuzzyfeed advise FILE -o REL.csv --gcode REL` would, into RESULTS_DIR at the "
                    "same relative path REL: the advised program REL, REL.csv with its sidecar "
                    "(drawings: the CSV of every contour, no program), REL.png with --plots, the "
                    "value report REL.report.html with a machine and --reports html. "
                    "A refused or failing file is recorded with its reason and the batch goes on "
                    "(exit code 1 if any file failed). RESULTS_DIR/.manifest/ keeps the SHA-256 of "
                    "each input, of the options and the version: a rerun skips files whose three "
                    "are unchanged (--force redoes them). RESULTS_DIR/summary.csv and summary.html "
                    "summarise the run. Ctrl-C stops, keeping the finished files.")
    p.add_argument("inputs", nargs="+", metavar="DIR_OR_GLOB",
                   help="folders (searched recursively), glob patterns (quote them; ** reaches into "
                        "sub-folders) or files")
    p.add_argument("--out", required=True, metavar="RESULTS_DIR",
                   help="folder for the results (created; never one of the input folders)")
    p.add_argument("--workers", type=count_at_least(1, "workers", 4096), default=None, metavar="N",
                   help="worker processes of the local Dask cluster (default: one per core)")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT", default=None,
                   help="run on an existing Dask cluster instead (`dask scheduler` and `dask worker "
                        "tcp://HOST:PORT --nthreads 1` on each machine); its workers need the same "
                        "fuzzyfeed version and the inputs and RESULTS_DIR at the same paths")
    p.add_argument("--force", action="store_true", help="advise every file again, even unchanged ones")
    p.add_argument("--plots", action="store_true",
                   help="also draw each program's feed (advise --plot) as REL.png")
    p.add_argument("--reports", choices=("html", "csv"), default=None,
                   help="with a machine: also write each program's value report (advise --report) as "
                        "REL.report.html or REL.report.csv")
    group = p.add_argument_group("advise options, given to every file (see `fuzzyfeed advise --help`; "
                                 "--units, --points and --rule-strengths reach drawings only, --step-mm, "
                                 "--no-reference and the G-code options programs only)")
    for action in forwarded_actions():
        mine = copy.copy(action)
        mine.dest = PREFIX + action.dest
        group._add_action(mine)
    for action in _advise_command()._actions:   # named per file by the batch: refused, not mistaken
        if action.option_strings and action.dest in PER_FILE - {"help"}:    # for --gcode-decimals
            p.add_argument(*action.option_strings, action=_PerFile, nargs=action.nargs, help=argparse.SUPPRESS)
    p.set_defaults(run=run)


class _PerFile(argparse.Action):
    """An advise option that names one output file: the batch names them for every file."""

    def __call__(self, parser, namespace, values, option_string=None):
        parser.error(f"{option_string}: the batch writes every file's results itself (REL.csv, the "
                     "advised program REL, REL.png with --plots, REL.report.html with --reports html) "
                     "under --out RESULTS_DIR; leave it out")


def run(args: argparse.Namespace) -> int:
    """The command: the batch, its failures one line each, the totals; exit 0 when every file was
    advised, 1 when some were not, 130 (143) when Ctrl-C (SIGTERM) stopped it."""
    values = {a.dest: getattr(args, PREFIX + a.dest) for a in forwarded_actions()}
    frame = batch(args.inputs, args.out, workers=args.workers, scheduler=args.scheduler, force=args.force,
                  plots=args.plots, reports=args.reports, **values)
    failed = frame[frame["status"].isin(("refused", "failed"))]
    for row in failed.head(20).itertuples():
        print(f"{row.status}: {row.file}: {row.reason}")
    if len(failed) > 20:
        print(f"... and {len(failed) - 20} more (see summary.csv)")
    ok = frame[frame["status"] == "ok"]
    tally = ", ".join(f"{k} {v}" for k, v in frame["status"].value_counts().items())
    how = "as the machine runs them" if "contour_tol_um" in frame.columns else "feed moves, no acceleration"
    print(f"{len(frame)} files: {tally}; advised programs and drawings: {ok['time_written_s'].sum():.1f} s "
          f"as written, {ok['time_advised_s'].sum():.1f} s advised ({how})")
    print(f"wrote {' and '.join(frame.attrs['summary'])}")
    stopped = frame.attrs.get("interrupted")
    if stopped:
        print(f"fuzzyfeed: {stopped} stopped the batch; finished files are kept, run the same command "
              "again to go on", file=sys.stderr)
        return 143 if stopped == "SIGTERM" else 130
    return 1 if len(failed) or (frame["status"] != "ok").any() else 0
