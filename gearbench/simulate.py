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
from .errors import ConfigError, SolverError
from .interrupts import is_interrupt
from .schema import Choice, Number, show
from .control.controllers import Controller, pack_controller
from .plant.components import Plant
from .plant.effects.codegen import compiled_model, needs_states
from .plant.pack import pack_plant, rest_state, tolerance_scales

METHODS = {"rosenbrock23": L.METHOD_ROSENBROCK, "ode23s": L.METHOD_ROSENBROCK,
           "dopri5": L.METHOD_DOPRI, "ode45": L.METHOD_DOPRI, "rodas4": L.METHOD_RODAS4,
           "rodas4-exp": L.METHOD_RODAS4_EXP}


SHIFT_SPEED_REL = 1e-9
"""The thesis shift flips (Equation 1) once the motor speed is past this fraction
of its typical speed on the other side: far above round-off (a speed decaying to
rest must not flip it on a 1e-15 rad/s excursion), far below any real reversal,
and fixed, so the model is the same at every tolerance (tied to rtol, it hid the
small reversals of a bang-bang run with the shift at rtol 1e-6: 4 impacts
against 95, and an IAE 0.5 % off the converged one)."""


class _SegmentFields(NamedTuple):
    t: np.ndarray
    v: np.ndarray
    s: np.ndarray
    d: np.ndarray | None = None


class Segments(_SegmentFields):
    """Piecewise-linear input: on ``[t[k], t[k+1])`` the value is ``v[k] + s[k] (t - t[k])``.

    The last segment lasts until the end of the run.  SI units.  The arrays
    are checked when the segments are made (the compiled core would read past
    a short array, skip a reversed time and run on a NaN).

    Parameters
    ----------
    t : array_like
        Start of each segment, s: starts at 0, strictly increasing.
    v : array_like
        Value at each segment's start: the set point, rad, or for an open
        controller the input, V (N m or N for a torque or force drive).
    s : array_like
        Slope of each segment, rad/s (or V/s, N m/s, N/s).
    d : array_like or None
        For a sampled controller, a disturbance added to its output after the
        saturation, V, one value per segment; None: none.

    Raises
    ------
    ConfigError
        Naming the array, the first bad element and the unit: arrays of
        different lengths, an empty ``t``, ``t`` not starting at 0 or not
        strictly increasing, a NaN or infinite value.

    Examples
    --------
    >>> import numpy as np
    >>> from gearbench import Segments
    >>> seg = Segments([0.0, 1.0], np.radians([0.0, 10.0]), [0.0, 0.0])  # a 10 deg step at 1 s
    >>> seg.t
    array([0., 1.])
    >>> Segments([0.0, 2.0, 1.0], [0.0, 0.1, 0.2], [0.0, 0.0, 0.0])
    Traceback (most recent call last):
    ...
    gearbench.errors.ConfigError: Segments: t must increase strictly (s): t[2] = 1 s comes after t[1] = 2 s
    """
    __slots__ = ()

    def __new__(cls, t, v, s, d=None):
        arrays, problems = segment_problems(t, v, s, d)
        if problems:
            raise ConfigError("Segments", problems)
        return super().__new__(cls, *arrays)


_SEGMENT_UNITS = {"t": "s", "v": "rad, or V (N m, N) for an open controller",
                  "s": "rad/s, or V/s (N m/s, N/s) for an open controller", "d": "V"}


