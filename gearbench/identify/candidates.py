"""What can be tried on a record, why the rest cannot, and one way to try a single or a pair.

For every effect of the registry that the plant does not have and that can act on it
(``Effect.applicable``), in every place it can act (``location``, ``signal``), a
:class:`Candidate`; :func:`try_candidate` fits it (with any free plant parameters: a
space-filling scan of its parameters picks where the local least squares starts,
``search.py``), :func:`try_pair` fits two jointly.  :func:`rank` orders the fits by
:data:`RANKING`.  ``api.fit``, the CLI's ``fit`` and ``diagnose``'s ladder all try
candidates here.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from ..blas import single_threaded
from ..plant.components import Plant
from ..plant.effects import REGISTRY, AddedEffect
from .executor import Executor
from ..errors import FitError, NotConverged, ReplayError
from .fit import Free, FitResult, evaluate, fit, get_value, set_values, sharpen
from .scoring import Scorer, signal_evidence
from .refit import best_of, frees_of
from .replay import Replay
from . import search
from .timing import Cost, costed

RANKING = ("BIC of the noise-weighted residuals of every compared signal, n ln(RSS/n) + k ln n, "
           "lowest first; the places of one effect (location, signal) share the slots their BICs earn, in the "
           "order of the evidence of each signal, sum over signals of n_s ln(RSS_s/n_s); "
           "candidates whose fit failed last")
DRY = ("sign of the speed", "stick and breakaway")  # signatures of dry friction


def unknown_effects(names, where: str) -> list[str]:
    """A problem naming each of ``names`` that is not an effect of the library (``REGISTRY``),
    ``where`` the argument or option it came from."""
    return [f"{where}: unknown effect {n!r}; the library has {', '.join(REGISTRY)}" for n in names if n not in REGISTRY]


def check_names(names, where: str = "only") -> None:
    """``FitError`` naming each of ``names`` that is not an effect of the library."""
    problems = unknown_effects(names, where)
    if problems:
        raise FitError("; ".join(problems))


@dataclass(frozen=True)
class Candidate:
    """An effect to try: its name and its fixed options (location, signal)."""
    name: str
    options: dict

    def label(self) -> str:
        opts = ", ".join(f"{v}" for v in self.options.values())
        return f"{self.name} ({opts})" if opts else self.name


@dataclass
class Tried:
    """A candidate after fitting: ``params`` and ``stderr`` its own (file keys), ``note`` why it
    failed or what to know, ``cost`` what its fit cost wherever it ran (``timing.Cost``: wall time,
    replays, solver steps, fits; None for a single made from a pair's fit), ``later`` the starts of
    its scan not yet fitted (fit coordinates of every free: ``Trial.starts``, :func:`fit_each_later`)."""
    candidate: Candidate
    result: FitResult | None
    params: dict = field(default_factory=dict)
    stderr: dict = field(default_factory=dict)
    note: str = ""
    cost: Cost | None = field(default=None, repr=False, compare=False)
    later: tuple = field(default=(), repr=False, compare=False)

    @property
    def ok(self) -> bool:
        return self.result is not None and self.result.converged and math.isfinite(self.result.error)

    def label(self) -> str:
        return self.candidate.label()

    def effect(self) -> str:
        """The effect's name (the key of its cost in ``timing``)."""
        return self.candidate.name


def own_estimates(res: FitResult, i: int) -> tuple[dict, dict]:
    """Effect ``i``'s fitted values (its numbers, not its options) and their standard errors,
    by the effect's own keys."""
    values = {k: v for k, v in res.plant.effects[i].values.items() if not isinstance(v, str)}
    return values, {k: p.stderr for k, p in res.of_effect(i).items()}


def as_tried(cand: Candidate, res: FitResult) -> Tried:
    """``cand`` with ``res``'s fit of the plant's last effect (its own)."""
    return Tried(cand, res, *own_estimates(res, len(res.plant.effects) - 1))


def asked(name: str, only: tuple[str, ...] = (), also: tuple[str, ...] = ()) -> bool:
    """Whether effect ``name`` is to be tried: named in ``also``, or in ``only`` when it is given,
    else when it is not tried only on request (``Effect.on_request``)."""
    return name in also or (name in only if only else not REGISTRY[name].on_request)


def candidates(plant: Plant, replay: Replay, only: tuple[str, ...] = (),
               also: tuple[str, ...] = ()) -> list[Candidate]:
    """Every effect (of ``only``, if given; of ``also`` too), in every place, that the plant lacks
    and that could act on this record (:func:`asked`).

    On a rigid train (no clearance, no shaft) the motor and the load are one
    body, so friction there is tried once, at the load (the carriage).  In a
    closed-loop replay the compared column is the controller's output, which a
    sensor effect applied after the fact cannot change: those are left out
    (:func:`not_tried` says why for each).
    """
    have = {(e.name, tuple(sorted((k, v) for k, v in e.values.items() if k in e.effect.options)))
            for e in plant.effects}
    skipped = not_tried(plant, replay, only, also)
    out = []
    for name, eff in sorted(REGISTRY.items()):
        if not asked(name, only, also) or name in skipped:
            continue
        for c in _places(plant, replay, eff):
            if (name, tuple(sorted(c.items()))) in have or any(e.name == name and not e.effect.options
                                                               for e in plant.effects):
                continue
            out.append(Candidate(name, c))
    return out


def _places(plant: Plant, replay: Replay, eff) -> list[dict]:
    """Every combination of ``eff``'s options that can act on this plant and record."""
    signals = list(replay.data.signals)
    resolved = plant.resolved()
    one_body = resolved.gear.rigid and resolved.shaft is None
    choices = [{}]
    for opt, allowed in eff.options.items():
        if opt == "location":
            places = [a for a in allowed if a != "carriage"] if plant.leadscrew is None else (
                [a for a in allowed if a != "load"])
            if one_body:
                places = [a for a in places if a != "motor"]
        else:
            places = [a for a in allowed if a in signals]
        choices = [dict(c, **{opt: a}) for c in choices for a in places]
    return choices


def not_tried(plant: Plant, replay: Replay, only: tuple[str, ...] = (),
              also: tuple[str, ...] = ()) -> dict[str, str]:
    """The effects of the library (of ``only``, if given) that cannot act on this plant and record,
    or are tried only when named (``Effect.on_request``), each with why (``Effect.inapplicable``;
    a sensor effect in a closed-loop replay)."""
    signals = list(replay.data.signals)
    resolved = plant.resolved()
    out = {}
    for name, eff in sorted(REGISTRY.items()):
        if only and name not in only + also:
            continue
        if not asked(name, only, also):
            out[name] = (f"it is tried only when asked for (--also {name}): "
                         f"{(type(eff).__doc__ or '').strip().splitlines()[0]}")
        elif not eff.applicable(resolved, signals):
            out[name] = eff.inapplicable(resolved, signals) or "it does not apply to this plant"
        elif replay.closed_loop and eff.acts_on == "measured signal":
            out[name] = ("a sensor effect cannot change the controller's output, which a closed-loop "
                         "replay compares")
    return out


def start_values(plant: Plant, cand: Candidate) -> dict:
    """The candidate's options and each required parameter at its typical value."""
    from ..plant.effects.location import key as file_key
    eff = REGISTRY[cand.name]
    values = dict(cand.options)
    for q in eff.params:
        if not q.optional:
            k = file_key(values, q.name) if "location" in eff.options else q.name
            values[k] = q.start if q.start is not None else q.typical(plant, values)
    return values


@dataclass(frozen=True)
class Trial:
    """How to fit one candidate (:func:`try_candidate`): the plant values ``free_plant`` and the
    effects numbered ``refit`` fitted with it; ``start`` its values to start from (no scan);
    ``points`` the starts to fit from instead of a scan's (fit coordinates of every free); ``starts``
    how many of them to fit now, the rest coming back on ``Tried.later`` once one has converged
    (None: all); ``max_nfev``, ``restarts``, ``rounds_below``: as in
    :func:`gearbench.identify.fit.fit`."""
    free_plant: tuple = ()
    refit: tuple[int, ...] = ()
    start: dict | None = None
    max_nfev: int | None = None
    restarts: int = 0
    rounds_below: float | None = None
    points: tuple = ()
    starts: int | None = None


@single_threaded
def try_candidate(replay: Replay, scorer: Scorer, plant: Plant, cand: Candidate, how: Trial = Trial()) -> Tried:
    """:func:`fit_candidate`, its cost (wall time, replays, solver steps, fits) measured here, in the
    process that fits it, and carried back on the result (``Tried.cost``)."""
    tried, spent = costed(fit_candidate, replay, scorer, plant, cand, how)
    return replace(tried, cost=spent)


def fit_candidate(replay: Replay, scorer: Scorer, plant: Plant, cand: Candidate, how: Trial = Trial()) -> Tried:
    """Fit one candidate (its parameters, the free plant parameters and those of the plant's
    effects numbered in ``how.refit``, jointly) to the record.

    Parameters the data give directly (``Effect.estimate``: encoder counts) are
    read, the rest fitted: a space-filling scan of the candidate's own
    parameters (``search``) picks the basin, bounded least squares does the
    rest; with ``how.start`` given (a user's values, or a previous fit's) the local
    fit starts there without a scan, with ``how.points`` from each of those.
    """
    eff = REGISTRY[cand.name]
    values = dict(how.start) if how.start is not None else start_values(plant, cand)
    dt = replay.data.sample_time_s
    options = dict(max_nfev=how.max_nfev, restarts=how.restarts, rounds_below=how.rounds_below)
    later = []
    try:
        est = eff.estimate(values, replay.data.signals, plant)
        values.update(est or {})
        with_it = plant.with_effects(AddedEffect(cand.name, values))
        mine = Free.effect(with_it, len(with_it.effects) - 1, dt)
        frees = mine + frees_of(replay, with_it, how.free_plant, how.refit)
        if not frees:
            if est is None:
                return Tried(cand, None, note="nothing to fit and nothing read from the data")
            res = evaluate(replay, scorer, with_it, k=len(est))
        elif how.start is not None:
            res = fit(replay, with_it, frees, scorer, **options)
        else:
            points = list(how.points) or search.starts(
                replay, scorer, with_it, frees, len(mine), [get_value(with_it, f) for f in frees],
                guesses=guess_points(replay, with_it, len(with_it.effects) - 1, frees))[0]
            res, later = best_of(points, lambda x: fit(replay, with_it, frees, scorer, start=list(x), sharp=False,
                                                       **options), how.starts)
            res = replace(sharpen(replay, scorer, res), k=res.k + len(est or {}))
    except (ReplayError, ValueError) as exc:
        return Tried(cand, None, note=f"could not be simulated: {exc}")
    if not res.converged:
        return Tried(cand, res, note=res.message)
    return replace(as_tried(cand, res), later=tuple(later))


def guess_points(replay: Replay, plant: Plant, i: int, frees: list[Free]) -> list[list[float]]:
    """``frees``' fit coordinates at each of the values effect ``i`` of ``plant`` reads from the
    record (``Effect.guesses``), the rest as in ``plant``; a guess's keys with a dot are plant
    values (``motor.inertia``), and a guess that sets one ``frees`` does not free is left out."""
    e = plant.effects[i]
    free = {f.key: f for f in frees if f.index is None}
    out = []
    for g in e.effect.guesses(plant, replay.data):
        held = {k: v for k, v in g.items() if "." in k}
        if any(k not in free for k in held):
            continue
        p = set_values(plant, [free[k] for k in held], list(held.values()))
        effects = list(p.effects)
        effects[i] = AddedEffect(e.name, {**e.values, **{k: v for k, v in g.items() if "." not in k}})
        p = replace(p, effects=tuple(effects))
        out.append([get_value(p, f) for f in frees])
    return out


def run_candidate(args) -> Tried:
    """:func:`try_candidate` of one job tuple (what an :class:`Executor` maps)."""
    return try_candidate(*args)


@dataclass
class Pair:
    """Two candidates fitted jointly: ``first`` the one whose single fit ranked higher."""
    first: Tried
    second: Tried
    result: FitResult | None
    note: str = ""
    cost: Cost | None = field(default=None, repr=False, compare=False)  # as Tried.cost
    later: tuple = field(default=(), repr=False, compare=False)  # as Tried.later

    @property
    def ok(self) -> bool:
        return self.result is not None and self.result.converged and math.isfinite(self.result.error)

    def label(self) -> str:
        return f"{self.first.candidate.label()} + {self.second.candidate.label()}"

    def effect(self) -> str:
        """The two effects' names, ``"a+b"`` (the key of its cost in ``timing``)."""
        return f"{self.first.candidate.name}+{self.second.candidate.name}"

    def as_second(self) -> Tried:
        """The second candidate as a single whose fit is the pair's (for its rung)."""
        return as_tried(self.second.candidate, self.result)


def confounders(name: str) -> set[str]:
    """The effects declared confounded with ``name``, by it or by them (``Effect.confounders``)."""
    return ({n for n in REGISTRY[name].confounders if n in REGISTRY}
            | {n for n, e in REGISTRY.items() if name in e.confounders})


def pairable(a: Tried, b: Tried) -> bool:
    """Two different effects, neither the other's simpler form in the same place (Stribeck and
    Coulomb friction at one shaft are rivals, which the ladder's simplification settles, not a
    pair), and not two dry frictions: where one dry friction sits is the location rule's
    question, and dry friction on both sides of the clearance is very stiff for the regularised
    law (on the bench rig, Coulomb friction at the load with Stribeck's at the motor exhausted
    the step budget of one 3 s replay after 175 s)."""
    if a.candidate.name == b.candidate.name or all(REGISTRY[t.candidate.name].signature in DRY for t in (a, b)):
        return False
    for x, y in ((a, b), (b, a)):
        simpler = REGISTRY[x.candidate.name].simpler({**x.candidate.options, **x.params})
        if simpler and simpler[0] == y.candidate.name and y.candidate.options.items() <= simpler[1].items():
            return False
    return True


@single_threaded
def try_pair(replay: Replay, scorer: Scorer, plant: Plant, first: Tried, second: Tried,
             free_plant: tuple[str, ...] = (), refit: tuple[int, ...] = (), points: tuple = (),
             starts: int | None = None) -> Pair:
    """:func:`fit_pair`, its cost measured where it runs and carried back (``Pair.cost``), as
    :func:`try_candidate`'s."""
    pair, spent = costed(fit_pair, replay, scorer, plant, first, second, free_plant, refit, points, starts)
    return replace(pair, cost=spent)


def fit_pair(replay: Replay, scorer: Scorer, plant: Plant, first: Tried, second: Tried,
             free_plant: tuple[str, ...] = (), refit: tuple[int, ...] = (), points: tuple = (),
             starts: int | None = None) -> Pair:
    """Fit two candidates jointly (with the free plant parameters and the effects numbered in
    ``refit``); ``k`` counts both.  The local fit starts from the best of their single fits and
    a space-filling scan of both effects' parameters (``search``): a single fit of one member
    of a confounded pair is far from its value in the pair (Coulomb friction fitted alone on a
    record with a spring: 3.5 N m for 0.6).  A fit that gained nothing in its first round over
    the better of the two alone gets no second (``fit(rounds_below=)``: a pair that does not
    beat it does not pay).  ``points`` and ``starts`` as :class:`Trial`'s: the starts to fit from
    instead of the scan's, and how many of them now (the rest on ``Pair.later``)."""
    n = len(plant.effects)
    both = plant.with_effects(*(AddedEffect(t.candidate.name, {**t.candidate.options, **t.params})
                                for t in (first, second)))
    dt = replay.data.sample_time_s
    mine = Free.effect(both, n, dt) + Free.effect(both, n + 1, dt)
    frees = mine + frees_of(replay, both, free_plant, refit)
    try:
        points = list(points) or search.starts(
            replay, scorer, both, frees, len(mine), [get_value(both, f) for f in frees],
            guesses=guess_points(replay, both, n, frees) + guess_points(replay, both, n + 1, frees))[0]
        alone = min(t.result.rss for t in (first, second))
        res, later = best_of(points, lambda x: fit(replay, both, frees, scorer, start=list(x), rounds_below=alone,
                                                   sharp=False), starts)
        res = sharpen(replay, scorer, res)
    except (ReplayError, ValueError) as exc:
        return Pair(first, second, None, f"could not be simulated: {exc}")
    return Pair(first, second, res, "" if res.converged else res.message, later=tuple(later))


def run_pair(args) -> Pair:
    """:func:`try_pair` of one job tuple (what an :class:`Executor` maps)."""
    return try_pair(*args)


def fit_pairs_later(jobs, pairs: list[Pair], workers: Executor, progress=None) -> list[Pair]:
    """Each of ``pairs`` (made by the :func:`pair_jobs` job beside it in ``jobs``) fitted from the
    starts its first fit left (``Pair.later``) too, where ``workers`` runs them: the fit of lower RSS
    of each, none left (as :func:`fit_each_later`'s)."""
    again = run_jobs(run_pair, [job + (p.later, None) for job, p in zip(jobs, pairs)], workers, progress)
    return [better(p, a) for p, a in zip(pairs, again)]


def place_of(t: Tried) -> str | None:
    """Where a candidate acts (``Effect.places``): its ``location``, or its effect's one place; None
    for a sensor effect's and one of several places not chosen."""
    places = REGISTRY[t.candidate.name].places
    return t.candidate.options.get("location") or (places[0] if len(places) == 1 else None)


def pair_jobs(replay, scorer, plant, tried, free_plant, refit, top: int) -> list[tuple]:
    """The arguments of :func:`try_pair` for every pairable pair (:func:`pairable`) of the best
    places of the ``top`` best effects, and of each of them with the best place of each effect
    it is confounded with (:func:`confounders`, either way) wherever that ranked (the best few
    candidates are often one effect in several places; a bias hidden with Coulomb friction ranks
    low alone, as the friction explains most of what it does), and with that effect's place on
    its own shaft, or its own place on that effect's shaft, where the best places differ: what
    confounds two effects is that they act alike on one shaft, so where one of them ranks best
    alone is confounded too (a bias on the load hidden with Coulomb friction at the load: each
    friction alone ranked best at the motor, 20,849 against 20,945 in weighted RSS for Coulomb
    friction, and the pair with the friction at the motor did not pay).  In the order of the
    members' ranks alone, the better member's first: the best effect with each of its partners,
    then the second best, and so on."""
    best, placed = {}, {}
    for t in tried:
        if t.ok:
            best.setdefault(t.candidate.name, t)
            placed.setdefault((t.candidate.name, place_of(t)), t)
    order = {name: i for i, name in enumerate(best)}
    tops = list(best.values())[:top]
    names = {t.candidate.name for t in tops}
    pairs = [(a, b) for i, a in enumerate(tops) for b in tops[i + 1:]]
    pairs += [(a, best[name]) for a in tops for name in sorted(confounders(a.candidate.name))
              if name in best and name not in names]
    pairs += [same for a in tops for name in sorted(confounders(a.candidate.name)) if name in best
              for same in _on_one_shaft(a, best[name], placed)]
    ranked = {}  # the better member first, each pair once
    for a, b in pairs:
        a, b = sorted((a, b), key=lambda t: order[t.candidate.name])
        ranked.setdefault((id(a), id(b)), (a, b))
    pairs = sorted(ranked.values(), key=lambda p: (order[p[0].candidate.name], order[p[1].candidate.name]))
    return [(replay, scorer, plant, a, b, free_plant, refit) for a, b in pairs if pairable(a, b)]


def _on_one_shaft(a: Tried, b: Tried, placed: dict) -> list[tuple[Tried, Tried]]:
    """``a`` with ``b``'s effect where ``a`` acts, and ``a``'s effect where ``b`` acts with ``b``
    (``placed``: each effect's best candidate at each place), where ``a`` and ``b`` act apart."""
    pa, pb = place_of(a), place_of(b)
    if pa == pb or None in (pa, pb):
        return []
    return [pair for pair in ((a, placed.get((b.candidate.name, pa))), (placed.get((a.candidate.name, pb)), b))
            if None not in pair]


def _same_effect(tried: list[Tried]) -> dict[str, list[Tried]]:
    groups: dict[str, list[Tried]] = {}
    for t in tried:
        if t.ok and t.candidate.options:
            groups.setdefault(t.candidate.name, []).append(t)
    return {k: g for k, g in groups.items() if len(g) > 1 and all(t.result.signals for t in g)}


def rank(tried: list[Tried]) -> list[Tried]:
    """Best first by :data:`RANKING`: the BIC, and among the places of one effect the evidence
    of each signal (:func:`signal_evidence`)."""
    out = sorted(tried, key=lambda t: (not t.ok, t.result.bic if t.ok else math.inf))
    for group in _same_effect(out).values():
        slots = sorted(out.index(t) for t in group)
        for i, t in zip(slots, sorted(group, key=lambda t: signal_evidence(t.result))):
            out[i] = t
    return out


def fit_effect(plant: Plant, replay: Replay, name: str, options=None, start=None, free=(), refit: bool = False,
               max_evals: int | None = None, calibrate: bool = False, scheduler: str | None = None) -> list[Tried]:
    """Fit effect ``name`` in every place it may act (``options`` fixes some, e.g.
    ``{"location": "load"}``) to the replayed record; one :class:`Tried` per place.  ``start``:
    starting values of its parameters (file keys); ``free``: plant parameters fitted too; ``refit``:
    the plant's own effects refitted too; ``calibrate``: the plant's own values within their
    tolerances too (``calibration.plan``, restarted on a stall as diagnose's calibration is: tied
    datasheet values stall); ``scheduler``: the places are fitted on the Dask cluster at this
    address, one task each (in this process without it).  ``FitError`` names a bad name, option,
    starting value or free key before any fitting."""
    from . import calibration
    from .policy import Policy
    check_names([name], "effect")
    options = dict(options or {})
    why = not_tried(plant, replay, (name,)).get(name)
    if why:
        raise FitError(f"effect {name}: it cannot act on plant {plant.name}: {why}")
    places = [c for c in candidates(plant, replay, (name,)) if all(c.options.get(k) == v for k, v in options.items())]
    if not places:
        raise FitError(f"effect {name}: it cannot be added here (already in the plant, or options "
                       f"{options} not allowed)")
    for c in places:
        _check_start(c, start or {})
    for p in free:
        Free.plant(plant, p)  # a bad key is named before any solving
    scorer = Scorer(replay)
    again = tuple(range(len(plant.effects))) if refit else ()
    with Executor(1, scheduler) as where:  # a scheduler is reached (or named unreachable) before calibrating
        cal = calibration.plan(plant, replay, scorer).frees if calibrate else []
        how = Trial(tuple(free) + tuple(cal), again, None, max_evals, Policy().calibration_restarts if cal else 0)
        return run_jobs(run_candidate, [
            (replay, scorer, plant, c, replace(how, start={**c.options, **start_values(plant, c), **start}
                                               if start else None)) for c in places], where)


def _check_start(c: Candidate, start: dict) -> None:
    """``FitError`` naming a starting value that is not one of ``c``'s parameters (a misspelt one
    would ride along in the plant, unused)."""
    from ..plant.effects.location import key as file_key
    eff = REGISTRY[c.name]
    keys = {file_key(c.options, q.name) if "location" in eff.options else q.name: q.unit for q in eff.params}
    for k in start:
        if k not in keys:
            carriage = c.options.get("location") == "carriage"
            listing = ", ".join(k2 if carriage else f"{k2} ({u})" for k2, u in keys.items())
            raise FitError(f"effect {c.label()}: {k!r} is not one of its parameters; they are {listing}")


def best_tried(tried: list[Tried]) -> Tried:
    """The converged try of lowest BIC; :class:`NotConverged` when none converged."""
    ok = [t for t in tried if t.ok]
    if not ok:
        raise NotConverged("the fit did not converge: " + "; ".join(f"{t.candidate.label()}: {t.note}" for t in tried)
                           + ". The plant is unchanged.", tried)
    return min(ok, key=lambda t: t.result.bic)


def run_jobs(fn, jobs, workers: Executor, progress=None) -> list:
    """``fn`` over ``jobs`` where ``workers`` runs them (an :class:`Executor`: local processes or
    a Dask cluster), the results in the order of the jobs; the jobs with the most parameters to
    fit (:func:`cost`) start first; ``progress`` is called with each result as it comes."""
    return workers.map(fn, jobs, progress, cost=[cost(j) for j in jobs])


def cost(job) -> int:
    """A job's expected run time, for the order the jobs start in: the parameters it fits (a
    candidate's, or a pair's both; the scan takes 8 points per parameter, the local fits' finite
    differences one replay per parameter)."""
    members = [t.candidate if isinstance(t, Tried) else t for t in job if isinstance(t, (Candidate, Tried))]
    return sum(len(REGISTRY[c.name].params) for c in members)


def fit_each(replay, scorer, plant, cands, workers: Executor, progress=None, how: Trial = Trial()) -> list[Tried]:
    """Each candidate fitted alone where ``workers`` runs them, by ``how``; an item of ``cands``
    may be ``(candidate, start values)``, which replaces ``how.start``."""
    jobs = [(replay, scorer, plant, c[0], replace(how, start=c[1])) if isinstance(c, tuple)
            else (replay, scorer, plant, c, how) for c in cands]
    return run_jobs(run_candidate, jobs, workers, progress)


def fit_each_later(replay, scorer, plant, tried: list[Tried], workers: Executor, progress=None,
                   how: Trial = Trial()) -> list[Tried]:
    """Each of ``tried`` fitted by ``how`` from the starts its screen left (``Tried.later``) too, where
    ``workers`` runs them: the fit of lowest RSS of them all, none left, in their order (``progress``
    is given the new fits, with what they cost)."""
    again = run_jobs(run_candidate, [(replay, scorer, plant, t.candidate, replace(how, points=t.later, starts=None))
                                     for t in tried], workers, progress)
    return [better(t, a) for t, a in zip(tried, again)]


def better(first, again):
    """Of a :class:`Tried` (or :class:`Pair`) ``first`` and ``again``, its fit from the starts it
    left, the one of lower RSS, with no starts left."""
    return again if again.ok and again.result.rss < first.result.rss else replace(first, later=())
