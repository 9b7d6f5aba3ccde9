"""Every sentence of a diagnosis, written from the rungs after the climb (``ladder``).

Each rung's explanation (:func:`rung_text`): the evidence for its effect
(``evidence.explain``: its signature on the residual before it, where it acts, the phase the
error sits in, what it gains), why it came as a pair, or why it was taken out; the
simplifications later rungs made of it (:func:`simplified_text`).  Why the ladder stopped
(:func:`reason`), and what the residual tests say of a ladder that ended above its noise
(:func:`not_driven`).
"""
from __future__ import annotations

from .evidence import explain as evidence_text
from .fit import FitResult
from .ladder import Context, Joint, Rung, Simplified, State
from .policy import at_seams
from .scoring import bic_drop

NOT_IN_LIBRARY = "; the missing physics is not in the library"


def rung_text(ctx: Context, rung: Rung, number: int) -> str:
    """The explanation of ``rung``, step ``number`` of the ladder (1 = the first)."""
    if rung.action == "remove":
        return removal_text(ctx, rung, number)
    joint = rung.joint
    if joint is not None and not joint.first:
        return (evidence_text(ctx.replay, ctx.scorer, rung.before, rung.best)
                + f" Fitted jointly with {joint.pair.first.candidate.label()} (the pair's rung before).")
    text = evidence_text(ctx.replay, ctx.scorer, rung.before, rung.best, rung.tried)
    text += rivals_text(rivals(ctx, rung))
    return text if joint is None else text + " " + pair_text(joint)


AMBIGUOUS_BIC = 10.0
"""A rival within this BIC of a rung's candidate is one the record does not tell apart from it: a BIC
difference under 10 is not "very strong" evidence (Kass and Raftery 1995, section 3.2)."""


def rivals(ctx: Context, rung: Rung) -> list[dict]:
    """The other candidates of ``rung``'s screen that pay too and whose BIC is within
    :data:`AMBIGUOUS_BIC` of the chosen one's (both screen fits, the model before held): the effects or
    places this record cannot tell apart from it, best first, each ``{effect, options, params, error,
    bic_difference}``."""
    if rung.action != "add" or rung.best is None or (rung.joint is not None and not rung.joint.first):
        return []  # a pair's second rung was not chosen from its screen
    chosen = rung.best.candidate
    own = [t.result.bic for t in rung.tried if t.ok and t.candidate == chosen]
    if not own:
        return []
    out = [{"effect": t.candidate.name, "options": dict(t.candidate.options), "params": t.params,
            "error": t.result.error, "bic_difference": t.result.bic - own[0]}
           for t in rung.tried
           if t.ok and t.candidate != chosen and ctx.policy.pays(ctx.scorer, rung.before, t.result)
           and t.result.bic - own[0] < AMBIGUOUS_BIC]
    return sorted(out, key=lambda r: r["bic_difference"])


def rivals_text(found: list[dict]) -> str:
    """The sentence a rung gains when its record cannot tell its effect from others, else ''."""
    if not found:
        return ""
    names = "; ".join(f"{r['effect']}{' ' + str(r['options']) if r['options'] else ''} (BIC "
                      f"{r['bic_difference']:+.1f}, " + ", ".join(f"{k} = {v:.4g}" for k, v in r["params"].items())
                      + ")" for r in found)
    return (f" This record does not tell it apart from {names}: a BIC difference under {AMBIGUOUS_BIC:g} is no "
            "strong evidence either way; on what this record measures, they act alike.")


def removal_text(ctx: Context, rung: Rung, number: int) -> str:
    """Why an effect was taken out at step ``number``."""
    unit, p = ctx.replay.unit(ctx.scorer.primary), ctx.policy
    gain = -bic_drop(ctx.scorer, rung.before, rung.result)
    return (f"Taken out at step {number}: once {rung.after} is in, {rung.effect} no longer pays; refitted "
            f"without it the error is {rung.result.error:.4g} {unit} against {rung.before.error:.4g} {unit}, the "
            f"BIC (the residual's correlation counted) {'rises' if gain > 0 else 'falls'} by "
            f"{abs(gain):.1f} (an effect must lower it by more than {p.min_bic_drop:g} and the weighted RMS "
            f"by {p.min_error_drop:.0%} to stay).")


def pair_text(joint: Joint) -> str:
    """Why two rungs at once: the pair against the best single candidate."""
    r, b, unfitted = joint.pair.result, joint.best.result, joint.unfitted
    rest = (f" The {unfitted} pair{'s' if unfitted > 1 else ''} ranked after {'were' if unfitted > 1 else 'was'} "
            f"not fitted: a pair fitted before reached the noise floors." if unfitted else "")
    return (f"Added with the next rung as a pair: fitted jointly, {joint.pair.label()} take the weighted RMS to "
            f"{r.weighted_rms:.4g}x the noise floors (BIC {r.bic - b.bic:+.1f} against the best single candidate, "
            f"{joint.best.candidate.label()}, at {b.weighted_rms:.4g}x): each alone is confounded with the other.{rest}")


