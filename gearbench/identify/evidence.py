"""Why an effect is the verdict, in words an engineer checks against the figures.

Every effect declares its *signature* (``Effect.signature``): what the record must
show if that effect is what the model lacks.  The explanation of a rung measures
that signature on the residual before the effect was added and says how strong
it is beside the other signatures, where in the record the error sits (phases),
and how much the effect removes.

Two views of the residual ``e`` (measured minus simulated):

* **torque**: physical effects act through the dynamics, so an angle residual is
  the missing torque integrated twice.  It is turned back into the torque that
  would explain it with the rigid train at the output,
  ``tau = J e'' + b e'``, ``J = J_out + N^2 J_m``, ``b = b_out + N^2 (b_m + k_t k_e / R)``
  (N m at the output; derivatives by a Savitzky-Golay filter inside each
  re-initialisation window).  A closed-loop replay compares the drive input,
  which is already a force or torque: there ``tau = e``.
* **signal**: a sensor effect distorts the measured signal itself, so its
  residual is read as it is.

The correlations are Pearson's, of ``tau`` (or ``e``) with each feature; only
their size matters, so units cancel.

Where an effect acts (its ``location`` or ``signal``) is said with the evidence of
each signal (:func:`signal_evidence`, :func:`location_text`): each compared
signal's noise-weighted RMS under this place and under the others, and the
per-signal likelihood that ranked them.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.signal import savgol_filter

from ..measure.phases import classify_phases, error_shares, smoothed_speed
from ..plant.effects import REGISTRY
from ..measure import signals as S
from .scoring import signal_evidence

# signature -> (view, words naming what it shows)
SIGNATURES = {
    "sign of the speed": ("torque", "a torque of constant size opposing the motion (Coulomb friction)"),
    "stick and breakaway": ("torque", "a torque opposing the motion that peaks at low speed and holds the "
                                      "shaft in stick phases until it breaks away (Stribeck friction)"),
    "speed": ("torque", "a torque proportional to speed (viscous friction)"),
    "position": ("torque", "a torque that grows with position (a spring)"),
    "a constant": ("torque", "a constant torque (a bias)"),
    "acceleration": ("torque", "a torque that follows the acceleration (a compliance: inertia "
                               "that lags behind the rotor)"),
    "voltage lost in a dead zone": ("torque", "a torque deficit at small voltages (an amplifier dead zone)"),
    "heat put into the winding": ("torque", "a torque deficit that grows with the heat the current has put "
                                            "into the winding, (integral of i^2 dt) i (a resistance warming up)"),
    "lost motion": ("signal", "lost motion each time the motion reverses (a clearance): the residual follows "
                              "the measured gap between the motor angle / N and the load angle"),
    "a lag": ("signal", "the measured signal lagging the model (a delay): the residual follows the "
                        "signal's rate of change"),
    "steps of one count": ("signal", "steps of one encoder count: the residual is the rounding to the count grid"),
    "a constant offset": ("signal", "a constant on the measured signal (a sensor's offset): the residual's "
                                    "mean, |mean|/RMS"),
}


def location_text(best: Tried, tried: list[Tried]) -> str:
    """Why ``best`` acts where it does: each signal's weighted RMS (x its noise floor) against
    the same effect's other places, and the evidence (:func:`signal_evidence`) that decides."""
    rivals = [t for t in tried if t.ok and t is not best and t.candidate.name == best.candidate.name
              and t.candidate.options and t.result.signals and best.result.signals]
    if not rivals:
        return ""

    def per(t):
        return ", ".join(f"{n} {math.sqrt(r / k):.3g}" for n, (r, k) in t.result.signals.items())

    where = ", ".join(f"{v}" for v in best.candidate.options.values())
    parts = [f"at {where}: weighted RMS per signal (x noise floor) {per(best)}"]
    for t in rivals:
        worse = [n for n, (r, k) in t.result.signals.items() if r > best.result.signals[n][0]]
        gap = signal_evidence(t.result) - signal_evidence(best.result)
        parts.append(f"at {', '.join(str(v) for v in t.candidate.options.values())}: {per(t)} "
                     f"({', '.join(worse) or 'no signal'} worse; evidence of every signal "
                     f"{'against' if gap > 0 else 'for'} it by {abs(gap):.1f}, pooled BIC "
                     f"{t.result.bic - best.result.bic:+.1f})")
    return "the place is chosen on the evidence of every signal, sum n_s ln(RSS_s/n_s): " + "; ".join(parts)


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    """|Pearson correlation| of two series (0 when either is constant)."""
    a = a - a.mean()
    b = b - b.mean()
    den = np.linalg.norm(a) * np.linalg.norm(b)
    return float(abs(a @ b) / den) if den > 0 else 0.0


