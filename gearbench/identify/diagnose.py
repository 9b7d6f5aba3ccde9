"""Which physical effect is missing?  Try each, fit it, rank, and climb the ladder.

For every effect of the registry that the plant does not have and that can
act on it (``Effect.applicable``), in every place it can act (``location``,
``signal``), fit its parameters (with any free plant parameters: a
space-filling scan of its parameters picks where the local least squares
starts, ``search.py``) and score the fit by the Bayesian information
criterion of the noise-weighted residuals, ``BIC = n ln(RSS/n) + k ln n``,
which charges ``ln n`` per added parameter: an effect that does not explain
more than noise would never wins.  The places of one effect compete on the
evidence of every signal instead (``evidence.signal_evidence``,
``sum_s n_s ln(RSS_s/n_s)``): they keep the slots their BICs earn, best
evidence first, so a location one signal clearly contradicts is not chosen
because another signal's larger misfit dominates the pooled RSS.
The best one is the verdict when it lowers the BIC by more than
``MIN_BIC_DROP`` (10: "very strong" evidence, Kass & Raftery 1995) and the
error by more than ``MIN_ERROR_DROP``, also with both models' angles reset at the
same window seams (``_accepts``); ``None`` when the model already sits
at the noise floor, or when no candidate explains the residual.

Confounded pairs (Coulomb friction + a bias, a spring + a bias): each alone
explains part of the other's residual, so the best single candidate can be a
third effect that mimics both.  When the best single leaves more than noise
and the ladder has room for two rungs, the ``PAIR_TOP`` best candidates are
refitted in pairs jointly (the best place of each of the ``PAIR_TOP`` best effects, and of
each of them with the effects it is declared confounded with, ``Effect.confounders``, wherever
those rank alone; from the best of their single fits and a scan of both effects' parameters;
``k`` counts both effects' parameters).  The pair of lowest BIC is taken when it beats both the
current model and the best single candidate by the criterion that adds an
effect (``_accepts``); it then takes two rungs, each with its explanation:
first its member that ranked higher alone (its single fit), then the other
with the joint fit.  Otherwise the best single is added, as before.  When the
first ``PAIR_BATCH`` pairs (the best single with its partners) leave more than
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
tolerance box (``_calibrate``).

The ladder repeats: add the verdict with its fitted parameters, diagnose
again, until nothing more pays.  It steps both ways: after each rung every
effect an earlier rung added is refitted out, and one that no longer pays by
the same criterion is taken out, as a rung of its own (``action: remove``).
The verdict is the first effect added that is still in the model at the end.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable

from ..plant.components import Plant
from ..plant.effects import REGISTRY, AddedEffect
from .evidence import explain, signal_evidence
from .fit import Free, FitResult, Scorer, evaluate, fit, get_value, plant_frees
from .replay import Replay, ReplayError
from .residuals import DEFAULT_LAGS, replay_residual_tests
from . import calibration, search
from .executor import Executor
from .uncertainty import strong_correlations
from ..blas import single_threaded
from ..interrupts import is_interrupt

RANKING = ("BIC of the noise-weighted residuals of every compared signal, n ln(RSS/n) + k ln n, "
           "lowest first; the places of one effect (location, signal) share the slots their BICs earn, in the "
           "order of the evidence of each signal, sum over signals of n_s ln(RSS_s/n_s); "
           "candidates whose fit failed last")
MIN_BIC_DROP = 10.0
MIN_ERROR_DROP = 0.03      # the primary error must fall by 3 % at least
AT_NOISE = 1.2             # a weighted RMS within 1.2x the noise floors is explained
JOINT_TOP = 3              # candidates refitted jointly with the effects already added
CALIBRATION_RESTARTS = 3    # the calibration fit restarts on a stall (fit)
PAIR_TOP = 6               # effects whose best places are refitted jointly in pairs (15 pairs at most)
PAIR_BATCH = 4             # pairs fitted at a time, until one reaches the noise floors


@dataclass
class Candidate:
    """An effect to try: its name and its fixed options (location, signal)."""
    name: str
    options: dict

    def label(self) -> str:
        opts = ", ".join(f"{v}" for v in self.options.values())
        return f"{self.name} ({opts})" if opts else self.name


@dataclass
class Tried:
    """A candidate after fitting."""
    candidate: Candidate
    result: FitResult | None
    params: dict = field(default_factory=dict)
    stderr: dict = field(default_factory=dict)
    note: str = ""

    @property
    def ok(self) -> bool:
        return self.result is not None and self.result.converged and math.isfinite(self.result.error)

    def label(self) -> str:
        return self.candidate.label()


def candidates(plant: Plant, replay: Replay, only: tuple[str, ...] = ()) -> list[Candidate]:
    """Every effect (of ``only``, if given), in every place, that the plant lacks
    and that could act on this record.

    On a rigid train (no clearance, no shaft) the motor and the load are one
    body, so friction there is tried once, at the load (the carriage).  In a
    closed-loop replay the compared column is the controller's output, which a
    sensor effect applied after the fact cannot change: those are left out
    (:func:`not_tried` says why for each).
    """
    have = {(e.name, tuple(sorted((k, v) for k, v in e.values.items() if k in e.effect.options)))
            for e in plant.effects}
    signals = list(replay.data.signals)
    resolved = plant.resolved()
    one_body = resolved.gear.rigid and resolved.shaft is None
    out = []
    skipped = not_tried(plant, replay, only)
    for name, eff in sorted(REGISTRY.items()):
        if (only and name not in only) or name in skipped:
            continue
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
        for c in choices:
            if (name, tuple(sorted(c.items()))) in have or any(e.name == name and not e.effect.options
                                                               for e in plant.effects):
                continue
            out.append(Candidate(name, c))
    return out


def not_tried(plant: Plant, replay: Replay, only: tuple[str, ...] = ()) -> dict[str, str]:
    """The effects of the library (of ``only``, if given) that cannot act on this plant and record,
    each with why (``Effect.inapplicable``; a sensor effect in a closed-loop replay)."""
    signals = list(replay.data.signals)
    resolved = plant.resolved()
    out = {}
    for name, eff in sorted(REGISTRY.items()):
        if only and name not in only:
            continue
        if not eff.applicable(resolved, signals):
            out[name] = eff.inapplicable(resolved, signals) or "it does not apply to this plant"
        elif replay.closed_loop and eff.acts_on == "measured signal":
            out[name] = ("a sensor effect cannot change the controller's output, which a closed-loop "
                         "replay compares")
    return out


def _start_values(plant: Plant, cand: Candidate) -> dict:
    """The candidate's options and each required parameter at its typical value."""
    from ..plant.effects.location import key as file_key
    eff = REGISTRY[cand.name]
    values = dict(cand.options)
    for q in eff.params:
        if not q.optional:
            k = file_key(values, q.name) if "location" in eff.options else q.name
            values[k] = q.start if q.start is not None else q.typical(plant, values)
    return values


