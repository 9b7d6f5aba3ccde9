"""Where the candidate fits of ``diagnose`` and ``fit`` run: here, local processes, or a Dask cluster.

A diagnosis maps one function over many independent jobs at each rung (every
candidate's fit, the pair fits); ``fit`` without a location maps over the places
an effect may act.  An :class:`Executor` is made once per diagnosis (or fit) and
runs each map:

* locally, on ``workers`` forked processes (:func:`gearbench.workers.process_pool`,
  a pool per map) or in this process when one is enough;
* on a running Dask distributed cluster (``scheduler``, ``tcp://HOST:PORT``), one
  client connected for the whole diagnosis (:func:`gearbench.workers.dask_client`),
  one task per job: a candidate's fit, with every replay of the record's windows it
  makes, stays in one task.

Either way the results come back in the order of the jobs, so the ranking, the
ladder and every number are the ones a local run gives.  What is passed to every job
of one map (the replay with its record, the scorer, the plant) is sent to the cluster
once (``Client.scatter``), not once per job.

Where what to run next depends on a job still running (the calibration's fits from a
scan's points are wanted only if the fit from the model's values does not settle it),
:meth:`Executor.pool` takes jobs one at a time, on the same workers, and drops the
ones still running when its block is left.
"""
from __future__ import annotations

import sys
from concurrent.futures import Future, as_completed
from contextlib import contextmanager
from typing import Any, Callable, Iterator, Sequence

from ..workers import dask_client, kill_workers, process_pool, worker_count

_SMALL = (type(None), bool, int, float, str, tuple)
"""Values left inside each job rather than scattered (cheap to send, and ``()``, ``None``,
small numbers and strings are the same object everywhere without being data)."""


class Executor:
    """Runs :meth:`map` locally (``workers`` processes) or on the Dask scheduler at ``scheduler``.

    Use it as a context manager: entering connects to the scheduler (a malformed or
    unreachable address raises :class:`gearbench.workers.SchedulerError` before any work),
    leaving closes the connection, also on an exception or Ctrl-C, after cancelling
    the tasks still running.  ``workers`` is ignored with a ``scheduler``.
    """

    def __init__(self, workers: int | None = None, scheduler: str | None = None):
        self.workers = workers
        self.scheduler = scheduler
        self._client = None

    def __enter__(self) -> Executor:
        if self.scheduler:
            self._client = dask_client(self.scheduler)
        return self

    def __exit__(self, *exc) -> None:
        if self._client is not None:
            self._client.close()
            self._client = None

    def map(self, fn: Callable[[Any], Any], jobs: Sequence, progress: Callable[[Any], None] | None = None,
            cost: Sequence[float] | None = None) -> list:
        """``[fn(job) for job in jobs]``, computed in parallel, in the order of the jobs.

        ``cost``: an estimate of each job's run time (any scale); the costliest start first, so
        a long job does not start last and leave the other workers idle (on the tutorial's
        record, one candidate, the shaft compliance, took 13 of the first rung's 22 s on one
        process, and in the registry's order it started eleventh of fifteen).  ``progress(result)``
        is called for each result as it is done (locally) or in the order of the jobs (Dask)."""
        order = sorted(range(len(jobs)), key=lambda i: -cost[i]) if cost is not None else range(len(jobs))
        if self._client is not None:
            return self._dask_map(fn, jobs, progress, order)
        workers = worker_count(self.workers, len(jobs))
        out: list = [None] * len(jobs)
        if workers > 1:
            with process_pool(workers) as pool:
                futures = {pool.submit(fn, jobs[i]): i for i in order}
                for fut in as_completed(futures):
                    out[futures[fut]] = fut.result()
                    if progress:
                        progress(out[futures[fut]])
            return out
        for i, j in enumerate(jobs):
            out[i] = fn(j)
            if progress:
                progress(out[i])
        return out

    @contextmanager
    def pool(self) -> Iterator["Pool"]:
        """A :class:`Pool` to submit jobs to one at a time, on this executor's workers (local
        processes, or the Dask cluster); leaving the block drops the jobs still running (their
        local workers killed, their Dask tasks cancelled).  With one worker each job runs in
        this process when it is submitted: a caller that asks whether a job is ``done()`` before
        submitting more, and looks at its result if so, runs no job it does not need."""
        if self._client is not None:
            pool = Pool(_scattering(self._client))
            try:
                yield pool
            finally:
                self._client.cancel([f for f in pool.futures if not f.done()])
            return
        workers = worker_count(self.workers, sys.maxsize)
        if workers == 1:
            yield Pool(_here)
            return
        with process_pool(workers) as local:
            pool = Pool(local.submit)
            yield pool
            if not all(f.done() for f in pool.futures):
                kill_workers(local)

    def _dask_map(self, fn, jobs, progress, order) -> list:
        """One task per job (``pure=False``: a job is never taken for another's cached result),
        submitted in ``order``; the values shared by every job (tuples of arguments) are scattered
        once (:func:`_shared`)."""
        client = self._client
        jobs = _shared(client, list(jobs))
        submitted = dict(zip(order, client.map(fn, [jobs[i] for i in order], pure=False)))
        futures = [submitted[i] for i in range(len(jobs))]
        try:
            out = []
            for fut in futures:
                out.append(fut.result())
                if progress:
                    progress(out[-1])
            return out
        except BaseException:  # a failed task, Ctrl-C: the rest are not wanted
            client.cancel(futures)
            raise