def simplified_text(s: Simplified, number: int) -> str:
    """The sentence a rung gains when step ``number`` replaced its effect by the simpler form."""
    return (f" Simplified at step {number}: {s.new} explains as well as {s.old} once the later effects are "
            f"in (BIC lower by {s.gain:.1f}), so the extra parameters do not pay.")


def seams_text(ctx: Context, current: FitResult, new: FitResult) -> str:
    """Why ``new`` does not pay though it would by its own resets (``Policy.accepts``), else ''."""
    if not ctx.policy.pays(ctx.scorer, current, new):
        return ""
    new_at, current_at = at_seams(ctx.scorer, new, current.seams), at_seams(ctx.scorer, current, new.seams)
    return (f"; it would pay only by where the replay resets the angles (at {len(new.seams)} window seams against "
            f"the model's {len(current.seams)}): with the resets at the same seams, the model's give it "
            f"{new_at.weighted_rms:.4g}x against {current.weighted_rms:.4g}x, and its own give the model "
            f"{current_at.weighted_rms:.4g}x against {new.weighted_rms:.4g}x; state the noise (--noise, "
            f"--noise-from) if it is coloured")


def reason(ctx: Context, state: State) -> str:
    """Why the ladder ended, in words (``state.stop``)."""
    stop, res = state.stop, state.model
    unit, floor, steps = ctx.replay.unit(ctx.scorer.primary), ctx.scorer.noise_floor, len(state.rungs)
    if stop.why == "interrupted":
        return f"interrupted during step {steps + 1}"
    if stop.why == "max steps":
        return (f"the ladder reached its longest, {ctx.max_steps} step(s) (max_steps); error "
                f"{res.error:.4g} {unit}, {res.weighted_rms:.3g}x the noise floors")
    if stop.why == "time limit":
        return (f"stopped by the time limit: {stop.elapsed_s:.0f} s had passed (time limit "
                f"{ctx.time_limit_s:g} s) after {steps} step(s); error {res.error:.4g} {unit}, "
                f"{res.weighted_rms:.3g}x the noise floors")
    if not stop.judged:  # the noise floors reached before a screen
        return (f"after {steps} step(s){' and the calibration' if state.calibration else ''} the model "
                f"explains the record down to its noise: error {res.error:.4g} {unit} against a "
                f"noise floor of {floor:.4g} {unit} (all signals: {res.weighted_rms:.3g}x their noise floors)")
    return _nothing_pays(ctx, state)


def _nothing_pays(ctx: Context, state: State) -> str:
    """Why the ladder ended where the best candidate of a screen did not pay (or there was none)."""
    stop, res, p = state.stop, state.model, ctx.policy
    unit, floor, best = ctx.replay.unit(ctx.scorer.primary), ctx.scorer.noise_floor, stop.best
    if best is None:
        gain = "no candidate could be fitted" if stop.screened else "no candidate is left to try"
    else:
        change = -bic_drop(ctx.scorer, res, best.result)
        gain = (f"the best, {best.candidate.label()}, would take the error to "
                f"{best.result.error:.4g} {unit} (BIC change {change:+.1f} counting the residual's correlation, "
                f"{best.result.bic - res.bic:+.1f} white, "
                f"weighted RMS {res.weighted_rms:.4g} -> {best.result.weighted_rms:.4g}; an "
                f"added effect must lower the BIC by more than {p.min_bic_drop:g} and the weighted RMS "
                f"by {p.min_error_drop:.0%}){seams_text(ctx, res, best.result)}")
    calibrated = " once its datasheet values are calibrated" if state.calibration else ""
    if state.steps > 0:
        return f"after {len(state.rungs)} step(s) nothing more pays: {gain}"
    if p.explained(res):
        return (f"the model explains the record down to its noise{calibrated}: error "
                f"{res.error:.4g} {unit} against a noise floor of {floor:.4g} {unit} "
                f"(all signals: {res.weighted_rms:.3g}x their noise floors); {gain}")
    return (f"no candidate explains the residual: the error {res.error:.4g} {unit} stays "
            f"{res.error / floor:.3g}x the noise floor ({floor:.4g} {unit}){calibrated} and {gain}{NOT_IN_LIBRARY}")


def not_driven(reason: str, tests: dict, replay) -> str:
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
