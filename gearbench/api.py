"""gearbench from Python: build or load, simulate, compare, diagnose, fit.

The functions here are the library's front door (``gearbench.__all__``).  They
take the same things the command line reads (a plant file or mapping, a
profile name or file, a measurement CSV) or the objects those become, check
every argument before anything is solved (a :class:`ConfigError` names each
bad argument and its unit, as for a file), and return results that carry
their signals in the measurement format's units: degrees at the edges (mm for
a leadscrew carriage), SI inside.  Gains are in the experiment files' units
(``kp`` in V/deg).

The command line's ``compare``, ``diagnose`` and ``fit`` do the same work
(``gearbench.cli_identify``); a result's ``to_dict()`` holds what their
``--json`` prints.

Examples
--------
>>> import gearbench as gb
>>> plant = gb.load_plant("experiments/plants/thesis_gear.yaml")
>>> run = gb.simulate(plant, gb.Controller("p", kp=50), "profile1", solver={"rtol": 1e-7})
>>> round(run.iae_deg_s, 2)
13.87
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from . import layout as L
from .control.controllers import Controller
from .errors import ConfigError, FitError, NotConverged, SolverError
from .experiment.files import Experiment, load_plant
from .measure.data import COLUMN_UNITS, Measurement, from_frame, read_measurement, with_gaps
from .measure.gaps import MODES as GAP_MODES, check_grid, entry as gaps_entry
from .plant.components import Plant
from .profiles import Profile, load_profile
from .schema import Number, check_mapping, show, unknown_key
from .simulate import MAX_SAMPLES, SOLVER, RunResult, Segments, SolverOptions, failure_message
from .simulate import simulate as _simulate
from .blas import single_threaded

__all__ = ["setpoint", "load_measurement", "simulate", "run_experiment", "compare", "diagnose", "fit",
           "Simulation", "Comparison", "DiagnosisReport", "FitReport"]

EXTRA_UNITS = {
    "error_deg": "deg",
    "motor_speed_deg_per_s": "deg/s",
    "load_speed_deg_per_s": "deg/s",
    "mesh_torque_Nm": "N m",
    "mesh_deflection_deg": "deg",
}
"""Units of the simulated signals that a measurement does not have (see :class:`Simulation`)."""


def _raise(where: str, problems: list[str]) -> None:
    if problems:
        raise ConfigError(where, problems)


# ------------------------------------------------------------------ inputs

def _check_scheduler(scheduler: Any, problems: list[str]) -> None:
    """``scheduler`` is None or an address string (whether anything answers there is known on connecting)."""
    if scheduler is not None and (not isinstance(scheduler, str) or not scheduler.strip()):
        problems.append(f"scheduler must be a Dask scheduler address like 'tcp://HOST:8786', got {show(scheduler)}")


def _as_plant(plant: Any, where: str) -> Plant:
    """A Plant as given, or loaded from a file path or a mapping (checked like a file)."""
    if isinstance(plant, Plant):
        return plant
    if isinstance(plant, (str, Path, Mapping)):
        return load_plant(plant)
    raise ConfigError(where, f"plant must be a Plant, a plant file path or a plant mapping, got {show(plant)}")


def _as_controller(controller: Any, where: str) -> Controller:
    """A Controller as given, or made from a mapping like an experiment's ``controllers`` entry."""
    if isinstance(controller, Controller):
        return controller
    if isinstance(controller, Mapping):
        from .control.controllers import KINDS, SETTING_UNITS
        allowed = {"kind": "|".join(KINDS), **{k: u for k, (u, _) in SETTING_UNITS.items()},
                   "shift": "boolean", "shift_deg": "deg", "compensator": "name"}
        bad = [unknown_key(f"controller.{k}", k, allowed, "a controller setting")
               for k in controller if k not in allowed]
        _raise(where, bad)
        return Controller(**controller)
    raise ConfigError(where, f"controller must be a Controller or a mapping like {{'kind': 'p', 'kp': 50}}, "
                             f"got {show(controller)}")


def _as_solver(solver: Any, where: str) -> SolverOptions:
    """SolverOptions as given, or from a mapping checked like an experiment's ``solver:`` section."""
    if solver is None:
        return SolverOptions()
    if isinstance(solver, SolverOptions):
        return solver
    problems: list[str] = []
    values = check_mapping(solver, "solver", SOLVER, problems, context="a solver setting")
    _raise(where, problems)
    return SolverOptions(**values)


def setpoint(start_s: Sequence[float], value_deg: Sequence[float],
             slope_deg_per_s: Sequence[float] | None = None, *, duration_s: float = 10.0,
             name: str = "setpoint") -> Profile:
    """A piecewise-linear set point in degrees, as a profile file's ``segments`` give it.

    On ``[start_s[k], start_s[k+1])`` the set point is
    ``value_deg[k] + slope_deg_per_s[k] (t - start_s[k])``; a value that
    differs from where the previous segment ended is a step.

    Parameters
    ----------
    start_s : sequence of float
        Start of each segment, s: the first is 0, strictly increasing, the
        last before ``duration_s``.
    value_deg : sequence of float
        Output angle at each segment's start, deg.
    slope_deg_per_s : sequence of float, optional
        Slope of each segment, deg/s; default 0 (steps and dwells only).
    duration_s : float
        Length of a run on this profile, s.
    name : str
        Name shown in tables and titles.

    Returns
    -------
    Profile
        The set point; ``profile(t)`` evaluates it (deg), ``profile.segments()``
        gives it in SI for the solver.

    Raises
    ------
    ConfigError
        Naming the argument, the element and the unit.

    Examples
    --------
    >>> import gearbench as gb
    >>> sp = gb.setpoint([0.0, 0.5, 1.5], [0.0, 0.0, 20.0], [0.0, 20.0, 0.0], duration_s=3.0)
    >>> float(sp(1.0)), float(sp(2.0))
    (10.0, 20.0)
    """
    problems: list[str] = []
    if slope_deg_per_s is None:
        slope_deg_per_s = [0.0] * len(np.atleast_1d(np.asarray(start_s, dtype=object)))
    arrays = {}
    for key, arr, unit in (("start_s", start_s, "s"), ("value_deg", value_deg, "deg"),
                           ("slope_deg_per_s", slope_deg_per_s, "deg/s")):
        try:
            a = np.asarray(arr, dtype=float)
        except (TypeError, ValueError):
            problems.append(f"{key} must be a sequence of numbers in {unit}, got {show(arr)}")
            continue
        if a.ndim != 1 or a.size == 0:
            problems.append(f"{key} must be a non-empty sequence of numbers in {unit}, got shape {a.shape}")
            continue
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            problems.append(f"{key}[{bad[0]}] must be a finite number in {unit}, got {a[bad[0]]}")
        arrays[key] = a
    Number("s").check(duration_s, "duration_s", problems)
    if len(arrays) == 3:
        n = arrays["start_s"].size
        for key in ("value_deg", "slope_deg_per_s"):
            if arrays[key].size != n:
                problems.append(f"{key} has {arrays[key].size} values, start_s has {n}: one per segment")
    t = arrays.get("start_s")
    if t is not None and not problems:
        if t[0] != 0.0:
            problems.append(f"start_s[0] must be 0 s, got {t[0]:g}")
        back = np.flatnonzero(np.diff(t) <= 0)
        if back.size:
            k = int(back[0]) + 1
            problems.append(f"start_s must increase strictly (s): start_s[{k}] = {t[k]:g} after {t[k - 1]:g}")
        if t[-1] >= duration_s:
            problems.append(f"the last segment starts at {t[-1]:g} s, at or after duration_s = {duration_s:g} s")
    _raise("setpoint", problems)
    return Profile(str(name), tuple(map(float, arrays["start_s"])), tuple(map(float, arrays["value_deg"])),
                   tuple(map(float, arrays["slope_deg_per_s"])), float(duration_s))