class Pool:
    """Jobs submitted one at a time (:meth:`Executor.pool`); each :meth:`submit` returns a
    future (``result()``, ``done()``)."""

    def __init__(self, submit: Callable):
        self._submit = submit
        self.futures: list = []

    def submit(self, fn: Callable[[Any], Any], job) -> Any:
        """``fn(job)``, started where the pool runs jobs; its future."""
        self.futures.append(self._submit(fn, job))
        return self.futures[-1]


def _scattering(client) -> Callable:
    """``submit(fn, job)`` of one Dask task per job (``pure=False``), each argument of a job tuple
    that is not a :data:`_SMALL` value sent to the cluster once per pool (``Client.scatter``, kept by
    the object's identity), as :func:`_shared` does for a map: the record travels once."""
    sent: dict[int, tuple] = {}  # id -> (the object, kept alive so its id is not reused; its future)

    def scattered(x):
        if isinstance(x, _SMALL):
            return x
        if id(x) not in sent:
            sent[id(x)] = (x, client.scatter(x, hash=False))
        return sent[id(x)][1]

    def submit(fn, job):
        return client.submit(fn, tuple(map(scattered, job)) if isinstance(job, tuple) else job, pure=False)
    return submit


def _here(fn: Callable[[Any], Any], job) -> Future:
    """``fn(job)`` run now, in this process, as a done future (its exception kept for ``result()``)."""
    fut: Future = Future()
    try:
        fut.set_result(fn(job))
    except Exception as exc:  # noqa: BLE001 - raised again by result(), as a pool's future does
        fut.set_exception(exc)
    return fut


def _shared(client, jobs: list) -> list:
    """``jobs`` (tuples of arguments) with each argument that is one and the same object in every job
    (and not a :data:`_SMALL` value) replaced by one future of it, scattered once: the record then
    travels to each Dask worker once per map instead of once per candidate (a 10 s record at 1 kHz is
    0.5 MB pickled), which also keeps Dask's large-graph warning quiet."""
    if len(jobs) < 2 or not all(isinstance(j, tuple) and len(j) == len(jobs[0]) for j in jobs):
        return jobs
    same = [i for i, x in enumerate(jobs[0])
            if not isinstance(x, _SMALL) and all(j[i] is x for j in jobs)]
    if not same:
        return jobs
    futures = dict(zip(same, client.scatter([jobs[0][i] for i in same], hash=False)))
    return [tuple(futures.get(i, x) for i, x in enumerate(j)) for j in jobs]


__all__ = ["Executor", "Pool"]
