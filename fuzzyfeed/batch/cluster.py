"""The Dask cluster a batch runs on: a ``distributed.LocalCluster`` of worker processes (one thread
each) sized to this machine, or an existing cluster reached through its scheduler's address; and
the check that every worker runs this fuzzyfeed and sees the inputs and the results folder."""

from __future__ import annotations

import contextlib
import logging
import os
import warnings
from collections.abc import Callable, Iterator

from fuzzyfeed.errors import BatchError

#: Seconds to reach an existing scheduler, and to wait for its first worker.
CONNECT_TIMEOUT_S = 20.0
#: The dashboard's port on a local cluster (another free port if it is taken).
DASHBOARD_ADDRESS = ":8787"


def machine_cores() -> int:
    """The cores this process may run on (its CPU affinity; ``os.cpu_count`` where there is none)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


class Cluster:
    """A ``distributed.Client`` (``.client``) on a new local cluster of ``workers`` processes
    (default: one per core) or on the cluster whose scheduler is at ``scheduler``
    (``tcp://HOST:PORT``); prints the dashboard's address. :meth:`close` (also on leaving a
    ``with``) disconnects and shuts a local cluster down: its workers are gone when it returns."""

    def __init__(self, workers: int | None = None, scheduler: str | None = None,
                 echo: Callable[[str], None] = print):
        from distributed import Client, LocalCluster

        self.local = scheduler is None
        self._cluster = None
        with _quiet():
            if scheduler:
                _reachable(scheduler)
                try:
                    self.client = Client(scheduler, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
                except (OSError, TimeoutError, ValueError) as exc:
                    raise BatchError(f"--scheduler {scheduler}: cannot connect "
                                     f"({' '.join(str(exc).split())})") from None
                try:
                    self.client.wait_for_workers(1, timeout=CONNECT_TIMEOUT_S)
                except (OSError, TimeoutError) as exc:
                    self.close()
                    raise BatchError(f"--scheduler {scheduler}: no worker joined within "
                                     f"{CONNECT_TIMEOUT_S:g} s ({exc})") from None
                where = f"the cluster at {scheduler}"
            else:
                n = workers or machine_cores()
                with _sigint_ignored():    # spawned workers inherit it: Ctrl-C is the batch's
                    self._cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                                 dashboard_address=DASHBOARD_ADDRESS,
                                                 silence_logs=logging.CRITICAL)
                self.client = Client(self._cluster, set_as_default=False)
                self.client.register_plugin(ignore_sigint_plugin(), name="fuzzyfeed-ignore-sigint")
                where = f"a local cluster of {n} worker process{'es' if n > 1 else ''}"
        link = self.client.dashboard_link if _has_dashboard(self.client) else "not available"
        echo(f"running on {where}; dashboard: {link}")

    def close(self) -> None:
        with _quiet():
            if getattr(self, "client", None) is not None:
                self.client.close()
            if self._cluster is not None:
                self._cluster.close()
                self._cluster = None

    def __enter__(self) -> Cluster:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _reachable(address: str) -> None:
    """A ``tcp://HOST:PORT`` scheduler that refuses connections is one line at once (Dask itself
    retries for CONNECT_TIMEOUT_S)."""
    import socket
    from urllib.parse import urlsplit

    parts = urlsplit(address if "://" in address else "tcp://" + address)
    if parts.scheme != "tcp":
        return
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        raise BatchError(f"--scheduler {address}: not an address tcp://HOST:PORT") from None
    if not host or not port:
        raise BatchError(f"--scheduler {address}: not an address tcp://HOST:PORT")
    try:
        socket.create_connection((host, port), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        raise BatchError(f"--scheduler {address}: cannot connect ({exc.strerror or exc})") from None


@contextlib.contextmanager
def _sigint_ignored() -> Iterator[None]:
    """SIGINT ignored while the local workers are spawned (in the main thread; elsewhere a no-op).
    A terminal's Ctrl-C reaches every process of the foreground group: the batch stops the cluster
    itself and keeps the finished files, and the workers stay quiet instead of each printing a
    KeyboardInterrupt."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def ignore_sigint_plugin():
    """A Dask worker plugin for the local cluster: the worker process ignores SIGINT (also a worker
    the nanny restarts after a crash). Defined on call: distributed is imported only when used."""
    from distributed.diagnostics.plugin import WorkerPlugin

    class IgnoreSigint(WorkerPlugin):
        idempotent = True

        def setup(self, worker) -> None:
            import signal
            import threading

            if threading.current_thread() is threading.main_thread():
                signal.signal(signal.SIGINT, signal.SIG_IGN)

    return IgnoreSigint()


def _has_dashboard(client) -> bool:
    try:
        return bool(client.scheduler_info().get("services", {}).get("dashboard"))
    except Exception:  # an old scheduler without services in its info
        return True


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    """Dask's start-up and shut-down chatter (port taken, heartbeats to a closed scheduler) kept
    off the terminal: fuzzyfeed prints what the user needs."""
    loggers = [logging.getLogger(n) for n in ("distributed", "tornado", "bokeh")]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)


def _worker_facts(out_dir: str, source: str, cwd: str) -> dict:
    """Run on every worker: its fuzzyfeed version and whether it sees the run's folder, an input and
    the results folder."""
    import fuzzyfeed

    here = os.path.isdir(cwd)
    path = source if os.path.isabs(source) else os.path.join(cwd, source)
    out = out_dir if os.path.isabs(out_dir) else os.path.join(cwd, out_dir)
    return {"version": fuzzyfeed.__version__, "cwd": here, "source": os.access(path, os.R_OK),
            "results": os.access(out, os.W_OK | os.X_OK)}


def check_workers(client, version: str, out_dir: str, source: str, cwd: str) -> int:
    """Refuse, in one line naming the worker, a worker that runs another fuzzyfeed or cannot see the
    inputs or write the results (workers of another machine need them at the same paths: a shared
    folder). Returns the number of workers."""
    facts = client.run(_worker_facts, out_dir, source, cwd)
    if not facts:
        raise BatchError("the cluster has no worker")
    for address, fact in sorted(facts.items()):
        if fact["version"] != version:
            raise BatchError(f"worker {address}: runs fuzzyfeed {fact['version']}, this is {version}; "
                             "install the same version on every worker")
        if not fact["cwd"]:
            raise BatchError(f"worker {address}: has no folder {cwd}; the workers need the inputs and "
                             "the results folder at the same paths (a shared folder)")
        if not fact["source"]:
            raise BatchError(f"worker {address}: cannot read {source}; the workers need the inputs at "
                             "the same paths (a shared folder)")
        if not fact["results"]:
            raise BatchError(f"worker {address}: cannot write {out_dir}; the workers need the results "
                             "folder at the same path (a shared folder)")
    return len(facts)