def segment_problems(t, v, s, d=None) -> tuple[list, list[str]]:
    """The four arrays as float arrays (``d`` may stay None), and every problem found."""
    arrays, problems = [], []
    for name, x in zip("tvsd", (t, v, s, d)):
        if x is None and name == "d":
            arrays.append(None)
            continue
        unit = _SEGMENT_UNITS[name]
        try:
            a = np.asarray(x, dtype=float)
        except (TypeError, ValueError):
            problems.append(f"{name} must be a one-dimensional array of numbers in {unit}, "
                            f"got a {type(x).__name__}")
            arrays.append(None)
            continue
        if a.ndim != 1 or a.size == 0:
            problems.append(f"{name} must be a non-empty one-dimensional array in {unit}, "
                            f"got shape {a.shape}")
            arrays.append(None)
            continue
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            more = f" ({bad.size} bad in all)" if bad.size > 1 else ""
            problems.append(f"{name}[{bad[0]}] is {a[bad[0]]}: every value must be a finite number "
                            f"in {unit}{more}")
        arrays.append(a)
    t = arrays[0]
    for name, a in zip("vsd", arrays[1:]):
        if a is not None and t is not None and a.size != t.size:
            problems.append(f"{name} has {a.size} values, t has {t.size}: one per segment")
    if t is not None and np.all(np.isfinite(t)):
        if t[0] != 0.0:
            problems.append(f"t[0] must be 0 s (a run starts at t = 0), got {t[0]:g} s")
        back = np.flatnonzero(np.diff(t) <= 0.0)
        if back.size:
            k = int(back[0]) + 1
            problems.append(f"t must increase strictly (s): t[{k}] = {t[k]:g} s comes after "
                            f"t[{k - 1}] = {t[k - 1]:g} s")
    return arrays, problems


@dataclass(frozen=True)
class SolverOptions:
    """How a run is solved; :func:`simulate` checks it as an experiment's ``solver:`` section.

    Parameters
    ----------
    method : str
        ``rodas4`` (default: L-stable Rosenbrock, fourth order), ``rodas4-exp``
        (the same, with an affine model's event-free steps between output samples
        exact: ``solver/exponential.py``; what a replay solves with),
        ``rosenbrock23`` (alias ``ode23s``, the thesis's stiff method, second
        order) or ``dopri5`` (alias ``ode45``, explicit).
    rtol : float
        Relative tolerance, between 0 and 1 (absolute tolerances follow from
        each state's typical scale).
    max_step_s : float
        Largest step, s (events inside a step are caught at the
        interpolant's extrema; the cap is a backstop).
    max_steps : int
        Step budget of one run.
    output_dt_s : float
        Sampling interval of the returned trace, s.
    friction_speed_rel : float
        The speed below which friction's sign is regularised
        (``tanh(w/eps)``), relative to each shaft's typical speed.

    Examples
    --------
    >>> from gearbench import SolverOptions
    >>> SolverOptions(rtol=1e-7).method
    'rodas4'
    """
    method: str = "rodas4"
    rtol: float = 1e-6
    max_step_s: float = 1e-2
    max_steps: int = 20_000_000
    output_dt_s: float = 1e-3
    friction_speed_rel: float = 1e-5


SOLVER = {
    "method": Choice(tuple(METHODS), required=False),
    "rtol": Number("", low=0.0, high=1.0, required=False),
    "max_step_s": Number("s", low=0.0, low_strict=True, required=False),
    "output_dt_s": Number("s", low=0.0, low_strict=True, required=False),
    "max_steps": Number("steps", low=0.0, low_strict=True, integer=True, required=False),
}
"""The keys of an experiment file's ``solver:`` section (:class:`SolverOptions` fields) and their
checks; :func:`run_problems` checks a :class:`SolverOptions` with them too."""


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
    """The compiled core's parameter vector for this plant and controller,
    both packed from the resolved plant (structural effects built in)."""
    return pack_controller(controller, plant.resolved(), pack_plant(plant))


