"""The ladder: an immutable sequence of rungs, climbed one step function at a time.

A :class:`State` is the model so far, the rungs that made it and what the climb carries from one
rung to the next; :func:`climb` yields a new state after every change (a screen, the calibration,
each rung added, each effect taken out), so whoever drives it holds the ladder as far as it got
when Ctrl-C comes.  Nothing is edited in place: a removal is a new rung, and a simplification is a
note on the rung that made it (:class:`Simplified`), which the explanation applies to the rung it
names (``explain``).  Every decision asks the :class:`~gearbench.identify.policy.Policy`; no
sentence is written here.

One rung (:func:`_rung`): screen the candidates with the model's effects held, refit the best
``joint_top`` with them (:func:`screen`); let the calibration of the datasheet values compete
(:func:`_calibration`); accept the best if it pays, fitted again without the resets that can hold
it beside its optimum (:func:`_settled`), or a pair fitted jointly that beats it (:func:`_pairs`),
so fitted again too; simplify what was added (:func:`_simplify`); take out what no longer pays
(:func:`_prune`).
"""
from __future__ import annotations

from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, field, replace
from functools import cache
from typing import Iterator

import numpy as np

from ..plant.components import Plant
from ..plant.effects import AddedEffect
from . import calibration, search
from .candidates import (Pair, Trial, Tried, as_tried, candidates, fit_each, fit_each_later, fit_pairs_later,
                         pair_jobs, rank, run_jobs, run_pair)
from .executor import Executor
from .fit import FitResult, Free, get_value, plant_frees, sharpen
from .numerics import refine
from .scoring import Scorer, bic_drop
from .timing import Cost
from .policy import Policy
from .progress import Tracker
from .refit import best_fit, frees_of, out_of_reach, refit, refit_job, without_resets
from .replay import Replay
from .uncertainty import strong_correlations


@dataclass(frozen=True)
class Context:
    """What a climb does not change: the record and its scorer, the user's plant and choices, the
    policy, where the fits run and the clock."""
    replay: Replay
    scorer: Scorer
    plant: Plant                  # the user's plant: its own effects are not the ladder's
    plan: calibration.Plan        # what a calibration of the datasheet values moves
    policy: Policy
    workers: Executor
    tracker: Tracker
    free_plant: tuple = ()
    only: tuple[str, ...] = ()
    max_steps: int = 4
    time_limit_s: float | None = None
    also: tuple[str, ...] = ()  # effects tried only on request, asked for

    def added(self, plant: Plant) -> tuple[int, ...]:
        """The numbers of ``plant``'s effects that the ladder added."""
        return tuple(range(len(self.plant.effects), len(plant.effects)))


@dataclass(frozen=True)
class Simplified:
    """An effect of the model replaced by its simpler form (``Effect.simpler``) at a rung:
    the rung that had added it (``rung``, its number in the ladder from 0), the names before and
    after, the BIC gain and the simpler form's values."""
    rung: int
    old: str
    new: str
    gain: float
    params: dict


@dataclass(frozen=True)
class Joint:
    """A rung that came as one of a pair fitted jointly: the pair, the best single candidate it
    beat, how many pairs were left unfitted, and whether this is its ``first`` member's rung."""
    pair: Pair
    best: Tried
    unfitted: int
    first: bool


@dataclass(frozen=True)
class Rung:
    """One rung: an effect added (``action`` "add") or taken out ("remove"), the model after it
    (``result``, its effects as in a plant file ``model`` and its free plant values
    ``plant_params``), and what its explanation is written from: the model it was judged
    against (``before``), the candidate (``best``) among the screen (``tried``), the pair it
    came in (``joint``), what it simplified, and what came in before a removal (``after``)."""
    action: str
    effect: str
    options: dict
    params: dict
    stderr: dict
    result: FitResult
    model: list
    plant_params: dict
    before: FitResult
    best: Tried | None = None
    tried: tuple = ()
    joint: Joint | None = None
    simplified: tuple[Simplified, ...] = ()
    after: str = ""
    correlations: list = field(default_factory=list)