@single_threaded
def try_candidate(replay: Replay, scorer: Scorer, plant: Plant, cand: Candidate,
                  free_plant: tuple[str, ...] = (), refit: tuple[int, ...] = (),
                  start: dict | None = None, max_nfev: int | None = None, restarts: int = 0,
                  rounds_below: float | None = None) -> Tried:
    """Fit one candidate (its parameters, the free plant parameters and those
    of the plant's effects numbered in ``refit``, jointly) to the record.
    ``restarts``, ``rounds_below``: as in :func:`gearbench.identify.fit.fit`.

    Parameters the data give directly (``Effect.estimate``: encoder counts) are
    read, the rest fitted: a space-filling scan of the candidate's own
    parameters (``search``) picks the basin, bounded least squares does the
    rest; with ``start`` given (a user's values, or a previous fit's) the local
    fit starts there without a scan.
    """
    eff = REGISTRY[cand.name]
    values = dict(start) if start is not None else _start_values(plant, cand)
    dt = replay.data.sample_time_s
    try:
        est = eff.estimate(values, replay.data.signals, plant)
        values.update(est or {})
        with_it = plant.with_effects(AddedEffect(cand.name, values))
        mine = Free.effect(with_it, len(with_it.effects) - 1, dt)
        frees = mine + _frees(replay, with_it, free_plant, refit)
        if not frees:
            if est is None:
                return Tried(cand, None, note="nothing to fit and nothing read from the data")
            res = evaluate(replay, scorer, with_it, k=len(est))
        elif start is not None:
            res = fit(replay, with_it, frees, scorer, max_nfev=max_nfev, restarts=restarts,
                      rounds_below=rounds_below)
        else:
            points, _ = search.starts(replay, scorer, with_it, frees, len(mine),
                                      [get_value(with_it, f) for f in frees])
            res = _best_fit([fit(replay, with_it, frees, scorer, start=list(x), max_nfev=max_nfev,
                                 restarts=restarts, rounds_below=rounds_below) for x in points])
            res.k += len(est or {})
    except (ReplayError, ValueError) as exc:
        return Tried(cand, None, note=f"could not be simulated: {exc}")
    if not res.converged:
        return Tried(cand, res, note=res.message)
    last = len(res.plant.effects) - 1
    params = {k: v for k, v in res.plant.effects[last].values.items() if not isinstance(v, str)}
    stderr = {k.split(".", 1)[1]: v for k, v in res.stderr.items() if k.startswith(f"effects[{last}].")}
    return Tried(cand, res, params, stderr)


def _best_fit(results: list[FitResult]) -> FitResult:
    """The converged fit of lowest RSS (the first, failed, when none converged)."""
    ok = [r for r in results if r.converged and math.isfinite(r.rss)]
    return min(ok, key=lambda r: r.rss) if ok else results[0]


def _run_candidate(args):
    return try_candidate(*args)


@dataclass
class Pair:
    """Two candidates fitted jointly: ``first`` the one whose single fit ranked higher."""
    first: Tried
    second: Tried
    result: FitResult | None
    note: str = ""

    @property
    def ok(self) -> bool:
        return self.result is not None and self.result.converged and math.isfinite(self.result.error)

    def label(self) -> str:
        return f"{self.first.candidate.label()} + {self.second.candidate.label()}"

    def as_second(self) -> Tried:
        """The second candidate as a single whose fit is the pair's (for its rung)."""
        last = len(self.result.plant.effects) - 1
        e = self.result.plant.effects[last]
        stderr = {k.split(".", 1)[1]: v for k, v in self.result.stderr.items() if k.startswith(f"effects[{last}].")}
        return Tried(self.second.candidate, self.result, {k: v for k, v in e.values.items()
                                                           if not isinstance(v, str)}, stderr)


DRY = ("sign of the speed", "stick and breakaway")  # signatures of dry friction


def _confounders(name: str) -> set[str]:
    """The effects declared confounded with ``name``, by it or by them (``Effect.confounders``)."""
    return ({n for n in REGISTRY[name].confounders if n in REGISTRY}
            | {n for n, e in REGISTRY.items() if name in e.confounders})


def _pairable(a: Tried, b: Tried) -> bool:
    """Two different effects, neither the other's simpler form in the same place (Stribeck and
    Coulomb friction at one shaft are rivals, which ``_simplify`` settles, not a pair), and not
    two dry frictions: where one dry friction sits is the location rule's question, and dry
    friction on both sides of the clearance is very stiff for the regularised law (on the
    bench rig, Coulomb friction at the load with Stribeck's at the motor exhausted the step
    budget of one 3 s replay after 175 s)."""
    if a.candidate.name == b.candidate.name or all(REGISTRY[t.candidate.name].signature in DRY for t in (a, b)):
        return False
    for x, y in ((a, b), (b, a)):
        simpler = REGISTRY[x.candidate.name].simpler({**x.candidate.options, **x.params})
        if simpler and simpler[0] == y.candidate.name and y.candidate.options.items() <= simpler[1].items():
            return False
    return True


@single_threaded
def try_pair(replay: Replay, scorer: Scorer, plant: Plant, first: Tried, second: Tried,
             free_plant: tuple[str, ...] = (), refit: tuple[int, ...] = ()) -> Pair:
    """Fit two candidates jointly (with the free plant parameters and the effects numbered in
    ``refit``); ``k`` counts both.  The local fit starts from the best of their single fits and
    a space-filling scan of both effects' parameters (``search``): a single fit of one member
    of a confounded pair is far from its value in the pair (Coulomb friction fitted alone on a
    record with a spring: 3.5 N m for 0.6).  A fit that gained nothing in its first round over
    the better of the two alone gets no second (``fit(rounds_below=)``: a pair that does not
    beat it does not pay)."""
    n = len(plant.effects)
    both = plant.with_effects(*(AddedEffect(t.candidate.name, {**t.candidate.options, **t.params})
                                for t in (first, second)))
    dt = replay.data.sample_time_s
    mine = Free.effect(both, n, dt) + Free.effect(both, n + 1, dt)
    frees = mine + _frees(replay, both, free_plant, refit)
    try:
        points, _ = search.starts(replay, scorer, both, frees, len(mine), [get_value(both, f) for f in frees])
        alone = min(t.result.rss for t in (first, second))
        res = _best_fit([fit(replay, both, frees, scorer, start=list(x), rounds_below=alone) for x in points])
    except (ReplayError, ValueError) as exc:
        return Pair(first, second, None, f"could not be simulated: {exc}")
    return Pair(first, second, res, "" if res.converged else res.message)