def simulate(plant: Plant, controller: Controller, inputs: Segments, t_end: float,
             options: SolverOptions = SolverOptions(), delta0: float = 0.0,
             label: str = "", raise_on_failure: bool = False) -> RunResult:
    """Simulate ``plant`` under ``controller`` following ``inputs`` for ``t_end`` s.

    ``delta0`` places the mesh inside its clearance at the start (rad, 0 =
    centred).  A failed run comes back with ``ok == False`` and its status,
    or raises :class:`SolverError` naming the run, the time and the likely
    cause when ``raise_on_failure``.  The arguments are checked first: a
    :class:`~gearbench.errors.ConfigError` names each bad one and its unit.
    """
    problems = run_problems(plant, controller, inputs, t_end, delta0, options)
    if problems:
        raise ConfigError("simulate", problems)
    run = simulate_packed(pack(plant, controller), tolerance_scales(plant), inputs, t_end,
                          rest_state(plant, delta0), options, label)
    if not run.ok:
        # kept with the run (it may come back from a worker) so its message can name a stiff mesh
        run.meta["mesh"] = mesh_figures(plant)
        if raise_on_failure:
            raise SolverError(failure_message(run, plant.name, plant))
    return run


MAX_SAMPLES = 10_000_000
"""Most samples a returned trace may hold (720 MB of outputs); more is refused, not allocated."""


def run_problems(plant, controller, inputs, t_end, delta0=0.0,
                 options: SolverOptions = SolverOptions()) -> list[str]:
    """What is wrong with :func:`simulate`'s arguments (empty when nothing is)."""
    problems = []
    for name, value, cls in (("plant", plant, Plant), ("controller", controller, Controller),
                             ("inputs", inputs, Segments)):
        if not isinstance(value, cls):
            problems.append(f"{name} must be a {cls.__name__}, got {show(value)}")
    t_end_ok = Number("s").check(t_end, "t_end", problems) is not None
    if isinstance(options, SolverOptions):
        before = len(problems)
        for name, spec in {**SOLVER, "friction_speed_rel": Number("")}.items():
            spec.check(getattr(options, name), f"options.{name}", problems)
        if t_end_ok and len(problems) == before and t_end / options.output_dt_s > MAX_SAMPLES:
            problems.append(f"t_end = {t_end:g} s sampled every options.output_dt_s = {options.output_dt_s:g} s "
                            f"is {t_end / options.output_dt_s:.3g} samples, more than {MAX_SAMPLES:.0e} "
                            f"(x {L.N_OUT} outputs x 8 bytes); raise output_dt_s or shorten the run")
    else:
        problems.append(f"options must be a SolverOptions, got {show(options)}")
    if isinstance(plant, Plant):
        try:
            h_deg = plant.resolved().gear.backlash_deg / 2.0  # the clearance may come from an effect
        except ValueError:  # a bad structural effect: load_plant names it
            h_deg = plant.gear.backlash_deg / 2.0
        if Number("rad", low=None).check(delta0, "delta0", problems) is not None \
                and abs(delta0) > math.radians(h_deg):
            problems.append(f"delta0 must lie within +-{math.radians(h_deg):.6g} rad (half of "
                            f"gear.backlash_deg = {2 * h_deg:g} deg), got {delta0!r}")
        shift = getattr(controller, "shift_deg", None)
        if shift is not None and shift > 2 * h_deg:
            problems.append(f"controller.shift_deg must lie between 0 and the clearance "
                            f"gear.backlash_deg = {2 * h_deg:g} deg, got {shift!r}")
    return problems


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
    p = np.asarray(p, dtype=float)
    model = compiled_model(needs_states(p))
    if len(p) > model.SIZE:
        raise ValueError(f"p has {len(p)} slots but the compiled model with the effects registered in this "
                         f"process has {model.SIZE}: pack the plant in the process that simulates it")
    # a vector packed before an effect module was loaded lacks only that module's blocks (absent: 0),
    # and a state made so lacks the effects' own states (at 0; their scales are 1 then)
    p = np.concatenate((p, np.zeros(model.SIZE - len(p)))) if len(p) < model.SIZE else p.copy()
    x0 = np.concatenate((x0, np.zeros(model.n_state - len(x0)))) if len(x0) < model.n_state else x0
    scales = np.concatenate((scales, np.ones(model.n_state - len(scales))))
    p[L.P_SPEED_EPS] = SHIFT_SPEED_REL * scales[L.X_WM]
    p[L.P_FRIC_EPS_M] = options.friction_speed_rel * scales[L.X_WM]
    p[L.P_FRIC_EPS_L] = options.friction_speed_rel * scales[L.X_WL]
    p[L.P_STOP_EPS_M] = options.rtol * scales[L.X_WM]
    p[L.P_STOP_EPS_L] = options.rtol * scales[L.X_WP if p[L.P_RIGID] > 0.0 else L.X_WL]
    if output_times is None:
        t_out = np.linspace(0.0, t_end, int(round(t_end / options.output_dt_s)) + 1)
    else:
        t_out = np.ascontiguousarray(output_times, dtype=float)
    d = np.zeros(len(inputs.t)) if inputs.d is None else inputs.d
    try:
        outputs, stats, x_end, seg_u = model.integrate(
            p, np.ascontiguousarray(inputs.t, dtype=float),
            np.ascontiguousarray(inputs.v, dtype=float), np.ascontiguousarray(inputs.s, dtype=float),
            np.ascontiguousarray(d, dtype=float), float(t_end), np.asarray(x0, dtype=float), t_out,
            float(options.rtol), options.rtol * scales, float(options.max_step_s),
            METHODS[options.method], int(options.max_steps))
    except SystemError as exc:
        # a Ctrl-C inside the compiled core surfaces as a SystemError; give callers the interrupt
        # itself, so that no `except Exception` records it as a failed run
        if is_interrupt(exc):
            raise KeyboardInterrupt from exc
        raise
    return RunResult(t_out, outputs, stats, float(t_end), label,
                     {"x_end": x_end, "segment_input": seg_u, "method": options.method})