def load_measurement(source: str | Path | pd.DataFrame | Measurement, gaps: str | None = None) -> Measurement:
    """A measured record, checked: from a measurement CSV, a DataFrame, or as given.

    The columns are the measurement format's (``time_s``, one input such as
    ``voltage_V``, measured signals such as ``load_angle_deg``, ``current_A``;
    see ``gearbench.measure.data``), every value finite, times strictly
    increasing.

    Parameters
    ----------
    source : str, Path, pandas.DataFrame or Measurement
        A CSV file, a table with the file's column names, or a record.
    gaps : {'interpolate', 'drop'}, optional
        Fill or drop a few missing samples (empty cells, rows missing from the time
        grid; :mod:`gearbench.measure.gaps`); the record's ``gaps`` says how many and
        where.  Default: refuse them.

    Returns
    -------
    Measurement
        ``time_s``, ``input`` (``input_name``), ``signals`` (name to array),
        and the set point if the record has one.

    Raises
    ------
    MeasurementError
        Listing every bad column and the first bad row of each.

    Examples
    --------
    >>> import gearbench as gb
    >>> data = gb.load_measurement("experiments/data/bench_rig_hidden.csv")
    >>> data.input_name, sorted(data.signals), round(data.duration_s, 3)
    ('voltage_V', ['current_A', 'load_angle_deg', 'motor_angle_deg'], 10.0)
    """
    if gaps is not None and gaps not in GAP_MODES:
        raise ConfigError("load_measurement", f"gaps must be None (refuse missing samples) or one of "
                                              f"{', '.join(GAP_MODES)}, got {show(gaps)}")
    if isinstance(source, Measurement):
        return source if gaps is None or source.gaps is not None else with_gaps(source, gaps)
    if isinstance(source, pd.DataFrame):
        return from_frame(source, source="<DataFrame>", gaps=gaps)
    if isinstance(source, (str, Path)):
        return read_measurement(source, gaps=gaps)
    raise ConfigError("load_measurement", f"source must be a measurement CSV path, a DataFrame or a "
                                          f"Measurement, got {show(source)}")


# -------------------------------------------------------------- simulation

def _signals(result: RunResult, plant: Plant) -> dict[str, np.ndarray]:
    """The run's sampled outputs as named columns in their edge units (the trace
    file's columns first, from ``report.traces.trace_frame``)."""
    from .synth import input_column
    from .report.traces import trace_frame
    frame = trace_frame(result, plant)
    cols = {c: frame[c].to_numpy() for c in frame.columns if c != "time_s"}
    if plant.drive != "voltage":  # the input is a drive torque or force, and there is no current
        cols[input_column(plant)] = cols.pop("voltage_V")
        cols.pop("current_A")
    if plant.leadscrew is not None:
        cols["setpoint_mm"] = result.outputs[:, L.O_SETPOINT] * plant.leadscrew.radius * 1e3
    o = result.outputs
    deg = math.degrees(1.0)
    cols["error_deg"] = cols["setpoint_deg"] - cols["load_angle_deg"]
    cols["motor_speed_deg_per_s"] = o[:, L.O_WM] * deg
    cols["load_speed_deg_per_s"] = o[:, L.O_WL] * deg
    cols["mesh_torque_Nm"] = o[:, L.O_TORQUE].copy()
    cols["mesh_deflection_deg"] = o[:, L.O_DELTA] * deg
    return cols


@dataclass
class Simulation:
    """One simulated run: named signals in their units, the scores, the status.

    Parameters
    ----------
    result : RunResult
        The solver's output (SI: rad, rad/s), kept as ``result``.
    plant : Plant
        The plant simulated.
    controller : Controller
        Its controller.
    profile : str
        Name of the set point (or input) followed.

    Attributes
    ----------
    time_s : numpy.ndarray
        Sample times, s.
    signals : dict of str to numpy.ndarray
        ``setpoint_deg``, ``load_angle_deg``, ``motor_angle_deg`` (the rotor,
        deg of its own shaft), ``voltage_V`` (``drive_torque_Nm`` /
        ``drive_force_N`` for a torque or force drive), ``current_A`` (voltage
        drive), ``error_deg`` (set point minus output), ``motor_speed_deg_per_s``,
        ``load_speed_deg_per_s``, ``mesh_torque_Nm`` (on the load),
        ``mesh_deflection_deg`` (``theta_pinion/N - theta_load``); with a
        leadscrew also ``load_position_mm`` and ``setpoint_mm``.
    units : dict of str to str
        Each signal's unit.
    scores : dict
        ``iae_deg_s`` (deg s), ``rms_deg``, ``max_deg`` (deg),
        ``saturated_fraction``, ``impacts``, ``switchings`` (voltage sign
        changes), ``steps``; with a leadscrew ``iae_mm_s`` (mm s).
    status : str
        ``ok`` or why the solver stopped (``message`` says where).

    Examples
    --------
    >>> import gearbench as gb
    >>> run = gb.simulate("experiments/plants/thesis_gear.yaml", gb.Controller("p", kp=50), "profile1",
    ...                   duration_s=2.0)
    >>> run.units["load_angle_deg"], run.status
    ('deg', 'ok')
    >>> list(run.to_pandas().columns[:4])
    ['time_s', 'voltage_V', 'motor_angle_deg', 'load_angle_deg']
    """
    result: RunResult
    plant: Plant
    controller: Controller
    profile: str = ""
    signals: dict = field(init=False, repr=False)
    units: dict = field(init=False, repr=False)

    def __post_init__(self):
        self.signals = _signals(self.result, self.plant)
        self.units = {name: COLUMN_UNITS.get(name) or EXTRA_UNITS[name] for name in self.signals}

    @property
    def time_s(self) -> np.ndarray:
        return self.result.time_s

    @property
    def ok(self) -> bool:
        return self.result.ok

    @property
    def status(self) -> str:
        return self.result.status

    @property
    def message(self) -> str:
        """Empty for a finished run; else which run failed, where, and the likely cause."""
        return "" if self.ok else failure_message(self.result, self.plant.name)

    @property
    def iae_deg_s(self) -> float:
        """Integrated absolute output error, deg s."""
        return self.result.iae_deg_s

    @property
    def scores(self) -> dict:
        s = {k: v if isinstance(v, int) else float(v) for k, v in self.result.scores().items()}
        if self.plant.leadscrew is not None:
            s["iae_mm_s"] = math.radians(s["iae_deg_s"]) * self.plant.leadscrew.radius * 1e3
        return s

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.signals[name]
        except KeyError:
            raise KeyError(f"no signal {name!r}; this run has {', '.join(self.signals)}") from None

    def to_pandas(self) -> pd.DataFrame:
        """The trace as a table: ``time_s`` then every signal, the unit in each
        column's name (and in ``frame.attrs["units"]``)."""
        df = pd.DataFrame({"time_s": self.time_s, **self.signals})
        df.attrs["units"] = {"time_s": "s", **self.units}
        return df

    def to_dict(self) -> dict:
        """The run's identity, status and scores as plain values (JSON-ready)."""
        c = self.controller
        return {"plant": self.plant.name, "profile": self.profile, "controller": c.kind,
                "kp_V_per_deg": c.kp if c.kind in ("p", "pi", "pid") else None,
                "compensator": c.effective_compensator, "status": self.status, "message": self.message,
                **self.scores}

    def plot(self, title: str = ""):
        """Set point, output and motor angle / N (deg), the error (deg), the
        input (V, or N m / N) and the current (A) against time.

        Returns a ``matplotlib.figure.Figure`` not managed by pyplot (as the
        command line's figures): it never changes the backend or closes other
        figures, works headless, shows in a notebook, saves with ``fig.savefig``.
        """
        from matplotlib.figure import Figure
        c = self.controller
        gain = f" Kp={c.kp:g} V/deg" if c.kind in ("p", "pi", "pid") else ""
        t, sig = self.time_s, self.signals
        fig = Figure(figsize=(9, 7), layout="constrained")
        ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True, gridspec_kw={"height_ratios": [3, 1.5, 1.5]})
        ax1.plot(t, sig["setpoint_deg"], "k--", lw=1, label="set point")
        ax1.plot(t, sig["motor_angle_deg"] / self.plant.gear.ratio, lw=1, label="motor angle / N")
        ax1.plot(t, sig["load_angle_deg"], lw=1, label="output angle")
        ax1.set_ylabel("output angle (deg)")
        ax1.legend(loc="best", fontsize=8)
        ax1.set_title(title or f"{self.plant.name}: {self.profile}, {c.kind}{gain}, {c.effective_compensator}")
        ax2.plot(t, sig["error_deg"], lw=0.8, color="C3")
        ax2.set_ylabel("output error (deg)")
        name = next(n for n in ("voltage_V", "drive_torque_Nm", "drive_force_N") if n in sig)
        ax3.plot(t, sig[name], lw=0.6, color="C2")
        ax3.set_ylabel(f"{name.split('_')[0]} ({self.units[name]})")
        if "current_A" in sig:
            ax4 = ax3.twinx()
            ax4.plot(t, sig["current_A"], lw=0.6, color="C4", alpha=0.7)
            ax4.set_ylabel("current (A)", color="C4")
        ax3.set_xlabel("time (s)")
        for ax in (ax1, ax2, ax3):
            ax.grid(alpha=0.3)
        return fig

    def _repr_html_(self) -> str:
        """A notebook's view: the run's identity and scores as a table, and a small plot."""
        from .report.html import simulation_card
        return simulation_card(self)

    def __repr__(self) -> str:
        return (f"Simulation({self.plant.name!r}, {self.profile!r}, {self.controller.kind}, "
                f"status={self.status!r}, iae_deg_s={self.iae_deg_s:.6g}, samples={self.time_s.size})")