@dataclass(frozen=True)
class CalibrationStep:
    """The plant's datasheet values calibrated (``calibration.plan``'s), after ``after`` ladder
    steps: the model before and after."""
    after: int
    before: FitResult
    result: FitResult


@dataclass(frozen=True)
class Ahead:
    """The next rung's screen, made during a rung's pair stage (:func:`_pairs`): ``fitted`` is the
    model with the rung's best candidate added alone and simplified (``notes``), ``tried`` the
    candidates ranked on it; ``reaches``: its best pays and reaches the noise floors."""
    fitted: FitResult
    notes: tuple
    tried: tuple
    reaches: bool


@dataclass(frozen=True)
class Stop:
    """Why the climb ended (``why``: one of ``results.STOPPED``) and what its sentence needs:
    ``judged`` whether a screen's best was judged (else the ladder stopped before a screen),
    ``best`` that candidate (None: there was none to fit), ``screened`` whether there were any to
    try, ``elapsed_s`` the clock then."""
    why: str
    judged: bool = False
    best: Tried | None = None
    screened: bool = True
    elapsed_s: float = 0.0


@dataclass(frozen=True)
class State:
    """The ladder so far: the model (``model``, a fit of the plant with the effects added), the
    rungs, the rung that added each effect of the model past the plant's own (``owners``), the
    calibration, the plant values refitted with every joint refit (``refitted``), the first
    rung's screen, the next rung's screen when it was made ahead, the steps taken (a pair is
    one), and the stop once there is one."""
    model: FitResult
    rungs: tuple[Rung, ...] = ()
    owners: tuple[int, ...] = ()
    calibration: CalibrationStep | None = None
    refitted: tuple = ()
    first_tried: tuple = ()
    ahead: Ahead | None = None
    steps: int = 0
    stop: Stop | None = None
    uncalibrated: str = ""  # why the datasheet values were not calibrated, where it was not tried


def climb(ctx: Context, state: State) -> Iterator[State]:
    """Every state of the climb from ``state``, the last with its :class:`Stop`."""
    while state.stop is None:
        for state in _rung(ctx, state):
            yield state


def _stop_before(ctx: Context, state: State) -> Stop | None:
    """A stop before the next rung: the longest ladder, the noise floors reached, the time limit."""
    if state.steps >= ctx.max_steps:
        return Stop("max steps")
    if (state.rungs or state.calibration) and ctx.policy.explained(state.model):
        return Stop("noise floor")
    elapsed = ctx.tracker.elapsed_s
    if ctx.time_limit_s is not None and (state.rungs or state.calibration) and elapsed > ctx.time_limit_s:
        return Stop("time limit", elapsed_s=elapsed)
    return None


def _rung(ctx: Context, state: State) -> Iterator[State]:
    """One step of the climb: its states, as :func:`climb`'s."""
    stop = _stop_before(ctx, state)
    if stop is not None:
        yield replace(state, stop=stop)
        return
    number, added = len(state.rungs) + 1, ctx.added(state.model.plant)
    ahead = state.ahead
    tried = ahead.tried if ahead is not None and ahead.fitted is state.model else tuple(
        screen(ctx, state.model, state.refitted, number))
    state = replace(state, ahead=None, first_tried=state.first_tried or tried)
    yield state
    best = tried[0] if tried and tried[0].ok else None
    if ctx.plan.frees and state.calibration is None:
        state, calibrated = _calibration(ctx, state, best, added, number)
        if calibrated is not None:  # not a rung: the effects are tried again on the calibrated plant
            yield calibrated
            pruned = calibrated
            for pruned in _prune(ctx, calibrated, "the calibration", number):
                yield pruned
            if pruned is not calibrated:  # made with effects now out: along the valley again
                again = _along_the_valley(ctx, pruned, number)
                if again is not None:
                    yield again
            return
    if best is None or not ctx.policy.accepts(ctx.scorer, state.model, best.result):
        yield replace(state, stop=Stop("noise floor" if ctx.policy.explained(state.model) else "nothing pays",
                                       True, best, bool(tried)))
        return
    best = _settled(ctx, best, number)
    pair, unfitted, ahead = (_pairs(ctx, state, best, tried, added, number)
                             if len(state.rungs) + 2 <= ctx.max_steps else (None, 0, None))
    if pair is not None:
        pair = replace(pair, result=_unreset(ctx, pair.result, number))
    ctx.tracker.stage("simplify", number)
    state = (_add(ctx, state, best, tried, ahead) if pair is None
             else _add_pair(ctx, state, Joint(pair, best, unfitted, True), tried, added))
    yield state
    after = (best if pair is None else pair.second).candidate.label()
    for state in _prune(ctx, state, after, number):
        yield state
    yield replace(state, steps=state.steps + 1, ahead=ahead)


