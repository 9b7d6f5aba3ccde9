"""How far a model is from a record, per signal, and where in the record it fails."""
from __future__ import annotations

import numpy as np

from ..measure.phases import classify_phases, error_shares, smoothed_speed
from .scoring import primary_signal
from .replay import Replay, ReplayRun
from .residuals import DEFAULT_LAGS, check_lags, replay_residual_tests


def comparison(replay: Replay, plant, sim: ReplayRun | None = None, lags: int | None = DEFAULT_LAGS) -> dict:
    """Per compared column: RMS and maximum error (its unit), noise floor and the rule it was
    read by (``Replay.noise_rule``), their ratio, relative error (%); the record cut into phases with each phase's
    share of the primary column's squared error; the residual tests of every
    column (:mod:`gearbench.identify.residuals`, ``lags`` samples; None: none);
    the times (s) at which the replay re-initialised the model's angles; the
    arrays for figures.  ``sim``: ``replay``'s run of ``plant``, made here when not given."""
    if lags is not None:
        check_lags(lags, replay.windows(plant))     # before the solving, not after
    sim = sim if sim is not None else replay.run(plant)
    res = replay.residuals(sim)
    rows = []
    for name, r in res.items():
        y = replay.measured(name)
        nf, rule = replay.noise_reading(name)
        unit = replay.unit(name)
        rms = float(np.sqrt(np.mean(r ** 2)))
        rows.append({"signal": name, "unit": unit, "rms_error": rms, "max_error": float(np.max(np.abs(r))),
                     "noise_floor": nf, "noise_rule": rule, "ratio_to_noise": rms / nf if nf > 0 else float("inf"),
                     "relative_error_pct": float(100 * np.linalg.norm(r) / max(np.linalg.norm(y), 1e-300))})
    primary = primary_signal(replay)
    name, th = replay.motion(plant)
    out = {"signals": rows, "primary": primary, "sim": sim, "residuals": res,
           "reinitialised_s": list(sim.reinitialised_s)}
    if lags is not None:
        out["residual_tests"] = replay_residual_tests(replay, plant, res, lags)
    if th is not None:
        v, sigma_v, _ = smoothed_speed(replay.t, th)
        labels = classify_phases(replay.t, th, v)
        out.update(labels=labels, speed=v, position=th, position_signal=name,
                   phases={k: {**d} for k, d in error_shares(labels, res[primary]).items()})
    return out
