"""One BLAS thread for gearbench's own numerical loops.

A replay calls BLAS thousands of times on tiny arrays (the straight-line fit of each
re-initialisation window, dot products of residual vectors, least squares' small
factorisations).  OpenBLAS spreads even those over its threads, whose start-up and
busy-waiting cost more than the work: measured on this 2-core machine, fitting the first
rung's 14 candidates of the tutorial's record, docs/tutorial.md (``diagnose``'s screen, shaft
compliance left out) took 16.7 s in one process with OpenBLAS's default two threads and
9.1 s with one; on two worker processes 13.7 s against 6.7 s (each worker's BLAS threads
competed with the other worker for the two cores).  So the fitting entry points and every
pool worker run with one BLAS thread (``threadpoolctl``, as joblib's workers do), and the
command line sets ``OPENBLAS_NUM_THREADS=1`` before numpy loads (``gearbench.cli``): a limit
set once OpenBLAS has started its threads helps less (the same screen on two workers: 9.5 s
against 6.3 s).  The compiled integrator does not use BLAS at all.
"""
from __future__ import annotations

from threadpoolctl import threadpool_limits


def single_threaded(fn):
    """Decorate ``fn`` to run with one BLAS thread (restored afterwards; about 0.2 ms a call)."""
    return threadpool_limits.wrap(limits=1, user_api="blas")(fn)


def limit_this_process() -> None:
    """One BLAS thread for the rest of this process (a pool worker's initializer)."""
    threadpool_limits(limits=1, user_api="blas")