def simulate(plant: Plant | str | Path | Mapping, controller: Controller | Mapping,
             setpoint: Profile | Segments | str | Path, duration_s: float | None = None, *,
             solver: SolverOptions | Mapping | None = None, initial_delta_deg: float = 0.0,
             raise_on_failure: bool = True) -> Simulation:
    """Simulate a plant under a controller following a set point.

    Parameters
    ----------
    plant : Plant, str, Path or Mapping
        A plant, a plant YAML file, or a mapping with the file's sections
        (``motor``, ``gear``, ``load``, ...; checked like the file).
    controller : Controller or Mapping
        The law; a mapping such as ``{"kind": "p", "kp": 50}`` (kp in V/deg)
        is checked like an experiment's ``controllers`` entry.
    setpoint : Profile, Segments, str or Path
        A profile (``setpoint(...)``, ``load_profile(...)``), a profile name
        (``"profile1"``) or file; or ``Segments`` in SI units (rad; for
        ``Controller("open")`` the input itself, V).
    duration_s : float, optional
        Simulated time, s; default the profile's ``duration_s`` (required
        with ``Segments``).
    solver : SolverOptions or Mapping, optional
        Solver settings, e.g. ``{"method": "rodas4", "rtol": 1e-7}``
        (checked like an experiment's ``solver:`` section); default
        ``SolverOptions()`` (rodas4, rtol 1e-6, 1 ms output).
    initial_delta_deg : float
        Where the mesh sits in its clearance at t = 0, output deg (0 = centred,
        within +-``backlash_deg/2``).
    raise_on_failure : bool
        Raise :class:`SolverError` when the solver cannot finish (default);
        False returns the partial run with its ``status`` and ``message``.

    Returns
    -------
    Simulation
        Signals in degrees (mm for a carriage), V, A; scores in deg s.

    Raises
    ------
    ConfigError
        Naming every bad argument and its unit, before anything is solved.
    SolverError
        A run the solver could not finish (``raise_on_failure``), naming the
        time and the likely cause.

    Examples
    --------
    >>> import gearbench as gb
    >>> run = gb.simulate("experiments/plants/thesis_gear.yaml", {"kind": "p", "kp": 50}, "profile1",
    ...                   duration_s=3.0)
    >>> float(run["setpoint_deg"][-1]), round(float(run["load_angle_deg"][-1]), 2)  # lags the ramp
    (20.0, 18.29)
    >>> gb.simulate("experiments/plants/thesis_gear.yaml", {"kind": "p", "kp": 50}, "profile1",
    ...             duration_s=-1.0)
    Traceback (most recent call last):
    ...
    gearbench.errors.ConfigError: simulate: duration_s must be a positive number in s, got -1.0
    """
    where = "simulate"
    plant = _as_plant(plant, where)
    controller = _as_controller(controller, where)
    options = _as_solver(solver, where)
    problems: list[str] = []
    if isinstance(setpoint, (str, Path)):
        setpoint = load_profile(setpoint)
    if isinstance(setpoint, Profile):
        if controller.kind == "open":
            problems.append("an open controller is driven by its input itself: give setpoint as Segments "
                            "in V (N m, N for a torque or force drive), not a profile in deg")
        name, inputs = setpoint.name, setpoint.segments()
        duration_s = setpoint.duration_s if duration_s is None else duration_s
    elif isinstance(setpoint, Segments):
        name, inputs = "segments", setpoint
        if duration_s is None:
            problems.append("duration_s is needed with Segments (s)")
    else:
        problems.append(f"setpoint must be a Profile, a profile name or file, or Segments, got {show(setpoint)}")
        name, inputs = "", None
    if duration_s is not None and Number("s").check(duration_s, "duration_s", problems) is not None:
        if options.output_dt_s > duration_s:  # the trace would hold t = 0 alone
            problems.append(f"solver.output_dt_s must be at most duration_s ({duration_s:g} s), "
                            f"got {options.output_dt_s!r}")
        elif duration_s / options.output_dt_s > MAX_SAMPLES:
            problems.append(f"duration_s = {duration_s:g} s sampled every solver.output_dt_s = "
                            f"{options.output_dt_s:g} s is {duration_s / options.output_dt_s:.3g} samples, more than "
                            f"{MAX_SAMPLES:.0e} (x {L.N_OUT} signals x 8 bytes); raise output_dt_s or shorten the run")
    half = plant.gear.backlash_deg / 2.0
    d0 = Number("deg", low=None).check(initial_delta_deg, "initial_delta_deg", problems)
    if d0 is not None and abs(d0) > half:
        problems.append(f"initial_delta_deg must lie within +-{half:g} deg (half of gear.backlash_deg = "
                        f"{2 * half:g} deg), got {initial_delta_deg!r}")
    _raise(where, problems)
    run = _simulate(plant, controller, inputs, float(duration_s), options, math.radians(d0), label=name)
    if raise_on_failure and not run.ok:
        raise SolverError(failure_message(run, plant.name))
    return Simulation(run, plant, controller, name)


