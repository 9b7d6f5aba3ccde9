"""One tuning, start to end: the checked entry point :func:`tune` (``gb.tune``), the plants, a
search per compensator, the slices, the untuned run."""
from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..control.controllers import COMPENSATORS, Controller
from ..errors import ConfigError
from ..plant.components import Plant
from ..profiles import Profile, load_profile
from ..schema import show
from ..simulate import SolverOptions
from .draws import Uncertainty, draw_plants
from .objective import OBJECTIVES, ROBUST, parse_limits
from .result import TuneResult, Tuned
from .search import Problem, Runner, search, slices
from .space import TUNED, space


def tune_plant(plant: Plant, kind: str, profile: Profile, *, compensators: Sequence[str] = ("none",),
               objective: str = "iae", limits: Mapping[str, float] | None = None, robust: int = 0,
               robust_stat: str = "mean", uncertainty: Uncertainty | None = None, use_tolerances: bool = True,
               ranges: Mapping | None = None, baseline: Controller | None = None, duration_s: float | None = None,
               solver: SolverOptions = SolverOptions(), workers: int | None = 1, scheduler: str | None = None,
               seed: int = 0, plant_path: str | None = None, profile_ref: str | None = None,
               progress: Callable[[str], None] | None = None) -> TuneResult:
    """Tune ``kind`` with each of ``compensators`` on ``plant`` following ``profile``
    (arguments as :func:`gearbench.tune`'s, already checked)."""
    t0 = time.perf_counter()
    t_end = float(profile.duration_s if duration_s is None else duration_s)
    plants = (tuple(draw_plants(plant, robust, uncertainty=uncertainty, use_tolerances=use_tolerances, seed=seed))
              if robust else (plant,))
    # traces are not kept: a coarse output grid (the scores are integrated by the solver, not from it)
    opts = SolverOptions(solver.method, solver.rtol, solver.max_step_s, solver.max_steps, t_end / 10,
                         solver.friction_speed_rel)
    limits = dict(limits or {})
    tuned = []
    with Runner(workers, scheduler) as runner:
        for comp in compensators:
            problem = Problem(kind, comp, space(kind, comp, plant.resolved().gear.backlash_deg, ranges), plants,
                              profile.segments(), t_end, opts, objective, robust_stat, limits)
            found = search(problem, runner, seed=seed, progress=progress)
            i = found.best_index
            u = found.points[i]
            ctrl = problem.controller(u)
            nominal = problem.with_plants([plant]).evaluate(runner, [u])[0] if robust else found.history[i]
            tuned.append(Tuned(comp, ctrl, found.history[i], nominal, slices(problem, runner, np.array(u)),
                               len(found.history)))
        base = baseline or default_baseline(kind)
        named = space(base.kind, base.compensator, plant.resolved().gear.backlash_deg) if base.kind in TUNED else ()
        base_ev = Problem(base.kind, base.compensator, named, plants, profile.segments(), t_end, opts, objective,
                          robust_stat, limits).evaluate(runner, [], controllers=[base])[0]
        runs = runner.runs
    return TuneResult(plant, plant_path, profile_ref or profile.name, t_end, solver, kind, objective, robust_stat,
                      limits, tuned, base, base_ev, len(plants), runs, time.perf_counter() - t0,
                      profile_object=profile_ref is None)


def default_baseline(kind: str) -> Controller:
    """The untuned controller a tuning is compared with: the thesis's Table I gains
    (Kp = 50 V/deg; Ki = 0.005 1/s for PI and PID; Kd = 0), no compensator."""
    return Controller(kind, kp=50.0, **({"ki": 0.005} if kind in ("pi", "pid") else {}))


