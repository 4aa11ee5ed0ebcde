"""Map a function over task specs on a Dask ``distributed`` cluster, yielding as they finish.

::

    for r in map_tasks(run_one, specs, keys=names, workers=2, on_progress=show):
        print(r.key, "ok" if r.ok else r.error)

Where the tasks run:

- default: a ``LocalCluster`` of ``workers`` processes (default: the cores this process may
  use, ``os.sched_getaffinity``), one thread each, no dashboard; it is started for the
  call and shut down after it (also on an error or Ctrl-C);
- ``scheduler="tcp://host:8786"`` (or the environment variable ``TACTILE_DASK_SCHEDULER``):
  an existing cluster; its workers must import the same ``tactile_cli`` and see the same
  paths (a shared file system);
- ``workers=0``: in this process, one task after another (tests and debugging; the same
  results, no cluster: every task runs with one-threaded BLAS and OpenMP, as in a local
  worker, see :func:`_guarded`).

At most one task per worker thread is submitted at a time (the next when one finishes),
so a long task never waits behind another on a busy worker while a free one idles, and the
progress counts what really runs.

Specs and results travel between processes, so they must pickle: paths and plain dicts,
never open files. ``func`` must be importable by the workers (a module-level function).

A task that raises an ``Exception`` is a failed :class:`TaskResult` with the exception as
one line (:func:`one_line`); it is not run again (the same input fails the same way). A
worker that dies in the middle of a task (out of memory, killed) is replaced by the local
cluster's nanny and the scheduler runs the task again on a live worker, up to ``retries``
more times (``distributed.scheduler.allowed-failures``; on an existing cluster its own
setting holds); after that the task is a failed result saying its workers died. The others
go on. Tasks write their outputs under a temporary name and rename them, so a task killed
half-way leaves no output under the final name.

HDF5 file locking is left on (the ``HDF5_USE_FILE_LOCKING`` variable is not touched): the
tasks of a sweep open their inputs read-only, and HDF5 lets any number of processes hold
a read-only (shared) lock on one file, while every output is written to a temporary name
and renamed. On a file system without working ``flock`` (some NFS mounts) set
``HDF5_USE_FILE_LOCKING=FALSE`` in the environment; local workers inherit it.

Ctrl-C: local workers ignore SIGINT (the terminal sends it to every process of the
group); the loop here checks :func:`tactile_cli.interrupt.raise_if_requested` several
times a second, cancels what is left and shuts the cluster down, which stops the workers.
Dask's log messages are held at ERROR level for the call (CRITICAL in the local workers),
so the command's output stays readable.
"""

from __future__ import annotations

import logging
import math
import os
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from typing import Any

from ..errors import InputError, TactileError
from ..interrupt import raise_if_requested
from ..threads import check_threads

#: Environment variable with the address of an existing Dask scheduler.
SCHEDULER_ENV = "TACTILE_DASK_SCHEDULER"

#: Loggers held at ERROR during a call (distributed logs to stderr at INFO and WARNING).
_LOGGERS = ("distributed", "bokeh", "tornado")
#: The local workers log only what stops them: a task's error comes back as its result,
#: and the heartbeat tracebacks of workers stopped by Ctrl-C (CommClosedError) would break
#: the command's one-line report
_WORKER_LOG_LEVEL = logging.CRITICAL
#: Seconds between checks for Ctrl-C while waiting for tasks.
_POLL_S = 0.1


@dataclass(frozen=True)
class TaskResult:
    """One task's outcome: ``value`` (what ``func`` returned) when ``ok``, else ``error``
    (one line). ``index``: the spec's position; ``seconds``: the task's own wall time
    (NaN when its worker died)."""

    index: int
    key: str
    ok: bool
    value: Any = None
    error: str | None = None
    seconds: float = math.nan

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class BatchCounts:
    """Tasks finished (``done``: ok), ``failed``, ``running`` (at most one per worker
    thread) and ``total`` so far."""

    total: int
    done: int
    running: int
    failed: int

    @property
    def waiting(self) -> int:
        return self.total - self.done - self.failed - self.running