def screen(ctx: Context, res: FitResult, refitted: tuple, number: int) -> list[Tried]:
    """A rung's candidates ranked: each fitted with the model's effects and calibrated values held
    (cheap) from the best start of its scan, the best ``second_top`` from their second starts too
    (:class:`~gearbench.identify.policy.Policy`), then the best ``joint_top`` refitted with the
    model's effects; neither for a candidate out of the leader's reach
    (:func:`~gearbench.identify.refit.out_of_reach`: the leader at the noise floors, and as many
    fitted values or more)."""
    model = res.plant
    added = ctx.added(model)
    cands = candidates(model, ctx.replay, ctx.only, ctx.also)
    how = Trial(free_plant=ctx.free_plant, rounds_below=res.rss, starts=1)
    tried = rank(fit_each(ctx.replay, ctx.scorer, model, cands, ctx.workers,
                          ctx.tracker.stage("candidates", number, len(cands)), how))
    lead = _lead(tried)
    top = [t for t in tried[:ctx.policy.second_top] if t.later and not out_of_reach(lead, t.result.k)]
    if top:
        again = fit_each_later(ctx.replay, ctx.scorer, model, top, ctx.workers,
                               ctx.tracker.stage("second starts", number, len(top)), how)
        tried = rank(again + [t for t in tried if all(t is not u for u in top)])
    if added:
        lead = _lead(tried)
        top = [t for i, t in enumerate(tried[:ctx.policy.joint_top])
               if t.ok and (i == 0 or not out_of_reach(lead, t.result.k))]
        starts = [(t.candidate, {**t.candidate.options, **t.params}) for t in top]
        joint = fit_each(ctx.replay, ctx.scorer, model, starts, ctx.workers,
                         ctx.tracker.stage("joint refit", number, len(top)), Trial(free_plant=refitted, refit=added))
        tried = rank(joint + [t for t in tried if all(t is not u for u in top)])
    return tried


def _lead(tried: list[Tried]) -> FitResult | None:
    """The fit of a ranked screen's first candidate, None where it failed."""
    return tried[0].result if tried and tried[0].ok else None


def _model(plant: Plant, free_plant) -> tuple[list, dict]:
    """A rung's ``model`` (effects as in a plant file) and ``plant_params`` (the free plant values)."""
    return [e.to_dict() for e in plant.effects], {f.name: get_value(plant, f) for f in plant_frees(plant, free_plant)}


def correlated(res: FitResult) -> list[dict]:
    """``[{a, b, rho}]``: the fit's pairs of estimates correlated beyond ``STRONG_CORRELATION``."""
    return [{"a": a, "b": b, "rho": rho} for a, b, rho in strong_correlations(res.correlation)]


def _added_rung(state: State, t: Tried, result: FitResult, before: FitResult, **why) -> Rung:
    """The rung that adds candidate ``t``; ``result`` the model after it."""
    return Rung("add", t.candidate.name, t.candidate.options, t.params, t.stderr, result,
                *_model(result.plant, state.refitted), before, t, correlations=correlated(t.result), **why)


def _with_rung(state: State, rung: Rung, model: FitResult | None = None) -> State:
    """``state`` with ``rung`` added; with ``model``, its effect the model's last."""
    owners = state.owners + (len(state.rungs),) if rung.action == "add" else state.owners
    return replace(state, rungs=state.rungs + (rung,), owners=owners, model=model or state.model)


