"""Fit named parameters of a plant and its effects to a record (bounded least squares).

Free parameters are an effect's (``Free.effect(plant, i, key)``) or a plant
field's (``Free.plant(plant, "leadscrew.mass")``), each with bounds and a
typical scale, the way lmfit names them.  The objective is the simulation
error of a :class:`~gearbench.identify.replay.Replay`: every compared column's
residual divided by that column's noise floor, so signals in different units
weigh by how well they are measured.  ``scipy.optimize.least_squares`` (trust
region reflective) works on the parameters divided by their scales, with a
Jacobian by finite differences kept up to date by secant updates between them
(:class:`SecantJacobian`); standard errors and correlations come from a
finite-difference Jacobian at the end and the residuals by a sandwich
covariance valid for residuals correlated in time (:mod:`gearbench.identify.uncertainty`).

An ordering constraint between two parameters of one effect is a change of
coordinates, not a penalty: the fit moves Stribeck friction's breakaway level as
its excess over the sliding level, ``x = T_s - T_c >= 0`` (N m; N at the
carriage), so no fit ends with ``T_s < T_c`` (the effect would silently act as
Coulomb friction there).  ``Free.above`` names the parameter it is the excess
over; :func:`get_value` and :func:`set_values` speak those coordinates, the
fitted values and standard errors are reported in the effect's own
(``T_s = x + T_c``, the covariance carried through the linear map).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np
from scipy.optimize import OptimizeResult, least_squares
from scipy.optimize._numdiff import approx_derivative

from ..errors import FitError, FitSettled, ReplayError
from ..plant.components import FITTABLE, Plant
from ..plant.effects import AddedEffect
from .replay import Replay
from .scoring import Scorer, criterion, objective_signals
from . import uncertainty as U


EXCESS = {("stribeck_friction", "static_torque"): "coulomb_torque"}
"""(effect, parameter) -> the parameter of the same effect it must not fall below: the fit moves
the excess (file keys: ``static_force`` over ``coulomb_force`` at the carriage)."""


@dataclass(frozen=True)
class Free:
    """One free parameter: ``key`` of effect number ``index`` of the plant, or
    (``index`` None) a plant field path such as ``leadscrew.mass``."""
    key: str
    index: int | None
    low: float
    high: float
    scale: float
    unit: str
    above: str | None = None  # the fit coordinate is this value minus parameter ``above`` (>= 0)
    tied: tuple = ()  # ((path, factor), ...): plant fields moved with it, set to factor x its value

    @property
    def name(self) -> str:
        return self.key if self.index is None else f"effects[{self.index}].{self.key}"

    @property
    def label(self) -> str:
        """The name, with the fields tied to it (``motor.torque_constant ~ back_emf_constant``)."""
        return " ~ ".join([self.name] + [t.split(".")[1] for t, _ in self.tied])

    @staticmethod
    def plant(plant: Plant, path: str) -> "Free":
        if path not in FITTABLE:
            raise FitError(f"--free {path}: not a plant parameter gearbench can fit; choose from "
                           f"{', '.join(FITTABLE)}")
        section, key = path.split(".")
        comp = getattr(plant, section)
        if comp is None:
            raise FitError(f"--free {path}: the plant has no {section}")
        v = float(getattr(comp, key))
        unit, low = FITTABLE[path]
        return Free(path, None, low, math.inf, abs(v) if v else 1.0, unit)

    @staticmethod
    def effect(plant: Plant, i: int, sample_time_s: float | None = None) -> list["Free"]:
        """The fit parameters of effect ``i`` (file keys: ``force`` at the carriage), bounded for
        a record sampled every ``sample_time_s`` s where the effect says so (``Param.fit_high``, ``Param.fit_low``)."""
        from ..plant.effects.location import key as file_key
        e = plant.effects[i]
        out = []
        for q in e.effect.fit_params(e.values):
            if q.integer:
                continue
            k = file_key(e.values, q.name) if "location" in e.effect.options else q.name
            scale = q.typical(plant, e.values)
            floor = EXCESS.get((e.name, q.name))
            above = None if floor is None else (
                file_key(e.values, floor) if "location" in e.effect.options else floor)
            out.append(Free(k, i, 0.0 if above else q.fit_floor(plant, e.values),
                            q.fit_bound(plant, e.values, sample_time_s), scale,
                            file_unit(q.unit, e.values.get("location") == "carriage"), above))
        return out


def bounds_of(frees: list[Free]) -> tuple[np.ndarray, np.ndarray]:
    """The lower and upper bounds of ``frees``, in their own units."""
    return np.array([f.low for f in frees]), np.array([f.high for f in frees])


def plant_frees(plant: Plant, items) -> list[Free]:
    """Free plant parameters from ``items``: paths (``--free``: bounded below only) or
    :class:`Free` objects as they are (calibration's, bounded by their tolerances)."""
    return [Free.plant(plant, p) if isinstance(p, str) else p for p in items]


def file_unit(unit: str, carriage: bool) -> str:
    """The unit of a file key: ``"N m (N at the carriage: force)"`` -> ``"N m"``, or ``"N"`` at the
    carriage (where the file key is the force)."""
    base, _, rest = unit.partition(" (")
    return rest.split(" at the carriage")[0] if carriage and rest else base


def param_value(plant: Plant, f: Free) -> float:
    """The parameter's own value (its unit), whatever coordinate the fit moves."""
    if f.index is None:
        section, key = f.key.split(".")
        return float(getattr(getattr(plant, section), key))
    return float(plant.effects[f.index].values[f.key])


def get_value(plant: Plant, f: Free) -> float:
    """The fit coordinate of ``f``: the value, or its excess over ``f.above``."""
    v = param_value(plant, f)
    return v - float(plant.effects[f.index].values[f.above]) if f.above else v


def set_values(plant: Plant, frees: list[Free], values) -> Plant:
    """``plant`` with the free parameters set to ``values`` (fit coordinates, their units).

    An excess is added to its floor parameter's new value (set first), or to its value in
    the plant when that one is not free."""
    effects = list(plant.effects)
    pairs = sorted(zip(frees, values), key=lambda fv: fv[0].above is not None)
    for f, v in pairs:
        v = float(v)
        if f.index is None:
            for path, factor in ((f.key, 1.0),) + f.tied:
                section, key = path.split(".")
                plant = replace(plant, **{section: replace(getattr(plant, section), **{key: v * factor})})
        else:
            e = effects[f.index]
            if f.above:
                v += float(e.values[f.above])
            effects[f.index] = AddedEffect(e.name, {**e.values, f.key: v})
    return replace(plant, effects=tuple(effects))


def own_jacobian(jac: np.ndarray, frees: list[Free]) -> np.ndarray:
    """``dr/dp`` in the parameters' own values from ``jac = dr/du`` in the fit coordinates
    (unscaled).  For ``u_s = p_s - p_c`` (an excess) and ``u_c = p_c``:
    ``dr/dp_s = dr/du_s`` and ``dr/dp_c = dr/du_c - dr/du_s``."""
    out = np.array(jac, dtype=float, copy=True)
    for s, f in enumerate(frees):
        if f.above:
            for c, g in enumerate(frees):
                if g.index == f.index and g.key == f.above:
                    out[:, c] -= jac[:, s]
    return out


@dataclass(frozen=True)
class Parameter:
    """A fitted parameter, as lmfit's ``Parameter``: what was free (``free``: its name, bounds,
    scale, unit and ties), its value (in its own unit, whatever coordinate the fit moved), its
    standard error (the sandwich covariance, :func:`uncertainty.covariance`, valid for residuals
    correlated in time), the white-residual formula's (``stderr_white``, for comparison only)
    and its correlation with each parameter of the fit (``correl``, by name, itself 1)."""
    free: Free
    value: float
    stderr: float
    stderr_white: float = math.nan
    correl: dict = field(default_factory=dict)

    @property
    def name(self) -> str:
        return self.free.name

    @property
    def unit(self) -> str:
        return self.free.unit

    @property
    def key(self) -> str:
        """The plant-file key (an effect's) or field path (the plant's)."""
        return self.free.key

    @property
    def effect(self) -> int | None:
        """The number of the plant's effect it belongs to; None for a plant field."""
        return self.free.index


@dataclass
class FitResult:
    """A fitted plant: its parameters (:class:`Parameter`, by name: value, standard error,
    correlations), errors, convergence."""
    plant: Plant
    params: dict
    error: float
    rss: float
    n: int
    k: int
    converged: bool
    message: str
    nfev: int
    sim: dict | None = None
    signals: dict = field(default_factory=dict)  # column -> (weighted RSS, n): the evidence of each signal
    seams: tuple = ()  # the window seams (first samples) at which its replay moved the angles (ReplayRun.seams)
    noise: dict = field(default_factory=dict)  # column -> scoring.NoiseModel of its weighted residual
    rescored: dict = field(default_factory=dict, repr=False, compare=False)  # seams -> the plant scored there
    # (the plant fitted from, its end in fit coordinates) of a fit whose standard errors are still the
    # first estimate's where estimates trade off (fit(sharp=False)); None once sharpened or not needed
    unsharp: tuple | None = field(default=None, repr=False, compare=False)
    # dw/dp of the weighted residual w in the parameters' own values, the standard errors' Jacobian
    jac: np.ndarray | None = field(default=None, repr=False, compare=False)
    # name -> how far the replay's tolerance had moved the value, own unit (numerics.refine; {} unchecked),
    # and whether that has been taken out of the values
    numerical: dict = field(default_factory=dict)
    refined: bool = False

    @property
    def values(self) -> dict:
        """Each parameter's value, by name."""
        return {n: p.value for n, p in self.params.items()}

    @property
    def stderr(self) -> dict:
        """Each parameter's standard error, by name."""
        return {n: p.stderr for n, p in self.params.items()}

    @property
    def stderr_white(self) -> dict:
        """Each parameter's standard error by the white-residual formula (for comparison only)."""
        return {n: p.stderr_white for n, p in self.params.items()}

    @property
    def units(self) -> dict:
        """The unit of each parameter's value and standard error, by name."""
        return {n: p.unit for n, p in self.params.items()}

    @property
    def correlation(self) -> dict:
        """Name -> name -> correlation of the two estimates."""
        return {n: dict(p.correl) for n, p in self.params.items()}

    def of_effect(self, i: int) -> dict:
        """The parameters of the plant's effect number ``i``, by its own keys."""
        return {p.key: p for p in self.params.values() if p.effect == i}

    @property
    def weighted_rms(self) -> float:
        """RMS of all compared signals' residuals in units of their noise floors (1 = at noise)."""
        return math.sqrt(self.rss / self.n) if self.n else math.nan

    @property
    def bic(self) -> float:
        """The Bayesian information criterion of the weighted residuals, ``n ln(RSS/n) + k ln n``
        (:func:`gearbench.identify.scoring.criterion`): the fit's own least squares, charged per
        parameter.  Candidates are ranked by it; what pays is decided by
        :func:`gearbench.identify.scoring.bic_drop`, which counts the residual's correlation."""
        return criterion(self.rss, self.n, self.k)


def evaluate(replay: Replay, scorer: Scorer, plant: Plant, k: int = 0, seams: tuple | None = None) -> FitResult:
    """Score a plant as it is (no fitting), the replay's angles moved where its rule says (``seams``
    None) or at exactly ``seams`` (:meth:`Replay.run`)."""
    sim = replay.run(plant, seams=seams)
    w = scorer.weighted(sim)
    return FitResult(plant, {}, scorer.error(sim), float(w @ w), w.size, k, True, "evaluated", 1, sim,
                     scorer.per_signal(sim), seams=sim.seams, noise=scorer.noise_models(sim))


POOR_STEP = 0.1
POOR_STEPS = 2
"""After this many steps in a row whose cost fell by less than :data:`POOR_STEP` of what the
Jacobian's linear model foretold, the next Jacobian is a fresh finite-difference one (MINPACK's
``hybrd`` rule for its Broyden-updated Jacobian: 0.1, twice)."""


FTOL = XTOL = 1e-6
"""``least_squares``' tolerances: a fit stops where an accepted step lowered the RSS by less than
``FTOL`` of itself (``ftol``), or moved the values by less than ``XTOL`` of their norm (``xtol``).

Once the trust region has rejected a trial from a point, a further trial that the point's
finite-difference Jacobian foretells to lower the RSS by less than ``FTOL`` of itself is not
replayed (:class:`~gearbench.errors.FitSettled`): the fit ends there, as ``ftol`` ends it.  Where
the residual is kinked below the differences' step (a stick-slip friction's breakaways) the trust
region shrank, one rejected replay after another, until ``xtol`` stopped it at a point its first
trial had not left: on practice case p01 a Stribeck friction at the motor foretold gains of 1e-2 to
1e-3 of the noise's variance while every replay came out 0.6 worse, the replay's own numerical
scatter.  Not trusted further: the first trial from a point is replayed whatever it foretells,
and so is every trial foretold by a secant update.  With both withheld too, the LuGre friction's
bristle stiffness fitted on coloured noise (``tests/test_effect_states.py``) stopped 4.8 standard
errors short of the truth; with the first trials withheld and the secant ones replayed, that fit
ended at 3.5x the noise."""


class SecantJacobian:
    """The Jacobian ``dr/dz`` of a fit's residual for ``least_squares``: by finite differences
    where needed, else by Broyden's rank-one update from one accepted point to the next,

        J+ = J + (r+ - r - J dz) dz^T / (dz^T dz),

    which costs no replay.  Fresh (forward differences of step :func:`fd_step`) at the start,
    after a step the trust region rejected at least once, and after :data:`POOR_STEPS` poorly
    foretold steps in a row; :meth:`end` gives the finite-difference one at the end, for the
    standard errors (central differences with ``central``), and :func:`secant_least_squares`
    goes on with a fresh one (and a fresh trust region) from a stop on the step size made after
    updates.  Why: a finite-difference Jacobian costs a replay per
    parameter, and they were more than half of a diagnosis's replays (issue 18's 4 s record, in
    one process with one worker: 4,270 replays before, 3,150 with the updates; the same ladder
    and values).

    ``residual`` is the function to give ``least_squares``: it keeps the trials since the last
    Jacobian, so a call finds the residual at the accepted point and knows whether the step was
    taken at its first trial; with ``ftol`` it raises :class:`~gearbench.errors.FitSettled` instead of
    replaying a trial after a rejected one that a finite-difference Jacobian foretells to lower the
    RSS by less than ``ftol`` of itself (:data:`FTOL`)."""

    def __init__(self, fun, bounds, central: bool, ftol: float = 0.0):
        self.fun, self.bounds, self.ftol = fun, bounds, ftol
        self.central = central
        self.trials: list = []   # (z, r) of each residual since the last Jacobian
        self.J = self.z = self.r = None
        self.calls = 0           # residuals replayed (least_squares' nfev)
        self.updated = False     # whether the last Jacobian given was a secant update
        self.updates = 0         # secant updates given
        self.first = None        # (z, r, J) at the first Jacobian's point
        self.poor = 0            # steps in a row the linear model foretold poorly

    @property
    def start_rss(self) -> float:
        """The residual's sum of squares at the first Jacobian's point (inf before it)."""
        return math.inf if self.first is None else float(self.first[1] @ self.first[1])

    def residual(self, z):
        z = np.array(z, dtype=float)
        if self.ftol and self.trials and not self.updated:
            rss, linear = float(self.r @ self.r), self.r + self.J @ (z - self.z)
            if rss - float(linear @ linear) < self.ftol * rss:
                raise FitSettled
        r = self.fun(z)
        self.calls += 1
        self.trials.append((z, r))
        return r

    def settled(self) -> OptimizeResult:
        """The accepted point as ``least_squares`` gives it stopped on ``ftol`` (status 2)."""
        return OptimizeResult(x=self.z, fun=self.r, cost=0.5 * float(self.r @ self.r), jac=self.J,
                              nfev=self.calls, status=2, success=True,
                              message=f"the next step was foretold to lower the cost by less than "
                                      f"{self.ftol:g} of itself")

    def fresh(self, z, r, central: bool = False) -> np.ndarray:
        """The finite-difference Jacobian at ``z`` (residual ``r`` there): forward differences, central
        with ``central``."""
        self.updated = False
        # scipy's own differences, with its rule at the bounds (a step leaving them is reversed).  The
        # step is given absolute: scipy's ``rel_step`` takes ``1e-3 |z|``, which near z = 0 (a rest
        # angle at 0 deg) fell to the scale of the replay's solver error: the tutorial's rest angle
        # had a standard error of 8e-9 deg where its estimates spread by 6e-6 over noise seeds
        return approx_derivative(self.fun, z, method="3-point" if central else "2-point", abs_step=fd_step(z), f0=r,
                                 bounds=self.bounds)

    def end(self, z, r) -> np.ndarray:
        """The finite-difference Jacobian at a fit's end ``z`` for its standard errors: central
        differences with ``central`` (the steps' own are forward: :func:`fit`)."""
        return self.fresh(z, r, self.central)

    def _poorly_foretold(self, z, r) -> bool:
        """Whether the step from the last point to ``z`` lowered the cost by less than
        :data:`POOR_STEP` of what the last Jacobian's linear model predicted."""
        linear = self.r + self.J @ (z - self.z)
        predicted = float(self.r @ self.r - linear @ linear)
        return not (predicted > 0.0 and float(self.r @ self.r - r @ r) >= POOR_STEP * predicted)

    def __call__(self, z):
        z = np.array(z, dtype=float)
        first = len(self.trials) == 1 and np.array_equal(self.trials[0][0], z)
        r = self.trials[-1][1] if self.trials and np.array_equal(self.trials[-1][0], z) else self.fun(z)
        if self.J is not None:
            self.poor = self.poor + 1 if self._poorly_foretold(z, r) else 0
        if self.J is None or not first or self.poor >= POOR_STEPS:
            self.J = self.fresh(z, r)
            self.first = self.first or (z, r, self.J)
            self.poor = 0
        else:
            dz = z - self.z
            self.J = self.J + np.outer(r - self.r - self.J @ dz, dz) / float(dz @ dz)
            self.updated = True
            self.updates += 1
        self.z, self.r, self.trials = z, r, []
        return self.J


def secant_least_squares(fun, z, bounds, central: bool = False, max_nfev: int = 200, lazy: bool = False):
    """``scipy.optimize.least_squares`` of the residual ``fun`` from ``z`` within ``bounds`` (TRF,
    ``ftol`` :data:`FTOL`, ``xtol`` :data:`XTOL`, at most ``max_nfev`` residuals in all) with
    :class:`SecantJacobian` s, a trial foretold to gain less than ``ftol`` not replayed.
    A stop on the step size alone (status 3) after secant updates may be a trust region their
    poorer foresight shrank: while such a stop has lowered the cost by more than
    :data:`RESTART_GAIN`, it goes on from there with a fresh Jacobian and trust region (the hidden
    shaft compliance of ``studies.hidden_effects`` stopped so at 125.6 N m/rad and 3.19x the noise
    floors; going on, 19.6 for 20 at 1.3x).  The result's ``jac`` is a finite-difference one at
    its end (for the standard errors; central differences with ``central``, the steps' own forward
    ones), its ``nfev`` counts every round's residuals, and its ``start`` is ``(z, r, J)`` at ``z``
    (the first finite-difference Jacobian's point, forward differences).

    ``lazy``: where the last Jacobian was a secant update (or a forward one with ``central``),
    ``jac`` is that and ``fresh_jac()`` gives the finite-difference one (:func:`fresh_jacobian`), for a caller that
    needs it only if it keeps this result: :func:`fit`'s rounds keep one of several."""
    used, start = 0, None
    while True:
        secant = SecantJacobian(fun, bounds, central, FTOL)
        try:
            res = least_squares(secant.residual, z, bounds=bounds, x_scale=1.0, jac=secant,
                                max_nfev=max_nfev - used, method="trf", ftol=FTOL, xtol=XTOL)
        except FitSettled:
            res = secant.settled()
        used += res.nfev
        start = start or secant.first
        gained = 2.0 * res.cost < (1.0 - RESTART_GAIN) * secant.start_rss
        if res.status != 3 or not secant.updates or not gained or used >= max_nfev:
            break
        z = res.x
    res.fresh_jac = partial(secant.end, res.x, res.fun) if secant.updated or central else None
    res.nfev, res.start = used, start
    return res if lazy else fresh_jacobian(res)


def fresh_jacobian(res):
    """``res`` (of :func:`secant_least_squares`) with its finite-difference Jacobian at its end as
    ``jac``, made now if it was left for later (``lazy``)."""
    if getattr(res, "fresh_jac", None) is not None:
        res.jac, res.fresh_jac = res.fresh_jac(), None
    return res


FD_STEP = 1e-3
"""Finite-difference step of the fit coordinates (the values over their typical scale)."""


def fd_step(z) -> np.ndarray:
    """The finite-difference steps at ``z``: ``FD_STEP max(1, |z|)``, signed as ``z`` (+ at 0).
    Not scipy's relative step ``FD_STEP |z|`` (``least_squares(diff_step=)``, ``approx_derivative(rel_step=)``),
    which shrinks with ``z`` to nothing near 0 and below the solver's error well before."""
    z = np.asarray(z, dtype=float)
    return FD_STEP * np.where(z >= 0.0, 1.0, -1.0) * np.maximum(1.0, np.abs(z))


RESTART_GAIN = 1e-3
"""A restarted fit (``fit(restarts=...)``) goes on while a restart lowers the RSS by more than this
fraction."""


@dataclass
class _Trials:
    """A fit's replays of ``plant`` with ``frees`` at scaled fit coordinates ``z`` (values
    ``z * scales``), and why those that failed did."""
    replay: Replay
    scorer: Scorer
    plant: Plant
    frees: list
    scales: np.ndarray
    failures: list = field(default_factory=list)
    size: int | None = None  # the residual's length, once a replay has run
    last_settle: tuple | None = None  # (z, run) of the last :meth:`settle`, which ends a fit where it is

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The frees' bounds in the fit coordinates ``z``."""
        low, high = bounds_of(self.frees)
        return low / self.scales, high / self.scales

    def residual(self, z, seams: tuple) -> np.ndarray:
        """The weighted residual at ``z``, the replay's angles moved at exactly ``seams``."""
        try:
            sim = self.replay.run(set_values(self.plant, self.frees, z * self.scales), seams=seams)
            r = self.scorer.weighted(sim)
            self.size = r.size
            return r
        except ReplayError as exc:
            self.failures.append(str(exc))
            # a solver failure is a very bad fit, not a crash of the fit
            return np.full(self.size or 1, 1e6)
        except ValueError as exc:
            # free parameters that together make no plant (a shaft's pinion_inertia above a free
            # motor.inertia it is taken out of): as bad as a failed solve, so the step backs off
            self.failures.append(f"no plant at these values: {exc}")
            return np.full(self.size or 1, 1e6)

    def settle(self, z) -> tuple[tuple[int, ...], float]:
        """The seams the replay resets at ``z`` by its own rule, and the RSS there."""
        try:
            run = self.own_run(z)
            w = self.scorer.weighted(run)
        except (ReplayError, ValueError) as exc:
            self.failures.append(str(exc))
            return (), math.inf
        self.last_settle = (np.array(z, dtype=float), run)
        return run.seams, float(w @ w)

    def own_run(self, z):
        """The replay at ``z`` by its own resets: the last :meth:`settle`'s where that was at ``z``
        (a fit's last round ends where it settled), else a new one."""
        if self.last_settle is not None and np.array_equal(self.last_settle[0], z):
            return self.last_settle[1]
        return self.replay.run(set_values(self.plant, self.frees, z * self.scales))


def fit(replay: Replay, plant: Plant, frees: list[Free], scorer: Scorer | None = None,
        max_nfev: int | None = None, start: list[float] | None = None, central: bool = False,
        restarts: int = 0, rounds_below: float | None = None, sharp: bool = True,
        seams: tuple | None = None) -> FitResult:
    """Fit ``frees`` of ``plant`` to the replayed record.

    ``central``: the Jacobian at the end, for the standard errors, by central differences (2k
    replays for k values, once); the fit steps on forward differences either way (the datasheet
    calibration's steps took central ones until 2026-12-02: on practice record p04 its fits of
    nine values took 1,360, 691 and 488 replays for 775, 384 and 417, to the same ends, the RSS
    within 0.05 %; forward steps had stalled before fits held the resets: ``docs/speed.md``).

    The least squares runs in rounds, each with the replay's window resets held where they are
    at its start (``Replay.run(seams=...)``): the test that decides whether a seam resets switches
    on and off as the parameters move, and the RSS jumps there.  Where the resets at a round's
    end are not those it was fitted with, one more round starts from there; a round that ends
    worse by the replay's own resets (or does not converge) is dropped.  The result is scored
    by the replay as it is.  With the resets free to switch, the calibration of the bench rig with
    p04's datasheet errors stopped in a false minimum at 5.0x the noise floors (resistance 3.19
    ohm for 3.0); held, its first round ended at 1.015x and the second at 0.993x, the truth's
    own (``tests/test_datasheet.py``).  A round must be allowed to end where its resets differ:
    the fit ended where its start's resets, no longer needed, stayed held, and the standard
    errors' coverage (``tests/test_uncertainty.py``) fell to 72 %.
    The first round too: a fit that ends worse than its start so ends where it started (:func:`_rounds`).
    ``seams``: the resets its first round holds (``()`` none) instead of its start's (``refit.without_resets``).

    ``rounds_below``: start another round only while the RSS (by the replay's own resets) is
    below this by more than :data:`RESTART_GAIN`.  Diagnose's screen passes the RSS of the model
    without the candidate: a candidate that has gained nothing in its first round is not worth
    more (on issue 18's 4 s record a shaft compliance went nearly rigid, 1.8e6 N m/rad on a pinion
    of 1 % of the rotor, 1e-5 below the model without it, where a replay took 2.6 s; its second
    round took that rung's screen, in one process, from 22 to 164 s).

    ``restarts``: after a stop on the step tolerance (``xtol``), also start another round, up to
    this many, while a round lowers the RSS by more than :data:`RESTART_GAIN` (a fresh trust region
    after an impact, a breakaway); a first round out of residuals still going down goes on once.

    ``sharp``: where estimates trade off, the standard errors are taken again at the end
    (:func:`sharpen`, 2k replays); False leaves them the first estimate's, for the caller to
    sharpen the fit it keeps (a multi-start's best, a calibration it accepts).

    A fit that does not converge comes back with ``converged`` False and the
    plant as given (unchanged), and says why in ``message``.
    """
    scorer = scorer or Scorer(replay)
    if replay.meter is not None:
        replay.meter.fitted()
    if not frees:
        return evaluate(replay, scorer, plant)
    x0 = np.array(start if start is not None else [get_value(plant, f) for f in frees], dtype=float)
    sc = np.array([f.scale for f in frees])
    trials = _Trials(replay, scorer, plant, frees, sc)
    z0 = np.clip(x0 / sc, *trials.bounds)
    try:
        res, nfev, rounds = _rounds(trials, z0, trials.bounds, central, max_nfev or 40 * (len(frees) + 1), restarts,
                                    rounds_below, seams)
    except ValueError as exc:
        return FitResult(plant, {}, math.nan, math.nan, 0, len(frees), False,
                         f"the fit could not run: {exc}", 0)
    return _result(trials, res, nfev, rounds, sharp)


def _rounds(trials: _Trials, z0, bounds, central: bool, max_nfev: int, restarts: int,
            rounds_below: float | None, held: tuple | None = None):
    """:func:`fit`'s rounds of least squares from ``z0``, the first with the resets ``held`` (None:
    ``z0``'s own), each other with them held where the last ended: the kept round's
    ``least_squares`` result, the replays spent and the rounds after the first.
    Only the kept round's end is given a finite-difference Jacobian (for the standard errors): each
    round that another follows or replaces would cost k replays for one (2k central; ``lazy``).

    Where the first round ends worse than ``z0`` by the replay's own resets, the result is ``z0``'s,
    with the Jacobian there for the standard errors.  Why: on practice record p10 (coloured noise)
    the simplification's refit of Coulomb friction from a Stribeck law's sliding level, 0.0299964
    N m, ended 2e-5 of itself away with a reset at a false seam, RSS 622,479 where its start scored
    589,543, and the BIC kept the Stribeck law.

    A first round that used up ``max_nfev`` while lowering the RSS by more than :data:`RESTART_GAIN`
    goes on for one more round from its end, with ``max_nfev`` more: with exact replay steps
    (``rodas4-exp``) the hidden shaft compliance of ``studies.hidden_effects`` went down a long
    valley, from RSS 551,893 to 63,074 at 19.66 N m/rad for 20, and was dropped there as not
    converged for another start's 582,423 at 70.6 (the diagnosis then ended "nothing pays")."""
    nfev, kept, rounds = 0, None, 0
    seams, start_rss = trials.settle(z0)
    seams = seams if held is None else tuple(held)
    for rounds in range(max(restarts, 1) + 1):
        fun = partial(trials.residual, seams=seams)
        res = secant_least_squares(fun, z0, bounds, central, max_nfev, lazy=True)
        after, rss_after = trials.settle(res.x)
        nfev += res.nfev + 1
        if kept is None and res.status > 0 and rss_after > start_rss:
            return _the_start(res, start_rss, rss_after, SecantJacobian(fun, bounds, central)), nfev, 0
        if kept is not None and (res.status <= 0 or rss_after > kept[1]):
            res = kept[0]  # worse, or it did not converge: keep the round it started from
            break
        gained = kept is None or rss_after < (1.0 - RESTART_GAIN) * kept[1]
        # out of residuals while still going down: the first round may go on once more
        spent = res.status == 0 and kept is None and rss_after < (1.0 - RESTART_GAIN) * start_rss
        kept = (res, rss_after)
        stalled = res.status == 3 and rounds < restarts and gained  # 3: stopped on xtol
        if (res.status <= 0 and not spent) or (after == seams and not stalled and not spent) or (
                rounds_below is not None and rss_after >= (1.0 - RESTART_GAIN) * rounds_below):
            break
        seams, z0 = after, res.x
    return fresh_jacobian(res), nfev, rounds


def _the_start(res, start_rss: float, rss_after: float, secant: SecantJacobian):
    """The least squares' result ``res`` taken back to its start (``res.start``), where its end
    scored ``rss_after`` by the replay's own resets, above the start's ``start_rss``; its Jacobian
    there the start's own, or ``secant.end``'s where that is central."""
    z, r, jac = res.start
    jac = secant.end(z, r) if secant.central else jac
    return OptimizeResult(x=z, fun=r, cost=0.5 * float(r @ r), jac=jac, nfev=res.nfev, status=res.status,
                          success=True, message=f"ended where it started: the least squares' end scored "
                                            f"RSS {rss_after:.6g} by the replay's own resets, the start "
                                            f"{start_rss:.6g}")


SHARP_STEP = 1.0
"""The steps of :func:`_sharp_jacobian`, in the fit's first standard errors."""


def _sharp_jacobian(trials: _Trials, z: np.ndarray, r: np.ndarray, seams: tuple,
                    first_stderr: np.ndarray) -> np.ndarray | None:
    """The Jacobian ``dr/dz`` at the fit's end by central differences of :data:`SHARP_STEP`
    standard errors (of the first estimate ``first_stderr``, in ``z``; no larger than
    :func:`fd_step`), the replay's angles moved at ``seams``; None where a replay failed or an
    error is not finite.

    Why: where estimates trade off (``|rho|`` above ``uncertainty.STRONG_CORRELATION``), their
    standard errors come from the small differences between nearly parallel columns, and a step
    of 0.1 % of the scale, some 100 standard errors, does not give the local slope along the
    valley.  On 10 s of practice case p04 (six datasheet values and a spring, the independent
    simulator's record) the resistance came out 4.9 and the spring 5.6 standard errors from the
    truth, while the spring held at the truth with the rest refitted raised the weighted RSS by
    0.09; central differences of 1e-4 to 1e-6 of the values agreed with each other, with errors
    2.2-2.5x larger, and the truth 2.0 and 2.3 of them away (``tests/test_practice_cases.py``)."""
    if not np.all(np.isfinite(first_stderr)) or np.any(first_stderr <= 0.0):
        return None
    step = np.minimum(np.abs(fd_step(z)), SHARP_STEP * first_stderr)
    failed = len(trials.failures)
    jac = approx_derivative(partial(trials.residual, seams=seams), z, method="3-point", abs_step=step,
                            f0=r, bounds=trials.bounds)
    return jac if len(trials.failures) == failed and np.all(np.isfinite(jac)) else None


def _result(trials: _Trials, res, nfev: int, rounds: int, sharp: bool = True) -> FitResult:
    """The :class:`FitResult` of the least squares' end ``res``: the fitted plant scored by the
    replay's own resets, its standard errors and correlations (sharpened where estimates trade
    off, :func:`sharpen`, unless ``sharp`` is False)."""
    replay, scorer, plant, frees, sc = trials.replay, trials.scorer, trials.plant, trials.frees, trials.scales
    fitted = set_values(plant, frees, res.x * sc)
    try:
        sim = trials.own_run(res.x)
    except ReplayError as exc:
        return FitResult(plant, {}, math.nan, math.nan, 0, len(frees), False,
                         f"the fitted plant does not simulate: {exc}", nfev)
    w = scorer.weighted(sim)
    # res.jac is in the scaled coordinates z = u / scale; the errors are of the parameters' own values
    jac = own_jacobian(res.jac / sc, frees)
    params, rho = _params(replay, fitted, frees, jac, w)
    converged = res.status > 0
    msg = res.message if converged else f"did not converge: {res.message}"
    if rounds:
        msg += f" (restarted {rounds}x)"
    if trials.failures and converged:
        msg += f" ({len(trials.failures)} trial simulation(s) failed on the way)"
    out = FitResult(fitted if converged else plant, params, scorer.error(sim), float(w @ w), w.size, len(frees),
                    converged, msg, nfev, sim, scorer.per_signal(sim), seams=sim.seams,
                    noise=scorer.noise_models(sim),
                    unsharp=(plant, res.x.copy()) if converged and U.strongly_correlated(rho) else None, jac=jac)
    return sharpen(replay, scorer, out) if sharp else out


def _params(replay: Replay, fitted: Plant, frees: list[Free], jac: np.ndarray, w: np.ndarray) -> tuple[dict, np.ndarray]:
    """The :class:`Parameter` of each free at ``fitted`` from the Jacobian ``jac`` of the weighted
    residual ``w`` in the parameters' own values, and their correlation matrix."""
    cov = U.covariance(jac, w, len(objective_signals(replay)))
    stderr, rho = U.standard_errors(cov), U.correlation(cov)
    white = U.standard_errors(U.white_covariance(jac, w))
    names = [f.name for f in frees]
    return {f.name: Parameter(f, param_value(fitted, f), float(stderr[i]), float(white[i]),
                              {b: float(rho[i, j]) for j, b in enumerate(names)}) for i, f in enumerate(frees)}, rho


def sharpen(replay: Replay, scorer: Scorer, res: FitResult) -> FitResult:
    """``res`` with the standard errors of a fit whose estimates trade off (a correlation beyond
    ``uncertainty.STRONG_CORRELATION``) taken again by :func:`_sharp_jacobian` (2k replays for k
    values, counted in ``nfev``); ``res`` itself when they need not be or already were (the
    first estimate's, if a replay there fails).  ``fit`` does it unless told ``sharp=False``: a
    multi-start's fits each skip it, and only the one kept pays for it."""
    if res.unsharp is None:
        return res
    plant, z = res.unsharp
    frees = [p.free for p in res.params.values()]
    sc = np.array([f.scale for f in frees])
    w = scorer.weighted(res.sim)
    first = np.array([p.stderr for p in res.params.values()]) / sc
    sharp = _sharp_jacobian(_Trials(replay, scorer, plant, frees, sc, size=w.size), z, w, res.seams, first)
    if sharp is None:
        return replace(res, unsharp=None)
    jac = own_jacobian(sharp / sc, frees)
    params, _ = _params(replay, res.plant, frees, jac, w)
    return replace(res, params=params, nfev=res.nfev + 2 * len(frees), unsharp=None, jac=jac)