def _run_pair(args):
    return try_pair(*args)


def _pair_jobs(replay, scorer, plant, tried, free_plant, refit) -> list[tuple]:
    """The arguments of :func:`try_pair` for every pairable pair (:func:`_pairable`) of the best
    places of the ``PAIR_TOP`` best effects, and of each of them with the best place of each effect
    it is confounded with (``confounders``, either way) wherever that ranked (the best few
    candidates are often one effect in several places; a bias hidden with Coulomb friction ranks
    low alone, as the friction explains most of what it does).  In the order of the members' ranks
    alone, the better member's first: the best effect with each of its partners, then the second
    best, and so on."""
    best = {}
    for t in tried:
        if t.ok:
            best.setdefault(t.candidate.name, t)
    rank = {name: i for i, name in enumerate(best)}
    top = list(best.values())[:PAIR_TOP]
    names = {t.candidate.name for t in top}
    pairs = [(a, b) for i, a in enumerate(top) for b in top[i + 1:]]
    pairs += [(a, best[name]) for a in top for name in sorted(_confounders(a.candidate.name))
              if name in best and name not in names]
    pairs.sort(key=lambda p: (rank[p[0].candidate.name], rank[p[1].candidate.name]))
    return [(replay, scorer, plant, a, b, free_plant, refit) for a, b in pairs if _pairable(a, b)]


def _fit_pairs(replay, scorer, plant, tried, free_plant, refit, workers,
               track: _Tracker, ahead: Callable[[list[Pair]], bool]) -> tuple[list[Pair], int, bool]:
    """The pairs of :func:`_pair_jobs` fitted jointly, ``PAIR_BATCH`` at a time, until a batch
    ends with a pair within ``AT_NOISE`` of the noise floors; returns the pairs fitted, how
    many were left unfitted and whether ``ahead`` stopped them.  Past the noise floors another
    pair could only tie on the error, and the pairs come in the order of their members' ranks.
    What this gives up: a later pair at the floors with fewer parameters, which the BIC would
    prefer by ln n per parameter; ``_simplify`` recovers it where it is the simpler form of the
    same effect (Coulomb for Stribeck friction).  The batches are fixed (not the workers'
    count), so the answer does not depend on how many ran.

    ``ahead``: called once with the first batch, when more remain and none of it reached the
    floors; True stops the pairs there (the greedy ladder reaches the floors in two rungs, see
    :func:`_diagnose`)."""
    jobs = _pair_jobs(replay, scorer, plant, tried, free_plant, refit)
    each = track.stage("pairs", len(jobs))
    out: list[Pair] = []
    for start in range(0, len(jobs), PAIR_BATCH):
        out += _map(_run_pair, jobs[start:start + PAIR_BATCH], workers, each)
        if any(p.ok and p.result.weighted_rms <= AT_NOISE for p in out):
            break
        if start == 0 and len(jobs) > PAIR_BATCH and ahead(out):
            return out, len(jobs) - len(out), True
    return out, len(jobs) - len(out), False


STOPPED = ("noise floor", "nothing pays", "max steps", "time limit", "interrupted")
"""Why a ladder ends (``Diagnosis.stopped``): the model explains the record down to its noise; no
candidate pays; ``max_steps`` rungs; the ``time_limit_s`` was crossed (after the rung that crossed
it); Ctrl-C (:class:`DiagnosisInterrupted`)."""
STAGES = ("baseline", "calibration plan", "candidates", "joint refit", "calibration", "pairs", "simplify",
          "prune")
"""The stages of one rung, in order (``ProgressEvent.stage``); the first two come once, before the first."""


@dataclass(frozen=True)
class ProgressEvent:
    """Where a diagnosis is, for a progress display: ``diagnose(progress=f)`` calls ``f(event)``
    when a stage starts (``done`` 0) and after each fit of it.

    step: the ladder step being decided (1 = the first rung); stage: one of :data:`STAGES`;
    done, total: fits finished and to do in this stage; label: the fit just finished, e.g.
    ``"coulomb_friction (load)"``; best: the best fit of this stage so far, its label and
    weighted RMS (x the noise floors), "" before the first; elapsed_s: since the diagnosis
    started, s.  The next step's "candidates" and "joint refit" may come inside a step's "pairs"
    (the look-ahead, module docstring), and then not again at that step."""
    step: int
    stage: str
    done: int
    total: int
    label: str = ""
    best: str = ""
    elapsed_s: float = 0.0


class _Tracker:
    """Sends :class:`ProgressEvent` s to a callback (none: does nothing) and keeps the clock."""

    def __init__(self, callback: Callable[[ProgressEvent], None] | None):
        self.callback, self.t0, self.step = callback, time.perf_counter(), 1

    @property
    def elapsed_s(self) -> float:
        return time.perf_counter() - self.t0

    def stage(self, name: str, total: int = 1):
        """Announce stage ``name`` of ``total`` fits; returns the callback ``_map`` calls with each
        finished :class:`Tried` or :class:`Pair` (None without a callback)."""
        if self.callback is None:
            return None
        done, best = 0, None
        self.callback(ProgressEvent(self.step, name, 0, total, "", "", self.elapsed_s))

        def each(item):
            nonlocal done, best
            done += 1
            if item.ok and (best is None or item.result.bic < best[0]):
                best = (item.result.bic, f"{item.label()} at {item.result.weighted_rms:.3g}x noise")
            self.callback(ProgressEvent(self.step, name, done, total, item.label(), best[1] if best else "",
                                        self.elapsed_s))
        return each


from ..errors import DiagnosisInterrupted  # noqa: E402,F401 - defined in gearbench.errors, importable here


@dataclass
class Step:
    """One rung of the ladder: the effect added, its parameters, the error after
    it, and the whole refitted model at that point (``model``: effects as in a
    plant file, ``plant_params``: the free plant parameters)."""
    effect: str
    options: dict
    params: dict
    stderr: dict
    error: float
    relative_error_pct: float
    bic: float
    model: list
    plant_params: dict
    explanation: str = ""
    action: str = "add"     # "add", or "remove": an effect of an earlier rung that no longer pays
    correlations: list = field(default_factory=list)  # strongly correlated estimates (see _correlated)