def run_experiment(experiment: Experiment | str | Path, *, workers: int | None = 1,
                   traces: bool = True) -> list[Simulation]:
    """Every run of an experiment (profiles x controllers x shifts), as ``gearbench run`` solves them.

    Parameters
    ----------
    experiment : Experiment, str or Path
        An experiment, or its YAML file (``load_experiment``).
    workers : int or None
        Processes (None: all cores).
    traces : bool
        Keep each run's sampled trace (``output_dt_s`` of the experiment);
        False keeps the scores only (the signals hold the start and the end).

    Returns
    -------
    list of Simulation
        In the experiment's order; a failed run has ``ok`` False and its ``message``.

    Examples
    --------
    >>> import gearbench as gb
    >>> exp = gb.load_experiment("experiments/table1.yaml")
    >>> runs = gb.run_experiment(exp, traces=False)
    >>> len(runs), runs[2].profile, runs[2].controller.kind, round(runs[2].iae_deg_s, 2)
    (30, 'profile1', 'p', 13.87)
    """
    from .experiment.files import load_experiment
    from .runner import run_experiment as _run
    if isinstance(experiment, (str, Path)):
        experiment = load_experiment(experiment)
    if not isinstance(experiment, Experiment):
        raise ConfigError("run_experiment", f"experiment must be an Experiment or an experiment file path, "
                                            f"got {show(experiment)}")
    if workers is not None:
        problems: list[str] = []
        Number("processes", integer=True).check(workers, "workers", problems)
        _raise("run_experiment", problems)
    records = _run(experiment, workers=workers, keep_traces=traces)
    return [Simulation(r.result, experiment.plant, r.controller, r.profile) for r in records]


# ------------------------------------------------------ models against data

def _replay(plant: Any, data: Any, controller: Any, window_s: float, rtol: float, where: str,
            noise_std: Mapping | None = None, noise_from: Any = None, gaps: str | None = None,
            reset_speeds: bool = False):
    """Plant, record and replay, every argument checked before any solving (the CLI's ``_setup``
    reads the files, then comes here).  ``gaps``: what to do with missing samples (``load_measurement``);
    without it a record missing rows from its time grid is refused (``measure.gaps.check_grid``).
    ``reset_speeds``: ``Replay(reset_speeds=)``."""
    from .control.sampled import SampledPV
    from .experiment.controller_file import load_controller
    from .identify.replay import Replay, solver_options, stated_noise
    plant = _as_plant(plant, where)
    data = load_measurement(data, gaps)
    if gaps is None:
        check_grid(data.time_s, data.source)
    problems: list[str] = []
    Number("s", low=0.0, low_strict=False).check(window_s, "window_s", problems)
    Number("", high=1.0).check(rtol, "rtol", problems)
    if isinstance(controller, (str, Path)):
        controller = load_controller(controller)
    elif controller is not None and not isinstance(controller, SampledPV):
        problems.append(f"controller must be None (open loop), a controller file path or a SampledPV, "
                        f"got {show(controller)}")
    if noise_std is not None and not isinstance(noise_std, Mapping):
        problems.append(f"noise_std must be a mapping {{column: standard deviation in its unit}}, got "
                        f"{show(noise_std)}")
    if not isinstance(reset_speeds, bool):
        problems.append(f"reset_speeds must be True or False, got {show(reset_speeds)}")
    elif reset_speeds and (controller is not None or not window_s):
        problems.append("reset_speeds sets the speeds at the seams of an open-loop replay's windows: it needs "
                        "no controller and window_s > 0 s")
    _raise(where, problems)
    rest = None if noise_from is None else load_measurement(noise_from)
    replay = Replay(data, controller, window_s or None, solver_options(rtol),
                    noise_std=stated_noise(data, controller is not None, noise_std, rest), reset_speeds=reset_speeds)
    replay.check(plant)
    return plant, data, replay


@dataclass
class Comparison:
    """A model against a record, per compared signal and per phase of the motion.

    Parameters
    ----------
    plant : Plant
        The model.
    data : Measurement
        The record.
    closed_loop : bool
        Whether the replay ran a controller on the record's set point.
    figures : dict
        What ``identify.compare.comparison`` returns: ``signals`` (one row per
        compared signal: ``signal``, ``unit``, ``rms_error``, ``max_error``,
        ``noise_floor``, ``ratio_to_noise``, ``relative_error_pct``),
        ``primary``, ``phases``, and the arrays ``sim``, ``residuals``.
    time_s : numpy.ndarray
        Sample times from the record's start, s.
    plant_label : str
        What figure titles call the model: its file's name when it came from
        a file, else the plant's name.

    Examples
    --------
    >>> import gearbench as gb
    >>> c = gb.compare("experiments/plants/bench_rig.yaml", "experiments/data/bench_rig_hidden.csv")
    >>> c.primary, c.to_pandas().loc["current_A", "unit"]
    ('load_angle_deg', 'A')
    """
    plant: Plant
    data: Measurement
    closed_loop: bool
    figures: dict = field(repr=False)
    time_s: np.ndarray = field(repr=False)
    plant_label: str = ""

    @property
    def primary(self) -> str:
        """The signal whose error the phases split (and ``diagnose`` minimises)."""
        return self.figures["primary"]

    @property
    def signals(self) -> list[dict]:
        return self.figures["signals"]

    @property
    def simulated(self) -> dict[str, np.ndarray]:
        """Simulated columns at the record's samples, in the record's units."""
        return self.figures["sim"]

    @property
    def residuals(self) -> dict[str, np.ndarray]:
        """Measured minus simulated, per compared column."""
        return self.figures["residuals"]

    def measured(self, name: str) -> np.ndarray:
        """The record's column ``name`` (its unit)."""
        return np.asarray(self.data.input if name == self.data.input_name else self.data.signals[name], float)

    def to_dict(self) -> dict:
        """What ``gearbench compare --json`` prints, without the figure paths (JSON-ready)."""
        plain = (str, int, float, bool, list, dict, type(None))
        extra = {k: v for k, v in self.figures.items() if k not in ("sim", "residuals", "labels", "speed", "position",
                                                                 "residual_tests") and isinstance(v, plain)}
        tests = {k: v.to_json() for k, v in self.figures.get("residual_tests", {}).items()}
        return {"plant": self.plant.name, "data": self.data.source, "closed_loop": self.closed_loop,
                "phases": {}, **extra, "residual_tests": tests, **gaps_entry(self.data)}

    def to_markdown(self, title: str, figures: Sequence[str] = ()) -> str:
        """``compare.md``: per signal the errors against the noise floor, where the primary
        signal's error sits, the residual tests' sentences, and the ``figures`` (file names beside it)."""
        md = [f"# {title} (plant {self.plant.name})", "",
              "| signal | unit | RMS error | max error | noise floor | RMS/noise | relative % |",
              "|---|---|---|---|---|---|---|"]
        md += [f"| {r['signal']} | {r['unit']} | {r['rms_error']:.4g} | {r['max_error']:.4g} | {r['noise_floor']:.3g} | "
               f"{r['ratio_to_noise']:.3g} | {r['relative_error_pct']:.3g} |" for r in self.signals]
        phases = self.figures.get("phases")
        if phases:
            md += ["", f"Where the {self.primary} error sits:", "", "| phase | time share | error share | RMS |",
                   "|---|---|---|---|"]
            md += [f"| {k} | {v['time_share']:.1%} | {v['error_share']:.1%} | {v['rms']:.4g} |" for k, v in phases.items()]
        md += ["", "Residual tests (lagged products within each re-initialisation window):", ""]
        md += [f"- {v.sentence()}" for v in self.figures.get("residual_tests", {}).values()]
        md += [""] + [f"![{f}]({f})" for f in figures]
        return "\n".join(md) + "\n"

    def to_pandas(self) -> pd.DataFrame:
        """One row per compared signal (index ``signal``): unit, RMS and maximum
        error, noise floor, their ratio, relative error (%)."""
        return pd.DataFrame(self.signals).set_index("signal")

    def to_html(self, path: str | Path | None = None) -> str:
        """The comparison as one self-contained HTML page, as ``gearbench compare`` writes it
        (``report.html``): the files, the noise floors, per signal the errors, the figures
        (embedded PNGs), the phases and the residual tests.

        Parameters
        ----------
        path : str or Path, optional
            Also write the page there (atomically).

        Returns
        -------
        str
            The HTML document.
        """
        from .report.html import comparison_page, write
        return write(path, comparison_page(self))

    def _repr_html_(self) -> str:
        """A notebook's view: the signals table and the primary signal measured against simulated."""
        from .report.html import comparison_card
        return comparison_card(self)

    def plot(self, signal: str | None = None):
        """Measured against simulated ``signal`` (default the primary) with the
        residual under it and the motion's phases shaded; returns the Figure."""
        from .report.compare import comparison_figure
        name = signal or self.primary
        if name not in self.simulated:
            raise KeyError(f"no compared signal {name!r}; compared: {', '.join(self.simulated)}")
        unit = next(r["unit"] for r in self.signals if r["signal"] == name)
        return comparison_figure(self.time_s, self.measured(name), self.simulated[name], self.figures.get("labels"),
                                 name, unit, title=f"{self.plant_label or self.plant.name} vs "
                                                   f"{Path(self.data.source).name}")


