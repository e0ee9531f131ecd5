"""Where a calibration's cases run: the Dask cluster and the workers' side of a case.

The parent's side: :func:`local_cluster` (single-thread worker processes that
ignore SIGINT/SIGTERM, each with a numba cache folder of its own),
:func:`numba_folder` (the run's slot in the user's kernel cache),
:func:`check_scheduler_address` and :func:`cores`. The workers' side:
:func:`case_lock` (one process computes a case folder at a time),
:func:`stop_watch` (a case stops when the sweep's stop event is set) and
:func:`quiet_asyncio`.
"""

from __future__ import annotations

import contextlib
import logging
import os
import threading
import time
from collections.abc import Iterator
from pathlib import Path

from fe_impact.errors import CalibrationError
from fe_impact.interrupts import Interrupted, ignore_signals
from fe_impact.output.files import folder_lock

logger = logging.getLogger(__name__)

#: A stopping case checks its stop event every STOP_POLL seconds (see
#: :data:`fe_impact.calibration.execution.STOP_GRACE`).
STOP_POLL = 0.25


class CaseStopped(CalibrationError):
    """A case stopped part-way because the sweep was interrupted."""


def import_distributed() -> None:
    """Import dask.distributed, keeping the level of its logger.

    Importing it sets that logger to INFO, which would print every worker's
    start and, at shutdown, a closed-connection traceback; the level the
    caller chose stays (the CLI: WARNING unless -vv).
    """
    log = logging.getLogger("distributed")
    level = log.level
    import dask.distributed  # noqa: F401

    log.setLevel(level)


def check_scheduler_address(address: str) -> str:
    """``address`` if it names a Dask scheduler (``[tcp://]host:port``), else a clear error."""
    import_distributed()
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        _, location = parse_address(address)
        parse_host_port(location)
    except ValueError as exc:
        raise CalibrationError(f"--scheduler {address!r}: not a scheduler address ({exc}); "
                               "give host:port or tcp://host:port") from None
    return address


@contextlib.contextmanager
def numba_folder(cache: Path) -> Iterator[Path]:
    """Where this run's local workers keep their compiled numba kernels, held for the run.

    The user's cache (``$XDG_CACHE_HOME`` or ``~/.cache``, then
    ``fe-impact/numba/slotK``), so that a run with a new mesh cache does not
    compile them again (about 7 s a worker at its first case, measured on
    the coarse calibration); ``cache/numba`` if that cannot be written. A
    run holds its slot's lock while it lives: runs at the same time take
    different slots (two processes compiling into one folder at once can
    leave files that crash a later load), later runs the first free one.
    """
    from fe_impact.runtime import user_cache

    root = user_cache("numba") or Path(cache) / "numba"
    for k in range(64):
        with folder_lock(root / f"slot{k}", wait=False) as held:
            if held:
                yield root / f"slot{k}"
                return
    yield Path(cache) / "numba"   # 64 runs at once: share the mesh cache's folder