def _simplified(ctx: Context, state: State, fitted: FitResult, notes) -> tuple[Simplified, ...]:
    """``_simplify``'s notes as :class:`Simplified` records, each naming the rung that added it."""
    first = len(ctx.plant.effects)
    return tuple(Simplified(state.owners[i - first], old, new, gain,
                            {k: v for k, v in fitted.plant.effects[i].values.items() if not isinstance(v, str)})
                 for i, old, new, gain in notes)


def _add(ctx: Context, state: State, best: Tried, tried, ahead: Ahead | None) -> State:
    """``state`` with the rung that adds ``best`` alone (simplified; the look-ahead's fit when it
    was made, ``ahead``)."""
    fitted, notes = (ahead.fitted, ahead.notes) if ahead is not None else _alone(ctx, state, best)
    rung = _added_rung(state, best, fitted, state.model, tried=tuple(tried))
    state = _with_rung(state, rung, fitted)
    return _with_notes(ctx, state, fitted, notes)


def _with_notes(ctx: Context, state: State, fitted: FitResult, notes) -> State:
    """``state`` whose last rung carries ``notes`` of the simplification that gave ``fitted``."""
    if not notes:
        return state
    last = replace(state.rungs[-1], simplified=_simplified(ctx, state, fitted, notes))
    return replace(state, rungs=state.rungs[:-1] + (last,))


def _add_pair(ctx: Context, state: State, joint: Joint, tried, added: tuple[int, ...]) -> State:
    """``state`` with the two rungs of ``joint``'s pair: its first member (its single fit), then
    the second with the joint fit, simplified."""
    pair = joint.pair
    first, second = pair.first, pair.as_second()
    state = _with_rung(state, _added_rung(state, first, first.result, state.model, tried=tuple(tried), joint=joint))
    n = len(state.model.plant.effects)
    fitted, notes = _simplify(ctx, pair.result, added + (n, n + 1), state.refitted)
    state = _with_rung(state, _added_rung(state, second, fitted, first.result, joint=replace(joint, first=False)),
                       fitted)
    return _with_notes(ctx, state, fitted, notes)


def _alone(ctx: Context, state: State, best: Tried) -> tuple[FitResult, list]:
    """The model with ``best`` added alone, simplified (:func:`_simplify`: the result and its notes)."""
    added = ctx.added(state.model.plant) + (len(state.model.plant.effects),)
    return _simplify(ctx, best.result, added, state.refitted)


def _unreset(ctx: Context, res: FitResult, number: int) -> FitResult:
    """:func:`~gearbench.identify.refit.without_resets` of ``res`` (a stage of step ``number`` where
    its replay resets at some seam)."""
    if not res.seams:
        return res
    ctx.tracker.stage("without resets", number)
    return without_resets(ctx.replay, ctx.scorer, res)


def _settled(ctx: Context, best: Tried, number: int) -> Tried:
    """``best`` (the candidate a rung adds) with its fit :func:`_unreset`."""
    got = _unreset(ctx, best.result, number)
    if got is best.result:
        return best
    fresh = as_tried(best.candidate, got)
    return replace(best, result=got, params=fresh.params, stderr=fresh.stderr)


def _look_ahead(ctx: Context, state: State, best: Tried, number: int) -> Ahead:
    """The next rung's screen (step ``number``) on the model with ``best`` alone (simplified); its
    stages' time is theirs, the pairs' goes on after it (``Timing.nested``)."""
    with ctx.tracker.timing.nested():
        fitted, notes = _alone(ctx, state, best)
        tried = tuple(screen(ctx, fitted, state.refitted, number))
    nxt = tried[0] if tried and tried[0].ok else None
    reaches = (nxt is not None and ctx.policy.explained(nxt.result)
               and ctx.policy.accepts(ctx.scorer, fitted, nxt.result))
    return Ahead(fitted, tuple(notes), tried, reaches)