def compare(plant: Plant | str | Path | Mapping, data: str | Path | pd.DataFrame | Measurement, *,
            controller: str | Path | None = None, window_s: float = 1.0, rtol: float = 1e-6,
            noise_std: Mapping[str, float] | None = None, noise_from: Any = None,
            gaps: str | None = None, reset_speeds: bool = False) -> Comparison:
    """Drive the model as the record was driven and measure where it fails.

    Parameters
    ----------
    plant : Plant, str, Path or Mapping
        The model (a plant, its YAML file or mapping).
    data : str, Path, pandas.DataFrame or Measurement
        The record (see :func:`load_measurement`).
    controller : str, Path or SampledPV, optional
        Replay in closed loop with this controller (a controller file, e.g.
        ``experiments/controllers/emps.yaml``) driven by the record's set
        point; default open loop, driven by the measured input.
    window_s : float
        Open loop: re-initialise the model's angles from the record every
        ``window_s`` s, so an integrating plant does not drift; 0 = never.
    rtol : float
        Solver relative tolerance.
    noise_std : dict, optional
        The measurement noise of some compared columns, ``{column: standard
        deviation}`` in each column's unit (e.g. ``{"load_angle_deg": 0.015}``),
        where it is known (a record of the machine at rest, the sensor's
        datasheet): it is that column's noise floor and weight, and the least
        drift a window's reset acts on; the key ``"all"`` sets every compared
        column (the ones named beside it win).  Default: read from the record's
        third differences, which assumes white noise (coloured noise shows there
        only in part).
    noise_from : str, Path, pandas.DataFrame or Measurement, optional
        A record of the machine at rest (as ``--noise-from``): each compared
        column's noise is its standard deviation there; ``noise_std`` wins
        where both give one.
    gaps : {'interpolate', 'drop'}, optional
        What to do with a few missing samples (as ``--gaps``; see
        :func:`load_measurement` and :mod:`gearbench.measure.gaps`): interpolate up to
        5 in a row, or drop rows at the record's ends.  Default: refuse the record,
        naming the first missing sample.  The JSON's ``gaps`` says how many and where.
    reset_speeds : bool
        Open loop: at every window seam also set the model's speeds to the measured
        ones (a local quartic fit of the measured angles; as ``--reset-speeds``), not
        only its angles, and start the model as the record's first sample has it
        (angles, a shaft's twist, speeds), not at rest.  For a record whose low
        frequencies are not excited (a multisine on a current-driven machine), where a
        window's speed error carried into the next drifts the angles more than the
        dynamics move them.  Default off.

    Returns
    -------
    Comparison
        Per signal: RMS and maximum error in its unit, noise floor, ratio;
        the error's share per phase of the motion.

    Raises
    ------
    ConfigError, MeasurementError
        A bad plant, controller file, record or argument (named, with its unit).
    ReplayError
        A record this plant cannot replay (wrong drive, mm without a leadscrew)
        or a replay the solver could not finish.

    Examples
    --------
    >>> import gearbench as gb
    >>> c = gb.compare("experiments/plants/bench_rig.yaml", "experiments/data/bench_rig_hidden.csv")
    >>> row = c.to_pandas().loc["motor_angle_deg"]
    >>> bool(row["ratio_to_noise"] > 10)   # the plant file misses two effects
    True
    """
    from .identify.compare import comparison
    label = Path(plant).name if isinstance(plant, (str, Path)) else ""
    plant, data, replay = _replay(plant, data, controller, window_s, rtol, "compare", noise_std, noise_from, gaps,
                                  reset_speeds)
    return Comparison(plant, data, replay.closed_loop, comparison(replay, plant), replay.t, label or plant.name)


def _comparison(plant: Plant, replay, label: str) -> Comparison:
    """``plant`` against the record of ``replay``, as :func:`compare` gives it."""
    from .identify.compare import comparison
    if replay is None:
        raise ConfigError("comparison", "this result keeps no replay of its record (made before reports kept one)")
    return Comparison(plant, replay.data, replay.closed_loop, comparison(replay, plant), replay.t, label or plant.name)