def _constant(x: np.ndarray) -> float:
    """How much of ``x`` is a constant: |mean| / RMS."""
    rms = float(np.sqrt(np.mean(x ** 2)))
    return float(abs(x.mean()) / rms) if rms > 0 else 0.0


def _window_derivatives(y: np.ndarray, dt: float, windows) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """First and second derivative of ``y`` by a cubic Savitzky-Golay filter applied within each
    window (a re-initialisation makes the residual jump), and the mask of samples far enough
    from a window's ends for the filter to be centred."""
    d1, d2 = np.zeros_like(y), np.zeros_like(y)
    mask = np.zeros(y.size, dtype=bool)
    for a, b in windows:
        n = b - a
        w = min(51, n - 1 if n % 2 == 0 else n)
        if w < 7:
            continue
        d1[a:b] = savgol_filter(y[a:b], w, 3, deriv=1, delta=dt)
        d2[a:b] = savgol_filter(y[a:b], w, 3, deriv=2, delta=dt)
        mask[a + w // 2:b - w // 2] = True
    return d1, d2, mask


def rigid_output(plant) -> tuple[float, float]:
    """Inertia (kg m^2) and damping (N m s/rad) of the whole train seen at the output gear,
    the motor's back-emf included when it is voltage-driven."""
    r = plant.resolved()
    n = r.gear.ratio
    b_m = r.motor.damping
    if r.drive == "voltage":
        b_m += r.motor.torque_constant * r.motor.back_emf_constant / r.motor.resistance
    return r.output_inertia + n * n * r.motor_inertia_total, r.output_damping + n * n * b_m


class Evidence:
    """The residual of a model against a record, in both views, with the motion it goes with."""

    def __init__(self, replay, plant, sim: dict):
        self.replay = replay
        self.sim = sim
        self.residuals = replay.residuals(sim)
        _, th = replay.motion(plant)
        self.position = th
        self.t = replay.t
        self.dt = float(np.median(np.diff(self.t)))
        if th is None:
            self.speed = None
            return
        self.speed, _, _ = smoothed_speed(self.t, th)
        self.windows = replay.windows(plant)

    def torque(self, name: str, plant) -> tuple[np.ndarray, np.ndarray]:
        """``(tau, mask)``: the residual of column ``name`` as the torque that explains it."""
        e = self.residuals[name]
        if not S.is_position(name):  # the drive input (closed loop), or a current
            return e, np.ones(e.size, dtype=bool)
        e_rad = S.to_output_rad(name, e, plant)
        d1, d2, mask = _window_derivatives(e_rad, self.dt, self.windows)
        j, b = rigid_output(plant)
        return j * d2 + b * d1, mask

    def torque_features(self, tau: np.ndarray, mask: np.ndarray, cand, params: dict, plant) -> dict[str, float]:
        """|correlation| of the torque residual with each torque-view feature; with a candidate's
        fitted parameters, the Stribeck curve, the dead zone's lost voltage and a winding's heat too."""
        v, th = self.speed[mask], self.position[mask]
        tau = tau[mask]
        vmax = float(np.max(np.abs(v))) or 1.0
        moving = np.abs(v) > 0.02 * vmax
        out = {"sign of the speed": _corr(tau, np.where(moving, np.sign(v), 0.0)),
               "speed": _corr(tau, v), "position": _corr(tau, th), "a constant": _constant(tau),
               "acceleration": _corr(tau, np.gradient(v, self.t[mask]))}
        ws = params.get("stribeck_speed") or params.get("stribeck_speed_m_s")
        if ws:  # the fitted curve Tc + (Ts - Tc) exp(-|w|/ws), ws as an output speed (rad/s)
            loc = cand.options.get("location")
            ws_out = ws / plant.gear.ratio if loc == "motor" else (
                ws / plant.leadscrew.radius if loc == "carriage" else ws)
            tc = params.get("coulomb_torque", params.get("coulomb_force", 0.0))
            ts = params.get("static_torque", params.get("static_force", tc))
            curve = tc + max(ts - tc, 0.0) * np.exp(-np.abs(v) / max(ws_out, 1e-12))
            out["stick and breakaway"] = _corr(tau, np.where(moving, np.sign(v), 0.0) * curve)
        thr = params.get("threshold")
        if thr and self.replay.data.input_name == "voltage_V":
            u = np.asarray(self.replay.data.input, dtype=float)[mask]
            out["voltage lost in a dead zone"] = _corr(tau, np.clip(u, -thr, thr))
        if params.get("thermal_resistance"):
            i = self.replay.data.signals.get("current_A", self.sim.get("current_A"))
            if i is not None:
                i = np.asarray(i, dtype=float)
                heat = np.concatenate(([0.0], np.cumsum(0.5 * (i[1:] ** 2 + i[:-1] ** 2) * np.diff(self.t))))
                out["heat put into the winding"] = _corr(tau, (heat * i)[mask])
        return out

    def signal_feature(self, signature: str, name: str, params: dict, plant) -> float | None:
        """|correlation| of signal ``name``'s residual with a signal-view signature (None when
        the record cannot show it: lost motion needs both angles measured)."""
        e = self.residuals[name]
        y = self.replay.measured(name)
        if signature == "lost motion":
            sig = self.replay.data.signals
            if "motor_angle_deg" not in sig or "load_angle_deg" not in sig:
                return None
            gap = np.asarray(sig["motor_angle_deg"], dtype=float) / plant.gear.ratio - np.asarray(
                sig["load_angle_deg"], dtype=float)
            return _corr(e, gap)
        if signature == "a lag":
            return _corr(e, np.gradient(y, self.t))
        if signature == "a constant offset":
            return _constant(e)
        counts = params.get("counts_per_rev")
        if signature == "steps of one count" and counts:
            q = 360.0 / counts if name.endswith("_deg") else None
            if q is None:
                return 0.0
            y_sim = self.sim[name]
            return _corr(e, q * np.round(y_sim / q) - y_sim)
        return 0.0


def signature_text(ev: Evidence, scorer, before, best) -> str:
    """The signature of ``best``'s effect measured on ``ev``, the residual of ``before``, in words."""
    cand = best.candidate
    sig = REGISTRY[cand.name].signature
    if sig not in SIGNATURES:
        return ""
    view, words = SIGNATURES[sig]
    if ev.position is None:
        return f"{cand.name} shows as {words}"
    name = cand.options.get("signal", scorer.primary)
    if view == "signal":
        c = ev.signal_feature(sig, name, best.params, before.plant)
        if c is None:
            return f"its signature is {words}, which this record cannot show"
        return f"its signature is {words}: on the {name} residual the correlation with it is {c:.2f}"
    tau, mask = ev.torque(name, before.plant)
    feats = ev.torque_features(tau, mask, cand, best.params, before.plant)
    c = feats.get(sig, 0.0)
    top = max(feats, key=feats.get)
    rank = (f"the strongest of the {len(feats)} torque signatures measured" if top == sig else
            f"the strongest is {top}, {feats[top]:.2f}")
    how = "the residual" if not S.is_position(name) else "the residual turned into the torque that explains it"
    return f"its signature is {words}: {how} ({name}) follows {sig} with correlation {c:.2f} ({rank})"


def explain(replay, scorer, before, best, tried=()) -> str:
    """One paragraph: the effect's signature on the residual before it, where it acts and why
    (against the same effect's other places among ``tried``), the phase the error sits in, and
    what adding the effect gains."""
    name = scorer.primary
    unit = replay.unit(name)
    ev = Evidence(replay, before.plant, before.sim)
    r0 = ev.residuals[name]
    r1 = replay.residuals(best.result.sim)[name]
    parts = []
    sig = signature_text(ev, scorer, before, best)
    if sig:
        parts.append(sig)
    where = location_text(best, tried)
    if where:
        parts.append(where)
    if ev.position is not None:
        labels = classify_phases(replay.t, ev.position, ev.speed)
        shares = error_shares(labels, r0)
        ph = max(shares, key=lambda k: shares[k]["error_share"])
        parts.append(f"{shares[ph]['error_share']:.0%} of the {name} residual's squared error sits in {ph} "
                     f"({shares[ph]['time_share']:.0%} of the time)")
    cand = best.candidate
    pars = ", ".join(f"{k} = {v:.4g}" for k, v in best.params.items())
    parts.append(f"adding {cand.label()} with {pars} lowers the error from {before.error:.4g} to "
                 f"{best.result.error:.4g} {unit} (noise floor {scorer.noise_floor:.4g} {unit}), "
                 f"RMS after/before {np.sqrt(np.mean(r1 ** 2)) / max(np.sqrt(np.mean(r0 ** 2)), 1e-300):.2f}")
    text = "; ".join(parts)
    return text[0].upper() + text[1:] + "."

