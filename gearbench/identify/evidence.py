"""Why an effect is the verdict, in words an engineer checks against the figures.

From the baseline residual of the primary signal: where in the record it sits
(phases: standstill, steady motion, direction reversal, acceleration; shares
of the squared error) and what it follows (the correlation of the residual
with the sign of the speed, the speed, the position, a constant, the
acceleration), then how much the effect removes.
"""
from __future__ import annotations

import numpy as np

from ..measure.phases import classify_phases, error_shares, smoothed_speed

FEATURES = {  # what the residual follows -> what that points to
    "sign of the speed": "friction that changes sign with the motion, or a clearance taken up on reversal",
    "speed": "a force proportional to speed (viscous friction)",
    "position": "a force that grows with position (a spring)",
    "a constant": "a constant force or torque (a bias)",
    "acceleration": "inertia or a lag (a compliance, a delay)",
}


def motion(replay, plant):
    """Measured position (output rad) and its smoothed speed, or (None, None)."""
    name, th = replay._motion(plant)
    if th is None:
        return None, None
    v, _, _ = smoothed_speed(replay.t, th)
    return th, v


def features(residual: np.ndarray, th: np.ndarray, v: np.ndarray, t: np.ndarray) -> dict:
    """|correlation| of the residual with each feature."""
    acc = np.gradient(v, t)
    vmax = np.max(np.abs(v)) or 1.0
    cols = {"sign of the speed": np.where(np.abs(v) > 0.02 * vmax, np.sign(v), 0.0), "speed": v,
            "position": th - th.mean(), "acceleration": acc}
    out = {}
    r = residual - residual.mean()
    for k, c in cols.items():
        c = c - c.mean()
        den = np.linalg.norm(r) * np.linalg.norm(c)
        out[k] = float(abs(r @ c) / den) if den > 0 else 0.0
    rms = np.sqrt(np.mean(residual ** 2))
    out["a constant"] = float(abs(residual.mean()) / rms) if rms > 0 else 0.0
    return out


def explain(replay, scorer, before, best) -> str:
    """One paragraph: the residual's signature before, the phase it sits in, the gain."""
    name = scorer.primary
    unit = replay.data.signal_unit(name) if name in replay.data.signals else replay.data.input_unit
    r0 = replay.residuals(before.sim)[name]
    r1 = replay.residuals(best.result.sim)[name]
    th, v = motion(replay, before.plant)
    parts = []
    if th is not None:
        feats = features(r0, th, v, replay.t)
        top = max(feats, key=feats.get)
        parts.append(f"the {name} residual follows {top} (correlation {feats[top]:.2f}): "
                     f"{FEATURES[top]}")
        labels = classify_phases(replay.t, th, v)
        shares = error_shares(labels, r0)
        ph = max(shares, key=lambda k: shares[k]["error_share"])
        parts.append(f"{shares[ph]['error_share']:.0%} of its squared error sits in {ph} "
                     f"({shares[ph]['time_share']:.0%} of the time)")
    cand = best.candidate
    pars = ", ".join(f"{k} = {v:.4g}" for k, v in best.params.items())
    parts.append(f"adding {cand.label()} with {pars} lowers the error from {before.error:.4g} to "
                 f"{best.result.error:.4g} {unit} (noise floor {scorer.noise_floor:.4g} {unit}), "
                 f"RMS after/before {np.sqrt(np.mean(r1 ** 2)) / max(np.sqrt(np.mean(r0 ** 2)), 1e-300):.2f}")
    text = "; ".join(parts)
    return text[0].upper() + text[1:] + "."