def fit_pairs(jobs: list, policy: Policy, workers: Executor, progress, ahead,
              again=lambda n: nullcontext()) -> tuple[list[Pair], Ahead | None]:
    """The pairs of ``jobs`` (:func:`~gearbench.identify.candidates.pair_jobs`) fitted jointly,
    ``policy.pair_batch`` at a time, until a batch ends with a pair within ``at_noise`` of the noise
    floors.  Past the noise floors another pair could only tie on the error, and the pairs come in
    the order of their members' ranks.  What this gives up: a later pair at the floors with fewer
    parameters, which the BIC would prefer by ln n per parameter; the simplification recovers it
    where it is the simpler form of the same effect (Coulomb for Stribeck friction).  The batches
    are fixed (not the workers' count), so the answer does not depend on how many ran.

    Each pair is fitted from its scan's best start; after each batch, the ``policy.second_top``
    best of the pairs fitted so far (by BIC) are fitted from their second starts too
    (:func:`_second_starts`; ``again(n)``: a context giving the progress callback of those ``n``).

    ``ahead(batch)``: called once with the first batch, when more remain and none of it reached
    the floors; it returns the next rung's screen (:class:`Ahead`, or None when it was not made),
    which ends the pairs when it ``reaches`` the floors.  Returns the pairs fitted and the screen."""
    out: list[Pair] = []
    looked = None
    for start in range(0, len(jobs), policy.pair_batch):
        out += run_jobs(run_pair, [job + ((), 1) for job in jobs[start:start + policy.pair_batch]], workers, progress)
        out = _second_starts(jobs, out, policy, workers, again)
        if any(p.ok and policy.explained(p.result) for p in out):
            break
        if start == 0 and len(jobs) > policy.pair_batch:
            looked = ahead(out)
            if looked is not None and looked.reaches:
                break
    return out, looked


def _second_starts(jobs: list, pairs: list[Pair], policy: Policy, workers: Executor, again) -> list[Pair]:
    """``pairs`` (of the first of ``jobs``, in order) with the ``policy.second_top`` best by BIC that
    have starts left (``Pair.later``) fitted from them too, each keeping the better fit.

    Why: of the 34 pairs fitted from two starts in diagnoses of practice cases p02, p04 and p05
    (the code before, every start fitted; logged 2026-12-01), 14 ended lower from the second, 2
    by more than 1e-3 of the RSS.  One of them decided the stage: p05's Stribeck friction with
    viscous friction at the load, second after its first start (RSS 78,756), first after its
    second (75,284); the others stayed losers or won anyway.  A pair ranked below the best few
    keeps its first fit, as the screen's candidates do (:func:`screen`), and so does a pair out of
    the best one's reach (:func:`~gearbench.identify.refit.out_of_reach`).  A pair's rank among
    those fitted so far only falls as later batches come, so its batch decides for good."""
    best = sorted((p for p in pairs if p.ok), key=lambda p: p.result.bic)[:policy.second_top]
    top = [i for i, p in enumerate(pairs) if p.later and any(p is b for b in best)
           and not out_of_reach(best[0].result, p.result.k)]
    if not top:
        return pairs
    with again(len(top)) as progress:
        redone = dict(zip(top, fit_pairs_later([jobs[i] for i in top], [pairs[i] for i in top], workers, progress)))
    return [redone.get(i, p) for i, p in enumerate(pairs)]


def _pairs(ctx: Context, state: State, best: Tried, tried, added: tuple[int, ...],
           number: int) -> tuple[Pair | None, int, Ahead | None]:
    """The pair of lowest BIC when it beats both the current model and the best single candidate
    by ``Policy.accepts`` (else None: none does, or the best single already explains the record
    down to its noise, nothing left for a pair to resolve), how many pairs were left unfitted, and
    the next rung's screen on the best single alone when it was made: when none of the first batch
    pays.  If that screen's best is at the floors, the greedy ladder reaches them in two rungs
    where no pair is, and the pairs end there with none (a delay that ranks low alone beside
    Coulomb friction: 14 pairs fitted for nothing)."""
    policy, model = ctx.policy, state.model
    if policy.explained(best.result) or policy.explained(model):
        return None, 0, None

    def pays(p: Pair) -> bool:
        return p.ok and policy.accepts(ctx.scorer, model, p.result) and policy.accepts(ctx.scorer, best.result, p.result)

    @contextmanager
    def again(n: int):
        with ctx.tracker.timing.nested():
            yield ctx.tracker.stage("pair second starts", number, n)
    jobs = pair_jobs(ctx.replay, ctx.scorer, model.plant, tried, state.refitted, added, policy.pair_top)
    fitted, ahead = fit_pairs(jobs, policy, ctx.workers, ctx.tracker.stage("pairs", number, len(jobs)),
                              lambda batch: None if any(pays(p) for p in batch) else
                              _look_ahead(ctx, state, best, number + 1), again)
    unfitted = len(jobs) - len(fitted)
    pairs = [p for p in fitted if p.ok]
    if not pairs or (ahead is not None and ahead.reaches):
        return None, unfitted, ahead
    pair = min(pairs, key=lambda p: p.result.bic)
    return (pair if pays(pair) else None), unfitted, ahead