def default_workers() -> int:
    """The cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def one_line(exc: BaseException) -> str:
    """An exception as one line: our errors as they print (file: message), others as
    ``Class: first line``."""
    text = " ".join(str(exc).split("\n")[0].split()) if not isinstance(exc, TactileError) \
        else " ".join(str(exc).split())
    if isinstance(exc, TactileError):
        return text
    return f"{exc.__class__.__name__}: {text}" if text else exc.__class__.__name__


def _lost(exc: BaseException) -> str:
    """The one line of a task that did not come back: its workers died, or it was
    cancelled."""
    if type(exc).__name__ == "KilledWorker":
        return ("the worker running it died every time it ran (killed, or out of memory); "
                "nothing was written under its output name")
    return one_line(exc)


def _guarded(func: Callable[[Any], Any], spec: Any) -> tuple[bool, Any, str | None, float]:
    """Run one task where it lands: (ok, value, error, seconds); an exception is caught
    here, so it never has to pickle and never stops the batch.

    Every task runs with one BLAS and one OpenMP thread, wherever it lands: a local
    worker gets that from distributed's environment (``OPENBLAS_NUM_THREADS=1`` and the
    like), and ``workers=0`` or an existing cluster's workers must run the same way, or a
    BLAS call's summation order (and the last bit of a result) would depend on the number
    of workers."""
    from threadpoolctl import threadpool_limits

    started = time.perf_counter()
    try:
        with threadpool_limits(limits=1):
            value = func(spec)
    except Exception as exc:  # a failed task is a result, not a stop
        return False, None, one_line(exc), time.perf_counter() - started
    return True, value, None, time.perf_counter() - started


def _ignore_sigint() -> None:
    """In a local worker process: let the parent handle Ctrl-C (it shuts the cluster
    down); without this every worker prints its own KeyboardInterrupt."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextmanager
def _quiet_logs() -> Iterator[None]:
    levels = {name: logging.getLogger(name).level for name in _LOGGERS}
    for name in _LOGGERS:
        logging.getLogger(name).setLevel(logging.ERROR)
    try:
        yield
    finally:
        for name, level in levels.items():
            logging.getLogger(name).setLevel(level)


@contextmanager
def _client(address: str | None, workers: int, retries: int = 1) -> Iterator[Any]:
    """A connected ``distributed.Client``: to ``address``, or to a LocalCluster of
    ``workers`` single-thread processes started here (a task whose worker dies is run
    again up to ``retries`` times); both closed on exit."""
    import dask
    from distributed import Client, LocalCluster

    if address:
        try:
            client = Client(address, timeout="10s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError(f"cannot reach the Dask scheduler at {address!r} ({one_line(exc)}); "
                             f"check `scheduler` (or {SCHEDULER_ENV}), or leave it out to run "
                             "on this machine") from None
        try:
            yield client
        finally:
            client.close()
        return
    # no dashboard, and the scheduler's HTTP endpoints on a free port of this host only (on
    # the default 8787 a second sweep, or any Dask user, makes distributed warn)
    # the nanny starts workers with MALLOC_TRIM_THRESHOLD_=65536 (distributed's default
    # pre-spawn environment): measured 18 % slower ingest per task than in-process, so it
    # is left out (the config keys are set after `distributed` is imported, as required)
    environ = {k: v for k, v in
               dask.config.get("distributed.nanny.pre-spawn-environ", {}).items()
               if k != "MALLOC_TRIM_THRESHOLD_"}
    with dask.config.set({"distributed.scheduler.allowed-failures": retries,
                          "distributed.nanny.pre-spawn-environ": environ}):
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               host="127.0.0.1", dashboard_address=None,
                               scheduler_kwargs={"dashboard": False,
                                                 "dashboard_address": "127.0.0.1:0"},
                               silence_logs=_WORKER_LOG_LEVEL)
    try:
        client = Client(cluster)
        try:
            client.run(_ignore_sigint)
            yield client
        except BaseException:
            # stop the tasks at once: a closing worker waits for its running task (a whole
            # training run), so the processes exit here and the cluster then closes
            for nanny in list(cluster.workers.values()):
                try:
                    cluster.sync(nanny.kill, timeout=1, reason="tactile-interrupted")
                except Exception:  # already gone: nothing to stop
                    pass
            raise
        finally:
            client.close()
    finally:
        cluster.close()


