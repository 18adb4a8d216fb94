"""What a worker does with a chunk of files: for each, unless this run (or, without ``force``, an
earlier one) already made its results, hash it, run the per-file task and record the outcome in
its manifest entry.

The task is the caller's (:func:`fuzzyfeed.batch.library.advise_task`: advise_file and write), called as
``task(job, finish)``; it writes the file's results in one output transaction and, inside it after
the work, calls ``finish(figures, notes)``, which adds the manifest entry to that transaction (it
is renamed last). It returns ``{"status": "ok"}`` or ``{"status": "refused", "reason": LINE}``;
anything it raises is recorded as a failure with its one-line reason, and the batch goes on.
"""

from __future__ import annotations

import contextlib
import datetime
import os
import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field

from fuzzyfeed.batch.manifest import (entry_text, is_current, read_entry, remove_outputs,
                                      sha256_file)

#: One file at a time per process: a task redirects the process's output streams and warnings, and
#: works inside ``Run.cwd`` (a worker with several threads runs its files one after the other).
_ONE_AT_A_TIME = threading.Lock()


@dataclass(frozen=True)
class Job:
    """One input of a batch: ``rel`` its relative path (the key in the summary), ``source`` the
    path the task reads, ``files`` the task's per-file outputs ((keyword, path) pairs),
    ``options`` the value it advises with (pickled to the worker as it is), ``outputs`` every file it writes,
    ``entry`` its manifest entry, ``key`` the digest of its options and arguments
    (:func:`~fuzzyfeed.batch.manifest.file_key`), ``size`` its bytes (to balance the chunks)."""

    rel: str
    source: str
    files: tuple[tuple[str, str], ...]
    options: object
    outputs: tuple[str, ...]
    entry: str
    key: str = ""
    size: int = 0


@dataclass(frozen=True)
class Run:
    """What every file of one batch run shares: its id, the fuzzyfeed version,
    ``force`` (earlier runs' results are redone), the folder relative paths start from, and the
    file whose existence stops the run between two files (the workers see the results folder)."""

    id: str
    version: str
    force: bool = False
    cwd: str = field(default_factory=os.getcwd)
    stop_file: str | None = None


def one_line(exc: BaseException) -> str:
    """An exception as one line: its type and message, whitespace folded, at most 300 characters."""
    text = " ".join(str(exc).split())
    line = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
    return line if len(line) <= 300 else line[:297] + "..."


def make_entry(job: Job, run: Run, input_sha256: str | None, status: str, reason: str = "",
               figures: dict | None = None, notes: str = "", compute_s: float = 0.0, **extra) -> dict:
    """A manifest entry (plain JSON values)."""
    try:
        from distributed import get_worker

        worker = get_worker().address
    except (ImportError, ValueError):
        worker = ""
    return {"file": job.rel, "source": job.source, "input_sha256": input_sha256,
            "options_sha256": job.key, "fuzzyfeed": run.version, "status": status,
            "reason": reason, "figures": _plain(figures or {}), "notes": notes,
            "outputs": list(job.outputs), "compute_s": round(compute_s, 6), "worker": worker,
            "run": run.id, "finished": datetime.datetime.now(datetime.timezone.utc).isoformat(), **extra}


def _plain(figures: dict) -> dict:
    """Figures as JSON values: numpy scalars as Python numbers, NaN and infinities as None."""
    import math

    out = {}
    for key, value in figures.items():
        value = value.item() if hasattr(value, "item") else value
        if isinstance(value, float) and not math.isfinite(value):
            value = None
        out[str(key)] = value if isinstance(value, (int, float, str, bool, type(None))) else str(value)
    return out


def _stopped(run: Run) -> bool:
    return run.stop_file is not None and os.path.exists(run.stop_file)


def run_jobs(jobs: list[Job], task: Callable, run: Run) -> list[dict]:
    """The manifest entries of ``jobs`` in order (a stopped run ends early: fewer entries)."""
    entries = []
    with _ONE_AT_A_TIME:
        here = os.getcwd()
        os.chdir(run.cwd)
        try:
            for job in jobs:
                if entries and _stopped(run):
                    break
                entries.append(run_job(job, task, run))
        finally:
            os.chdir(here)
    return entries


def run_job(job: Job, task: Callable, run: Run) -> dict:
    """One file: its entry if this run already made it (a retried chunk) or, without ``force``, an
    earlier run did from the same input, options and version; else the task's outcome."""
    start = time.perf_counter()
    old = read_entry(job.entry)
    try:
        digest = sha256_file(job.source)
    except OSError as exc:
        entry = make_entry(job, run, None, "refused", f"{job.source}: cannot read ({exc.strerror or exc})")
        return record_failure(job, entry)
    if is_current(old, digest, job.key, run.version, job.outputs) and (old.get("run") == run.id or not run.force):
        return old
    done: dict = {}

    def finish(figures: dict, notes: str = "") -> None:
        """Called by the task inside its output transaction: the entry joins it, renamed last."""
        from fuzzyfeed.base.atomic import atomic_write

        entry = make_entry(job, run, digest, "ok", "", figures, notes, time.perf_counter() - start)
        with atomic_write(job.entry, "w") as handle:
            handle.write(entry_text(entry))
        done["entry"] = entry

    try:
        outcome = task(job, finish)
    except Exception as exc:  # whatever the per-file work raises: recorded, the batch goes on
        entry = make_entry(job, run, digest, "failed", one_line(exc), compute_s=time.perf_counter() - start,
                           traceback=traceback.format_exc(limit=20))
        return record_failure(job, entry)
    if outcome.get("status") == "ok" and "entry" in done:
        return done["entry"]
    entry = make_entry(job, run, digest, outcome.get("status", "failed"),
                       outcome.get("reason", "the task returned no outcome"), notes=outcome.get("notes", ""),
                       compute_s=time.perf_counter() - start)
    return record_failure(job, entry)


def record_failure(job: Job, entry: dict) -> dict:
    """A failed file keeps no results of an earlier run (they would not match its input) and gets
    its entry with the reason."""
    from fuzzyfeed.base.atomic import atomic_write

    remove_outputs(job.outputs)
    with contextlib.suppress(OSError):
        with atomic_write(job.entry, "w") as handle:
            handle.write(entry_text(entry))
    return entry