@dataclass
class DiagnosisReport:
    """Which effect a model is missing: the candidates ranked, the verdict, the ladder.

    Parameters
    ----------
    diagnosis : gearbench.identify.results.Diagnosis
        The full result (fits, plants), kept as ``diagnosis``.
    replay : gearbench.identify.replay.Replay, optional
        The record and how the model was driven by it; with it :meth:`to_html` shows the
        signals and residuals of each rung's model too.
    plant_label : str
        What the page calls the model: its file's name when it came from a file.

    Examples
    --------
    >>> import gearbench as gb
    >>> import pandas as pd
    >>> first_3s = pd.read_csv("experiments/data/bench_rig_hidden.csv").iloc[:3000]
    >>> d = gb.diagnose("experiments/plants/bench_rig.yaml", first_3s, only=("coulomb_friction",), max_steps=1)
    >>> d.to_pandas()[["effect", "options", "error"]].round(1)
                 effect                options  error
    0  coulomb_friction   {'location': 'load'}    ...
    1  coulomb_friction  {'location': 'motor'}    ...
    """
    diagnosis: Any = field(repr=False)
    replay: Any = field(default=None, repr=False)
    plant_label: str = ""

    def comparison(self) -> Comparison:
        """The fitted model against the record it was fitted on (needs ``replay``): a
        :class:`Comparison`, as :func:`compare` gives it."""
        return _comparison(self.plant, self.replay, self.plant_label)

    @property
    def verdict(self) -> str | None:
        """The first effect the ladder added that is still in the model at its end, or None (see ``reason``)."""
        return self.diagnosis.verdict

    @property
    def reason(self) -> str:
        return self.diagnosis.reason

    @property
    def stopped(self) -> str:
        """Why the ladder ended: "noise floor", "nothing pays", "max steps", "time limit" or "interrupted"."""
        return self.diagnosis.stopped

    @property
    def plant(self) -> Plant:
        """The plant with every effect the ladder added, fitted."""
        return self.diagnosis.plant

    @property
    def baseline_error(self) -> float:
        """RMS of the primary signal's residual before any effect is added, in ``unit``."""
        return self.diagnosis.baseline_error

    @property
    def calibration(self) -> pd.DataFrame:
        """The plant's calibrated values (final model), one row per value: file value, value,
        standard error, unit, tolerance (%), status (``calibrated``, ``held`` or ``file value``), message."""
        rows = {k: {"nominal": c["nominal"], "value": c["value"], "stderr": c["stderr"], "unit": c["unit"],
                    "tolerance_pct": c["tolerance_pct"], "status": c["status"], "message": c.get("message", "")}
                for k, c in self.diagnosis.calibration.items()}
        return pd.DataFrame.from_dict(rows, orient="index",
                                      columns=["nominal", "value", "stderr", "unit", "tolerance_pct", "status",
                                               "message"])

    @property
    def noise_floor(self) -> float:
        return self.diagnosis.noise_floor

    @property
    def timing(self) -> dict:
        """Where the diagnosis spent its time (``to_dict()["timing"]``): ``wall_s``, and per stage and
        per candidate effect the wall time, replays, solver steps (stages) and fits
        (``docs/diagnose-json.md``)."""
        return self.diagnosis.timing

    @property
    def unit(self) -> str:
        return self.diagnosis.unit

    def to_dict(self) -> dict:
        """What ``gearbench diagnose --json`` prints (JSON-ready)."""
        return self.diagnosis.to_json()

    def to_pandas(self) -> pd.DataFrame:
        """The first rung's candidates, best first: effect, options, error (in
        ``unit``), BIC, parameters, standard errors, note."""
        rows = [{"effect": c["effect"], "options": c.get("options", {}), "error": c["error"],
                 "bic": c.get("bic"), "params": c["params"], "stderr": c.get("stderr", {}),
                 "note": c.get("note", "")} for c in self.to_dict()["candidates"]]
        return pd.DataFrame(rows, columns=["effect", "options", "error", "bic", "params", "stderr", "note"])

    def plot(self):
        """The ladder: the error as effects are added, against the noise floor; returns the Figure."""
        from .report.compare import ladder_figure
        d = self.diagnosis
        return ladder_figure(d.ladder_steps(), noise_floor=d.noise_floor, unit=d.unit,
                             title=f"{d.plant.name}: diagnosis", calibration=d.calibration)

    def to_html(self, path: str | Path | None = None) -> str:
        """The diagnosis as one self-contained HTML page, as ``gearbench diagnose`` writes it
        (``report.html``): the files, the noise floors, the ladder with each rung's error before
        and after, the explanations, the fitted values with their standard errors and
        correlations, the final model's signals and residual tests, the calibration, the
        candidates, what was not tried and the timing (when the diagnosis has it).  Figures are
        embedded PNGs; with ``replay`` each rung's model is replayed once for them.

        Parameters
        ----------
        path : str or Path, optional
            Also write the page there (atomically).

        Returns
        -------
        str
            The HTML document.
        """
        from .report.html import diagnosis_page, write
        return write(path, diagnosis_page(self))

    def _repr_html_(self) -> str:
        """A notebook's view: the verdict, the ladder table and the ladder figure."""
        from .report.html import diagnosis_card
        return diagnosis_card(self)

    def __repr__(self) -> str:
        return (f"DiagnosisReport(verdict={self.verdict!r}, baseline_error={self.baseline_error:.4g} {self.unit}, "
                f"ladder={[s.effect for s in self.diagnosis.ladder]})")


def diagnose(plant: Plant | str | Path | Mapping, data: str | Path | pd.DataFrame | Measurement, *,
             controller: str | Path | None = None, window_s: float = 1.0, rtol: float = 1e-6,
             free: Sequence[str] = (), only: Sequence[str] = (), also: Sequence[str] = (), max_steps: int = 4,
             workers: int | None = 1, calibrate: bool = True, scheduler: str | None = None,
             time_limit_s: float | None = None, progress=None,
             noise_std: Mapping[str, float] | None = None, noise_from: Any = None,
             gaps: str | None = None, reset_speeds: bool = False) -> DiagnosisReport:
    """Which physical effect is the model missing?  Fit each, rank by BIC, climb the ladder.

    Parameters
    ----------
    plant : Plant, str, Path or Mapping
        The model.
    data : str, Path, pandas.DataFrame or Measurement
        The record.
    controller : str, Path or SampledPV, optional
        Closed-loop replay with this controller (see :func:`compare`).
    window_s : float
        Open-loop re-initialisation interval, s (0 = never).
    rtol : float
        Solver relative tolerance.
    noise_std : dict, optional
        The measurement noise of some compared columns, as in :func:`compare`.
    noise_from : str, Path, pandas.DataFrame or Measurement, optional
        A record of the machine at rest, as in :func:`compare`.
    gaps : {'interpolate', 'drop'}, optional
        Missing samples, as in :func:`compare`.
    reset_speeds : bool
        Set the model's speeds too at every window seam, as in :func:`compare`.
    free : sequence of str
        Plant parameters refitted with every candidate, e.g. ``("leadscrew.mass",)``.
    only : sequence of str
        Try only these effects (a model structure).
    also : sequence of str
        Effects tried only when asked for (``lugre_friction``, ``winding_heating``: each
        refines physics the library has, at a cost every record would pay) to try as well.
    max_steps : int
        Longest ladder.
    workers : int or None
        Processes fitting candidates (None: all cores).  Ignored with ``scheduler``.
    calibrate : bool
        The plant's own datasheet values within their tolerances (the plant file's
        ``{value, tolerance_pct}``, else 20 %) may be calibrated, once, as a step that
        competes with the effects (``gearbench.identify.calibration``); the report's
        ``calibration``.
    scheduler : str, optional
        Address of a running Dask distributed scheduler (``tcp://HOST:PORT``): what
        ``workers`` would run runs there, one task per fit (each rung's candidate fits,
        the best three refitted with the effects already added, the pair fits;
        ``gearbench.identify.executor``), with the same answer as locally; the baseline,
        calibration, simplification and pruning stay in this process.
    time_limit_s : float, optional
        Start no new rung after this many seconds, s (the rung that crosses it finishes;
        ``to_dict()["stopped"]`` is then ``"time limit"``).
    progress : callable, optional
        Called with a ``gearbench.identify.progress.ProgressEvent`` (step, stage, fits done
        and to do, the fit just finished, the best so far, seconds elapsed) as each stage
        starts and each fit finishes.

    Returns
    -------
    DiagnosisReport
        ``verdict``, ``reason``, the ladder, the fitted ``plant``.

    Raises
    ------
    ConfigError, MeasurementError, ReplayError
        As :func:`compare`; an unknown effect in ``only`` or ``also`` is named.
    gearbench.errors.DiagnosisInterrupted
        On Ctrl-C during the ladder (a ``KeyboardInterrupt``): its ``diagnosis`` is the
        ladder so far.
    SchedulerError
        ``scheduler`` is malformed or nothing answers there
        (:class:`gearbench.errors.SchedulerError`, a ``ValueError``).

    Examples
    --------
    >>> import gearbench as gb
    >>> d = gb.diagnose("experiments/plants/bench_rig.yaml", "experiments/data/bench_rig_hidden.csv",
    ...                 only=("coulomb_friction",), max_steps=1)
    >>> d.verdict, d.unit
    ('coulomb_friction', 'deg')
    """
    _check_diagnose(max_steps, workers, time_limit_s, progress, scheduler, free, only, also)
    label = Path(plant).name if isinstance(plant, (str, Path)) else ""
    plant, data, replay = _replay(plant, data, controller, window_s, rtol, "diagnose", noise_std, noise_from, gaps,
                                  reset_speeds)
    report = _diagnose_replay(plant, replay, free, only, max_steps, workers, calibrate, scheduler, time_limit_s,
                              progress, also)
    report.plant_label = label or plant.name
    return report


