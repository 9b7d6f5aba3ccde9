"""What a diagnosis gives back: the ladder as steps with their sentences, the verdict, the
noise floors, the residual tests and the calibration, in one :class:`Diagnosis` with the SPEC's
``diagnose --json`` object (:meth:`Diagnosis.to_json`).  :func:`diagnosis` builds it from the
climb's last state (``ladder``), writing every sentence there (``explain``)."""
from __future__ import annotations

import math

from dataclasses import dataclass, field

from ..plant.components import Plant
from .candidates import RANKING, Tried
from .explain import not_driven, reason, rivals, rung_text, simplified_text
from .fit import FitResult
from .scoring import Scorer
from .ladder import CalibrationStep, Context, State, correlated, refined
from .policy import Policy
from .missing import MissingTorque, missing_torque
from .replay import Replay
from .residuals import DEFAULT_LAGS, replay_residual_tests

STOPPED = ("noise floor", "nothing pays", "max steps", "time limit", "interrupted")
"""Why a ladder ends (``Diagnosis.stopped``): the model explains the record down to its noise; no
candidate pays; ``max_steps`` rungs; the ``time_limit_s`` was crossed (after the rung that crossed
it); Ctrl-C (:class:`DiagnosisInterrupted`)."""

@dataclass(frozen=True)
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
    rivals: list = field(default_factory=list)  # candidates the record does not tell apart (explain.rivals)


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
    timing: dict = field(default_factory=dict)  # timing.Timing.report(): where the time went
    gaps: dict | None = None  # measure.gaps.Gaps.to_dict() of the record's missing samples, when asked to fill them
    missing: MissingTorque | None = None  # the final model's residual as a torque, when it ends above its noise
    # the final model's values: how far the replay's tolerance had moved each (by name, own unit), and
    # whether that has been taken out (numerics.refine, ladder.refined)
    numerical: dict = field(default_factory=dict)
    refined: bool = False

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

    def rows(self) -> list:
        """The ladder's rows after the baseline: ``(number, Step)``, and ``(None, error)`` where the
        datasheet values were calibrated."""
        rungs = iter(enumerate(self.ladder, 1))
        return [(None, st["error"]) if st.get("action") == "calibrate" else next(rungs)
                for st in self.ladder_steps()[1:]]

    def to_markdown(self, title: str) -> str:
        """``diagnose.md``: the verdict, the ladder with each rung's explanation, what was not tried,
        the calibration; ``ladder.png`` beside it."""
        unit, cal = self.unit, self.calibration
        md = [f"# {title}", "",
              f"Error: RMS of the {self.signal} residual (measured - simulated), {unit}. Baseline "
              f"{self.baseline_error:.4g} {unit}, noise floor {self.noise_floor:.4g} {unit}.",
              "", f"Verdict: **{self.verdict}**" if self.verdict else f"Verdict: none. {self.reason}.", "",
              "| step | effect | parameters | error |", "|---|---|---|---|",
              f"| 0 | (baseline) | | {self.baseline_error:.4g} {unit} |"]
        for i, s in self.rows():
            md.append(f"| | (datasheet values calibrated, below) | | {s:.4g} {unit} |" if i is None else
                      f"| {i} | {'- ' if s.action == 'remove' else ''}{s.effect} {s.options or ''} | "
                      + ", ".join(f"{p} = {v:.4g}" for p, v in s.params.items()) + f" | {s.error:.4g} {unit} |")
        md += [""] + [f"{i}. {s.explanation}" for i, s in enumerate(self.ladder, 1)] + ["", "![ladder](ladder.png)"]
        if self.refined:
            moved = ", ".join(f"{n} {v:+.3g}" for n, v in self.numerical.items() if v)
            md += ["", "The final model's fit was finished at a hundredth of the replay's solver tolerance, "
                   f"which moved its values ({moved}; `numerical` in `diagnose.json`)."]
        if self.missing is not None:
            md += ["", "## The torque the model misses", "", self.missing.sentence() + ".", "",
                   "![missing torque](missing_torque.png)"]
        if self.not_tried:
            md += ["", "Not tried (they cannot act on this plant and record):", ""]
            md += [f"- {name}: {why}" for name, why in self.not_tried.items()]
        if cal:
            md += ["", "## Calibration of the plant's own values (the final model)", "",
                   "| value | file | calibrated | standard error | unit | tolerance | |", "|---|---|---|---|---|---|---|"]
            md += [f"| {k} | {c['nominal']:.6g} | {c['value']:.6g} | "
                   f"{'' if c['stderr'] is None else format(c['stderr'], '.3g')} | {c['unit']} | {c['tolerance_pct']:g} % | "
                   f"{c['status']}{': ' + c['message'] if c.get('message') else ''} |" for k, c in cal.items()]
        return "\n".join(md) + "\n"

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
        whether it was ``stated`` (``Replay.noise_std``) or read from the record, and its ``rule``
        (``Replay.noise_rule``), and its ``final_rms`` and ``over_read`` (:func:`noise`).
        ``residual_tests``: per compared column, the final model's residual tests
        (``residuals.ResidualTest``: ``white``, ``input_independent``, ``lag1`` its lag-1
        autocorrelation, ``ljung_box_p``, ``sentence``).
        ``not_tried``: the effects of the library (of ``only``) that cannot act on this plant and
        record, each with why (:func:`not_tried`).
        ``gaps`` (with ``gaps=``/``--gaps``): the missing samples filled or dropped, ``Gaps.to_dict()``.
        ``correlations`` (candidates and rungs): ``[{a, b, rho}]``, the pairs of fitted parameters
        (full names, e.g. ``effects[1].stiffness``) whose estimates correlate beyond
        ``|rho| > 0.9`` (``uncertainty.STRONG_CORRELATION``), where a standard error alone misleads.
        ``numerical``, ``refined``: ``ladder.refined`` of the final model (``docs/diagnose-json.md``).
        ``missing_torque``: when the ladder ends above the record's noise (not stopped at the noise
        floor, not interrupted), the final model's residual as the torque that would explain it,
        :meth:`missing.MissingTorque.to_dict` (``signal``, ``unit``, ``rms``, ``signatures``, ``resembles``,
        ``resembles_words``, ``against``: binned means against ``position_deg``, ``speed_deg_s``,
        ``time_s``, and a ``sentence``); else null.
        ``timing``: where the time went (``timing.Timing.report``), ``{"wall_s", "stages": [{"stage",
        "wall_s", "replays", "solver_steps", "fits"}], "candidates": [{"effect", "wall_s", "replays",
        "fits"}]}``: per stage of :data:`~gearbench.identify.progress.STAGES` (each once, summed over
        the rungs, in the order they first came) and per candidate effect (its places and rungs summed;
        a pair ``"a+b"``); ``docs/diagnose-json.md``."""
        return {
            "ranking": RANKING,
            "baseline_error": self.baseline_error,
            "noise_floor": self.noise_floor,
            "error_signal": self.signal,
            "error_unit": self.unit,
            "error_metric": f"RMS of the {self.signal} residual (measured - simulated), {self.unit}",
            "candidates": [candidate_json(t) for t in self.tried],
            "verdict": self.verdict,
            "reason": self.reason,
            "stopped": self.stopped,
            "baseline_relative_error_pct": self.baseline_relative_pct,
            "ladder": [step_json(s) for s in self.ladder],
            "noise_floors": self.noise,
            "residual_tests": {name: residual_test_json(t) for name, t in self.residual_tests.items()},
            "not_tried": self.not_tried,
            **({"gaps": self.gaps} if self.gaps else {}),
            "calibration": self.calibration,
            "calibration_step": calibration_step_json(self.calibration_step),
            "missing_torque": None if self.missing is None else self.missing.to_dict(),
            "numerical": self.numerical,
            "refined": self.refined,
            "timing": self.timing,
        }


def calibration_step_json(c: CalibrationStep | None) -> dict | None:
    """``diagnose --json``'s ``calibration_step``: after which step, the error after it, its BIC change."""
    return None if c is None else {"after_step": c.after, "error": c.result.error,
                                   "bic_change": c.result.bic - c.before.bic}