@dataclass
class Diagnosis:
    baseline_error: float
    noise_floor: float
    unit: str
    signal: str
    tried: list[Tried]
    verdict: str | None
    ladder: list[Step]
    reason: str
    plant: Plant
    baseline: FitResult
    baseline_plant: Plant
    baseline_relative_pct: float
    calibration: dict = field(default_factory=dict)  # calibration.Plan.report of the final model
    calibration_step: CalibrationStep | None = None
    stopped: str = ""  # why the ladder ended: one of STOPPED
    noise: dict = field(default_factory=dict)  # column -> {floor, unit, stated}
    residual_tests: dict = field(default_factory=dict)  # column -> residuals.ResidualTest of the final model
    not_tried: dict = field(default_factory=dict)  # effect -> why it cannot act on this plant and record

    def ladder_steps(self) -> list[dict]:
        """The bars of ``report.compare.ladder_figure``: the baseline, each rung, and the
        calibration of the datasheet values where it came (``action: calibrate``)."""
        steps = [{"effect": "baseline", "error": self.baseline_error}]
        for i, s in enumerate(self.ladder + [None]):
            c = self.calibration_step
            if c is not None and c.after == i:
                steps.append({"effect": "calibrated", "error": c.result.error, "action": "calibrate"})
            if s is not None:
                steps.append({"effect": s.effect, "error": s.error, "action": s.action})
        return steps

    def to_json(self) -> dict:
        """The SPEC's ``diagnose --json`` object (plus units and explanations).

        ``candidates`` are the first rung's, best first by :data:`RANKING`; each carries
        ``effect``, ``options`` ({} when it has none), ``params``, ``error`` and ``bic``,
        ``stderr``, ``correlations``, the number ``k`` of fitted parameters, a ``status`` (``ok``, or
        ``failed`` with ``error`` and ``bic`` null) and a ``message`` saying why it failed.
        ``calibration``: per datasheet value its file value, final value, standard error,
        unit, tolerance and status (``calibrated``; ``held``, the record cannot resolve it;
        ``file value``, calibration did not pay), with a ``message``;
        ``calibration_step``: when calibration paid, after how many ladder steps, the error
        after it and its BIC change, else null.
        ``stopped``: why the ladder ended, one of :data:`STOPPED` (``reason`` says it in words).
        ``noise_floors``: per compared column its noise ``floor`` (the residuals' weight), ``unit``,
        and whether it was ``stated`` (``Replay.noise_std``) or read from the record.
        ``residual_tests``: per compared column, the final model's residual tests
        (``residuals.ResidualTest``: ``white``, ``input_independent``, ``lag1`` its lag-1
        autocorrelation, ``ljung_box_p``, ``sentence``).
        ``not_tried``: the effects of the library (of ``only``) that cannot act on this plant and
        record, each with why (:func:`not_tried`).
        ``correlations`` (candidates and rungs): ``[{a, b, rho}]``, the pairs of fitted parameters
        (full names, e.g. ``effects[1].stiffness``) whose estimates correlate beyond
        ``|rho| > 0.9`` (``uncertainty.STRONG_CORRELATION``), where a standard error alone misleads."""
        def cand(t: Tried) -> dict:
            d = {"effect": t.candidate.name, "options": dict(t.candidate.options), "params": t.params,
                 "error": t.result.error if t.ok else None, "bic": t.result.bic if t.ok else None,
                 "stderr": t.stderr if t.ok else {}, "correlations": _correlated(t.result) if t.ok else [],
                 "k": t.result.k if t.ok else None,
                 "status": "ok" if t.ok else "failed"}
            if t.note or not t.ok:
                d["message"] = t.note or "the fit did not converge"
            return d
        return {
            "ranking": RANKING,
            "baseline_error": self.baseline_error,
            "noise_floor": self.noise_floor,
            "error_signal": self.signal,
            "error_unit": self.unit,
            "error_metric": f"RMS of the {self.signal} residual (measured - simulated), {self.unit}",
            "candidates": [cand(t) for t in self.tried],
            "verdict": self.verdict,
            "reason": self.reason,
            "stopped": self.stopped,
            "baseline_relative_error_pct": self.baseline_relative_pct,
            "ladder": [{"effect": s.effect, "action": s.action, **({"options": s.options} if s.options else {}),
                        "params": s.params, "stderr": s.stderr, "error": s.error,
                        "relative_error_pct": s.relative_error_pct, "model": s.model,
                        "plant_params": s.plant_params, "explanation": s.explanation,
                        "correlations": s.correlations}
                       for s in self.ladder],
            "noise_floors": self.noise,
            "residual_tests": {name: {"input": t.input_name, "white": t.white,
                                      "input_independent": t.input_independent,
                                      "lag1": float(t.autocorrelation[1]), "ljung_box_p": t.ljung_box_p,
                                      "sentence": t.sentence()}
                               for name, t in self.residual_tests.items()},
            "not_tried": self.not_tried,
            "calibration": self.calibration,
            "calibration_step": None if self.calibration_step is None else {
                "after_step": self.calibration_step.after, "error": self.calibration_step.result.error,
                "bic_change": self.calibration_step.result.bic - self.calibration_step.before.bic},
        }


NOT_IN_LIBRARY = "; the missing physics is not in the library"


def _noise(replay: Replay, scorer: Scorer) -> dict:
    """Per weighed column: its noise floor, unit and whether it was stated."""
    return {n: {"floor": f, "unit": replay.unit(n), "stated": n in replay.noise_std} for n, f in scorer.floors.items()}


def _residual_tests(replay: Replay, plant: Plant, res: FitResult) -> dict:
    """The residual tests (``residuals.replay_residual_tests``) of the final model; {} where the
    windows are too short for them."""
    sim = res.sim if res.sim is not None else replay.run(plant)
    try:
        return replay_residual_tests(replay, plant, replay.residuals(sim), DEFAULT_LAGS)
    except ValueError:
        return {}


def _not_driven(reason: str, tests: dict, replay: Replay) -> str:
    """``reason`` of a ladder that ended above the noise floor, with what the residual tests say when
    the residual is independent of the input on every compared column: then no effect the input drives
    is missing, and what is left is noise (coloured: the floors read from a record's differences assume
    white noise and see a quarter of an AR(1) noise of lag-1 correlation 0.9) or a disturbance."""
    if not tests or not all(t.input_independent for t in tests.values()):
        return reason
    u = next(iter(tests.values())).input_name
    coloured = [f"{n} {t.autocorrelation[1]:.2f}" for n, t in tests.items() if not t.white]
    colour = f" but not white (lag-1 autocorrelation {', '.join(coloured)})" if coloured else ""
    if all(n in replay.noise_std for n in tests):
        cause = "noise larger than stated, or a disturbance the input does not drive"
    else:
        cause = ("noise that is not white, whose level the floors read from the record's differences "
                 "underestimate (state it where you know it: --noise SIGNAL=STD, noise_std in Python), "
                 "or a disturbance the input does not drive")
    return (reason.replace(NOT_IN_LIBRARY, "") + f". The residual left is independent of the input {u} on "
            f"every signal{colour}: what the model misses is not driven by the input, so it is not missing "
            f"physics; it is {cause}")