def _simplify(ctx: Context, res: FitResult, added: tuple[int, ...], free_plant) -> tuple[FitResult, list]:
    """Replace each added effect by its simpler form (``Effect.simpler``: Stribeck
    by Coulomb, asymmetric by symmetric friction) when, refitted with the others,
    the BIC says the extra parameters do not pay.  Returns the result and notes
    ``(effect number, old name, new name, BIC gain)``."""
    notes = []
    for i in added:
        e = res.plant.effects[i]
        simpler = e.effect.simpler(e.values)
        if simpler is None:
            continue
        effects = list(res.plant.effects)
        effects[i] = AddedEffect(*simpler)
        r = refit(ctx.replay, ctx.scorer, replace(res.plant, effects=tuple(effects)), free_plant, added)
        if r is not None and r.bic <= res.bic:
            notes.append((i, e.name, simpler[0], res.bic - r.bic))
            res = r
    return res, notes


def _calibration(ctx: Context, state: State, best: Tried | None, added: tuple[int, ...],
                 number: int) -> tuple[State, State | None]:
    """``state``, and ``state`` calibrated when the calibration pays (``Policy.accepts``) and
    explains more than the best candidate (it pays no less: the lower BIC wins), else None.

    Not tried where the best candidate pays and the calibration's values are out of its reach
    (:func:`~gearbench.identify.refit.out_of_reach`: it is at the noise floors and fits no more
    values); ``state`` then says so (``State.uncalibrated``)."""
    model, accepts = state.model, ctx.policy.accepts
    k = len(frees_of(ctx.replay, model.plant, tuple(state.refitted) + tuple(ctx.plan.frees), added))
    if best is not None and out_of_reach(best.result, k) and accepts(ctx.scorer, model, best.result):
        return replace(state, uncalibrated=(
            f"kept: {best.label()} explains the record down to its noise floors with {best.result.k} fitted "
            f"value{'s' * (best.result.k != 1)}, and a calibration of {k} could not rank above it by the "
            "criterion, so it was not tried")), None
    ctx.tracker.stage("calibration", number)
    state = replace(state, uncalibrated="")
    cal = calibrate(ctx, model, state.refitted, added)
    if cal is None or not accepts(ctx.scorer, model, cal) or not (
            best is None or not accepts(ctx.scorer, model, best.result) or cal.bic <= best.result.bic):
        return state, None
    cal = sharpen(ctx.replay, ctx.scorer, cal)
    return state, replace(state, model=cal, calibration=CalibrationStep(len(state.rungs), model, cal),
                          refitted=state.refitted + tuple(ctx.plan.frees))


