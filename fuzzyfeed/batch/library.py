"""``advise_library(paths, out, options)``: every program and drawing of a library advised on Dask
with one :class:`~fuzzyfeed.advice.options.AdviceOptions` value, each file exactly as
:func:`~fuzzyfeed.advice.pipeline.advise_file` and its ``write`` do (what ``fuzzyfeed advise FILE
-o REL.csv --gcode REL`` writes), results under ``out`` at the same relative paths. The options
value goes to the workers as it is (pickled); a worker parses nothing."""

from __future__ import annotations

import contextlib
import io
import os

from fuzzyfeed.errors import BatchError, FuzzyfeedError

#: write()'s keywords and the flags that name them in messages (the command's).
FLAGS = {"csv": "-o", "gcode": "--gcode", "plot": "--plot", "report": "--report"}


def output_paths(out_dir: str, rel: str, kind: str, plots: bool, reports: str | None = None) -> dict[str, str]:
    """A file's results (``write`` keyword -> path): ``REL.csv`` (and its sidecar), the advised
    program at ``REL`` itself, ``REL.png`` with ``plots`` and the value report ``REL.report.html``
    (or ``.csv``) with ``reports`` (programs)."""
    base = os.path.join(out_dir, *rel.split("/"))
    paths = {"csv": base + ".csv"}
    if kind == "program":
        paths["gcode"] = base
        if plots:
            paths["plot"] = base + ".png"
        if reports:
            paths["report"] = f"{base}.report.{reports}"
    return paths


def error_line(exc: BaseException, what: str) -> str:
    """An error as the command's one line, without its ``fuzzyfeed: error:`` prefix."""
    if isinstance(exc, FuzzyfeedError):
        message = str(exc)
    elif isinstance(exc, OSError):
        message = f"{exc.filename}: {exc.strerror}" if exc.filename else (exc.strerror or str(exc))
    else:  # MemoryError, RecursionError: an input too big or too deep that no check caught
        kind = "too large to process (out of memory)" if isinstance(exc, MemoryError) else \
            "too deeply nested to process"
        message = f"{what}: {kind}"
    return " ".join(message.split())


def advise_task(job, finish) -> dict:
    """One file on a worker: :func:`advise_file` with the job's options and ``write`` of its results
    in one output transaction with its manifest entry (``finish``); the same error line as the
    command. Output and notices are kept off the worker's terminal."""
    from fuzzyfeed.advice.pipeline import advise_file, collect_notices
    from fuzzyfeed.base.outputs import OutputPathError, OutputSet
    from fuzzyfeed.io.csv import metadata_path

    files = dict(job.files)
    options = job.options
    outputs = [(FLAGS[key], path) for key, path in files.items()]
    sidecar = metadata_path(files["csv"])
    if sidecar is not None:
        outputs.append(("-o (its sidecar)", sidecar))
    inputs = [("SHAPE", job.source), ("--tool-table", options.tool_table)]
    if isinstance(options.rules, (str, os.PathLike)):
        inputs.append(("--rules", options.rules))
    notices: list[str] = []
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            with OutputSet([*outputs, ("manifest entry", job.entry)], inputs):
                with collect_notices() as notices:
                    result = advise_file(job.source, options)
                    result.write(**files)
                finish(result.figures(), " | ".join(notices))
    except (FuzzyfeedError, OSError, MemoryError, RecursionError) as exc:
        status = "refused" if isinstance(exc, FuzzyfeedError) and not isinstance(exc, OutputPathError) \
            else "failed"
        return {"status": status, "reason": error_line(exc, job.source), "notes": ""}
    return {"status": "ok"}


def advise_library(paths, out, options=None, *, workers: int | None = None, scheduler: str | None = None,
                   force: bool = False, plots: bool = False, reports: str | None = None,
                   progress: bool | None = None, echo=print, **overrides):
    """Advise every program and drawing under ``paths`` (folders searched recursively, globs, files)
    into the folder ``out`` on Dask and return the summary as a pandas DataFrame (one row per file:
    status, reason, cuts, time as written and advised, feed %, ...; also ``out/summary.csv`` and
    ``out/summary.html``).

    ``options``: an :class:`~fuzzyfeed.advice.options.AdviceOptions` (default: every field at its
    default), any field replaced by ``overrides`` (``rules="my.toml"``, ``feed_step_mm_min=100``,
    ``machine="reference"``); each file gets the fields that apply to it (a drawing no G-code
    export, a program no ``points``). ``workers`` local worker processes (default: one per core)
    or an existing cluster at ``scheduler`` (``"tcp://HOST:PORT"``); ``force`` redoes files whose
    input, options and version are unchanged since the last run; ``plots`` adds a PNG per program,
    ``reports`` (``"html"`` or ``"csv"``, with a machine) its value report. A refused or failed file
    is a row with its reason, not an exception."""
    from fuzzyfeed.advice.options import make_options
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
    options = make_options(options, **overrides)      # a bad option: its own one-line error
    if reports and options.machine is None:
        raise BatchError(f"--reports {reports}: the value report needs a machine (--machine FILE, or a "
                         "machine flag such as --contour-tol-um)")
    per_kind = {"program": options.for_kind("program"), "drawing": options.for_kind("drawing")}
    sources = find_sources(specs, out, GCODE_SUFFIXES)

    def plan(src):
        files = output_paths(out, src.rel, src.kind, plots, reports)
        written = [*files.values(), metadata_path(files["csv"])]
        return tuple(files.items()), per_kind[src.kind], written

    key = [*per_kind["program"].key_words(), "|", *per_kind["drawing"].key_words(),
           *(["--plots"] if plots else []), *([f"--reports={reports}"] if reports else [])]
    return run_batch(sources, out, plan, advise_task, key, workers=workers, scheduler=scheduler,
                     force=force, progress=progress, echo=echo)