def _correlated(res: FitResult) -> list[dict]:
    """``[{a, b, rho}]``: the fit's pairs of estimates correlated beyond ``STRONG_CORRELATION``."""
    return [{"a": a, "b": b, "rho": rho} for a, b, rho in strong_correlations(res.correlation)]


def _same_effect(tried: list[Tried]) -> dict[str, list[Tried]]:
    groups: dict[str, list[Tried]] = {}
    for t in tried:
        if t.ok and t.candidate.options:
            groups.setdefault(t.candidate.name, []).append(t)
    return {k: g for k, g in groups.items() if len(g) > 1 and all(t.result.signals for t in g)}


def _rank(tried: list[Tried]) -> list[Tried]:
    """Best first by :data:`RANKING`: the BIC, and among the places of one effect the evidence
    of each signal (:func:`signal_evidence`)."""
    out = sorted(tried, key=lambda t: (not t.ok, t.result.bic if t.ok else math.inf))
    for group in _same_effect(out).values():
        slots = sorted(out.index(t) for t in group)
        for i, t in zip(slots, sorted(group, key=lambda t: signal_evidence(t.result))):
            out[i] = t
    return out


def _fit_all(replay, scorer, plant, cands, free_plant, refit, workers, progress, rounds_below=None):
    """Fit candidates in parallel (where the :class:`Executor` ``workers`` runs them); an item of
    ``cands`` may be ``(candidate, start values)``.  ``rounds_below``: see :func:`try_candidate`."""
    jobs = [(replay, scorer, plant, *(c if isinstance(c, tuple) else (c, None)), free_plant, refit)
            for c in cands]
    jobs = [(r, s, p, c, fp, rf, st, None, 0, rounds_below) for r, s, p, c, st, fp, rf in jobs]
    return _map(_run_candidate, jobs, workers, progress)


def _map(fn, jobs, workers: Executor, progress):
    """``fn`` over ``jobs`` where ``workers`` runs them (an :class:`Executor`: local processes or
    a Dask cluster), the results in the order of the jobs; the jobs with the most parameters to
    fit (:func:`_cost`) start first."""
    return workers.map(fn, jobs, progress, cost=[_cost(j) for j in jobs])


def _cost(job) -> int:
    """A job's expected run time, for the order the jobs start in: the parameters it fits (a
    candidate's, or a pair's both; the scan takes 8 points per parameter, the local fits' finite
    differences one replay per parameter)."""
    members = [t.candidate if isinstance(t, Tried) else t for t in job if isinstance(t, (Candidate, Tried))]
    return sum(len(REGISTRY[c.name].params) for c in members)


def _pays(current: FitResult, new: FitResult) -> bool:
    """The BIC falls by more than MIN_BIC_DROP and the noise-weighted RMS error of all compared
    signals by more than MIN_ERROR_DROP."""
    return (current.bic - new.bic > MIN_BIC_DROP
            and new.weighted_rms < (1.0 - MIN_ERROR_DROP) * current.weighted_rms)


def _at_seams(scorer: Scorer, res: FitResult, seams: tuple) -> FitResult:
    """``res``'s plant scored with the replay's angles moved at exactly ``seams``
    (``Replay.resets_frozen``), its ``k`` kept; made once per seams."""
    if seams == res.seams:
        return res
    if seams not in res.rescored:
        with scorer.replay.resets_frozen(seams):
            res.rescored[seams] = evaluate(scorer.replay, scorer, res.plant, res.k)
    return res.rescored[seams]


def _accepts(scorer: Scorer, current: FitResult, new: FitResult) -> bool:
    """An added effect pays (:func:`_pays`), and it still does with both models' angles moved at
    the same window seams: the current model's, and the new one's.

    A window's reset sets the model's angles from the record, fitted values the BIC does not
    count, and where the noise is coloured and not stated the test that decides a reset fires on
    the noise (``Replay``).  An effect could then pay by where the replay resets rather than by
    what it does: on 16 s of the bench rig with nothing hidden and AR(1) noise (lag-1 correlation
    0.9) read from the record, a Stribeck friction of 4.7e-7 N m at the motor moved the resets
    from 8 seams to 10 and the weighted RMS from 3.579 to 3.470 (3.04 %); at the right model's 8
    seams it gave 3.669, and the right model at its 10 gave 3.502."""
    if not _pays(current, new):
        return False
    if new.seams == current.seams:
        return True
    return (_pays(current, _at_seams(scorer, new, current.seams))
            and _pays(_at_seams(scorer, current, new.seams), new))


def _seams_text(scorer: Scorer, current: FitResult, new: FitResult) -> str:
    """Why ``new`` does not pay though it would by its own resets (:func:`_accepts`), else ''."""
    if not _pays(current, new):
        return ""
    new_at, current_at = _at_seams(scorer, new, current.seams), _at_seams(scorer, current, new.seams)
    return (f"; it would pay only by where the replay resets the angles (at {len(new.seams)} window seams against "
            f"the model's {len(current.seams)}): with the resets at the same seams, the model's give it "
            f"{new_at.weighted_rms:.4g}x against {current.weighted_rms:.4g}x, and its own give the model "
            f"{current_at.weighted_rms:.4g}x against {new.weighted_rms:.4g}x; state the noise (--noise, "
            f"--noise-from) if it is coloured")


def _better_pair(replay, scorer, current, current_res, best, tried, free_plant, added, workers, track,
                 ahead: Callable[[], bool]):
    """The pair of lowest BIC (:func:`_fit_pairs`) when it beats both the current model and the
    best single candidate by :func:`_accepts` (else None: none does, or the best single already
    explains the record down to its noise, nothing left for a pair to resolve), and how many pairs
    were left unfitted.  ``ahead``, the next rung's screen on the best single (True: its best is
    at the floors), runs when none of the first batch pays, and then a True ends the pairs with
    None: the greedy ladder reaches the floors, where none of them is."""
    if best.result.weighted_rms <= AT_NOISE or current_res.weighted_rms <= AT_NOISE:
        return None, 0

    def pays(p: Pair) -> bool:
        return p.ok and _accepts(scorer, current_res, p.result) and _accepts(scorer, best.result, p.result)
    fitted, unfitted, greedy = _fit_pairs(replay, scorer, current, tried, free_plant, added, workers, track,
                                          lambda batch: not any(pays(p) for p in batch) and ahead())
    pairs = [p for p in fitted if p.ok]
    if not pairs or greedy:
        return None, unfitted
    pair = min(pairs, key=lambda p: p.result.bic)
    return (pair if pays(pair) else None), unfitted


