"""Where :func:`lodkit.batch` and :func:`lodkit.simplify_large` run their tasks.

One small interface over three engines, so the callers read the same whatever runs them:

* Dask (``dask.distributed``): a ``LocalCluster`` of worker processes made here (the
  default), a running cluster by its scheduler address (``"tcp://host:8786"``), or a
  ``distributed.Client`` the caller made;
* ``"threads"``: a ``concurrent.futures.ThreadPoolExecutor`` in this process (lodkit's core
  releases the GIL while it simplifies, so threads run meshes in parallel);
* ``"sync"``: every task at once, in this process, in order (for debugging and tests).

``submit(fn, *args)`` returns a future; ``completed(futures)`` yields ``(future, result,
exception)`` as each finishes.  A task that raises, or whose worker died more often than
Dask allows, comes out with its exception; it never stops the others.  A Dask cluster left
without any worker (workers that cannot start: lodkit missing on them, a broken
environment) would leave the tasks waiting for ever: after ``NO_WORKER_GRACE`` seconds
with none, ``completed`` raises a LodkitError that says so.
"""
from __future__ import annotations

import concurrent.futures as cf
import os
import socket
import threading
import time

from .errors import DependencyError, LodkitError, OptionError

__all__ = ["Executor", "open_executor", "default_workers", "worker_name"]

#: what the caller may give as ``scheduler=``, besides a scheduler address
LOCAL_SCHEDULERS = ("processes", "threads", "sync")
#: seconds a Dask cluster may have no worker at all while tasks wait, before completed() gives up
NO_WORKER_GRACE = 60.0
#: seconds between two looks at the cluster while nothing finishes
_POLL = 2.0


def default_workers() -> int:
    """One worker per core this process may use."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except (AttributeError, OSError):  # not Linux
        return max(os.cpu_count() or 1, 1)


def import_distributed():
    """``dask.distributed``, or a DependencyError that says how to install it."""
    try:
        import distributed
    except ImportError as exc:
        raise DependencyError(
            "running on Dask needs dask.distributed, which is not installed: "
            "pip install 'lodkit[dask]' (or pass scheduler='threads' to run in this process)"
            f" ({exc})") from exc
    return distributed


def worker_name() -> str:
    """Who runs the calling task: the Dask worker's address, else host, process and thread."""
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        pass
    return f"{socket.gethostname()}:{os.getpid()}:{threading.current_thread().name}"


class Executor:
    """Tasks on one engine; made by :func:`open_executor`, used as a context manager."""

    def __init__(self, kind: str, *, pool=None, client=None, cluster=None, owns_client: bool = False):
        self.kind = kind            # "dask", "threads" or "sync"
        self.pool = pool
        self.client = client
        self.cluster = cluster
        self.owns_client = owns_client

    def describe(self) -> str:
        if self.kind == "dask":
            return f"dask scheduler {self.client.scheduler.address}"
        if self.kind == "threads":
            return f"{self.pool._max_workers} threads"
        return "this process, one task at a time"

    def submit(self, fn, *args):
        if self.kind == "dask":
            return self.client.submit(fn, *args, pure=False)
        if self.kind == "threads":
            return self.pool.submit(fn, *args)
        future = cf.Future()
        try:
            future.set_result(fn(*args))
        except Exception as exc:  # handed to the caller through completed(), as the others do
            future.set_exception(exc)
        return future

    def completed(self, futures):
        """Yield ``(future, result, exception)`` for each future as it finishes."""
        if self.kind == "dask":
            pending = list(futures)
            alone_since = None                 # when the cluster was first seen without workers
            last_look = time.monotonic()
            nap = 0.01
            while pending:
                done = [f for f in pending if f.done()]
                for future in done:
                    try:
                        yield future, future.result(), None
                    except Exception as exc:  # a failed task, or a worker that died too often
                        yield future, None, exc
                if done:
                    finished = {id(f) for f in done}
                    pending = [f for f in pending if id(f) not in finished]
                    alone_since, nap = None, 0.01
                    continue
                time.sleep(nap)
                nap = min(2 * nap, 0.25)
                if time.monotonic() - last_look < _POLL:
                    continue
                last_look = time.monotonic()
                if self.n_workers() > 0:
                    alone_since = None
                elif alone_since is None:
                    alone_since = last_look
                elif last_look - alone_since > NO_WORKER_GRACE:
                    for f in pending:
                        f.cancel()
                    raise LodkitError(
                        f"the Dask cluster ({self.describe()}) has had no worker for {NO_WORKER_GRACE:g} s "
                        f"while {len(pending)} task(s) wait: its workers did not start or all died (can "
                        "they import lodkit? see the workers' logs)")
            return
        for future in cf.as_completed(futures):
            exc = future.exception()
            yield future, (None if exc is not None else future.result()), exc

    def n_workers(self) -> int:
        """Workers the Dask scheduler knows of now."""
        try:
            return len(self.client.scheduler_info().get("workers", {}))
        except Exception:  # noqa: BLE001 - a scheduler that does not answer has no worker for us
            return 0

    def map(self, fn, items):
        """``[fn(*item) for item in items]``, run on the engine; the first exception is raised."""
        futures = [self.submit(fn, *item) for item in items]
        index = {id(f): i for i, f in enumerate(futures)}
        results = [None] * len(futures)
        for future, result, exc in self.completed(futures):
            if exc is not None:
                for f in futures:
                    f.cancel()
                raise exc
            results[index[id(future)]] = result
        return results

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=True)
        if self.owns_client and self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def open_executor(scheduler=None, *, workers: int | None = None, client=None,
                  memory_limit="auto") -> Executor:
    """An :class:`Executor` for ``scheduler``:

    None or "processes" : a new Dask ``LocalCluster``, ``workers`` processes of one thread
                          each (default: one per core), on the loopback interface
    "threads"           : a pool of ``workers`` threads in this process (no Dask needed)
    "sync"              : this process, one task after the other (no Dask needed)
    an address          : a running Dask scheduler (``"tcp://127.0.0.1:8786"``)
    ``client``          : a ``distributed.Client`` made by the caller (then ``scheduler`` must be None)
    """
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise OptionError(f"workers must be a positive integer, got {workers!r}")
    if client is not None:
        if scheduler is not None:
            raise OptionError("give either client= or scheduler=, not both")
        return Executor("dask", client=client)
    if scheduler == "sync":
        return Executor("sync")
    if scheduler == "threads":
        return Executor("threads", pool=cf.ThreadPoolExecutor(max_workers=workers or default_workers(),
                                                              thread_name_prefix="lodkit"))
    if scheduler is None or scheduler == "processes":
        distributed = import_distributed()
        cluster = distributed.LocalCluster(n_workers=workers or default_workers(), threads_per_worker=1,
                                           processes=True, host="127.0.0.1", dashboard_address=None,
                                           memory_limit=memory_limit)
        try:
            client = distributed.Client(cluster, set_as_default=False)
        except BaseException:
            cluster.close()
            raise
        return Executor("dask", client=client, cluster=cluster, owns_client=True)
    if not isinstance(scheduler, str) or "://" not in scheduler and ":" not in scheduler:
        raise OptionError(f"scheduler must be 'processes', 'threads', 'sync' or a Dask scheduler address "
                          f"such as 'tcp://127.0.0.1:8786', got {scheduler!r}")
    if workers is not None:
        raise OptionError("workers= does not apply to a running Dask cluster (its workers are started there)")
    distributed = import_distributed()
    try:
        client = distributed.Client(scheduler, timeout="20s", set_as_default=False)
    except OSError as exc:
        raise OptionError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from exc
    return Executor("dask", client=client, owns_client=True)
