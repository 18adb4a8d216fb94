"""A batch run, on the machine that starts it: which files are still to do, the chunks sent to the
Dask cluster, progress, a killed worker's files tried again, Ctrl-C, and the summary at the end.

The per-file work is handed in (``plan`` and ``task``): :mod:`fuzzyfeed.batch.library` hands in
:func:`~fuzzyfeed.advice.pipeline.advise_file` and its result's ``write``."""

from __future__ import annotations

import os
import uuid
from collections.abc import Callable

from fuzzyfeed.batch.discover import Source
from fuzzyfeed.batch.manifest import (entry_path, file_key, is_current, options_sha256, read_entry,
                                      remove_partial_files, results_lock, sha256_file, stop_path)
from fuzzyfeed.batch.work import Job, Run, make_entry, run_jobs

#: Chunks per worker (for balance at the end of a run) and files per chunk at most (for progress
#: and for what a killed worker's chunk makes redo): start-up and compilation are once per worker
#: process whatever the chunks, the scheduler's cost is once per chunk.
CHUNKS_PER_WORKER = 8
MAX_FILES_PER_CHUNK = 16


def make_chunks(jobs: list[Job], workers: int) -> list[list[Job]]:
    """Jobs grouped into chunks, the largest files first and alone, then the smaller ones together
    up to about 1/(CHUNKS_PER_WORKER · workers) of all the bytes or MAX_FILES_PER_CHUNK files."""
    order = sorted(jobs, key=lambda j: (-j.size, j.rel))
    target = sum(max(j.size, 1) for j in order) / max(1, CHUNKS_PER_WORKER * workers)
    chunks, current, size = [], [], 0
    for job in order:
        current.append(job)
        size += max(job.size, 1)
        if size >= target or len(current) >= MAX_FILES_PER_CHUNK:
            chunks.append(current)
            current, size = [], 0
    if current:
        chunks.append(current)
    return chunks


def run_batch(sources: list[Source], out_dir: str | os.PathLike, plan: Callable, task: Callable,
              options: list[str], *, workers: int | None = None, scheduler: str | None = None,
              force: bool = False, progress: bool | None = None, echo: Callable[[str], None] = print):
    """Advise ``sources`` into ``out_dir`` on Dask; returns the summary as a pandas DataFrame (also
    written to ``summary.csv`` and ``summary.html``), its ``attrs["interrupted"]`` set when Ctrl-C or
    SIGTERM stopped the run (the finished files are kept).

    ``plan(source) -> (files, options, outputs)`` gives a file's own outputs ((keyword, path)
    pairs), the options value it is advised with, and every file it writes;
    ``task(job, finish)`` does the work on a worker (see :mod:`fuzzyfeed.batch.work`); ``options``
    are the options shared by every file as words (their digest, with the files they name, is part of
    every file's key). A file whose input, options and fuzzyfeed version match its manifest entry
    is kept as it is, unless ``force``."""
    from fuzzyfeed import __version__
    from fuzzyfeed.batch.cluster import Cluster
    from fuzzyfeed.batch.summary import summary_frame, write_summary

    out = os.fspath(out_dir)
    _check_results_folder(out)
    run_id = uuid.uuid4().hex
    run = Run(id=run_id, version=__version__, force=force, cwd=os.getcwd(),
              stop_file=os.path.abspath(stop_path(out, run_id)))
    shared = options_sha256(options)
    jobs = []
    for src in sources:
        files, file_options, outputs = plan(src)
        words = [src.path, *(f"{name}={path}" for name, path in files)]
        jobs.append(Job(rel=src.rel, source=src.path, files=tuple(files), options=file_options,
                        outputs=tuple(outputs), entry=entry_path(out, src.rel), key=file_key(shared, words),
                        size=_size(src.path)))
    entries, todo = _split(jobs, run)
    programs = sum(s.kind == "program" for s in sources)
    echo(f"{len(sources)} files ({programs} programs, {len(sources) - programs} drawings); "
         f"{len(entries)} unchanged since the last run, kept; {len(todo)} to advise")
    interrupted = None
    # the cluster first: an unreachable scheduler is refused before anything is written
    cluster = Cluster(workers, scheduler, echo) if todo else None
    try:
        os.makedirs(out, exist_ok=True)
        with results_lock(out):
            remove_partial_files(out)
            entries, todo = _split(jobs, run)          # again, now that the folder is ours
            kept = set(entries)
            if todo:
                cluster = cluster or Cluster(workers, scheduler, echo)
                interrupted = _dispatch(cluster.client, todo, task, run, out, entries, progress, total=len(jobs))
                if cluster.local:       # its workers are gone: nothing writes any more
                    cluster.close()
                if cluster.local or not interrupted:   # (a stopped run's tasks may still be running)
                    remove_partial_files(out)           # a killed worker's temporary files
                for job in todo:        # a file finished after the driver stopped listening
                    late = entries.get(job.rel) or read_entry(job.entry)
                    if late is not None and late.get("run") == run.id:
                        entries[job.rel] = late
            frame = summary_frame(sources, entries, kept)
            csv_path, html_path = write_summary(out, frame)
    finally:
        if cluster is not None:
            cluster.close()
    frame.attrs["interrupted"] = interrupted
    frame.attrs["summary"] = (csv_path, html_path)
    return frame


