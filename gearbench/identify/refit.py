"""Refit a model: which of its parameters are free, the joint refit, the best of several fits."""
from __future__ import annotations

import math

from ..blas import single_threaded
from ..errors import ReplayError
from ..plant.components import Plant
from .fit import Free, FitResult, evaluate, fit, plant_frees
from .timing import Cost, costed


def frees_of(replay, plant: Plant, free_plant, effects) -> list[Free]:
    """The free plant values ``free_plant`` (paths or ``Free``s), then the parameters of the
    effects numbered in ``effects``."""
    frees = plant_frees(plant, free_plant)
    for j in effects:
        frees += Free.effect(plant, j, replay.data.sample_time_s)
    return frees


def refit(replay, scorer, plant: Plant, free_plant, effects, central: bool = False,
          restarts: int = 0, sharp: bool = True) -> FitResult | None:
    """``plant`` with the free plant values ``free_plant`` (paths or ``Free``s) and the parameters
    of the effects numbered in ``effects`` fitted jointly (scored as it is when there are none);
    None when it cannot be simulated or does not converge.  ``central``, ``restarts``, ``sharp``:
    see :func:`gearbench.identify.fit.fit`."""
    frees = frees_of(replay, plant, free_plant, effects)
    try:
        r = (fit(replay, plant, frees, scorer, central=central, restarts=restarts, sharp=sharp) if frees
             else evaluate(replay, scorer, plant))
    except (ReplayError, ValueError):
        return None
    return r if r.converged else None


def without_resets(replay, scorer, res: FitResult) -> FitResult:
    """``res`` fitted again (its own free values) from its values, its first round holding no
    window resets, where its replay resets at some seam; the new fit where it ends lower by the
    replay's own resets, else ``res``.  Diagnose so fits each rung's model (``ladder``).

    Why: resets at a fit's start can hold it in a false basin.  They hide the drift of values a
    little off, and the values fitted under them drift where they were reset, so the next round
    resets there again.  On ``studies.hidden_effects``' LuGre friction at the rotor the screen's fit
    ended so, at 2.41x the noise floor with 10 of 15 seams reset, its bristles' damping 8 % high;
    started there with no resets, the same fit took 54 replays to the truth's own 1.00x and no reset
    (``tests/test_reset_basin.py``)."""
    if not res.seams or not res.params:
        return res
    try:
        got = fit(replay, res.plant, [p.free for p in res.params.values()], scorer, seams=())
    except (ReplayError, ValueError):
        return res
    return got if got.converged and got.rss < res.rss else res


@single_threaded
def refit_job(job) -> tuple[FitResult | None, Cost]:
    """:func:`refit` of one job tuple ``(replay, scorer, plant, free_plant, effects)`` (what an
    :class:`~gearbench.identify.executor.Executor` maps), forward differences, the standard errors
    not sharpened; with what it cost where it ran."""
    replay, scorer, plant, free_plant, effects = job
    return costed(refit, replay, scorer, plant, free_plant, effects, sharp=False)


AT_FLOORS = 1.0
"""A multi-start (:func:`best_of`) ends at a fit whose weighted RMS is at most this: the record
explained down to its noise floors, another basin could only fit the noise.  On practice case p01
the second start of the Stribeck friction that explains the record (0.977x) took 79 least-squares
residuals, and more replays for their finite differences, to end 0.003 lower in an RSS of 46,117
(measured on the code before this rule, 2026-11-30)."""


def best_of(starts, fit_from, enough: int | None = None) -> tuple[FitResult, list]:
    """:func:`best_fit` of ``fit_from(x)`` for each of ``starts`` in order, and the starts left
    unfitted: none after the first fit that reaches the noise floors (:data:`AT_FLOORS`); with
    ``enough``, the rest once that many are fitted and one of them converged (the ladder's screen
    and pairs fit the others' later, where the candidate or pair ranks high enough:
    ``ladder.screen``, ``ladder.fit_pairs``)."""
    results = []
    for i, x in enumerate(starts):
        results.append(fit_from(x))
        if results[-1].converged and results[-1].weighted_rms <= AT_FLOORS:
            return best_fit(results), []
        if enough is not None and i + 1 >= enough and any(r.converged for r in results):
            return best_fit(results), list(starts[i + 1:])
    return best_fit(results), []


def out_of_reach(lead: FitResult | None, k: int) -> bool:
    """Whether no fit of ``k`` values can rank above ``lead`` by the BIC (``n ln(RSS/n) + k ln n``):
    ``lead`` converged at the noise floors (weighted RMS at most :data:`AT_FLOORS`) and fits no
    more values than ``k``.  Below the floors only the noise is left to fit, which lowers the RSS
    by about one per value fitted, where the BIC charges ``ln n`` per value (10.8 for the 48,333
    samples of p01's three signals, 16 s at 1 kHz); so a fit of as many values or more could at
    best tie on the noise.  Like :func:`best_of`'s stop, this takes the floors for the noise's level.

    Diagnose fits no second start of a candidate (or pair) out of a leader's reach, refits no such
    candidate with the model's effects, and tries no calibration of as many values
    (``ladder.screen``, ``ladder._second_starts``, ``ladder._calibration``).  On practice case p01
    the Stribeck friction at the load came in at 0.977x the floors with 3 values (BIC -2,237); the
    second start of the Stribeck friction at the motor (BIC 414,907, 111 replays) and a calibration
    of six datasheet values (210 replays) were fitted for nothing (Coulomb friction, one value, still
    gets its second start)."""
    return lead is not None and lead.converged and lead.weighted_rms <= AT_FLOORS and k >= lead.k


def best_fit(results: list[FitResult]) -> FitResult:
    """The converged fit of lowest RSS (the first, failed, when none converged)."""
    ok = [r for r in results if r.converged and math.isfinite(r.rss)]
    return min(ok, key=lambda r: r.rss) if ok else results[0]
