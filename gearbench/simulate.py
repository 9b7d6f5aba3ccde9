"""Simulate one run: the small solver interface behind one function.

>>> from gearbench.simulate import simulate                     # doctest: +SKIP
>>> run = simulate(plant, Controller("p", kp=50), profile.segments(), 10.0)
>>> run.iae_deg_s
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from . import layout as L
from .control.controllers import Controller, pack_controller
from .plant.components import Plant
from .plant.pack import pack_plant, rest_state, tolerance_scales
from .solver.integrate import integrate

METHODS = {"rosenbrock23": L.METHOD_ROSENBROCK, "ode23s": L.METHOD_ROSENBROCK,
           "dopri5": L.METHOD_DOPRI, "ode45": L.METHOD_DOPRI, "rodas4": L.METHOD_RODAS4}


SHIFT_SPEED_REL = 1e-9
"""The thesis shift flips (Equation 1) once the motor speed is past this fraction
of its typical speed on the other side: far above round-off (a speed decaying to
rest must not flip it on a 1e-15 rad/s excursion), far below any real reversal,
and fixed, so the model is the same at every tolerance (tied to rtol, it hid the
small reversals of a bang-bang run with the shift at rtol 1e-6: 4 impacts
against 95, and an IAE 0.5 % off the converged one)."""


class Segments(NamedTuple):
    """Piecewise-linear input: on ``[t[k], t[k+1])`` the value is ``v[k] + s[k] (t - t[k])``.

    SI units: s, and rad (set point) or V / N m / N (open-loop input).  ``d``:
    for a sampled controller, a disturbance (V) added to its output after the
    saturation, one value per segment (None = none).
    """
    t: np.ndarray
    v: np.ndarray
    s: np.ndarray
    d: np.ndarray | None = None


@dataclass(frozen=True)
class SolverOptions:
    """method: ``rodas4`` (default: L-stable Rosenbrock, fourth order),
    ``rosenbrock23`` (alias ``ode23s``, the thesis's stiff method, second
    order) or ``dopri5`` (alias ``ode45``, explicit); rtol: relative tolerance (absolute tolerances
    follow from each state's typical scale); max_step_s: largest step, s (events
    inside a step are caught at the interpolant's extrema; the cap is a backstop);
    output_dt_s: sampling interval of the returned trace, s;
    friction_speed_rel: the speed below which friction's sign is regularised
    (``tanh(w/eps)``), relative to each shaft's typical speed."""
    method: str = "rodas4"
    rtol: float = 1e-6
    max_step_s: float = 1e-2
    max_steps: int = 20_000_000
    output_dt_s: float = 1e-3
    friction_speed_rel: float = 1e-5


class SolverError(RuntimeError):
    """A run the solver could not finish; the message says where and why."""


@dataclass
class RunResult:
    """A finished (or failed) run: sampled trace and scores."""
    time_s: np.ndarray
    outputs: np.ndarray
    stats: np.ndarray
    t_end: float
    label: str = ""
    meta: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return int(self.stats[L.S_STATUS]) == L.STATUS_OK

    @property
    def status(self) -> str:
        return L.STATUS_TEXT[int(self.stats[L.S_STATUS])]

    @property
    def iae_deg_s(self) -> float:
        """Integrated absolute output error, deg s."""
        return math.degrees(self.stats[L.S_IAE])

    @property
    def rms_deg(self) -> float:
        """Root-mean-square output error, deg."""
        return math.degrees(math.sqrt(self.stats[L.S_ISE] / self.t_end))

    @property
    def max_deg(self) -> float:
        """Largest output error seen at a step end or a set-point jump, deg."""
        return math.degrees(self.stats[L.S_MAX_ERR])

    @property
    def saturated_fraction(self) -> float:
        """Fraction of the run with the controller at its voltage limit."""
        return self.stats[L.S_T_SAT] / self.t_end

    @property
    def impacts(self) -> int:
        return int(self.stats[L.S_IMPACTS])

    @property
    def switchings(self) -> int:
        """Changes of sign of the applied voltage (bang-bang: every switch; a
        continuous law counts a change once the voltage is past rtol * Vmax)."""
        return int(self.stats[L.S_SWITCHES])

    @property
    def steps(self) -> int:
        return int(self.stats[L.S_STEPS])

    def scores(self) -> dict:
        """The run's figures of merit as plain numbers."""
        return {
            "iae_deg_s": self.iae_deg_s,
            "rms_deg": self.rms_deg,
            "max_deg": self.max_deg,
            "saturated_fraction": self.saturated_fraction,
            "impacts": self.impacts,
            "switchings": self.switchings,
            "steps": self.steps,
        }

    def column(self, name: int) -> np.ndarray:
        return self.outputs[:, name]


def pack(plant: Plant, controller: Controller) -> np.ndarray:
    """The compiled core's parameter vector for this plant and controller."""
    p = pack_plant(plant)
    return pack_controller(controller, plant.gear.backlash_deg, p)


def simulate(plant: Plant, controller: Controller, inputs: Segments, t_end: float,
             options: SolverOptions = SolverOptions(), delta0: float = 0.0,
             label: str = "", raise_on_failure: bool = False) -> RunResult:
    """Simulate ``plant`` under ``controller`` following ``inputs`` for ``t_end`` s.

    ``delta0`` places the mesh inside its clearance at the start (rad, 0 =
    centred).  A failed run comes back with ``ok == False`` and its status,
    or raises :class:`SolverError` naming the run, the time and the likely
    cause when ``raise_on_failure``.
    """
    run = simulate_packed(pack(plant, controller), tolerance_scales(plant), inputs, t_end,
                          rest_state(plant, delta0), options, label)
    if raise_on_failure and not run.ok:
        raise SolverError(failure_message(run, plant.name))
    return run


def simulate_packed(p: np.ndarray, scales: np.ndarray, inputs: Segments, t_end: float,
                    x0: np.ndarray, options: SolverOptions = SolverOptions(),
                    label: str = "", output_times: np.ndarray | None = None) -> RunResult:
    """Lower-level entry: an already packed parameter vector ``p`` (``layout.P_*``),
    the states' typical scales (``atol = rtol * scales``) and an initial state.

    ``output_times`` (s, increasing, within [0, t_end]) replaces the regular
    ``options.output_dt_s`` grid.  ``meta["segment_input"]`` holds the input
    held on each segment (a sampled controller's commands)."""
    if options.method not in METHODS:
        raise ValueError(f"unknown solver method {options.method!r}; choose one of {sorted(METHODS)}")
    scales = np.asarray(scales, dtype=float)
    p = np.array(p, dtype=float)
    p[L.P_SPEED_EPS] = SHIFT_SPEED_REL * scales[L.X_WM]
    p[L.P_FRIC_EPS_M] = options.friction_speed_rel * scales[L.X_WM]
    p[L.P_FRIC_EPS_L] = options.friction_speed_rel * scales[L.X_WL]
    if output_times is None:
        t_out = np.linspace(0.0, t_end, int(round(t_end / options.output_dt_s)) + 1)
    else:
        t_out = np.ascontiguousarray(output_times, dtype=float)
    d = np.zeros(len(inputs.t)) if inputs.d is None else inputs.d
    outputs, stats, x_end, seg_u = integrate(
        p, np.ascontiguousarray(inputs.t, dtype=float),
        np.ascontiguousarray(inputs.v, dtype=float), np.ascontiguousarray(inputs.s, dtype=float),
        np.ascontiguousarray(d, dtype=float), float(t_end), np.asarray(x0, dtype=float), t_out, float(options.rtol),
        options.rtol * scales, float(options.max_step_s),
        METHODS[options.method], int(options.max_steps))
    return RunResult(t_out, outputs, stats, float(t_end), label,
                     {"x_end": x_end, "segment_input": seg_u})


def failure_message(run: RunResult, name: str) -> str:
    """Which run failed, where in time, and the likely cause."""
    t = run.stats[L.S_T_FAIL]
    hint = {
        L.STATUS_STEP_TOO_SMALL: "the plant is probably unphysical or far too stiff for the tolerance "
                                 "(check mesh_stiffness/mesh_damping against the inertias, and the gains)",
        L.STATUS_MAX_STEPS: "a chattering mode switch (bang-bang band or set-point shift) or an unstable gain; "
                            "widen the band, lower the gain, or raise max_steps",
        L.STATUS_NONFINITE: "the state blew up: an unstable gain or a non-physical parameter",
    }.get(int(run.stats[L.S_STATUS]), "")
    name = run.label or name
    return f"run {name!r} failed at t = {t:.6g} s: {run.status}; likely cause: {hint}"