STIFF_MESH_HZ = 1e6
"""An engaged mesh mode above this frequency is called very stiff when a run fails.
Gear meshes ring at kHz to a few hundred kHz (the thesis's ~110 kHz); far above, the
mesh is as good as rigid for the load's motion, yet it still sets the solver's step
where the teeth strike and rattle."""

MESH_BOUND_PERIODS = 10.0
"""An explicit method whose mean step stayed under this many mesh periods was held
to the mesh's period by its stability limit (a stiff method is not)."""


def mesh_figures(plant: Plant) -> tuple[float, float | None]:
    """``(k, f)``: the mesh stiffness (N m/rad) and the engaged mesh mode's frequency (Hz).

    ``f`` is the damped oscillatory mode in which the mesh deflection takes part most
    (:func:`gearbench.plant.linear.plant_info`'s rule, with the plant's own drive); for an overdamped mesh, the undamped
    ``sqrt(k (1/Jl + 1/(Jm N^2))) / 2 pi`` (``Jm`` with the pinion, ``Jl`` the output
    inertia); None if neither can be computed.
    """
    from .plant.linear import _mode_of, _oscillatory  # late: scipy's eigen-solver, for failed runs only

    k = float(plant.gear.mesh_stiffness)
    try:
        # the engaged modes of the plant as driven: a torque- or force-driven plant has no
        # electrics (``plant_info``'s figures are a DC motor's; a torque drive's failed run raised
        # TypeError here, on its resistance None)
        mesh = _mode_of(_oscillatory(plant, electrics=plant.drive == "voltage"), "delta")
        f = mesh["frequency_hz"] if mesh else None
        if f is None:
            jm = plant.motor.inertia + (plant.shaft.pinion_inertia if plant.shaft is not None else 0.0)
            f = math.sqrt(k * (1.0 / plant.output_inertia + 1.0 / (jm * plant.gear.ratio ** 2))) / (2 * math.pi)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError):
        f = None
    return k, (float(f) if f is not None and math.isfinite(f) and f > 0 else None)