def _along_the_valley(ctx: Context, state: State, number: int) -> State | None:
    """``state`` (its last rung a removal after the calibration) with its calibrated values fitted
    again from the best point of the valley of one reflected inertia (``calibration.split_points``),
    when that point is not the model's own and the fit from it ends lower; else None.

    Why: the calibration was made with an effect in the model that then came out (a viscous
    friction standing in for the wrong values), and the values refitted locally without it stay in
    the basin that effect led them to.  On practice record p08 that basin keeps the reflected
    inertia and splits it wrong (rotor +2.8 %, load -4.8 %, the current at 11x its noise floor),
    and a shaft compliance came in for what it left (``docs/diagnose.md``)."""
    model = state.model
    if ctx.policy.explained(model):
        return None
    frees = frees_of(ctx.replay, model.plant, state.refitted, ctx.added(model.plant))
    split = calibration.split_points(frees, [get_value(model.plant, f) for f in frees], model.plant.gear.ratio)
    if not split:
        return None
    ctx.tracker.stage("calibration", number)
    ranked = search.scan_on(ctx.workers, ctx.replay, ctx.scorer, model.plant, frees, split,
                            ctx.tracker.timing.add_here)
    if not ranked or np.array_equal(ranked[0][1], split[0]):
        return None
    got, spent = calibration.fit_from((ctx.replay, ctx.scorer, model.plant, frees, list(ranked[0][1]),
                                       ctx.policy.calibration_restarts))
    ctx.tracker.timing.add_here(spent)
    if not got.converged or got.rss >= model.rss:
        return None
    got = sharpen(ctx.replay, ctx.scorer, got)
    effects, values = _model(got.plant, state.refitted)
    rung = replace(state.rungs[-1], result=got, model=effects, plant_params=values)
    return replace(state, rungs=state.rungs[:-1] + (rung,), model=got)


def refined(ctx: Context, state: State) -> State:
    """``state`` with its final model's numerical error measured and, where it exceeds 0.3 of a
    standard error, taken out at a hundredth of the replay's tolerance (``numerics.refine``); the
    rung or calibration that made the model follows it (its ``model`` and ``plant_params``)."""
    ctx.tracker.stage("numerical check", state.steps)
    got = refine(ctx.replay, ctx.scorer, state.model)
    if not got.refined:
        return replace(state, model=got)
    rungs, cal = state.rungs, state.calibration
    if rungs and rungs[-1].result is state.model:
        effects, values = _model(got.plant, state.refitted)
        rungs = rungs[:-1] + (replace(rungs[-1], result=got, model=effects, plant_params=values),)
    if cal is not None and cal.result is state.model:
        cal = replace(cal, result=got)
    return replace(state, rungs=rungs, calibration=cal, model=got)


def calibrate(ctx: Context, res: FitResult, free_plant, added: tuple[int, ...]) -> FitResult | None:
    """The datasheet values ``ctx.plan.frees`` fitted with ``free_plant`` and the effects numbered
    ``added`` (the end's Jacobian by central differences, restarts), from the model's values; where that pays
    (``Policy.accepts`` against ``res``) but leaves more than ``at_noise`` x the noise floors, also
    from the best points of a scan of the tolerance box (``calibration.starts``); the best fit
    kept (None when none converged), its standard errors not yet sharpened (``fit.sharpen``:
    :func:`_calibration` sharpens the one it accepts).  On 8 s of the bench rig with p04's datasheet
    errors and Coulomb friction hidden at the load, fitted with the friction: from the file's values
    25.9x the noise floors (load inertia 0.00545 kg m^2 for 0.006), from the scan's best points
    2.07x, the truth 0.99x; in the ladder, after a pair with a load spring, 0.988x on 2026-11-28,
    and 2.10x since the solver's step cap of 2026-12-07 took the ladder another path (a strict
    xfail in ``tests/test_datasheet.py``).

    With several workers the scan and its points' fits do not wait for the fit from the model's
    values: they start on the workers it leaves free, the worse point's first (it has further to
    go), and are dropped when that fit settles the calibration alone (not counted in ``timing``, so
    its counts are those of one worker, which never starts them).  On practice records p04 and
    p08 the fit from the model's values took 709 and 830 replays, and the longer of the points'
    fits 1,396 and 1,579, which had waited for it (``docs/speed.md``)."""
    replay, scorer, policy, model = ctx.replay, ctx.scorer, ctx.policy, res.plant
    cal_frees, restarts, spent = ctx.plan.frees, policy.calibration_restarts, ctx.tracker.timing.add_here
    # the same values in two orders: the first fit keeps refit's (the free plant values first), the
    # scan takes the calibrated ones first (``calibration.starts`` scans the first len(cal_frees))
    own = frees_of(replay, model, tuple(free_plant) + tuple(cal_frees), added)
    frees = frees_of(replay, model, tuple(cal_frees) + tuple(free_plant), added)
    with ctx.workers.pool() as pool:
        first = pool.submit(calibration.fit_from, (replay, scorer, model, own, None, restarts))

        @cache
        def refitted() -> FitResult | None:
            got, cost = first.result()
            spent(cost)
            return got if got.converged else None

        def alone() -> bool:  # the fit from the model's values settles it: no point's fit is wanted
            cal = refitted()
            return cal is None or policy.explained(cal) or not policy.accepts(scorer, res, cal)

        def settled() -> bool:  # ... and it is in
            return first.done() and alone()

        if settled():  # one worker: it ran first, by itself
            return refitted()
        scanned: list[Cost] = []  # counted once wanted: the counts are those of one worker's work
        points = calibration.starts(replay, scorer, model, frees, len(cal_frees), pool=pool, spent=scanned.append,
                                    until=settled)
        if points is None:
            return refitted()
        fits = [pool.submit(calibration.fit_from, (replay, scorer, model, frees, list(x), restarts))
                for x in reversed(points)]
        if alone():
            return refitted()  # leaving the pool drops the points' fits
        for cost in scanned:
            spent(cost)
        got = []
        for job in reversed(fits):
            fitted, cost = job.result()
            spent(cost)
            got.append(fitted)
    return best_fit([refitted()] + [f for f in got if f.converged])