def local_cluster(n: int, numba_cache: Path | None = None):
    """A local Dask cluster of ``n`` single-thread worker processes and its client.

    The workers are started with SIGINT and SIGTERM ignored (they keep
    that): Ctrl-C in a terminal signals the whole process group, and a
    worker that got it printed tracebacks and stopped mid-write. The
    scheduler's HTTP server (the dashboard's) takes a free port, so a second
    run never finds 8787 taken. With ``numba_cache``, each worker compiles
    its numba kernels into a folder of its own (``numba_cache/wN``): two
    processes compiling one cached kernel into one folder at once can leave
    an index and a data file that do not belong together, and a process
    that loads them crashes (numba/numba#4807, #10128). The folders are
    stable per worker name, so a later run loads its compiled kernels.

    Each worker may use the machine's memory divided by ``n``: Dask's
    default divides it by the number of cores whatever ``n`` is, so a single
    worker on two cores was restarted at half the memory (a stage-3
    approach corner, ``--corners --workers 1``, at 11.7 GB of 23).
    """
    from dask.distributed import Client, LocalCluster
    from distributed.system import MEMORY_LIMIT

    class _Cluster(LocalCluster):
        def new_worker_spec(self):
            spec = super().new_worker_spec()
            if numba_cache is None:
                return spec
            out = {}
            for name, s in spec.items():
                options = dict(s.get("options", {}))
                options["env"] = {**options.get("env", {}),
                                  "NUMBA_CACHE_DIR": str(Path(numba_cache) / f"w{name}")}
                out[name] = {**s, "options": options}
            return out

    cluster = _Cluster(n_workers=0, threads_per_worker=1, processes=True,
                           memory_limit=int(MEMORY_LIMIT // max(n, 1)),
                           dashboard_address=None, silence_logs=logging.ERROR,
                           scheduler_kwargs={"dashboard_address": ":0"})
    try:
        before = _spawned_children()
        with ignore_signals():
            cluster.scale(n)
            _wait_spawned(cluster, n, before)
        client = Client(cluster)
    except BaseException:
        cluster.close()
        raise
    return cluster, client


def _spawned_children() -> int | None:
    """How many child processes run multiprocessing's spawn entry point (Linux), or None."""
    try:
        pids = {pid for task in Path("/proc/self/task").iterdir()
                for pid in (task / "children").read_text().split()}
    except OSError:
        return None
    count = 0
    for pid in pids:
        with contextlib.suppress(OSError):
            count += b"spawn_main" in Path(f"/proc/{pid}/cmdline").read_bytes()
    return count


def _wait_spawned(cluster, n: int, before: int | None, timeout: float = 60.0) -> None:
    """Wait until the ``n`` worker processes exist (a started process keeps ``SIG_IGN``)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        count = _spawned_children()
        if count is not None and before is not None:
            if count >= before + n:
                return
        elif len(cluster.workers) >= n and all(
                getattr(getattr(w, "process", None), "pid", None)
                for w in cluster.workers.values()):
            return
        time.sleep(0.02)



class _UnretrievedTimeout(logging.Filter):
    """Drops asyncio's "Future exception was never retrieved" records of a ``TimeoutError``."""

    def filter(self, record: logging.LogRecord) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        return not (isinstance(exc, TimeoutError)
                    and str(record.msg).startswith("Future exception was never retrieved"))


def quiet_asyncio() -> None:
    """Filter one kind of record out of this process's ``asyncio`` logger, once.

    A stop, or a scheduler closing, can leave one of Dask's internal futures
    with a ``TimeoutError`` nobody retrieves; in a worker process, whose
    ``asyncio`` logger has no handler, Python's last-resort handler then
    printed "Future exception was never retrieved" into the user's terminal
    in the middle of a clean Ctrl-C (seen once, in the interrupt test under
    the test suite's load). Only that record is dropped: a case's own failure
    reaches the user through its future, and other asyncio errors still show.
    """
    log = logging.getLogger("asyncio")
    if not any(isinstance(f, _UnretrievedTimeout) for f in log.filters):
        log.addFilter(_UnretrievedTimeout())


@contextlib.contextmanager
def case_lock(folder: Path, case_id: str):
    """Hold the case folder's lock, polling (a stop request must get through the wait)."""
    waited = False
    while True:
        with folder_lock(folder, wait=False) as held:
            if held:
                yield
                return
        if not waited:
            logger.info("case %s: another run is computing it; waiting", case_id)
            waited = True
        time.sleep(STOP_POLL)


@contextlib.contextmanager
def stop_watch(stop_name: str | None, case_id: str):
    """Raise KeyboardInterrupt in this thread once the event ``stop_name`` is set.

    A watcher thread polls the event (and the worker's status: a closing
    worker stops its case too) every :data:`STOP_POLL` s and raises the
    exception asynchronously in the case's thread, which gets it at its next
    Python statement. Outside a Dask worker nothing is watched.
    """
    import ctypes

    try:
        from distributed import Event, get_client, get_worker

        worker = get_worker()
    except (ImportError, ValueError):
        worker = None
    if stop_name is None or worker is None:
        yield
        return
    event = Event(stop_name, client=get_client())
    if event.is_set():
        raise CaseStopped(f"case {case_id}: stopped before it started")
    target = threading.get_ident()
    guard = threading.Lock()
    finished = threading.Event()

    def raise_in_target(exc) -> None:
        ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(target),
                                                   None if exc is None else ctypes.py_object(exc))

    def watch() -> None:
        while not finished.wait(STOP_POLL):
            try:
                stop = event.is_set() or worker.status.name not in ("running", "paused")
            except Exception:   # the scheduler is gone: the run is over
                stop = True
            if stop:
                with guard:
                    if not finished.is_set():
                        logger.info("case %s: stopping", case_id)
                        raise_in_target(Interrupted)
                return

    thread = threading.Thread(target=watch, name=f"stop-watch-{case_id}", daemon=True)
    thread.start()
    try:
        yield
    finally:
        with guard:
            finished.set()
            raise_in_target(None)   # one raised too late would hit the worker's own code


def cores() -> int:
    """The cores this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else \
        (os.cpu_count() or 1)