def _pair_text(pair: Pair, best: Tried, unfitted: int) -> str:
    """Why two rungs at once: the pair against the best single candidate."""
    r, b = pair.result, best.result
    rest = (f" The {unfitted} pair{'s' if unfitted > 1 else ''} ranked after {'were' if unfitted > 1 else 'was'} "
            f"not fitted: a pair fitted before reached the noise floors." if unfitted else "")
    return (f"Added with the next rung as a pair: fitted jointly, {pair.label()} take the weighted RMS to "
            f"{r.weighted_rms:.4g}x the noise floors (BIC {r.bic - b.bic:+.1f} against the best single candidate, "
            f"{best.candidate.label()}, at {b.weighted_rms:.4g}x): each alone is confounded with the other.{rest}")


def _simplify(replay, scorer, res: FitResult, added: tuple[int, ...], free_plant) -> tuple[FitResult, list]:
    """Replace each added effect by its simpler form (``Effect.simpler``: Stribeck
    by Coulomb, asymmetric by symmetric friction) when, refitted with the others,
    the BIC says the extra parameters do not pay.  Returns the result and notes."""
    notes = []
    for i in added:
        e = res.plant.effects[i]
        simpler = e.effect.simpler(e.values)
        if simpler is None:
            continue
        effects = list(res.plant.effects)
        effects[i] = AddedEffect(*simpler)
        r = _refit(replay, scorer, replace(res.plant, effects=tuple(effects)), free_plant, added)
        if r is not None and r.bic <= res.bic:
            notes.append((i, e.name, simpler[0], res.bic - r.bic))
            res = r
    return res, notes


def _calibrate(replay, scorer, model: Plant, res: FitResult, free_plant, cal_frees: list[Free],
               added: tuple[int, ...]) -> FitResult | None:
    """The datasheet values ``cal_frees`` fitted with ``free_plant`` and the effects numbered
    ``added`` (:func:`_refit`, central differences, restarts), from the model's values; where that
    pays (:func:`_accepts` against ``res``) but leaves more than ``AT_NOISE`` x the noise floors,
    also from the best points of a scan of the tolerance box (``calibration.starts``), the best
    fit kept.  On 8 s of the bench rig with p04's datasheet errors and Coulomb friction hidden at
    the load, fitted with the friction: from the file's values 25.9x the noise floors (load
    inertia 0.00545 kg m^2 for 0.006), from the scan's best points 2.07x, the truth 0.99x; in the
    ladder, after a pair with a load spring, 0.988x (``tests/test_datasheet.py``)."""
    cal = _refit(replay, scorer, model, tuple(free_plant) + tuple(cal_frees), added, central=True,
                 restarts=CALIBRATION_RESTARTS)
    if cal is None or cal.weighted_rms <= AT_NOISE or not _accepts(scorer, res, cal):
        return cal
    frees = _frees(replay, model, tuple(cal_frees) + tuple(free_plant), added)
    fits = [fit(replay, model, frees, scorer, start=list(x), central=True, restarts=CALIBRATION_RESTARTS)
            for x in calibration.starts(replay, scorer, model, frees, len(cal_frees))]
    return _best_fit([cal] + [f for f in fits if f.converged])


def _model(plant: Plant, free_plant) -> tuple[list, dict]:
    """A rung's ``model`` (effects as in a plant file) and ``plant_params`` (the free plant values)."""
    return [e.to_dict() for e in plant.effects], {f.name: get_value(plant, f) for f in plant_frees(plant, free_plant)}


def _without(res: FitResult, i: int, first: int, replay, scorer, free_plant) -> FitResult | None:
    """The model of ``res`` without effect ``i``, the other ladder effects (numbers
    ``first`` on) and the free plant parameters refitted from where they are."""
    effects = res.plant.effects[:i] + res.plant.effects[i + 1:]
    return _refit(replay, scorer, replace(res.plant, effects=effects), free_plant, range(first, len(effects)))


def _frees(replay, plant: Plant, free_plant, effects) -> list[Free]:
    """The free plant values ``free_plant`` (paths or ``Free``s), then the parameters of the
    effects numbered in ``effects``."""
    frees = plant_frees(plant, free_plant)
    for j in effects:
        frees += Free.effect(plant, j, replay.data.sample_time_s)
    return frees


def _refit(replay, scorer, plant: Plant, free_plant, effects, central: bool = False,
           restarts: int = 0) -> FitResult | None:
    """``plant`` with the free plant values ``free_plant`` (paths or ``Free``s) and the parameters
    of the effects numbered in ``effects`` fitted jointly (scored as it is when there are none);
    None when it cannot be simulated or does not converge.  ``central``, ``restarts``: see :func:`fit`."""
    frees = _frees(replay, plant, free_plant, effects)
    try:
        r = (fit(replay, plant, frees, scorer, central=central, restarts=restarts) if frees
             else evaluate(replay, scorer, plant))
    except (ReplayError, ValueError):
        return None
    return r if r.converged else None


def _prune(replay, scorer, res: FitResult, first: int, free_plant) -> list[tuple[AddedEffect, FitResult, float]]:
    """Stepwise backwards: with two or more effects on the ladder, each is refitted out
    (the newest too: it was judged against the model before it, not against the same
    effects refitted); one whose removal the model with it does not beat by the criterion
    that added it (:func:`_accepts`) no longer pays and comes out, the one that pays least
    first, until every effect left pays.  Returns ``(removed effect, model without it, BIC
    change)``."""
    out = []
    while len(res.plant.effects) - first >= 2:
        options = []
        for i in range(first, len(res.plant.effects)):
            r = _without(res, i, first, replay, scorer, free_plant)
            if r is not None and not _accepts(scorer, r, res):
                options.append((r.bic - res.bic, i, r))
        if not options:
            break
        gain, i, r = min(options, key=lambda o: o[0])
        out.append((res.plant.effects[i], r, gain))
        res = r
    return out


@dataclass
class _NextRung:
    """The next rung's screen, made during a rung's pair stage (``_diagnose``'s ``look_ahead``):
    ``fitted`` is the model with the rung's best candidate added alone and simplified (``notes``),
    ``tried`` the candidates ranked on it."""
    fitted: FitResult
    notes: list
    tried: list[Tried]


@dataclass
class CalibrationStep:
    """The plant's datasheet values calibrated (``calibration.plan``'s), after ``after`` ladder
    steps: the model before and after."""
    after: int
    before: FitResult
    result: FitResult