def removals(replay: Replay, scorer: Scorer, policy: Policy, res: FitResult, first: int,
             free_plant, workers: Executor | None = None, spent=None) -> list[tuple[AddedEffect, FitResult, float]]:
    """Stepwise backwards: with two or more effects past the plant's own ``first``, each is
    refitted out (the newest too: it was judged against the model before it, not against the
    same effects refitted); one whose removal the model with it does not beat by the criterion
    that added it (``Policy.accepts``) no longer pays and comes out, the one that pays least
    first, until every effect left pays.  Returns ``(removed effect, model without it, BIC
    change)``.  ``workers``: an :class:`Executor` the refits of one step run on (in this process
    without it), each one's cost given to ``spent``."""
    out = []
    while len(res.plant.effects) - first >= 2:
        effects = res.plant.effects
        jobs = [(replay, scorer, replace(res.plant, effects=effects[:i] + effects[i + 1:]), free_plant,
                 range(first, len(effects) - 1)) for i in range(first, len(effects))]
        options = []
        for i, (r, cost) in zip(range(first, len(effects)), (workers or Executor(1)).map(refit_job, jobs)):
            if spent is not None:
                spent(cost)
            if r is not None and not policy.accepts(scorer, r, res):
                options.append((bic_drop(scorer, r, res), i, r))
        if not options:
            break
        gain, i, r = min(options, key=lambda o: o[0])
        r = sharpen(replay, scorer, r)
        out.append((effects[i], r, gain))
        res = r
    return out


def _prune(ctx: Context, state: State, after: str, number: int) -> Iterator[State]:
    """``state`` after each effect :func:`removals` takes out, a "remove" rung each; ``after``
    names what came in."""
    ctx.tracker.stage("prune", number, max(0, len(state.model.plant.effects) - len(ctx.plant.effects)))
    first = len(ctx.plant.effects)
    for gone, without, gain in removals(ctx.replay, ctx.scorer, ctx.policy, state.model, first, state.refitted,
                                        ctx.workers, ctx.tracker.timing.add_here):
        i = state.model.plant.effects.index(gone) - first
        rung = Rung("remove", gone.name, {k: v for k, v in gone.values.items() if isinstance(v, str)},
                    {k: v for k, v in gone.values.items() if not isinstance(v, str)}, {}, without,
                    *_model(without.plant, state.refitted), state.model, after=after)
        state = replace(state, rungs=state.rungs + (rung,), owners=state.owners[:i] + state.owners[i + 1:],
                        model=without)
        yield state
