"""A batch run, on the machine that starts it: which files are still to do, the chunks sent to the
Dask cluster, progress, a killed worker's files tried again, Ctrl-C, and the summary at the end.

The per-file work is handed in (``plan`` and ``task``), so this package never imports the command
line: ``fuzzyfeed batch`` hands in the advise command's own work."""

from __future__ import annotations

import os
import uuid
from collections.abc import Callable

from fuzzyfeed.batch.discover import Source
from fuzzyfeed.batch.manifest import (entry_path, is_current, options_sha256, read_entry,
                                      remove_partial_files, results_lock, sha256_file)
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

    ``plan(source) -> (argv, outputs)`` gives a file's own arguments and every file it writes;
    ``task(job, finish)`` does the work on a worker (see :mod:`fuzzyfeed.batch.work`); ``options``
    are the arguments shared by every file (their digest, with the files they name, is part of
    every file's key). A file whose input, options and fuzzyfeed version match its manifest entry
    is kept as it is, unless ``force``."""
    from fuzzyfeed import __version__
    from fuzzyfeed.base.outputs import OutputPathError

    out = os.fspath(out_dir)
    try:
        os.makedirs(out, exist_ok=True)
    except OSError as exc:
        raise OutputPathError(f"--out {out}: cannot create the folder ({exc.strerror or exc})") from None
    with results_lock(out):
        remove_partial_files(out)
        run_id = uuid.uuid4().hex
        run = Run(id=run_id, options_sha256=options_sha256(options), version=__version__, force=force,
                  cwd=os.getcwd(), stop_event=f"fuzzyfeed-batch-stop-{run_id}")
        entries, kept, jobs = {}, set(), []
        for src in sources:
            argv, outputs = plan(src)
            job = Job(rel=src.rel, source=src.path, argv=tuple(argv), outputs=tuple(outputs),
                      entry=entry_path(out, src.rel), size=_size(src.path))
            old = None if force else read_entry(job.entry)
            if old is not None and is_current(old, _sha256(src.path), run.options_sha256, run.version):
                entries[src.rel] = old
                kept.add(src.rel)
            else:
                jobs.append(job)
        for job in jobs:
            for path in (*job.outputs, job.entry):
                os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
        programs = sum(s.kind == "program" for s in sources)
        echo(f"{len(sources)} files ({programs} programs, {len(sources) - programs} drawings); "
             f"{len(kept)} unchanged since the last run, kept; {len(jobs)} to advise")
        interrupted = None
        if jobs:
            interrupted = _dispatch(jobs, task, run, out, entries, workers, scheduler, progress, echo,
                                    total=len(sources))
            if scheduler is None:           # the local workers are gone: nothing writes any more
                remove_partial_files(out)
        from fuzzyfeed.batch.summary import summary_frame, write_summary

        frame = summary_frame(sources, entries, kept)
        csv_path, html_path = write_summary(out, frame)
    frame.attrs["interrupted"] = interrupted
    frame.attrs["summary"] = (csv_path, html_path)
    return frame


def _size(path: str) -> int:
    try:
        return os.path.getsize(path)
    except OSError:
        return 0


def _sha256(path: str) -> str | None:
    try:
        return sha256_file(path)
    except OSError:
        return None


def _dispatch(jobs: list[Job], task: Callable, run: Run, out: str, entries: dict, workers, scheduler,
              progress, echo, total: int) -> str | None:
    """Run ``jobs`` on the cluster, filling ``entries``; returns None, or how the run was stopped."""
    import dask
    from distributed import Event, KilledWorker, as_completed

    from fuzzyfeed.base.outputs import Terminated
    from fuzzyfeed.batch.cluster import check_workers, connect

    with connect(workers, scheduler, echo) as client:
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
                    todo = [job for job in chunk if job.rel not in entries]
                    if len(todo) > 1:       # find the file that kills its worker: one per task
                        for job in todo:
                            finished.add(submit([job], 0))
                        continue
                    deaths = dask.config.get("distributed.scheduler.allowed-failures") + 1
                    got = [_failure(job, run, "failed", f"the worker advising it died {deaths} times "
                                    "(killed, or out of memory)") for job in todo]
                except Exception as exc:  # the chunk itself failed (not one file): its files failed
                    from fuzzyfeed.batch.work import one_line

                    got = [_failure(job, run, "failed", one_line(exc)) for job in chunk if job.rel not in entries]
                for entry in got:
                    if entry["file"] not in entries:
                        entries[entry["file"]] = entry
                        bar.update(1)
        except (KeyboardInterrupt, Terminated) as exc:
            stopped = getattr(exc, "signal_name", "SIGINT")
            try:
                Event(run.stop_event, client=client).set()
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
    """A tqdm bar over files: a widget in notebooks, text in terminals, none when ``enabled`` is
    False (None: only when the output is a terminal or a notebook)."""
    from tqdm.auto import tqdm

    return tqdm(total=total, initial=initial, unit="file", desc="advising", smoothing=0.1,
                disable=None if enabled is None else not enabled)
