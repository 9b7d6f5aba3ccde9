"""Linear model of the engaged plant: eigen-modes and headline figures.

With the teeth in contact on one flank the contact torque is a linear
spring-damper, ``T = k (delta - h) + d ddelta`` (also for the
``elasto_backlash`` law while its damping torque is smaller than its spring
torque, i.e. for small motions about a loaded equilibrium).  The clearance
``h`` only shifts the equilibrium, so in deviations from it the plant is linear
and time-invariant.  Open loop, the input ``u`` is the motor voltage (V), or
without electrics the drive torque on the rotor (N m).  Equations (SI)::

    L di/dt     = u - R i - ke w_m
    dtheta_m/dt = w_m
    Jm dw_m/dt  = kt i - bm w_m - T/N                         (rigid shaft)
    Jr dw_m/dt  = kt i - bm w_m - Ts,   Ts = ks phi + ds (w_m - w_p)
    dphi/dt     = w_m - w_p,   Jp dw_p/dt = Ts - T/N          (with a shaft)
    ddelta/dt   = w_p/N - w_l          (w_p = w_m without a shaft)
    Jl dw_l/dt  = T - bl w_l,           T = k delta + d ddelta

plus, for each effect linear in the state (``Effect.linear``: a load spring,
symmetric viscous friction), ``- k_e theta - c_e w`` on its shaft, with
``theta_l = (theta_m - phi)/N - delta``.  States, in this order: ``[i, theta_m, w_m, (phi, w_p), delta, w_l]`` (``i``
dropped without electrics).  ``Jl`` and ``bl`` are ``Plant.output_inertia`` and
``Plant.output_damping`` (they include a leadscrew's reflected carriage), and
``Jm`` is ``Plant.motor.inertia`` (the rotor alone when there is a shaft).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import scipy.linalg

from .components import Plant

MIN_PARTICIPATION = 0.1
"""A mode counts as the mesh (shaft) mode only if ``delta`` (``phi``) takes at
least this share of its participation."""


class StateSpace(NamedTuple):
    """``dx/dt = a x + b u`` with the state names of the rows of ``a``."""
    a: np.ndarray
    b: np.ndarray
    states: tuple[str, ...]


def state_names(plant: Plant, electrics: bool = True) -> tuple[str, ...]:
    """``("i", "theta_m", "w_m", ["phi", "w_p",] "delta", "w_l")``."""
    names = ["i"] if electrics else []
    names += ["theta_m", "w_m"]
    if plant.shaft is not None:
        names += ["phi", "w_p"]
    return tuple(names + ["delta", "w_l"])


def engaged_state_space(plant: Plant, *, electrics: bool = True) -> StateSpace:
    """The engaged, open-loop plant as ``(a, b, states)`` (module docstring for the equations).

    Parameters
    ----------
    plant : Plant
    electrics : bool
        True: voltage input, current is a state.  False: drive-torque input
        on the rotor (N m), no current state.
    """
    m, g = plant.motor, plant.gear
    names = state_names(plant, electrics)
    ix = {s: j for j, s in enumerate(names)}
    a = np.zeros((len(names), len(names)))
    b = np.zeros(len(names))
    n, k, d = g.ratio, g.mesh_stiffness, g.mesh_damping
    wp = "w_p" if plant.shaft is not None else "w_m"
    mesh = {"delta": k, wp: d / n, "w_l": -d}          # T as a row over the states

    def add(row: str, terms: dict, scale: float) -> None:
        for state, coef in terms.items():
            a[ix[row], ix[state]] += scale * coef

    if electrics:
        add("i", {"i": -m.resistance, "w_m": -m.back_emf_constant}, 1.0 / m.inductance)
        b[ix["i"]] = 1.0 / m.inductance
        add("w_m", {"i": m.torque_constant}, 1.0 / m.inertia)
    else:
        b[ix["w_m"]] = 1.0 / m.inertia
    add("theta_m", {"w_m": 1.0}, 1.0)
    add("w_m", {"w_m": -m.damping}, 1.0 / m.inertia)
    if plant.shaft is not None:
        s = plant.shaft
        twist = {"phi": s.stiffness, "w_m": s.damping, "w_p": -s.damping}
        add("w_m", twist, -1.0 / m.inertia)
        add("phi", {"w_m": 1.0, "w_p": -1.0}, 1.0)
        add("w_p", twist, 1.0 / s.pinion_inertia)
        add("w_p", mesh, -1.0 / (n * s.pinion_inertia))
    else:
        add("w_m", mesh, -1.0 / (n * m.inertia))
    add("delta", {wp: 1.0 / n, "w_l": -1.0}, 1.0)
    add("w_l", mesh, 1.0 / plant.output_inertia)
    add("w_l", {"w_l": -plant.output_damping}, 1.0 / plant.output_inertia)
    # effects linear in the state (Effect.linear): -k theta - c w on their shaft;
    # theta_l = (theta_m - phi)/N - delta
    angle = {"motor": {"theta_m": 1.0},
             "load": {"theta_m": 1.0 / n, "delta": -1.0, **({"phi": -1.0 / n} if plant.shaft else {})}}
    for e in plant.effects:
        lin = e.effect.linear(e.values, plant)
        if lin is not None:
            shaft, k, c = lin
            row, j = ("w_m", m.inertia) if shaft == "motor" else ("w_l", plant.output_inertia)
            add(row, {s: -k * v for s, v in angle[shaft].items()}, 1.0 / j)
            add(row, {row: -c}, 1.0 / j)
    return StateSpace(a, b, names)


def engaged_matrix(plant: Plant, *, electrics: bool = True) -> np.ndarray:
    """System matrix ``A`` of the engaged open-loop plant (see :func:`engaged_state_space`)."""
    return engaged_state_space(plant, electrics=electrics).a


def _oscillatory(plant: Plant, electrics: bool = True) -> list[dict]:
    """Oscillatory eigen-pairs, lowest frequency first, with each state's participation.

    Participation factors ``p_ki = |wl_ki vr_ki| / sum_k |wl_ki vr_ki|`` (left and
    right eigenvectors) are independent of the states' units, unlike raw
    eigenvector entries, so they say robustly which state a mode lives in.
    """
    ss = engaged_state_space(plant, electrics=electrics)
    lam, vl, vr = scipy.linalg.eig(ss.a, left=True, right=True)
    part = np.abs(vl.conj() * vr)
    part /= np.maximum(part.sum(axis=0, keepdims=True), np.finfo(float).tiny)
    out = []
    for j, s in enumerate(lam):
        if s.imag > 1e-8 * abs(s):
            wn = float(abs(s))
            share = dict(zip(ss.states, part[:, j].tolist()))
            out.append({"frequency_hz": wn / (2.0 * math.pi), "damping_ratio": float(-s.real) / wn,
                        "dominant_state": max(share, key=share.get), "participation": share})
    return sorted(out, key=lambda mode: mode["frequency_hz"])


def modes(plant: Plant, *, electrics: bool = True) -> list[tuple[float, float]]:
    """Oscillatory modes of the engaged plant as ``(frequency_hz, damping_ratio)``.

    For each complex pair ``s = -zeta wn +- j wn sqrt(1 - zeta^2)``: the natural
    frequency ``wn / 2 pi = |s| / 2 pi`` (Hz) and ``zeta = -Re(s) / |s|``,
    lowest frequency first.  Real (overdamped) eigenvalues are left out.
    """
    return [(m["frequency_hz"], m["damping_ratio"]) for m in _oscillatory(plant, electrics)]


def _mode_of(osc: list[dict], state: str) -> dict | None:
    """The oscillatory mode in which ``state`` participates most, if it is a real share."""
    best = max(osc, key=lambda m: m["participation"].get(state, 0.0), default=None)
    if best is None or best["participation"].get(state, 0.0) < MIN_PARTICIPATION:
        return None
    return best


def steady_drag(plant: Plant) -> tuple[float, float]:
    """What resists steady forward motion, reflected to the motor shaft.

    Returns ``(b, T0)``: the viscous coefficient ``b`` (N m s/rad) and the
    constant torque ``T0`` (N m), both at the motor, such that in steady
    forward motion at motor speed ``w > 0`` the rotor must supply
    ``b w + T0``::

        b  = bm + c_m + (bl + c_l + c_c r^2) / N^2
        T0 = Tc_m + (Tc_l + F_c r - T_b) / N

    ``bm`` is ``motor.damping`` and ``bl`` is ``Plant.output_damping``
    (``load.damping`` plus ``leadscrew.damping r^2``); ``c_m``, ``c_l``
    (N m s/rad) and ``c_c`` (N s/m) are ``viscous_friction`` coefficients at
    the motor, the load (output shaft, the screw) and the carriage;
    ``Tc_m``, ``Tc_l`` (N m) and ``F_c`` (N) the ``coulomb_friction`` levels
    there (the forward level ``torque``/``force``, since the motion is
    forward) plus ``stribeck_friction``'s sliding level ``coulomb_torque``
    (``coulomb_force``): at speed its breakaway excess has decayed; ``T_b``
    (N m, N at the carriage times ``r``) is a ``bias_torque``, positive
    forward, so it helps.  ``N`` is the gear ratio and ``r = lead / 2 pi``
    (m/rad).  Each effect declares its share (``Effect.steady_drag``); the
    sign regularisation of the compiled friction equals 1 to many digits at
    speed and is ignored.  Effects without a single steady drag (a spring,
    the amplifier dead zone: whether it lowers the top speed depends on the
    command) add nothing.
    """
    n = plant.gear.ratio
    b = {"motor": plant.motor.damping, "load": plant.output_damping}
    t0 = {"motor": 0.0, "load": 0.0}
    for e in plant.effects:
        drag = e.effect.steady_drag(e.values, plant)
        if drag is not None:
            shaft, c, t = drag
            b[shaft] += c
            t0[shaft] += t
    return b["motor"] + b["load"] / n ** 2, t0["motor"] + t0["load"] / n


def steady_speed(plant: Plant, voltage: float | None = None) -> float:
    """Steady forward motor speed (rad/s) at a constant ``voltage`` (V; default ``Vmax``).

    The rotor's torque balance with the current settled (``di/dt = 0``)::

        kt (V - ke w) / R = b w + T0
        =>  w = (kt V - R T0) / (R b + kt ke)

    with ``kt`` (N m/A), ``ke`` (V s/rad), ``R`` (ohm) and ``(b, T0)`` (N m
    s/rad, N m) from :func:`steady_drag`.  0 when ``T0`` is at least the
    torque ``kt V / R`` the motor gives at standstill: the friction holds it
    (with a ``bias_torque`` larger than the friction the true answer would
    be a backward drift, which this does not report).  Without effects this
    is ``kt V / (R b + kt ke)``.
    """
    m = plant.motor
    v = m.max_voltage if voltage is None else voltage
    b, t0 = steady_drag(plant)
    kt, ke, r = m.torque_constant, m.back_emf_constant, m.resistance
    return max(0.0, (kt * v - r * t0) / (r * b + kt * ke))


def plant_info(plant: Plant) -> dict:
    """Headline figures of a plant, from the engaged linear model and steady state.

    Returns
    -------
    dict
        ``ratio`` (N); ``clearance_deg`` (total backlash, deg);
        ``mesh_frequency_hz`` and ``mesh_damping_ratio``: the oscillatory mode
        in which the mesh deflection ``delta`` participates most (None when the
        mesh is overdamped); without damping and shaft it is
        ``sqrt(k (1/Jl + 1/(Jm N^2))) / 2 pi``;
        ``shaft_frequency_hz`` and ``shaft_damping_ratio`` likewise for the
        shaft twist ``phi`` (None without a shaft);
        ``electrical_time_constant_s`` ``L/R``;
        ``mechanical_time_constant_s`` ``R J / (kt ke)`` with
        ``J = Jm (+ Jp) + Jl/N^2`` (viscous damping ignored, as usual);
        ``stall_torque_Nm`` ``kt Vmax / R`` at the motor and
        ``stall_torque_output_Nm`` that times N;
        ``drag_coefficient_Nm_s_rad`` and ``drag_torque_Nm``: the viscous
        coefficient ``b`` and the constant torque ``T0`` that resist steady
        forward motion, at the motor (:func:`steady_drag`: the plant's
        damping plus its friction effects, reflected through N and the lead);
        ``no_load_speed_rad_s`` / ``no_load_speed_rpm``: steady motor speed at
        ``Vmax`` with the load and its friction attached,
        ``(kt Vmax - R T0) / (R b + kt ke)`` (:func:`steady_speed`; without
        effects ``b = bm + bl/N^2`` and ``T0 = 0``);
        ``output_top_speed_deg_s`` that over N, in deg/s;
        with a leadscrew, ``top_speed_mm_s`` and ``top_speed_in_s``, the
        carriage speed ``w_l lead / 2 pi``;
        ``modes``: every oscillatory engaged mode as a dict with
        ``frequency_hz``, ``damping_ratio`` and ``dominant_state``.
    """
    m, g = plant.motor, plant.gear
    n = g.ratio
    osc = _oscillatory(plant)
    mesh = _mode_of(osc, "delta")
    shaft = _mode_of(osc, "phi") if plant.shaft is not None else None
    j_total = plant.driven_inertia
    kt_ke = m.torque_constant * m.back_emf_constant
    b_total, t_drag = steady_drag(plant)
    w0 = steady_speed(plant)
    info = {
        "ratio": n,
        "clearance_deg": g.backlash_deg,
        "mesh_frequency_hz": mesh["frequency_hz"] if mesh else None,
        "mesh_damping_ratio": mesh["damping_ratio"] if mesh else None,
        "shaft_frequency_hz": shaft["frequency_hz"] if shaft else None,
        "shaft_damping_ratio": shaft["damping_ratio"] if shaft else None,
        "electrical_time_constant_s": m.inductance / m.resistance,
        "mechanical_time_constant_s": m.resistance * j_total / kt_ke,
        "stall_torque_Nm": m.stall_torque,
        "stall_torque_output_Nm": m.stall_torque * n,
        "drag_coefficient_Nm_s_rad": b_total,
        "drag_torque_Nm": t_drag,
        "no_load_speed_rad_s": w0,
        "no_load_speed_rpm": w0 * 60.0 / (2.0 * math.pi),
        "output_top_speed_deg_s": math.degrees(w0 / n),
    }
    if plant.leadscrew is not None:
        v = w0 / n * plant.leadscrew.radius            # m/s
        info["top_speed_mm_s"] = v * 1e3
        info["top_speed_in_s"] = v / 0.0254
    info["modes"] = [{k: md[k] for k in ("frequency_hz", "damping_ratio", "dominant_state")}
                     for md in osc]
    return info