@single_threaded
def diagnose(plant: Plant, replay: Replay, free_plant: tuple[str, ...] = (), max_steps: int = 4,
             workers: int | None = None, progress: Callable[[ProgressEvent], None] | None = None,
             only: tuple[str, ...] = (), calibrate: bool = True, time_limit_s: float | None = None,
             scheduler: str | None = None) -> Diagnosis:
    """Diagnose ``plant`` against the replayed record and climb the ladder.

    Each rung fits every candidate with the effects added so far held (cheap),
    then refits the best ``JOINT_TOP`` jointly with them (the first rung's
    friction must give back what a later viscous term explains), accepts the
    best if it pays (``_accepts``), tries the simpler forms of what was added
    (``_simplify``), and takes out what no longer pays (``_prune``).

    free_plant: plant parameters refitted with every candidate (and in the
    baseline), e.g. ``("leadscrew.mass",)``; workers: processes (default: all
    usable cores, ``gearbench.workers``); only: restrict the candidates to
    these effect names (a model structure); calibrate: the plant's own
    datasheet values within their tolerances (``calibration.plan``) may be
    calibrated, once, as a step that competes with each rung's best effect by
    the criterion that adds an effect (``_accepts``; the lower BIC wins), with
    the effects already added refitted; from then on they are refitted with
    every joint refit.  A calibration is not a verdict, and the effects that no
    longer pay once it is in are taken out.

    progress: called with a :class:`ProgressEvent` as each stage starts and each fit
    finishes; time_limit_s: no new rung is started once this many seconds have passed
    (the rung that crosses it finishes; ``stopped`` is ``"time limit"``).  Ctrl-C during the
    ladder raises :class:`DiagnosisInterrupted`, which carries the ladder so far.
    scheduler: the address of a running Dask scheduler (``tcp://HOST:PORT``,
    connected once for the whole diagnosis; ``workers`` is then ignored): what
    runs on ``workers`` processes otherwise runs there (``executor``), one task
    per fit, the answer the same as a local run's: each rung's candidate fits,
    the best ``JOINT_TOP`` refitted with the effects already added, and the pair
    fits.  The baseline, the calibration plan and step, the simplification and
    the pruning stay in this process.  An unreachable scheduler raises
    :class:`gearbench.workers.SchedulerError` before any fitting.
    """
    with Executor(workers, scheduler) as where:
        return _diagnose(plant, replay, free_plant, max_steps, where, progress, only, calibrate, time_limit_s)