def _stiff_mesh_hint(run: RunResult, plant: Plant | None) -> str | None:
    """The cause of a run whose step collapsed against a stiff mesh, or None if it was not that.

    The mean accepted step ``h = t_fail / steps`` (s) is set against the mesh period
    ``1 / f``: a mesh above :data:`STIFF_MESH_HZ` is named whatever the method; below it, an
    explicit method whose ``h f`` stayed under :data:`MESH_BOUND_PERIODS` was held by the mesh.
    """
    k, f = mesh_figures(plant) if plant is not None else run.meta.get("mesh", (None, None))
    if not f:
        return None
    t, steps = float(run.stats[L.S_T_FAIL]), max(int(run.stats[L.S_STEPS]), 1)
    h = t / steps
    method = run.meta.get("method", "")
    explicit = METHODS.get(method) == L.METHOD_DOPRI
    seen = (f"the solver's steps averaged {h:.2g} s ({h * f:.3g} mesh periods) over {steps} steps "
            f"and {run.impacts} tooth impacts to t = {t:.6g} s")
    if f >= STIFF_MESH_HZ:
        fix = ("solve with the stiff method rodas4 (the default; the explicit "
               f"{method} must step inside every mesh period), or lower gear.mesh_stiffness"
               if explicit else "lower gear.mesh_stiffness")
        return (f"the mesh is very stiff (k = {k:.3g} N m/rad, f = {f:.3g} Hz): {seen}; {fix} to the pair's "
                f"real stiffness (gear meshes ring at kHz to a few 100 kHz; `gearbench info` prints f), "
                f"or raise solver.max_steps")
    if explicit and h * f < MESH_BOUND_PERIODS:
        return (f"the mesh (k = {k:.3g} N m/rad, f = {f:.3g} Hz) is too stiff for the explicit method "
                f"{method}, whose steps must stay inside the mesh period ({1 / f:.2g} s): {seen}; "
                f"solve with rodas4 (the default) or ode23s")
    return None


def _budget_hint(run: RunResult) -> str:
    """Where an exhausted budget of steps and events went, and what that points to."""
    steps, rejected, events = (int(run.stats[i]) for i in (L.S_STEPS, L.S_REJECTED, L.S_EVENTS))
    spent = f"{steps} steps, {rejected} rejected, and {events} mode switches"
    if events > steps:
        return (f"{spent}: modes switching back and forth (a bang-bang band, a set-point shift, stick-slip "
                "friction or teeth touching at zero force); widen the band, or raise max_steps")
    if rejected > steps:
        return (f"{spent}: the step size collapsing (an unstable gain, or a right-hand side that jumps "
                "without an event); lower the gain, or raise max_steps")
    return f"{spent}: a fast motion or a long run; raise max_steps, or check the gains"


def failure_message(run: RunResult, name: str, plant: Plant | None = None) -> str:
    """Which run failed, where in time, and the likely cause.

    ``plant`` (or, for a run from :func:`simulate`, ``run.meta["mesh"]``) lets the
    message name a stiff mesh, with its stiffness (N m/rad) and frequency (Hz), when
    the step size collapsed against it (:func:`_stiff_mesh_hint`).
    """
    t = run.stats[L.S_T_FAIL]
    status = int(run.stats[L.S_STATUS])
    hint = None
    if status in (L.STATUS_STEP_TOO_SMALL, L.STATUS_MAX_STEPS):
        hint = _stiff_mesh_hint(run, plant)
    hint = hint or {
        L.STATUS_STEP_TOO_SMALL: "the plant is probably unphysical or far too stiff for the tolerance "
                                 "(check mesh_stiffness/mesh_damping against the inertias, and the gains)",
        L.STATUS_MAX_STEPS: _budget_hint(run),
        L.STATUS_NONFINITE: "the state blew up: an unstable gain or a non-physical parameter",
        L.STATUS_CHATTER: (f"{int(run.stats[L.S_EVENTS])} mode switches and {int(run.stats[L.S_STEPS])} steps: "
                           "a contact or a stuck body switching at zero force (teeth touching without "
                           "clearance, stick-slip friction); check the clearance, the friction and the "
                           "stiffnesses"),
    }.get(status, "")
    name = run.label or name
    return f"run {name!r} failed at t = {t:.6g} s: {run.status}; likely cause: {hint}"
