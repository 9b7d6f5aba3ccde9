"""The torque the model is missing, when no effect of the library brings it to its noise.

A ladder that ends above the record's noise (nothing pays, or it ran out of steps or time)
leaves a residual no effect of the library explains.  Its shape is the user's starting
point for writing one (``docs/writing-an-effect.md``): the residual of the final model on
the primary column, turned into the torque at the output that would explain it
(:meth:`evidence.Evidence.torque`, ``tau = J e'' + b e'`` with the rigid train, N m at the
output; a current or a closed loop's drive input is read as it is, in its own unit),
measured against each torque signature of the library (|Pearson correlation|, as the
explanations measure them), and its mean binned against the output's position and speed
and against time: a friction shows as a step at zero speed, a spring as a slope in
position, a disturbance as a shape in time.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..measure import signals as S
from .evidence import SIGNATURES, Evidence

BINS = 24
"""Bins of each profile, equal in width between the 1st and 99th percentiles of its axis."""
MIN_COUNT = 10
"""Samples a bin needs for its mean to be shown (fewer: ``null``)."""


def profile(x: np.ndarray, y: np.ndarray, bins: int = BINS) -> dict:
    """``{"x", "mean", "count"}``: the mean of ``y`` in equal bins of ``x`` (centres), and how many
    samples each holds; a bin with fewer than :data:`MIN_COUNT` has mean ``None``."""
    lo, hi = np.percentile(x, [1.0, 99.0])
    if not hi > lo:
        lo, hi = float(np.min(x)), float(np.max(x)) + 1e-12
    edges = np.linspace(lo, hi, bins + 1)
    which = np.clip(np.digitize(x, edges) - 1, 0, bins - 1)
    inside = (x >= lo) & (x <= hi)
    count = np.bincount(which[inside], minlength=bins)
    total = np.bincount(which[inside], weights=y[inside], minlength=bins)
    mean = [float(s / c) if c >= MIN_COUNT else None for s, c in zip(total, count)]
    return {"x": [float(c) for c in 0.5 * (edges[:-1] + edges[1:])], "mean": mean,
            "count": [int(c) for c in count]}


@dataclass(frozen=True)
class MissingTorque:
    """The final model's residual as the torque that would explain it.

    ``torque`` (``unit``) at the samples ``time_s`` with the output's ``position_deg`` and
    ``speed_deg_s`` there; ``signatures``: |correlation| with each torque signature of the
    library, ``resembles`` the strongest."""
    signal: str
    unit: str
    time_s: np.ndarray
    position_deg: np.ndarray
    speed_deg_s: np.ndarray
    torque: np.ndarray
    signatures: dict

    @property
    def resembles(self) -> str:
        return max(self.signatures, key=self.signatures.get)

    @property
    def rms(self) -> float:
        return float(np.sqrt(np.mean(self.torque ** 2)))

    def sentence(self) -> str:
        """What the missing torque looks like, in words."""
        top = self.resembles
        others = ", ".join(f"{k} {v:.2f}" for k, v in sorted(self.signatures.items(), key=lambda kv: -kv[1])
                           if k != top)
        return (f"The torque the model misses ({self.signal} residual as a torque at the output, RMS "
                f"{self.rms:.3g} {self.unit}) most resembles {SIGNATURES[top][1]}: correlation "
                f"{self.signatures[top]:.2f} (then {others}). If no effect of the library is that, its shape "
                f"against position, speed and time is where an effect of your own starts")

    def to_dict(self) -> dict:
        """``diagnose --json``'s ``missing_torque``: the signatures, the one it most resembles, and the
        binned means against ``position_deg``, ``speed_deg_s`` and ``time_s``."""
        return {"signal": self.signal, "unit": self.unit, "rms": self.rms, "resembles": self.resembles,
                "resembles_words": SIGNATURES[self.resembles][1],
                "signatures": dict(sorted(self.signatures.items(), key=lambda kv: -kv[1])),
                "against": {"position_deg": profile(self.position_deg, self.torque),
                            "speed_deg_s": profile(self.speed_deg_s, self.torque),
                            "time_s": profile(self.time_s, self.torque)},
                "sentence": self.sentence()}


def missing_torque(replay, plant, sim, signal: str) -> MissingTorque | None:
    """The residual of ``plant``'s replay ``sim`` on column ``signal`` as the missing torque, or
    None when the record has no position to read the motion from."""
    ev = Evidence(replay, plant, sim)
    if ev.position is None:
        return None
    tau, mask = ev.torque(signal, plant)
    feats = ev.torque_features(tau, mask, None, {}, plant)
    unit = "N m at the output" if S.is_position(signal) else replay.unit(signal)
    return MissingTorque(signal, unit, ev.t[mask], np.degrees(ev.position[mask]), np.degrees(ev.speed[mask]),
                         np.asarray(tau[mask], dtype=float), feats)