def _serial(func: Callable[[Any], Any], specs: Sequence[Any], keys: Sequence[str],
            on_progress: Callable[[BatchCounts], None] | None) -> Iterator[TaskResult]:
    done = failed = 0
    for i, (spec, key) in enumerate(zip(specs, keys, strict=True)):
        raise_if_requested()
        if on_progress is not None:
            on_progress(BatchCounts(len(specs), done, 1, failed))
        ok, value, error, seconds = _guarded(func, spec)
        done, failed = done + ok, failed + (not ok)
        yield TaskResult(i, key, ok, value, error, seconds)
    if on_progress is not None:
        on_progress(BatchCounts(len(specs), done, 0, failed))


def map_tasks(
    func: Callable[[Any], Any],
    specs: Sequence[Any],
    *,
    keys: Sequence[str] | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    on_progress: Callable[[BatchCounts], None] | None = None,
    retries: int = 1,
) -> Iterator[TaskResult]:
    """Run ``func(spec)`` for every spec on Dask and yield a :class:`TaskResult` as each
    finishes (see the module docstring for where they run). ``keys`` name the tasks (default
    ``task-<i>``); ``on_progress`` gets the counts at the start and after every task.

    ``scheduler``: address of an existing cluster (default: the environment variable
    ``TACTILE_DASK_SCHEDULER``, else a local cluster); ``workers``: processes of the local
    cluster (default: the cores; 0: run in this process, one task after another);
    ``retries``: how many more times a task whose worker died runs (local cluster).
    """
    specs = list(specs)
    keys = [f"task-{i}" for i in range(len(specs))] if keys is None else list(keys)
    if len(keys) != len(specs):
        raise ValueError(f"`keys` ({len(keys)}) and `specs` ({len(specs)}) differ in length")
    if workers is not None and workers != 0:
        check_threads(workers, "workers")  # 1 to 4 x the cores: more only wait for each other
    if retries < 0:
        raise InputError(f"`retries` (={retries}) must be >= 0")
    if not specs:
        return
    address = scheduler or os.environ.get(SCHEDULER_ENV) or None
    if workers == 0 and not address:
        yield from _serial(func, specs, keys, on_progress)
        return
    n = min(workers or default_workers(), len(specs))
    with _quiet_logs(), _client(address, n, retries) as client:
        from distributed import as_completed

        token = uuid.uuid4().hex[:8]
        queue = list(enumerate(zip(specs, keys, strict=True)))
        futures: dict[Any, int] = {}
        finished = as_completed()
        done = failed = 0

        def fill() -> None:
            # at most one task per worker thread in flight: the scheduler would otherwise
            # hand a busy worker queued tasks of their own (each task its own group), and
            # a worker that dies counts every task it holds as a failure
            limit = max(1, sum(client.nthreads().values()))
            while queue and len(futures) < limit:
                i, (spec, key) = queue.pop(0)
                fut = client.submit(_guarded, func, spec, key=f"tactile-{key}-{token}",
                                    pure=False)
                futures[fut] = i
                finished.add(fut)

        def report() -> None:
            if on_progress is not None:
                on_progress(BatchCounts(len(specs), done, len(futures), failed))

        try:
            fill()
            report()
            while done + failed < len(specs):
                raise_if_requested()
                batch = finished.next_batch(block=False)
                if not batch:
                    time.sleep(_POLL_S)
                    fill()
                    continue
                for fut in batch:
                    i = futures.pop(fut)
                    try:
                        ok, value, error, seconds = fut.result()
                    except Exception as exc:  # the worker died, or the task was cancelled
                        ok, value, error, seconds = False, None, _lost(exc), math.nan
                    fut.release()
                    done, failed = done + ok, failed + (not ok)
                    fill()
                    yield TaskResult(i, keys[i], ok, value, error, seconds)
                    report()
        finally:
            client.cancel(list(futures))


__all__ = ["SCHEDULER_ENV", "BatchCounts", "TaskResult", "default_workers", "map_tasks",
           "one_line"]
