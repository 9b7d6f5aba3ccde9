"""The search: where the runs are solved, and how the next candidates are chosen.

Each candidate is a point of the unit cube (:mod:`.space`).  The search first solves a
scrambled Sobol sample of the cube (``2**ceil(log2(16 d))`` points for ``d`` settings), all
at once, spread over the workers, then polishes the best points with SciPy's bounded
Nelder-Mead (``scipy.optimize.minimize``): derivative-free, so it copes with the kinks
that saturation, the clearance and chatter put in every objective here, and it needs no
gradient of a run with impacts.  Polishing is sequential, so its runs spread over the
workers only when a candidate is run on several drawn plants (``robust``).

Runs go to a local pool held open for the whole tuning (:func:`gearbench.workers.process_pool`:
forked workers that end with this process) or to a running Dask cluster
(:func:`gearbench.workers.dask_client`); every run is the same compiled simulation
``gearbench run`` makes, so the results do not depend on where they ran.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable, Sequence

import numpy as np
from scipy.optimize import minimize
from scipy.stats import qmc

from ..control.controllers import Controller
from ..errors import ConfigError
from ..plant.components import Plant
from ..simulate import Segments, SolverOptions, failure_message, simulate
from ..workers import dask_client, process_pool, worker_count
from .objective import Evaluation, judge
from .space import controller_at


def run_scores(job: tuple) -> dict:
    """One run's scores (``RunResult.scores``), or ``{"failed": message}``: the unit of work
    sent to a worker (a module-level function, so it pickles by name)."""
    plant, controller, inputs, t_end, options, delta0 = job
    try:
        run = simulate(plant, controller, inputs, t_end, options, delta0=delta0)
    except ConfigError as exc:
        return {"failed": str(exc)}
    if not run.ok:
        return {"failed": failure_message(run, plant.name, plant)}
    return run.scores()


class Runner:
    """Maps :func:`run_scores` over jobs here, on ``workers`` local processes, or on the Dask
    scheduler at ``scheduler``; a context manager (the pool or client lives as long as it)."""

    def __init__(self, workers: int | None = 1, scheduler: str | None = None):
        self.workers, self.scheduler = workers, scheduler
        self._pool = self._pool_cm = self._client = None
        self._n = 1
        self.runs = 0

    def __enter__(self) -> Runner:
        if self.scheduler:
            self._client = dask_client(self.scheduler)
        elif worker_count(self.workers, 2) > 1:
            self._n = worker_count(self.workers, 1 << 20)
            self._pool_cm = process_pool(self._n)
            self._pool = self._pool_cm.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        if self._client is not None:
            self._client.close()
        if self._pool_cm is not None:
            self._pool_cm.__exit__(*exc)
        self._pool = self._pool_cm = self._client = None

    def map(self, jobs: Sequence[tuple]) -> list[dict]:
        self.runs += len(jobs)
        if self._client is not None and len(jobs) > 1:
            return self._client.gather(self._client.map(run_scores, list(jobs), pure=False))
        if self._pool is not None and len(jobs) > 1:
            return list(self._pool.map(run_scores, jobs, chunksize=max(1, len(jobs) // (4 * self._n))))
        return [run_scores(j) for j in jobs]


@dataclass(frozen=True)
class Problem:
    """What one tuning solves: the controller ``kind`` with ``compensator`` and its searched
    ``settings``, on ``plants`` (one, or the drawn ones), following ``inputs`` (SI) for
    ``t_end`` s; judged by ``objective``, the robust statistic ``robust`` and ``limits``."""
    kind: str
    compensator: str
    settings: tuple
    plants: tuple
    inputs: Segments
    t_end: float
    options: SolverOptions
    objective: str
    robust: str
    limits: dict
    delta0: float = 0.0

    def controller(self, u: Sequence[float]) -> Controller:
        return controller_at(self.kind, self.compensator, self.settings, u)

    def evaluate(self, runner: Runner, points: Sequence[Sequence[float]],
                 controllers: Sequence[Controller] | None = None) -> list[Evaluation]:
        """Each point (or each of ``controllers``) judged on every plant, all runs in one map."""
        ctrls = list(controllers) if controllers is not None else [self.controller(u) for u in points]
        jobs = [(p, c, self.inputs, self.t_end, self.options, self.delta0) for c in ctrls for p in self.plants]
        scores = runner.map(jobs)
        k = len(self.plants)
        return [judge({s.name: float(getattr(c, s.name)) for s in self.settings}, scores[i * k:(i + 1) * k],
                      self.objective, self.robust, self.limits) for i, c in enumerate(ctrls)]

    def with_plants(self, plants: Sequence[Plant]) -> Problem:
        return replace(self, plants=tuple(plants))


@dataclass
class Search:
    """The points a search solved (``history``, in order), the best one and where it lies."""
    history: list = field(default_factory=list)
    points: list = field(default_factory=list)

    def add(self, u: Sequence[float], ev: Evaluation) -> None:
        self.points.append(np.asarray(u, dtype=float))
        self.history.append(ev)

    @property
    def best_index(self) -> int:
        return int(np.argmin([e.score for e in self.history]))


def initial_sample(d: int, seed: int) -> np.ndarray:
    """A scrambled Sobol sample of the unit cube, ``2**ceil(log2(16 d))`` points."""
    return qmc.Sobol(d, scramble=True, seed=seed).random_base2(int(math.ceil(math.log2(16 * d))))


def search(problem: Problem, runner: Runner, *, seed: int = 0, starts: int = 2, max_polish: int | None = None,
           progress: Callable[[str], None] | None = None) -> Search:
    """Sample, then polish the ``starts`` best distinct points with bounded Nelder-Mead.

    ``max_polish``: most candidates each polish may solve (default ``40 d``); a polish ends
    earlier when the simplex has shrunk to 1e-3 of each setting's range (on a log scale for
    a gain) and the objective varies by less than 1e-4 of its value across it.
    """
    d = len(problem.settings)
    found = Search()
    sample = initial_sample(d, seed)
    for u, ev in zip(sample, problem.evaluate(runner, sample)):
        found.add(u, ev)
    if progress:
        progress(f"{problem.compensator}: sampled {len(sample)} points, best {found.history[found.best_index].score:.6g}")
    order = np.argsort([e.score for e in found.history])
    chosen: list[np.ndarray] = []
    for i in order:
        if len(chosen) == starts:
            break
        if all(np.max(np.abs(found.points[i] - c)) > 0.1 for c in chosen):
            chosen.append(found.points[i])
    cache: dict = {}

    def f(u):
        key = tuple(np.round(np.clip(u, 0, 1), 12))
        if key not in cache:
            cache[key] = problem.evaluate(runner, [np.clip(u, 0, 1)])[0]
            found.add(np.clip(u, 0, 1), cache[key])
        return cache[key].score

    for start in chosen:
        f0 = f(start)
        scale = abs(f0) if math.isfinite(f0) and f0 else 1.0
        minimize(f, start, method="Nelder-Mead", bounds=[(0.0, 1.0)] * d,
                 options={"xatol": 1e-3, "fatol": 1e-4 * scale, "maxfev": max_polish or 40 * d,
                          "initial_simplex": _simplex(start, 0.05)})
        if progress:
            progress(f"{problem.compensator}: polished, best {found.history[found.best_index].score:.6g} "
                     f"after {len(found.history)} candidates")
    return found


def _simplex(u: np.ndarray, size: float) -> np.ndarray:
    """A simplex of side ``size`` at ``u``, stepping inward where ``u`` is at a face."""
    d = u.size
    s = np.tile(u, (d + 1, 1))
    for i in range(d):
        s[i + 1, i] += size if u[i] + size <= 1 else -size
    return s


def slices(problem: Problem, runner: Runner, u: np.ndarray, half_width: float = 0.15, n: int = 9) -> dict:
    """The objective along each setting through ``u`` (``n`` points within +-``half_width`` of
    the cube, clipped): ``{name: [(value, Evaluation), ...]}``, all solved in one map."""
    pts, owner = [], []
    for i, s in enumerate(problem.settings):
        for x in np.linspace(max(0.0, u[i] - half_width), min(1.0, u[i] + half_width), n):
            p = u.copy()
            p[i] = x
            pts.append(p)
            owner.append(s)
    evs = problem.evaluate(runner, pts)
    out: dict = {s.name: [] for s in problem.settings}
    for s, p, ev in zip(owner, pts, evs):
        out[s.name].append((ev.settings[s.name], ev))
    return out


__all__ = ["run_scores", "Runner", "Problem", "Search", "initial_sample", "search", "slices"]