def _check_results_folder(out: str) -> None:
    """RESULTS_DIR is a folder or can be made one (checked before any work, one line)."""
    from fuzzyfeed.base.outputs import OutputPathError

    if os.path.exists(out) and not os.path.isdir(out):
        raise OutputPathError(f"--out {out}: is a file; give a folder for the results")
    existing = out
    while not os.path.exists(existing):
        parent = os.path.dirname(existing.rstrip(os.sep)) or "."
        if parent == existing:
            break
        existing = parent
    if not os.path.isdir(existing):
        raise OutputPathError(f"--out {out}: {existing} is a file, not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise OutputPathError(f"--out {out}: folder {existing} is not writable")


def _split(jobs: list[Job], run: Run) -> tuple[dict, list[Job]]:
    """(entries of the files kept from an earlier run, the jobs to do)."""
    kept, todo = {}, []
    for job in jobs:
        old = None if run.force else read_entry(job.entry)
        if old is not None and is_current(old, _sha256(job.source), job.key, run.version, job.outputs):
            kept[job.rel] = old
        else:
            todo.append(job)
    return kept, todo


def _size(path: str) -> int:
    try:
        return os.path.getsize(path)
    except OSError:
        return 0


def _sha256(path: str) -> str | None:
    """The input's SHA-256 (None if unreadable), hashed once per size and modification time."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    key = (os.path.abspath(path), st.st_size, st.st_mtime_ns)
    if key not in _HASHES:
        try:
            _HASHES[key] = sha256_file(path)
        except OSError:
            return None
    return _HASHES[key]


#: Input digests of this process, by (path, size, modification time): a run looks twice.
_HASHES: dict[tuple[str, int, int], str] = {}


def _dispatch(client, jobs: list[Job], task: Callable, run: Run, out: str, entries: dict, progress,
              total: int) -> str | None:
    """Run ``jobs`` on the cluster, filling ``entries``; returns None, or how the run was stopped."""
    import asyncio

    import dask
    from distributed import KilledWorker, as_completed

    from fuzzyfeed.base.outputs import Terminated
    from fuzzyfeed.batch.cluster import check_workers

    for job in jobs:
        for path in (*job.outputs, job.entry):
            os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    n = check_workers(client, run.version, out, jobs[0].source, run.cwd)
    chunks = make_chunks(jobs, n)
    pending: dict = {}

    def submit(chunk: list[Job], priority: int):
        future = client.submit(run_jobs, chunk, task, run, priority=priority, pure=False,
                               key=f"fuzzyfeed-batch-{run.id[:12]}-{uuid.uuid4().hex[:8]}")
        pending[future] = chunk
        return future

    finished = as_completed([submit(c, len(chunks) - i) for i, c in enumerate(chunks)], loop=client.loop)
    bar = _progress_bar(total, len(entries), progress)
    stopped = None
    try:
        for future in finished:
            chunk = pending.pop(future)
            try:
                got = future.result()
            except KilledWorker:
                left = [job for job in chunk if job.rel not in entries]
                if len(left) > 1:       # find the file that kills its worker: one per task
                    for job in left:
                        finished.add(submit([job], 0))
                    continue
                deaths = dask.config.get("distributed.scheduler.allowed-failures") + 1
                got = [_failure(job, run, "failed", f"the worker advising it died {deaths} times "
                                "(killed, or out of memory)") for job in left]
            except (Exception, asyncio.CancelledError) as exc:  # the chunk failed, not one file
                from fuzzyfeed.batch.work import one_line

                got = [_failure(job, run, "failed", one_line(exc)) for job in chunk if job.rel not in entries]
            for entry in got:
                if entry["file"] not in entries:
                    entries[entry["file"]] = entry
                    bar.update(1)
    except (KeyboardInterrupt, Terminated) as exc:
        stopped = getattr(exc, "signal_name", "SIGINT")
        try:
            with open(run.stop_file, "w"):     # a running chunk ends after its current file
                pass
            client.cancel(list(pending))
        except Exception:  # the cluster may already be going away
            pass
    finally:
        bar.close()
    return stopped


def _failure(job: Job, run: Run, status: str, reason: str) -> dict:
    from fuzzyfeed.batch.work import record_failure

    return record_failure(job, make_entry(job, run, None, status, reason))


def _progress_bar(total: int, initial: int, enabled: bool | None):
    """A tqdm bar over files: a widget in a notebook with ipywidgets (text in the cell without
    them), text in a terminal, none when ``enabled`` is False (None: only in a terminal or a
    notebook, not when the output is a file or a pipe)."""
    from tqdm import std

    settings = dict(total=total, initial=initial, unit="file", desc="advising", smoothing=0.1)
    if enabled is not False and _in_notebook():
        import importlib.util

        if importlib.util.find_spec("ipywidgets") is None:    # tqdm.notebook's widgets
            return std.tqdm(disable=False, **settings)
        from tqdm.notebook import tqdm

        return tqdm(**settings)
    return std.tqdm(disable=None if enabled is None else not enabled, **settings)


def _in_notebook() -> bool:
    import sys

    ipython = sys.modules.get("IPython")
    shell = ipython.get_ipython() if ipython is not None else None
    return shell is not None and "IPKernelApp" in getattr(shell, "config", {})