def diagnose_replay(plant: Plant, replay, *, free: Sequence[str] = (), only: Sequence[str] = (),
                    also: Sequence[str] = (), max_steps: int = 4, workers: int | None = 1, calibrate: bool = True,
                    scheduler: str | None = None, time_limit_s: float | None = None,
                    progress=None) -> DiagnosisReport:
    """:func:`diagnose` of a plant and a replay already built (``identify.replay.Replay``, as
    ``gearbench diagnose`` builds it from its files and options), with the same checks.

    Parameters
    ----------
    plant : Plant
        The model.
    replay : gearbench.identify.replay.Replay
        The record and how to drive the model with it.
    free, only, also, max_steps, workers, calibrate, scheduler, time_limit_s, progress
        As in :func:`diagnose`.

    Returns
    -------
    DiagnosisReport
    """
    _check_diagnose(max_steps, workers, time_limit_s, progress, scheduler, free, only, also)
    return _diagnose_replay(plant, replay, free, only, max_steps, workers, calibrate, scheduler, time_limit_s,
                            progress, also)


def _check_diagnose(max_steps, workers, time_limit_s, progress, scheduler, free, only, also) -> None:
    """:func:`diagnose`'s arguments checked, every problem named at once (``ConfigError``)."""
    from .identify.candidates import unknown_effects
    problems: list[str] = []
    Number("steps", integer=True).check(max_steps, "max_steps", problems)
    if workers is not None:
        Number("processes", integer=True).check(workers, "workers", problems)
    if time_limit_s is not None:
        Number("s", low_strict=False).check(time_limit_s, "time_limit_s", problems)
    if progress is not None and not callable(progress):
        problems.append(f"progress must be callable, got {show(progress)}")
    _check_scheduler(scheduler, problems)
    for key, seq in (("free", free), ("only", only), ("also", also)):
        if isinstance(seq, str) or not all(isinstance(s, str) for s in seq):
            problems.append(f"{key} must be a sequence of strings, got {show(seq)}")
    if not problems:
        problems += unknown_effects(only, "only") + unknown_effects(also, "also")
    _raise("diagnose", problems)


def _diagnose_replay(plant, replay, free, only, max_steps, workers, calibrate, scheduler, time_limit_s,
                     progress, also) -> DiagnosisReport:
    from .identify.diagnose import diagnose as _diagnose
    from .identify.fit import Free
    for p in free:
        Free.plant(plant, p)  # a bad key is named before any solving
    return DiagnosisReport(_diagnose(plant, replay, tuple(free), int(max_steps), workers, only=tuple(only),
                                     calibrate=bool(calibrate), scheduler=scheduler, time_limit_s=time_limit_s,
                                     progress=progress, also=tuple(also)), replay, plant.name)


@dataclass
class FitReport:
    """An effect added to a plant and fitted to a record.

    Parameters
    ----------
    effect : str
        The effect and the place it won (``coulomb_friction (load)``).
    plant : Plant
        The plant with the effect, fitted.
    values : dict
        Fitted values by parameter path (``effects[0].torque``), in the
        effect's units (see its plant-file keys).
    stderr : dict
        Their standard errors, same keys and units, valid for residuals correlated in time
        (:func:`gearbench.identify.uncertainty.covariance`).
    error_before, error_after : float
        RMS of the primary signal's residual before and after, in ``unit``.
    unit : str
        Unit of the errors.
    signal : str
        The primary signal.
    message : str
        The optimiser's message.
    units : dict
        The unit of each value and standard error, same keys.
    correlation : dict
        Parameter -> parameter -> correlation of the two estimates.
    tried : list of dict
        Every place tried: ``effect`` (its label), ``converged``, ``note``.
    replay : gearbench.identify.replay.Replay, optional
        The record and how the model was driven by it; with it :meth:`to_html` shows the
        fitted model's signals and residual tests.
    base_plant : Plant, optional
        The plant before the effect was added (the page's "before").
    plant_label : str
        What the page calls the model: its file's name when it came from a file.
    gaps : dict, optional
        What was done to the record's missing samples (``gaps=``): ``measure.gaps.Gaps.to_dict()``.
    numerical : dict
        How far each value moves when the fit is finished at a hundredth of ``rtol``, same keys
        and units (:func:`gearbench.identify.numerics.refine`: Gauss-Newton steps on the replay at
        that tolerance): the error the solver's tolerance left in it.  Where a move exceeds 0.3
        of its standard error the fit has been finished so (``refined``); a small one is only
        reported.
    refined : bool
        Whether ``values`` are the fit finished at the tighter tolerance (``message`` says so).

    Examples
    --------
    >>> import gearbench as gb
    >>> f = gb.fit("experiments/plants/bench_rig.yaml", "experiments/data/bench_rig_hidden.csv", "load_spring")
    >>> f.to_pandas().round(2)
                               value  stderr
    parameter
    effects[0].stiffness        2.34    0.06
    effects[0].rest_angle_deg   1.26    1.62
    """
    effect: str
    plant: Plant = field(repr=False)
    values: dict
    stderr: dict
    error_before: float
    error_after: float
    unit: str
    signal: str
    message: str = ""
    units: dict = field(default_factory=dict)
    correlation: dict = field(default_factory=dict)
    tried: list = field(default_factory=list)
    replay: Any = field(default=None, repr=False)
    base_plant: Plant | None = field(default=None, repr=False)
    plant_label: str = ""
    gaps: dict | None = None
    numerical: dict = field(default_factory=dict)
    refined: bool = False

    def comparison(self) -> Comparison:
        """The fitted model against the record it was fitted on (needs ``replay``): a
        :class:`Comparison`, as :func:`compare` gives it."""
        return _comparison(self.plant, self.replay, self.plant_label)

    def to_html(self, path: str | Path | None = None, output: str | Path | None = None) -> str:
        """The fit as one self-contained HTML page, as ``gearbench fit`` writes it: the files,
        the values with their standard errors and correlations, the places tried, and (with
        ``replay``) the noise floors, the signals before and after and the residual tests.

        Parameters
        ----------
        path : str or Path, optional
            Also write the page there (atomically).
        output : str or Path, optional
            The plant file the fitted plant was written to, named on the page.

        Returns
        -------
        str
            The HTML document.
        """
        from .report.html import fit_page, write
        return write(path, fit_page(self, output=output))

    def _repr_html_(self) -> str:
        """A notebook's view: the values table and the error before and after."""
        from .report.html import fit_card
        return fit_card(self)

    def to_dict(self) -> dict:
        """The fit as plain values (JSON-ready); ``gaps`` when the record's missing samples were filled
        or dropped (``measure.gaps.Gaps.to_dict()``)."""
        return {"effect": self.effect, "values": self.values, "stderr": self.stderr, "units": self.units,
                "correlation": self.correlation, "numerical": self.numerical, "refined": self.refined,
                "error_before": self.error_before, "error_after": self.error_after,
                "error_unit": self.unit, "error_signal": self.signal, "message": self.message, "tried": self.tried,
                **({"gaps": self.gaps} if self.gaps else {})}

    def to_pandas(self) -> pd.DataFrame:
        """One row per fitted parameter: value and standard error."""
        return pd.DataFrame({"value": self.values, "stderr": self.stderr}).rename_axis("parameter")

    def to_yaml(self) -> str:
        """The fitted plant as a plant file, the standard errors as comments."""
        from .experiment.writer import plant_to_yaml
        return plant_to_yaml(self.plant, self.stderr, f"{self.plant.name} + {self.effect}, fitted by gearbench\n"
                             f"error (RMS of {self.signal}): {self.error_before:.4g} -> {self.error_after:.4g} "
                             f"{self.unit}", self.units)


