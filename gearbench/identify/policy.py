"""What pays on the ladder: the tuning of ``diagnose`` in one frozen object.

An added effect pays when the Bayesian information criterion of the noise-weighted residuals,
counted as ``n / tau`` independent samples (``tau`` their correlation time, read by an
autoregressive noise model of each signal: :func:`gearbench.identify.scoring.bic_drop`), falls by
more than ``min_bic_drop`` and the weighted RMS error by more than ``min_error_drop``, also with both
models' angles reset at the same window seams (:meth:`Policy.accepts`).

The two rules beside the criterion stay, for reasons the criterion cannot see.  The 3 % rule is
the size of an effect worth a rung, not its evidence: on 16 s at 1 kHz an effect that moves the
error by 0.5 % can be certain, and still not what a user came for (a true 4096-count encoder
lowers the error by 1.1 % on 4 s of the bench rig, and the white BIC by 256).  The seams check is
there because a window's reset sets the model's angles from the record, values the criterion
does not count, at seams a test on the noise picks (:meth:`accepts`).

Everything the ladder decides goes through one :class:`Policy`; a caller (or a test) that wants
another tuning passes another one.
"""
from __future__ import annotations

from dataclasses import dataclass

from .fit import FitResult, evaluate
from .scoring import Scorer, bic_drop


@dataclass(frozen=True)
class Policy:
    """The ladder's tuning constants.

    min_bic_drop: an added effect must lower the BIC by more than this (10: "very strong"
    evidence, Kass & Raftery 1995); min_error_drop: and the weighted RMS by more than this
    fraction (0.03: 3 %); at_noise: a weighted RMS within this many times the noise floors is
    explained (1.2); second_top: the candidates of a rung's screen, ranked by the fits from their
    best starts, that are fitted from their second starts too, and so the best pairs fitted so far
    after each batch of pairs (3); joint_top: the candidates refitted jointly with the effects
    already added (3); calibration_restarts: the calibration fit restarts on a stall (3,
    :func:`gearbench.identify.fit.fit`); pair_top: the effects whose best places are refitted
    jointly in pairs (6: 15 pairs at most); pair_batch: pairs fitted at a time, until one reaches
    the noise floors (4)."""
    min_bic_drop: float = 10.0
    min_error_drop: float = 0.03
    at_noise: float = 1.2
    second_top: int = 3
    joint_top: int = 3
    calibration_restarts: int = 3
    pair_top: int = 6
    pair_batch: int = 4

    def pays(self, scorer: Scorer, current: FitResult, new: FitResult) -> bool:
        """The BIC, the residuals counted as ``n / tau`` independent samples
        (:func:`gearbench.identify.scoring.bic_drop`), falls by more than ``min_bic_drop`` and the
        noise-weighted RMS error of all compared signals by more than ``min_error_drop``."""
        return (bic_drop(scorer, current, new) > self.min_bic_drop
                and new.weighted_rms < (1.0 - self.min_error_drop) * current.weighted_rms)

    def accepts(self, scorer: Scorer, current: FitResult, new: FitResult) -> bool:
        """``new`` pays over ``current`` (:meth:`pays`), and it still does with both models' angles
        moved at the same window seams: the current model's, and the new one's.

        A window's reset sets the model's angles from the record, fitted values the BIC does not
        count, and where the noise is coloured and not stated the test that decides a reset fires
        on the noise (``Replay``).  An effect could then pay by where the replay resets rather than
        by what it does: on 16 s of the bench rig with nothing hidden and AR(1) noise (lag-1
        correlation 0.9) read from the record, a Stribeck friction of 4.7e-7 N m at the motor moved
        the resets from 8 seams to 10 and the weighted RMS from 3.579 to 3.470 (3.04 %); at the
        right model's 8 seams it gave 3.669, and the right model at its 10 gave 3.502."""
        if not self.pays(scorer, current, new):
            return False
        if new.seams == current.seams:
            return True
        return (self.pays(scorer, current, at_seams(scorer, new, current.seams))
                and self.pays(scorer, at_seams(scorer, current, new.seams), new))

    def explained(self, res: FitResult) -> bool:
        """The model explains the record down to its noise: a weighted RMS within ``at_noise``."""
        return res.weighted_rms <= self.at_noise


def at_seams(scorer: Scorer, res: FitResult, seams: tuple) -> FitResult:
    """``res``'s plant scored with the replay's angles moved at exactly ``seams``
    (``Replay.run(seams=...)``), its ``k`` kept; made once per seams (``FitResult.rescored``)."""
    if seams == res.seams:
        return res
    if seams not in res.rescored:
        res.rescored[seams] = evaluate(scorer.replay, scorer, res.plant, res.k, seams=seams)
    return res.rescored[seams]
