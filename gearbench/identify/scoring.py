"""How far a replay is from its record, in one place: the compared columns and their weights
(noise floors), the per-signal sums, the criterion that ranks and accepts fits, and the evidence
of each signal.

A replay's residual ``r_s = y_s - y_hat_s`` of each weighed column ``s`` is divided by that
column's noise floor ``sigma_s`` (``Replay.noise_floor``: stated, or read from the record), so
``RSS = sum_s |r_s / sigma_s|^2`` over ``n`` samples in all is 1 per sample at the noise.  The
criterion (:func:`criterion`) turns ``(RSS, n, k)`` into the number the ladder compares; it is the
one place a noise model of the residuals would change it.  The whiteness and independence tests
of the residuals are beside it, in ``residuals``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .replay import Replay


def criterion(rss: float, n: int, k: int) -> float:
    """The Bayesian information criterion of ``n`` noise-weighted residuals whose sum of squares is
    ``rss``, with ``k`` fitted parameters: ``BIC = n ln(RSS/n) + k ln n`` (Schwarz 1978), -2 ln L of
    white Gaussian residuals of one unknown variance, up to a constant, plus ``ln n`` per parameter:
    an effect that does not explain more than noise would never lowers it."""
    return n * math.log(max(rss, 1e-300) / n) + k * math.log(n)


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
    primary: str = field(init=False)

    def __post_init__(self):
        self.primary = primary_signal(self.replay)
        # a list, not a set: the floors' order is every text's and every sum's over the signals,
        # and a set's would change with the process's string-hash seed
        names = objective_signals(self.replay)
        names = names + [self.primary] * (self.primary not in names)
        self.floors = {}
        for n in names:
            y = self.replay.measured(n)
            nf = self.replay.noise_floor(n)
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