def tune(plant: Plant | str | Path | Mapping, controller: str = "pi", *, profile: Profile | str | Path = "profile1",
         compensator: str | Sequence[str] = "none", objective: str = "iae",
         limits: Mapping[str, float] | str | None = None, robust: int = 0, robust_stat: str = "mean",
         uncertainty: Any = None, tolerances: bool = True, ranges: Mapping[str, Sequence[float]] | None = None,
         baseline: Controller | Mapping | None = None, duration_s: float | None = None,
         solver: SolverOptions | Mapping | None = None, workers: int | None = 1, scheduler: str | None = None,
         seed: int = 0, progress: Callable[[str], None] | None = None) -> TuneResult:
    """Tune a controller's gains (and a compensator's shift) on a plant, within limits.

    For each compensator, a scrambled Sobol sample of the settings is solved, then the best
    points are polished with bounded Nelder-Mead (``gearbench.tuning.search``); gains are
    searched on a log scale.  Every candidate is the same compiled run ``gearbench run``
    makes, so :meth:`TuneResult.experiment_yaml` reproduces the tuned run exactly.

    Parameters
    ----------
    plant : Plant, str, Path or Mapping
        The plant (file, mapping or object), e.g. the one ``gearbench fit -o`` wrote.
    controller : {"p", "pi", "pid"}
        The law tuned: Kp (V/deg), and Ki (1/s), Kd (s) as in the experiment files.
    profile : Profile, str or Path
        The set point: ``profile1``...``profile3`` (the thesis's) or a profile file.
    compensator : str or sequence of str
        Backlash compensator(s) (``gearbench.control.controllers.COMPENSATORS``), each tuned
        in turn; any but ``none`` also tunes its shift ``shift_deg`` (0 to the clearance).
    objective : {"iae", "rms", "max"}
        Integrated absolute output error (deg s), its RMS (deg) or the largest error (deg).
    limits : Mapping or str, optional
        Upper bounds on each run, e.g. ``{"voltage_sign_changes": 20, "saturated_fraction": 0.1}``
        or the CLI's ``"voltage_sign_changes=20,saturated_fraction=0.1"``
        (``gearbench.tuning.objective.LIMITS``).  Robust: they hold on every drawn plant.
    robust : int
        0: tune on ``plant``.  N > 0: judge each candidate on N plants drawn from
        ``uncertainty`` and the datasheet tolerances (``gearbench.tuning.draws``), the same N
        for every candidate, and minimise ``robust_stat`` of the objective over them.
    robust_stat : {"mean", "p90", "max"}
        The robust objective: the mean, the 90th percentile or the worst over the plants.
    uncertainty : FitReport or Mapping, optional
        What the fit left uncertain: a :class:`gearbench.FitReport` or ``gearbench fit --json``'s
        object (``values``, ``stderr``, ``correlation``); its names must be values of ``plant``.
    tolerances : bool
        With ``robust``, also draw the datasheet values the fit did not estimate within their
        tolerances (the plant file's ``tolerance_pct``, else the datasheet default).
    ranges : Mapping, optional
        Search bounds ``{"kp": (low, high), ...}`` in each setting's unit
        (default ``gearbench.tuning.space.DEFAULT_RANGES``; ``shift_deg`` 0 to the clearance).
    baseline : Controller or Mapping, optional
        The untuned controller compared with (default: the thesis's Kp = 50 V/deg,
        Ki = 0.005 1/s, no compensator).
    duration_s : float, optional
        Simulated time, s (default the profile's).
    solver : SolverOptions or Mapping, optional
        Solver settings, as :func:`gearbench.simulate`'s.
    workers : int or None
        Local processes (None: all cores).  Ignored with ``scheduler``.
    scheduler : str, optional
        A running Dask scheduler (``tcp://HOST:PORT``) to solve the runs on.
    seed : int
        Seed of the Sobol sample and of the drawn plants.
    progress : callable, optional
        Called with a line of text as each compensator's sample and polish end.

    Returns
    -------
    TuneResult
        ``controller`` (the best), ``tuned`` (per compensator: settings, objective, limits,
        spread over the plants, slices), ``baseline``; ``to_dict()``, ``to_markdown()``,
        ``experiment_yaml(folder)``.

    Raises
    ------
    ConfigError
        Naming every bad argument and its unit, before anything is solved.

    Examples
    --------
    >>> import gearbench as gb
    >>> r = gb.tune("experiments/plants/thesis_gear.yaml", "p", profile="profile1",
    ...             limits={"voltage_sign_changes": 20})
    >>> r.controller.kind, r.best.best.feasible, r.best.best.objective < r.baseline.objective
    ('p', True, True)
    """
    from ..api import _as_controller, _as_plant, _as_solver
    where = "tune"
    plant_path = str(Path(plant).resolve()) if isinstance(plant, (str, Path)) else None
    plant = _as_plant(plant, where)
    options = _as_solver(solver, where)
    problems: list[str] = []
    if objective not in OBJECTIVES:
        problems.append(f"objective must be one of {', '.join(OBJECTIVES)}, got {show(objective)}")
    if robust_stat not in ROBUST:
        problems.append(f"robust_stat must be one of {', '.join(ROBUST)}, got {show(robust_stat)}")
    if not isinstance(robust, int) or isinstance(robust, bool) or robust < 0:
        problems.append(f"robust must be a whole number of plants >= 0, got {show(robust)}")
    comps = (compensator,) if isinstance(compensator, str) else tuple(compensator)
    bad = [c for c in comps if c not in COMPENSATORS]
    if bad or not comps:
        problems.append(f"compensator must be one or more of {', '.join(COMPENSATORS)}, got {show(compensator)}")
    if uncertainty is not None and not robust:
        problems.append("uncertainty is used by robust tuning only: give robust=N (plants drawn) too")
    if duration_s is not None and (not isinstance(duration_s, (int, float)) or not duration_s > 0):
        problems.append(f"duration_s must be a positive number in s, got {show(duration_s)}")
    if problems:
        raise ConfigError(where, problems)
    lim = parse_limits(limits)
    unc = Uncertainty.of(uncertainty) if uncertainty is not None else None
    for comp in comps:  # the ranges and kind are checked before anything is solved
        space(controller, comp, plant.resolved().gear.backlash_deg, ranges)
    base = _as_controller(baseline, where) if baseline is not None else None
    prof = profile if isinstance(profile, Profile) else load_profile(profile)
    ref = None if isinstance(profile, Profile) else (
        profile if isinstance(profile, str) and not Path(profile).suffix else str(Path(profile).resolve()))
    return tune_plant(plant, controller, prof, compensators=comps, objective=objective, limits=lim, robust=robust,
                      robust_stat=robust_stat, uncertainty=unc, use_tolerances=tolerances, ranges=ranges,
                      baseline=base, duration_s=duration_s, solver=options, workers=workers, scheduler=scheduler,
                      seed=seed, plant_path=plant_path, profile_ref=ref, progress=progress)


__all__ = ["tune", "tune_plant", "default_baseline"]
