"""Which physical effect is missing?  Try each, fit it, rank, and climb the ladder.

For every effect of the registry that the plant does not have and that can
act on it (``Effect.applicable``), in every place it can act (``location``,
``signal``), fit its parameters (with any free plant parameters: a
space-filling scan of its parameters picks where the local least squares
starts, ``search.py``) and score the fit by the Bayesian information
criterion of the noise-weighted residuals, ``BIC = n ln(RSS/n) + k ln n``,
which charges ``ln n`` per added parameter: an effect that does not explain
more than noise would never wins.  The places of one effect compete on the
evidence of every signal instead (``scoring.signal_evidence``,
``sum_s n_s ln(RSS_s/n_s)``): they keep the slots their BICs earn, best
evidence first, so a location one signal clearly contradicts is not chosen
because another signal's larger misfit dominates the pooled RSS.
The best one is the verdict when it lowers the BIC, its residuals counted as ``n / tau``
independent samples (``scoring.bic_drop``, ``tau`` their correlation time: coloured noise is not
evidence), by more than
``Policy.min_bic_drop`` (10: "very strong" evidence, Kass & Raftery 1995) and the
error by more than ``Policy.min_error_drop``, also with both models' angles reset at the
same window seams (``Policy.accepts``); ``None`` when the model already sits
at the noise floor, or when no candidate explains the residual.

Confounded pairs (Coulomb friction + a bias, a spring + a bias): each alone
explains part of the other's residual, so the best single candidate can be a
third effect that mimics both.  When the best single leaves more than noise
and the ladder has room for two rungs, the ``Policy.pair_top`` best candidates are
refitted in pairs jointly (the best place of each of the ``Policy.pair_top`` best effects, and of
each of them with the effects it is declared confounded with, ``Effect.confounders``, wherever
those rank alone, and with their places on one shaft, ``candidates.pair_jobs``; from the best of
their single fits and a scan of both effects' parameters; ``k`` counts both effects' parameters).
The pair of lowest BIC is taken when it beats both the current model and the best single
candidate by the criterion that adds an
effect (``Policy.accepts``); it then takes two rungs, each with its explanation:
first its member that ranked higher alone (its single fit), then the other
with the joint fit.  Otherwise the best single is added, as before.  When the
first ``Policy.pair_batch`` pairs (the best single with its partners) leave more than
noise and none of them pays, the next rung's screen is made on the best single
before any more pairs: if its best reaches the noise floors, the greedy ladder
does in two rungs what a pair could only tie, and the pairs stop there (a delay
that ranks low alone beside Coulomb friction: 14 pairs fitted for nothing).
The screen is the next rung's, made once, unless a later pair wins.

A plant file's datasheet values are typically 5-20 % off (``calibration``):
"a value is off" competes with "an effect is missing" at every rung until it
wins once.  Calibrating them from the start would let them take up part of
whatever is missing and run to their bounds (the bench rig with a spring and
Coulomb friction hidden: the ladder then took friction at the motor and a shaft
compliance, each taken out later); as a rival step, the calibration comes when
it explains more than the best effect, or after the effects that do.  Stick-slip
makes its residual jump between branches, so a calibration that pays but stops
short of the noise floors is fitted again from the best points of a scan of its
tolerance box (``ladder.calibrate``).

The ladder repeats: add the verdict with its fitted parameters, diagnose
again, until nothing more pays.  It steps both ways: after each rung every
effect an earlier rung added is refitted out, and one that no longer pays by
the same criterion is taken out, as a rung of its own (``action: remove``).
The verdict is the first effect added that is still in the model at the end.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Callable

from ..blas import single_threaded
from ..errors import DiagnosisInterrupted, ReplayError
from ..interrupts import is_interrupt
from ..plant.components import Plant
from . import calibration
from .candidates import check_names, not_tried
from .executor import Executor
from .fit import FitResult, evaluate, fit, plant_frees
from .scoring import Scorer
from .ladder import Context, State, Stop, climb
from .policy import Policy
from .progress import ProgressEvent, Tracker
from .replay import Replay
from .results import Diagnosis, diagnosis


@single_threaded
def diagnose(plant: Plant, replay: Replay, free_plant: tuple[str, ...] = (), max_steps: int = 4,
             workers: int | None = None, progress: Callable[[ProgressEvent], None] | None = None,
             only: tuple[str, ...] = (), calibrate: bool = True, time_limit_s: float | None = None,
             scheduler: str | None = None, policy: Policy | None = None, also: tuple[str, ...] = ()) -> Diagnosis:
    """Diagnose ``plant`` against the replayed record and climb the ladder.

    Each rung fits every candidate with the effects added so far held (cheap),
    then refits the best ``Policy.joint_top`` jointly with them (the first rung's
    friction must give back what a later viscous term explains), accepts the
    best if it pays (``Policy.accepts``), tries the simpler forms of what was added,
    and takes out what no longer pays (``ladder``).

    free_plant: plant parameters refitted with every candidate (and in the
    baseline), e.g. ``("leadscrew.mass",)``; workers: processes (default: all
    usable cores, ``gearbench.workers``); only: restrict the candidates to
    these effect names (a model structure); also: effects tried only on request
    (``Effect.on_request``: LuGre friction, a warming winding) to try as well; calibrate: the plant's own
    datasheet values within their tolerances (``calibration.plan``) may be
    calibrated, once, as a step that competes with each rung's best effect by
    the criterion that adds an effect (``Policy.accepts``; the lower BIC wins), with
    the effects already added refitted; from then on they are refitted with
    every joint refit.  A calibration is not a verdict, and the effects that no
    longer pay once it is in are taken out.  policy: the ladder's tuning
    (:class:`~gearbench.identify.policy.Policy`; None: today's defaults).

    progress: called with a :class:`ProgressEvent` as each stage starts and each fit
    finishes; time_limit_s: no new rung is started once this many seconds have passed
    (the rung that crosses it finishes; ``stopped`` is ``"time limit"``).  Ctrl-C during the
    ladder raises :class:`DiagnosisInterrupted`, which carries the ladder so far.
    scheduler: the address of a running Dask scheduler (``tcp://HOST:PORT``,
    connected once for the whole diagnosis; ``workers`` is then ignored): what
    runs on ``workers`` processes otherwise runs there (``executor``), one task
    per fit, the answer the same as a local run's: each rung's candidate fits,
    the best ``joint_top`` refitted with the effects already added, and the pair
    fits.  The baseline, the calibration plan and step, the simplification and
    the pruning stay in this process.  An unreachable scheduler raises
    :class:`gearbench.workers.SchedulerError` before any fitting.
    """
    check_names(only)
    check_names(also, "also")
    with Executor(workers, scheduler) as where:
        tracker = Tracker(progress)
        replay = replay.metered(tracker.timing)  # what runs here counts to the stage in progress
        scorer = Scorer(replay)
        base = baseline(replay, scorer, plant, free_plant, tracker)
        if calibrate:
            tracker.stage("calibration plan", 1)
        plan = calibration.plan(plant, replay, scorer) if calibrate else calibration.Plan()
        ctx = Context(replay, scorer, plant, plan, policy or Policy(), where, tracker, tuple(free_plant),
                      tuple(only), max_steps, time_limit_s, tuple(also))
        return _climb(ctx, State(base, refitted=tuple(free_plant)), base, not_tried(plant, replay, only, also))


def baseline(replay: Replay, scorer: Scorer, plant: Plant, free_plant, tracker: Tracker) -> FitResult:
    """The plant as given, scored (its ``free_plant`` values fitted); ``ReplayError`` when that fit
    does not converge."""
    tracker.stage("baseline", 1)
    frees = plant_frees(plant, free_plant)
    base = fit(replay, plant, frees, scorer) if frees else evaluate(replay, scorer, plant)
    if not base.converged:
        raise ReplayError(f"the baseline fit of {', '.join(free_plant)} did not converge: {base.message}")
    return base


def _climb(ctx: Context, state: State, base: FitResult, skipped: dict) -> Diagnosis:
    """The diagnosis of the climb from ``state``; on Ctrl-C, :class:`DiagnosisInterrupted` with the
    ladder as far as it got."""
    try:
        for state in climb(ctx, state):
            pass
    except BaseException as exc:
        if not is_interrupt(exc):
            raise
        raise DiagnosisInterrupted(diagnosis(ctx, replace(state, stop=Stop("interrupted")), base, skipped)) from None
    return diagnosis(ctx, state, base, skipped)