def step_json(s) -> dict:
    """One step of ``diagnose --json``'s ``ladder`` (:meth:`Diagnosis.to_json`)."""
    return {"effect": s.effect, "action": s.action, **({"options": s.options} if s.options else {}),
            "params": s.params, "stderr": s.stderr, "error": s.error,
            "relative_error_pct": s.relative_error_pct, "model": s.model,
            "plant_params": s.plant_params, "explanation": s.explanation,
            "correlations": s.correlations, "rivals": s.rivals}


def residual_test_json(t) -> dict:
    """One column's ``residual_tests`` entry of ``diagnose --json`` (:class:`residuals.ResidualTest`)."""
    return {"input": t.input_name, "white": t.white, "input_independent": t.input_independent,
            "lag1": float(t.autocorrelation[1]), "ljung_box_p": t.ljung_box_p, "sentence": t.sentence()}


def candidate_json(t: Tried) -> dict:
    """One candidate of ``diagnose --json`` (:meth:`Diagnosis.to_json`)."""
    d = {"effect": t.candidate.name, "options": dict(t.candidate.options), "params": t.params,
         "error": t.result.error if t.ok else None, "bic": t.result.bic if t.ok else None,
         "stderr": t.stderr if t.ok else {}, "correlations": correlated(t.result) if t.ok else [],
         "k": t.result.k if t.ok else None,
         "status": "ok" if t.ok else "failed"}
    if t.note or not t.ok:
        d["message"] = t.note or "the fit did not converge"
    return d