def fit(plant: Plant | str | Path | Mapping, data: str | Path | pd.DataFrame | Measurement, effect: str, *,
        options: Mapping | None = None, start: Mapping | None = None, free: Sequence[str] = (),
        refit: bool = False, controller: str | Path | None = None, window_s: float = 1.0, rtol: float = 1e-6,
        max_evals: int | None = None, calibrate: bool = False, scheduler: str | None = None,
        noise_std: Mapping[str, float] | None = None, noise_from: Any = None,
        gaps: str | None = None, reset_speeds: bool = False) -> FitReport:
    """Add an effect to a plant and fit its parameters (and ``free`` plant parameters) to a record.

    Without a ``location`` in ``options`` every place the effect may act is
    tried and the best (least BIC) kept, as ``gearbench fit`` does.

    Parameters
    ----------
    plant : Plant, str, Path or Mapping
        The model.
    data : str, Path, pandas.DataFrame or Measurement
        The record.
    effect : str
        The effect's name (``gearbench.plant.effects.REGISTRY``), e.g. ``coulomb_friction``.
    options : Mapping, optional
        Its options, e.g. ``{"location": "load"}``.
    start : Mapping, optional
        Starting values of its parameters in its units, e.g. ``{"torque": 0.5}`` (N m).
    free : sequence of str
        Plant parameters fitted too, e.g. ``("load.inertia",)``.
    refit : bool
        Refit the parameters of the effects the plant already has, too.
    controller : str, Path or SampledPV, optional
        Closed-loop replay with this controller (see :func:`compare`).
    window_s : float
        Open-loop re-initialisation interval, s (0 = never).
    rtol : float
        Solver relative tolerance.
    noise_std : dict, optional
        The measurement noise of some compared columns, as in :func:`compare`.
    noise_from : str, Path, pandas.DataFrame or Measurement, optional
        A record of the machine at rest, as in :func:`compare`.
    gaps : {'interpolate', 'drop'}, optional
        Missing samples, as in :func:`compare`.
    reset_speeds : bool
        Set the model's speeds too at every window seam, as in :func:`compare`.
    max_evals : int, optional
        Most simulations the least-squares fit may spend (default 40 per parameter + 40).
    calibrate : bool
        Fit the plant's own datasheet values within their tolerances too (as
        :func:`diagnose` does, restarted on a stall as its calibration is); they are
        among ``values`` and ``stderr``.  Off by
        default: fitted beside one effect while another is still missing, they take up
        part of the missing one (the tutorial's spring fitted alone with them: 1.94 for
        2.00 N m/rad, and the friction fitted next did not bring it back).
    scheduler : str, optional
        Address of a running Dask distributed scheduler (``tcp://HOST:PORT``): the
        places tried (every place the effect may act, without a ``location``) are
        fitted there, one task each, with the same answer as in this process.

    Returns
    -------
    FitReport
        The fitted plant, values, standard errors, the error before and after.

    Raises
    ------
    ConfigError, MeasurementError, ReplayError
        As :func:`compare`; a bad effect, option or free key is named.
    FitError
        No place converged; the plant is unchanged.
    SchedulerError
        ``scheduler`` is malformed or nothing answers there
        (:class:`gearbench.errors.SchedulerError`, a ``ValueError``).

    Examples
    --------
    >>> import gearbench as gb
    >>> f = gb.fit("experiments/plants/bench_rig.yaml", "experiments/data/bench_rig_hidden.csv", "load_spring")
    >>> f.effect, round(f.error_before, 1), round(f.error_after, 2), f.unit   # RMS of the load angle
    ('load_spring', 212.0, 20.21, 'deg')
    """
    from .identify.candidates import unknown_effects
    where = "fit"
    problems: list[str] = []
    if not isinstance(effect, str):
        problems.append(f"effect must be an effect name (a string), got {show(effect)}")
    for key, m in (("options", options), ("start", start)):
        if m is not None and not isinstance(m, Mapping):
            problems.append(f"{key} must be a mapping, got {show(m)}")
    if max_evals is not None:
        Number("simulations", integer=True).check(max_evals, "max_evals", problems)
    if isinstance(free, str) or not all(isinstance(s, str) for s in free):
        problems.append(f"free must be a sequence of strings, got {show(free)}")
    _check_scheduler(scheduler, problems)
    if isinstance(effect, str):
        problems += unknown_effects([effect], "effect")
    _raise(where, problems)
    label = Path(plant).name if isinstance(plant, (str, Path)) else ""
    plant, data, replay = _replay(plant, data, controller, window_s, rtol, where, noise_std, noise_from, gaps,
                                  reset_speeds)
    try:
        report = fit_report(plant, replay, effect, options, start, free, refit, max_evals, bool(calibrate), scheduler)
        report.plant_label = label or plant.name
        return report
    except FitError as exc:
        if isinstance(exc, NotConverged):
            raise
        raise ConfigError(where, str(exc)) from None


@single_threaded
def fit_report(plant: Plant, replay, effect: str, options: Mapping | None = None, start: Mapping | None = None,
               free: Sequence[str] = (), refit: bool = False, max_evals: int | None = None,
               calibrate: bool = False, scheduler: str | None = None) -> FitReport:
    """:func:`fit` of a plant and a replay already built (``identify.replay.Replay``, as
    ``gearbench fit`` builds it): every place of ``effect`` fitted
    (``identify.candidates.fit_effect``), the lowest BIC kept.  Raises ``FitError`` for a bad
    effect, option, starting value or free key, and its ``NotConverged`` (with each place's try)
    when no place converged.  The kept fit is finished at a hundredth of the replay's tolerance
    where that moves a value by more than 0.3 standard errors (``identify.numerics.refine``)."""
    from .identify.candidates import best_tried, fit_effect
    from .identify.numerics import refine
    from .identify.scoring import Scorer
    tried = fit_effect(plant, replay, effect, options, start, free, refit, max_evals, calibrate, scheduler)
    best = best_tried(tried)
    scorer = Scorer(replay)
    res = refine(replay, scorer, best.result)
    return FitReport(best.candidate.label(), res.plant, res.values, res.stderr,
                     scorer.error(replay.run(plant)), res.error, replay.unit(scorer.primary), scorer.primary,
                     res.message, res.units, res.correlation, attempts(tried), replay, plant, plant.name,
                     gaps_entry(replay.data).get("gaps"), res.numerical, res.refined)


def attempts(tried) -> list[dict]:
    """Each place tried: its label, whether it converged and why not."""
    return [{"effect": t.candidate.label(), "converged": t.ok, "note": t.note} for t in tried]
