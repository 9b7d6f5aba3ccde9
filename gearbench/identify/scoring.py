"""How far a replay is from its record, in one place: the compared columns and their weights
(noise floors), the per-signal sums, the criterion that ranks and accepts fits, and the evidence
of each signal.

A replay's residual ``r_s = y_s - y_hat_s`` of each weighed column ``s`` is divided by that
column's noise floor ``sigma_s`` (``Replay.noise_floor``: stated, or read from the record), so
``RSS = sum_s |r_s / sigma_s|^2`` over ``n`` samples in all is 1 per sample at the noise.

Candidates are ranked by the Bayesian information criterion of those residuals
(:func:`criterion`, ``FitResult.bic``).  Taken as white, a coloured noise (a sensor's filter, a
drifting amplifier) counts every slow wander an effect can follow as evidence: on 16 s of the
bench rig with nothing hidden and AR(1) noise of lag-1 correlation 0.95 read from the record, a
load spring lowered the white BIC by 624.  Its samples are not independent: a noise of integrated
correlation time ``tau`` (samples; ``(1+rho)/(1-rho)`` for AR(1)) carries the information of
``n/tau`` of them.  So what pays is decided by the BIC with that many (:func:`bic_drop`), ``tau``
read from the better-fitting model's residual by an autoregressive model of each column
(:func:`noise_model`, the order chosen by the BIC), for the share of that residual a noise of such
correlation can be (:meth:`Scorer.correlation_time`: the rest is misfit, not noise).  On white
noise ``tau`` is 1 and the drop is the BIC's own.

A prediction-error criterion (the BIC of each residual's innovations, as ARX and Box-Jenkins fits
score a model) was tried first.  It refused the null record's candidates, and EMPS's friction too
(its criterion rose by 5,875 where the error fell from 324 to 81 noise floors): it scores one-step
prediction, and the bare model's smooth misfit is predictable where the friction's sharp remainder
at the reversals is not.  The whiteness and independence tests of the residuals are in
``residuals``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .replay import Replay


AR_MAX_ORDER = 10
"""Highest order of a residual's noise model (:func:`noise_model`).  AR(1) sensor noise takes order
1; a residual with window resets or a misfit in it takes more (p05's true plant, AR(1) noise on
both angles: 8 and 9), and every order costs its ``ln n``."""


@dataclass(frozen=True)
class NoiseModel:
    """A column's residual ``w`` (in noise floors) as an autoregression of order ``order``:
    ``tau`` its integrated correlation time, samples (``sum_l rho(l)`` over every lag, the spectral
    density at zero frequency over the variance: ``sigma2_e / (A(1)^2 r_0)``, at least 1), over
    ``n`` samples."""
    order: int
    tau: float
    n: int


def noise_model(w: np.ndarray, max_order: int = AR_MAX_ORDER) -> NoiseModel:
    """The autoregression ``A(q) w = e`` of ``w`` whose order ``p`` (0 .. ``max_order``) minimises
    ``n ln sigma2_p + p ln n``, ``sigma2_p`` the variance of its one-step prediction error by the
    Yule-Walker equations on the biased autocorrelation ``r_j = (1/n) sum_t w_t w_{t+j}``
    (Levinson-Durbin: stable, ``sigma2_p`` never negative)."""
    w = np.asarray(w, dtype=float)
    n = w.size
    r0 = float(w @ w) / n if n else 0.0
    if n <= 2 * max_order or r0 <= 0.0:
        return NoiseModel(0, 1.0, n)
    r = np.array([r0] + [float(w[:n - j] @ w[j:]) / n for j in range(1, max_order + 1)])
    a = np.zeros(max_order + 1)
    a[0] = 1.0
    var, best, best_cost = r0, (0, r0, 1.0), n * math.log(r0)
    for m in range(1, max_order + 1):
        refl = -float(a[:m] @ r[m:0:-1]) / var
        a[1:m + 1] += refl * a[m - 1::-1]
        var *= 1.0 - refl * refl
        if var <= 1e-12 * r0:      # predicted to rounding: no longer a noise
            break
        cost = n * math.log(var) + m * math.log(n)
        if cost < best_cost:
            best, best_cost = (m, var, float(np.sum(a[:m + 1]))), cost
    order, var, a1 = best
    tau = var / (a1 * a1 * r0) if a1 * a1 * r0 > 0.0 else float(n)
    return NoiseModel(order, min(max(tau, 1.0), float(n)), n)


def criterion(rss: float, n: int, k: int) -> float:
    """The Bayesian information criterion ``n ln(RSS/n) + k ln n`` (Schwarz 1978) of ``n``
    independent noise-weighted residuals whose sum of squares is ``rss``, with ``k`` fitted
    parameters: -2 ln L of white Gaussian residuals of one unknown variance, up to a constant, plus
    ``ln n`` per parameter: an effect that does not explain more than noise would never lowers it."""
    return n * math.log(max(rss, 1e-300) / n) + k * math.log(n)


def read_as(tau: float, rule: str) -> float:
    """The mean square, in noise floors, of a noise of correlation time ``tau`` (samples) whose floor
    was read by ``rule`` (``Replay.noise_rule``): 1 where the floor is its level (``stated``, or an
    encoder's ``quantum``); ``20 / (20 - 30 rho + 12 rho^2 - 2 rho^3)`` where it was read from the
    record's third differences as if white (``measure.noise.difference_noise``), the variance of
    the third difference of an AR(1) of lag-1 correlation ``rho = (tau - 1)/(tau + 1)`` over its
    own, against 20 for white noise (5.7^2 at rho 0.95, 4.0^2 at 0.9)."""
    if rule in ("stated", "quantum"):
        return 1.0
    rho = (tau - 1.0) / (tau + 1.0)
    return 20.0 / max(20.0 - 30.0 * rho + 12.0 * rho ** 2 - 2.0 * rho ** 3, 1e-12)


def noise_share(mean_square: float, tau: float, rule: str) -> float:
    """The share (0-1) of a column's residual mean square ``mean_square`` (in noise floors) that a
    noise of correlation time ``tau`` read by ``rule`` (:func:`read_as`) can account for."""
    return min(1.0, read_as(tau, rule) / mean_square) if mean_square > 0 else 1.0


def bic_drop(scorer: "Scorer", current, new) -> float:
    """How much ``new`` (a ``FitResult``) lowers the BIC of ``current``'s residuals, both counted as
    ``n_eff = n / tau`` independent samples: ``n_eff ln(RSS_current / RSS_new) - (k_new - k_current)
    ln n_eff``.  ``tau`` is the better fit's (:meth:`Scorer.correlation_time`): its residual is the
    nearer to the noise.  With white residuals ``tau = 1`` and it is the plain BIC's drop."""
    tau = scorer.correlation_time(new if new.rss <= current.rss else current)
    n_eff = new.n / tau
    return (n_eff * math.log(max(current.rss, 1e-300) / max(new.rss, 1e-300))
            - (new.k - current.k) * math.log(n_eff))


def primary_signal(replay: Replay) -> str:
    """The column errors are reported in: the input in closed loop (EMPS: the
    force), else the output angle or position, else the motor's, else the current."""
    if replay.closed_loop:
        return replay.data.input_name
    for name in ("load_angle_deg", "load_position_mm", "motor_angle_deg", "motor_position_mm", "current_A"):
        if name in replay.data.signals:
            return name
    return next(iter(replay.data.signals))


def objective_signals(replay: Replay) -> list[str]:
    """Columns the fit weighs: all measured signals in open loop; in closed loop the
    input (the controller rejects the physics from the position: Gautier et al.)."""
    return [replay.data.input_name] if replay.closed_loop else list(replay.data.signals)


@dataclass
class Scorer:
    """Error measures of one replay: per-column noise floors, weights and the primary column."""
    replay: Replay
    floors: dict = field(init=False)
    rules: dict = field(init=False)  # column -> how its floor was read (Replay.noise_rule)
    primary: str = field(init=False)

    def __post_init__(self):
        self.primary = primary_signal(self.replay)
        # a list, not a set: the floors' order is every text's and every sum's over the signals,
        # and a set's would change with the process's string-hash seed
        names = objective_signals(self.replay)
        names = names + [self.primary] * (self.primary not in names)
        self.floors, self.rules = {}, {}
        for n in names:
            y = self.replay.measured(n)
            nf, self.rules[n] = self.replay.noise_reading(n)
            # a noiseless (simulated, unquantised) column still needs a finite weight
            self.floors[n] = max(nf, 1e-6 * float(np.sqrt(np.mean(y ** 2))) + 1e-12)

    def weighted(self, sim: dict) -> np.ndarray:
        res = self.replay.residuals(sim)
        return np.concatenate([res[n] / self.floors[n] for n in objective_signals(self.replay)])

    def per_signal(self, sim: dict) -> dict[str, tuple[float, int]]:
        """Each weighed column's ``(RSS, n)`` of its residual divided by its noise floor."""
        res = self.replay.residuals(sim)
        out = {}
        for n in objective_signals(self.replay):
            w = res[n] / self.floors[n]
            out[n] = (float(w @ w), int(w.size))
        return out

    def noise_models(self, sim: dict) -> dict[str, NoiseModel]:
        """Each weighed column's :func:`noise_model` of its residual divided by its noise floor."""
        res = self.replay.residuals(sim)
        return {n: noise_model(res[n] / self.floors[n]) for n in objective_signals(self.replay)}

    def correlation_time(self, res) -> float:
        """The integrated correlation time of ``res``'s (a ``FitResult``'s) noise, samples: over the
        columns, weighed by their shares of the RSS, ``1 + phi_s (tau_s - 1)``, ``tau_s`` the
        column's (:func:`noise_model`) and ``phi_s`` the share of its mean square that a noise of
        that correlation time can account for (:func:`noise_share`); the rest is the model's misfit,
        whose samples count as the BIC counts them.  A misfit's slow drift taken for noise left 15
        independent samples of a 10 s record whose Coulomb friction took the error from 239,924 to
        65,064 noise floors.  1 where no noise model was made."""
        if not res.noise or not res.rss > 0:
            return 1.0
        return sum(rss * (1.0 + noise_share(rss / n, res.noise[c].tau, self.rules[c]) * (res.noise[c].tau - 1.0))
                   for c, (rss, n) in res.signals.items()) / res.rss

    def error(self, sim: dict) -> float:
        """RMS of the primary column's residual, in its unit."""
        r = self.replay.residuals(sim)[self.primary]
        return float(np.sqrt(np.mean(r ** 2)))

    def relative_pct(self, sim: dict) -> float:
        """``100 ||y - y_hat|| / ||y||`` of the primary column (the EMPS paper's measure), %."""
        y = self.replay.measured(self.primary)
        return float(100.0 * np.linalg.norm(y - sim[self.primary]) / np.linalg.norm(y))

    @property
    def noise_floor(self) -> float:
        return self.floors[self.primary]


def signal_evidence(res) -> float:
    """``sum_s n_s ln(RSS_s / n_s)`` over the compared signals ``s``: -2 ln L of a fit whose
    residuals are Gaussian with a variance of their own in each signal (up to a constant).

    Pooled, one badly fitted signal (a drifting motor angle, thousands of noise floors) sets the
    RSS and the others hardly count; here a signal that a fit contradicts (its own RSS many
    times another fit's) weighs by that ratio whatever its size."""
    return sum(n * math.log(max(rss, 1e-300) / n) for rss, n in res.signals.values())