def noise(replay: Replay, scorer: Scorer, res: FitResult | None = None,
          at_noise: float = Policy.at_noise) -> dict:
    """Per weighed column: its noise floor, unit, whether it was stated, and the rule it was read by;
    with the final model ``res`` (None: interrupted), the RMS of its residual there (``final_rms``, the column's unit)
    and whether the floor, read from the record, is ``over_read``: above that RMS by more than
    ``at_noise`` (the ladder's ``Policy.at_noise``: a model within it of a floor is at it, so one
    that far below it is not).  No model leaves less than the noise, so such a floor is not the noise's:
    the record's motion shows in its third differences (a record sampled at 100 Hz, a PRBS's steps
    in the current), and "at the noise floor" is then an upper bound."""
    out = {}
    per = res.signals if res is not None else {}  # column -> (weighted RSS, n), scored with the fit
    for n, f in scorer.floors.items():
        out[n] = {"floor": f, "unit": replay.unit(n), "stated": n in replay.noise_std, "rule": scorer.rules[n]}
        if n in per:
            rss, count = per[n]
            rms = f * math.sqrt(rss / count)
            out[n]["final_rms"] = rms
            out[n]["over_read"] = n not in replay.noise_std and rms * at_noise < f
    return out


def over_read(reason: str, floors: dict) -> str:
    """``reason`` with a sentence on the floors :func:`noise` found over-read, if any."""
    high = [f"{n} ({c['final_rms']:.3g} against {c['floor']:.3g} {c['unit']})"
            for n, c in floors.items() if c.get("over_read")]
    if not high:
        return reason
    return (reason + ". But the final model leaves less than the noise floor read from the record on "
            + ", ".join(high) + ": those floors are not the noise's (the record's motion shows in its third "
            "differences at this sample rate), so the floors are an upper bound; state the noise where "
            "you know it (--noise SIGNAL=STD, --noise-from REST.csv) to test further")


def residual_tests(replay: Replay, plant: Plant, res: FitResult) -> dict:
    """The residual tests (``residuals.replay_residual_tests``) of the final model; {} where the
    windows are too short for them."""
    sim = res.sim if res.sim is not None else replay.run(plant)
    try:
        return replay_residual_tests(replay, plant, replay.residuals(sim), DEFAULT_LAGS)
    except ValueError:
        return {}


def steps(ctx: Context, state: State) -> list[Step]:
    """The rungs as the ladder's steps, each with its explanation, and each effect a later
    rung simplified shown in its simpler form, with a sentence saying when and why."""
    texts = [rung_text(ctx, r, i + 1) for i, r in enumerate(state.rungs)]
    shown = [(r.effect, r.params) for r in state.rungs]
    for i, r in enumerate(state.rungs):
        for s in r.simplified:
            shown[s.rung] = (s.new, s.params)
            texts[s.rung] += simplified_text(s, i + 1)
    out = []
    for r, text, (effect, params) in zip(state.rungs, texts, shown):
        res = r.result
        out.append(Step(effect, r.options, params, r.stderr, res.error, ctx.scorer.relative_pct(res.sim), res.bic,
                        r.model, r.plant_params, text, r.action, r.correlations, rivals(ctx, r)))
    return out


def diagnosis(ctx: Context, state: State, base: FitResult, not_tried: dict) -> Diagnosis:
    """The :class:`Diagnosis` of the climb's last ``state`` (its ``stop`` set) from the baseline ``base``;
    its ``timing`` up to now, the last stage ended where the climb did."""
    if state.stop.why != "interrupted":
        state = refined(ctx, state)
    ctx.tracker.timing.switch(None)
    ladder = steps(ctx, state)
    res, scorer, replay = state.model, ctx.scorer, ctx.replay
    verdict = ladder[state.owners[0]].effect if state.owners else None
    why = state.stop.why
    tests = {} if why == "interrupted" else residual_tests(replay, res.plant, res)
    said = reason(ctx, state)
    if why == "nothing pays" and not ctx.policy.explained(res):
        said = not_driven(said, tests, replay)
    floors = noise(replay, scorer, None if why == "interrupted" else res, ctx.policy.at_noise)
    said = over_read(said, floors)
    above = why != "interrupted" and not ctx.policy.explained(res) and res.sim is not None
    missing = missing_torque(replay, res.plant, res.sim, scorer.primary) if above else None
    return Diagnosis(base.error, scorer.noise_floor, replay.unit(scorer.primary), scorer.primary,
                     list(state.first_tried), verdict, ladder, said, res.plant, base, base.plant,
                     scorer.relative_pct(base.sim),
                     ctx.plan.report(res.plant, res.stderr, state.calibration is not None, state.uncalibrated),
                     state.calibration,
                     why, floors, tests, not_tried, ctx.tracker.timing.report(),
                     replay.data.gaps.to_dict() if replay.data.gaps else None, missing, res.numerical, res.refined)