def _diagnose(plant: Plant, replay: Replay, free_plant: tuple[str, ...], max_steps: int, workers: Executor,
              progress, only: tuple[str, ...], calibrate: bool, time_limit_s: float | None) -> Diagnosis:
    """:func:`diagnose`, its candidate and pair fits run by ``workers``."""
    unknown = [n for n in only if n not in REGISTRY]
    if unknown:
        raise ValueError(f"unknown effect(s) {', '.join(unknown)}; the library has {', '.join(REGISTRY)}")
    track = _Tracker(progress)
    track.stage("baseline")
    scorer = Scorer(replay)
    frees = plant_frees(plant, free_plant)
    base = fit(replay, plant, frees, scorer) if frees else evaluate(replay, scorer, plant)
    if not base.converged:
        raise ReplayError(f"the baseline fit of {', '.join(free_plant)} did not converge: {base.message}")
    unit = replay.unit(scorer.primary)
    if calibrate:
        track.stage("calibration plan")
    cal = calibration.plan(plant, replay, scorer) if calibrate else calibration.Plan()
    cal_step: CalibrationStep | None = None
    refitted = tuple(free_plant)  # the calibrated values join once calibration has paid
    current, current_res = base.plant, base
    ladder: list[Step] = []
    rungs: list[int] = []  # the ladder step that added each effect of the model past the plant's own
    first_tried: list[Tried] = []
    reason, stopped = "", "max steps"

    def prune(after: str):
        nonlocal current, current_res
        track.stage("prune", max(0, len(current_res.plant.effects) - len(plant.effects)))
        for gone, without, gain in _prune(replay, scorer, current_res, len(plant.effects), refitted):
            rungs.pop(current_res.plant.effects.index(gone) - len(plant.effects))
            opts = {k: v for k, v in gone.values.items() if isinstance(v, str)}
            ladder.append(Step(gone.name, opts, {k: v for k, v in gone.values.items() if not isinstance(v, str)},
                               {}, without.error, scorer.relative_pct(without.sim), without.bic,
                               *_model(without.plant, refitted),
                               f"Taken out at step {len(ladder) + 1}: once {after} is in, "
                               f"{gone.name} no longer pays; refitted without it the error is "
                               f"{without.error:.4g} {unit} against {current_res.error:.4g} {unit}, the BIC "
                               f"{'rises' if gain > 0 else 'falls'} by {abs(gain):.1f} (an effect must lower it by "
                               f"more than {MIN_BIC_DROP:g} and the weighted RMS by {MIN_ERROR_DROP:.0%} to stay).",
                               action="remove"))
            current, current_res = without.plant, without

    def screen(model: Plant, res: FitResult) -> list[Tried]:
        """A rung's candidates ranked: each fitted with the model's effects and calibrated values held
        (cheap), then the best ``JOINT_TOP`` refitted with them."""
        added = tuple(range(len(plant.effects), len(model.effects)))
        cands = candidates(model, replay, only)
        tried = _rank(_fit_all(replay, scorer, model, cands, free_plant, (), workers,
                               track.stage("candidates", len(cands)), res.rss))
        if added:
            top = [(t.candidate, {**t.candidate.options, **t.params}) for t in tried[:JOINT_TOP] if t.ok]
            joint = _fit_all(replay, scorer, model, top, refitted, added, workers,
                             track.stage("joint refit", len(top)))
            tried = _rank(joint + tried[len(top):])
        return tried

    def alone(best: Tried, added: tuple[int, ...]) -> tuple[FitResult, list]:
        """The model with ``best`` added alone, simplified (``_simplify``: the result and its notes)."""
        return _simplify(replay, scorer, best.result, added + (len(current.effects),), refitted)

    def look_ahead(best: Tried, added: tuple[int, ...]) -> bool:
        """The next rung's screen on the model with ``best`` alone (simplified), kept for that rung in
        ``next_rung``; True when its best pays and reaches the noise floors (``_better_pair``)."""
        nonlocal next_rung
        fitted, notes = alone(best, added)
        track.step += 1
        try:
            next_rung = _NextRung(fitted, notes, screen(fitted.plant, fitted))
        finally:
            track.step -= 1
        nxt = next_rung.tried[0] if next_rung.tried and next_rung.tried[0].ok else None
        return nxt is not None and nxt.result.weighted_rms <= AT_NOISE and _accepts(scorer, fitted, nxt.result)

    def _result() -> Diagnosis:
        verdict = ladder[rungs[0]].effect if rungs else None
        tests = {} if stopped == "interrupted" else _residual_tests(replay, current, current_res)
        said = reason
        if stopped == "nothing pays" and current_res.weighted_rms > AT_NOISE:
            said = _not_driven(reason, tests, replay)
        return Diagnosis(base.error, scorer.noise_floor, unit, scorer.primary, first_tried, verdict, ladder,
                         said, current, base, base.plant, scorer.relative_pct(base.sim),
                         cal.report(current, current_res.stderr, cal_step is not None), cal_step, stopped,
                         _noise(replay, scorer), tests, not_tried(plant, replay, only))

    next_rung: _NextRung | None = None
    step = 0
    try:
        while step < max_steps:
            track.step = len(ladder) + 1
            if (ladder or cal_step) and current_res.weighted_rms <= AT_NOISE:
                reason = (f"after {len(ladder)} step(s){' and the calibration' if cal_step else ''} the model "
                          f"explains the record down to its noise: error {current_res.error:.4g} {unit} against a "
                          f"noise floor of {scorer.noise_floor:.4g} {unit} (all signals: "
                          f"{current_res.weighted_rms:.3g}x their noise floors)")
                stopped = "noise floor"
                break
            if time_limit_s is not None and (ladder or cal_step) and track.elapsed_s > time_limit_s:
                reason = (f"stopped by the time limit: {track.elapsed_s:.0f} s had passed (time limit "
                          f"{time_limit_s:g} s) after {len(ladder)} step(s); error {current_res.error:.4g} {unit}, "
                          f"{current_res.weighted_rms:.3g}x the noise floors")
                stopped = "time limit"
                break
            added = tuple(range(len(plant.effects), len(current.effects)))
            reuse = next_rung is not None and next_rung.fitted.plant is current
            tried = next_rung.tried if reuse else screen(current, current_res)
            next_rung = None
            if not first_tried:
                first_tried = tried
            best = tried[0] if tried and tried[0].ok else None
            if cal.frees and cal_step is None:
                track.stage("calibration")
                cal_res = _calibrate(replay, scorer, current, current_res, refitted, cal.frees, added)
                if cal_res is not None and _accepts(scorer, current_res, cal_res) and (
                        best is None or not _accepts(scorer, current_res, best.result) or cal_res.bic <= best.result.bic):
                    cal_step = CalibrationStep(len(ladder), current_res, cal_res)
                    refitted += tuple(cal.frees)
                    current, current_res = cal_res.plant, cal_res
                    prune("the calibration")
                    continue  # not a rung: the effects are tried again on the calibrated plant
            if best is None or not _accepts(scorer, current_res, best.result):
                if best is None:
                    gain = "no candidate is left to try" if not tried else "no candidate could be fitted"
                else:
                    gain = (f"the best, {best.candidate.label()}, would take the error to "
                            f"{best.result.error:.4g} {unit} (BIC change {best.result.bic - current_res.bic:+.1f}, "
                            f"weighted RMS {current_res.weighted_rms:.4g} -> {best.result.weighted_rms:.4g}; an "
                            f"added effect must lower the BIC by more than {MIN_BIC_DROP:g} and the weighted RMS "
                            f"by {MIN_ERROR_DROP:.0%}){_seams_text(scorer, current_res, best.result)}")
                calibrated = " once its datasheet values are calibrated" if cal_step else ""
                stopped = "noise floor" if current_res.weighted_rms <= AT_NOISE else "nothing pays"
                if step > 0:
                    reason = f"after {len(ladder)} step(s) nothing more pays: {gain}"
                elif current_res.weighted_rms <= AT_NOISE:
                    reason = (f"the model explains the record down to its noise{calibrated}: error "
                              f"{current_res.error:.4g} {unit} against a noise floor of {scorer.noise_floor:.4g} {unit} "
                              f"(all signals: {current_res.weighted_rms:.3g}x their noise floors); {gain}")
                else:
                    reason = (f"no candidate explains the residual: the error {current_res.error:.4g} {unit} stays "
                              f"{current_res.error / scorer.noise_floor:.3g}x the noise floor ({scorer.noise_floor:.4g} "
                              f"{unit}){calibrated} and {gain}{NOT_IN_LIBRARY}")
                break
            pair, unfitted = (_better_pair(replay, scorer, current, current_res, best, tried, refitted, added,
                                           workers, track, lambda: look_ahead(best, added))
                              if len(ladder) + 2 <= max_steps else (None, 0))
            track.stage("simplify")
            if pair is None:
                text = explain(replay, scorer, current_res, best, tried)
                fitted, notes = (next_rung.fitted, next_rung.notes) if next_rung is not None else alone(best, added)
            else:
                first, second = pair.first, pair.as_second()
                ladder.append(Step(first.candidate.name, first.candidate.options, first.params, first.stderr,
                                   first.result.error, scorer.relative_pct(first.result.sim), first.result.bic,
                                   *_model(first.result.plant, refitted),
                                   explain(replay, scorer, current_res, first, tried) + " "
                                   + _pair_text(pair, best, unfitted),
                                   correlations=_correlated(first.result)))
                rungs.append(len(ladder) - 1)
                best = second
                text = explain(replay, scorer, first.result, second) + (
                    f" Fitted jointly with {first.candidate.label()} (the pair's rung before).")
                fitted, notes = _simplify(replay, scorer, pair.result, added + (len(current.effects),
                                                                                 len(current.effects) + 1), refitted)
            ladder.append(Step(best.candidate.name, best.candidate.options, best.params, best.stderr,
                               fitted.error, scorer.relative_pct(fitted.sim), fitted.bic,
                               *_model(fitted.plant, refitted),
                               text, correlations=_correlated(best.result)))
            rungs.append(len(ladder) - 1)
            for i, old, new, gain in notes:
                rung = ladder[rungs[i - len(plant.effects)]]
                e = fitted.plant.effects[i]
                rung.effect = new
                rung.params = {k: v for k, v in e.values.items() if not isinstance(v, str)}
                rung.explanation += (f" Simplified at step {len(ladder)}: {new} explains as well as {old} once "
                                     f"the later effects are in (BIC lower by {gain:.1f}), so the extra "
                                     "parameters do not pay.")
            current, current_res = fitted.plant, fitted
            prune(best.candidate.label())
            step += 1
        if step >= max_steps:
            reason = (f"the ladder reached its longest, {max_steps} step(s) (max_steps); error "
                      f"{current_res.error:.4g} {unit}, {current_res.weighted_rms:.3g}x the noise floors")
    except BaseException as exc:
        if not is_interrupt(exc):
            raise
        reason, stopped = f"interrupted during step {len(ladder) + 1}", "interrupted"
        raise DiagnosisInterrupted(_result()) from None
    return _result()
