"""Local process pools whose workers end with their parent, and the connection to a Dask cluster.

Every local pool of gearbench (``runner.run_experiment``, ``sweep``'s local
points, ``identify.diagnose``'s candidate fits) is made here, with one rule for
how many workers and one worker initializer:

* **Ctrl-C belongs to the parent.**  A terminal's Ctrl-C reaches the whole
  foreground process group; the workers ignore SIGINT, so they print no
  traceback, and the parent decides (:func:`process_pool` kills them at once
  when its block is left by an exception such as ``KeyboardInterrupt``).
* **No orphans.**  A parent killed with SIGKILL (``kill -9 PID``, the
  out-of-memory killer) runs no clean-up, and its workers would run on,
  re-parented to init: they hold the parent's inherited descriptors (a
  sweep store's ``flock``) and burn the cores.  On Linux each worker asks the
  kernel for SIGKILL when its parent dies (``prctl(PR_SET_PDEATHSIG,
  SIGKILL)``); elsewhere a daemon thread polls ``os.getppid()`` every
  :data:`POLL_S` seconds and kills the worker when it changes.  Either way the
  worker first checks that its parent is still the pid that created the pool,
  because the parent may have died between the fork and the ``prctl`` call
  (the death signal only covers deaths after it is armed).

The pools fork (the ``fork`` start method): a worker inherits the parent's
loaded, compiled numba core instead of loading it from the disk cache again.
With ``fork`` a ``ProcessPoolExecutor`` starts all its workers at the first
``submit``, from the submitting thread; Linux's parent-death signal fires when
*that thread* ends, so a pool must be used from a thread that outlives it (the
main thread, in gearbench).

The other way to spread work, a running Dask distributed cluster (``sweep`` and
``diagnose``/``fit`` with ``--scheduler``), is reached through :func:`dask_client`,
so the commands share one timeout and one error.
"""
from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import os
import signal
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Iterator

from .blas import limit_this_process
from .errors import SchedulerError

POLL_S = 0.2
"""Period of the fallback parent watch, s (a worker outlives its parent by at most this)."""

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>

CONNECT_TIMEOUT_S = 20
"""How long :func:`dask_client` waits for a scheduler to answer, s (an address where nothing
listens is only known to be wrong after it: the client retries a refused connection)."""


def default_workers() -> int:
    """Cores this process may run on (its CPU affinity; ``os.cpu_count()`` off Linux)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def worker_count(requested: int | None, jobs: int) -> int:
    """How many processes to use for ``jobs`` tasks.

    ``requested`` None means every usable core (:func:`default_workers`); any
    request is capped by the number of jobs (an idle worker costs a fork and
    memory) and floored at 1.  A result of 1 means: solve in this process.
    """
    n = default_workers() if requested is None else int(requested)
    return max(1, min(n, jobs))


def _kill_self() -> None:
    os.kill(os.getpid(), signal.SIGKILL)


def _arm_death_signal() -> bool:
    """Ask Linux to SIGKILL this process when its parent dies; False where that is not possible."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0
    except (OSError, AttributeError):  # no libc symbol: fall back to polling
        return False


def _watch_parent(parent_pid: int) -> None:
    """Poll the parent pid from a daemon thread; a change means the parent died (we were re-parented)."""
    def watch():
        while os.getppid() == parent_pid:
            time.sleep(POLL_S)
        _kill_self()

    threading.Thread(target=watch, name="gearbench-parent-watch", daemon=True).start()


def _init_worker(parent_pid: int, watch: str) -> None:
    """Worker initializer: ignore SIGINT, one BLAS thread (``gearbench.blas``), and die with the
    parent (see the module's text)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    limit_this_process()  # tiny BLAS calls on two threads per worker oversubscribe the cores (blas.py)
    armed = watch == "auto" and _arm_death_signal()
    if os.getppid() != parent_pid:  # the parent died before the death signal was armed
        _kill_self()
    if not armed:
        _watch_parent(parent_pid)


def kill_workers(pool: ProcessPoolExecutor) -> None:
    """SIGKILL the pool's live workers (their running tasks are abandoned) and shut it down."""
    # ``_processes`` (pid -> Process) is the executor's own table; there is no public one
    for proc in list((getattr(pool, "_processes", None) or {}).values()):
        with contextlib.suppress(OSError, ValueError, AttributeError):
            if proc.is_alive():
                proc.kill()
    # A worker killed while it wrote a result leaves half a message in the result pipe, and
    # the executor's manager thread would wait for the rest for ever (this process holds the
    # pipe's write end too, so no end-of-file comes).  With that end closed here (the workers'
    # copies close as they die) it reads end-of-file, declares the pool broken and cleans up.
    writer = getattr(getattr(pool, "_result_queue", None), "_writer", None)
    if writer is not None:
        with contextlib.suppress(OSError):
            writer.close()
    pool.shutdown(wait=True, cancel_futures=True)


@contextlib.contextmanager
def process_pool(workers: int, *, watch: str = "auto") -> Iterator[ProcessPoolExecutor]:
    """A forked ``ProcessPoolExecutor`` of ``workers`` processes that end with this one.

    Parameters
    ----------
    workers : int
        Number of worker processes (see :func:`worker_count`).
    watch : {"auto", "poll"}
        How a worker notices that its parent died: ``"auto"`` uses Linux's
        parent-death signal where it exists and polls elsewhere; ``"poll"``
        always polls ``os.getppid()`` (every :data:`POLL_S` s; for tests of
        the portable path).

    Yields
    ------
    ProcessPoolExecutor
        Left normally, the block waits for the submitted tasks; left by an
        exception (``KeyboardInterrupt``, a consumer that stops early), the
        workers are killed at once and their unfinished tasks dropped.
    """
    if watch not in ("auto", "poll"):
        raise ValueError(f"watch must be 'auto' or 'poll', got {watch!r}")
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("fork"),
                               initializer=_init_worker, initargs=(os.getpid(), watch))
    try:
        yield pool
    except BaseException:
        kill_workers(pool)
        raise
    pool.shutdown(wait=True)


def dask_client(address: str):
    """A ``distributed.Client`` of the running Dask scheduler at ``address`` (``tcp://HOST:PORT``).

    It is not made Dask's default client (``set_as_default=False``): gearbench's work goes
    to it by name, and a caller's own Dask code keeps its own client.  The caller closes it.
    Raises :class:`SchedulerError` naming the address when dask is missing, the address is
    malformed or nothing answers there within :data:`CONNECT_TIMEOUT_S`.
    """
    try:
        from distributed import Client
        from distributed.comm import get_address_host_port
    except ImportError:  # pragma: no cover - dask is a dependency
        raise SchedulerError("--scheduler needs dask[distributed] (pip install 'dask[distributed]')") from None
    problem = None
    # A malformed address is refused before a Client is made: one made from it never closes (at the
    # interpreter's exit it waits 40 s, then prints a traceback).  An in-process cluster's address
    # (inproc://) names no host and port.
    if not address.startswith("inproc://"):
        try:
            get_address_host_port(address)
        except ValueError as exc:
            problem = str(exc)
    if problem is None:
        try:
            return Client(address, timeout=f"{CONNECT_TIMEOUT_S}s", set_as_default=False)
        except (OSError, TimeoutError, ValueError) as exc:
            problem = str(exc)
    raise SchedulerError(f"cannot reach the Dask scheduler at {address}: {problem}")


__all__ = ["POLL_S", "CONNECT_TIMEOUT_S", "SchedulerError", "dask_client", "default_workers", "worker_count",
           "process_pool"]
