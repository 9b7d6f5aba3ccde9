"""Calibration of the plant's own parameters: datasheet values, each within its tolerance.

A plant file is written from datasheets, typically 5-20 % off on resistance,
torque constant, inertias and dampings.  Fitted with its values exact, such a
plant leaves a residual that a missing effect would leave too, and diagnose
would add an effect to explain a parameter that is off.  So diagnose may move
the plant's own values within their tolerance (bounds ``v (1 +- tolerance_pct/100)``),
as a step that competes with the effects (``diagnose.diagnose``), and
``fit --calibrate`` fits them beside its effect.

Which values: each one the plant file gives a tolerance
(``resistance: {value: 2.2, tolerance_pct: 10}``; ``tolerance_pct: 0`` holds it
exactly), and :data:`DATASHEET_TOLERANCE_PCT` for the datasheet values it gives
none.  The torque and back-emf constants are one physical constant (the motor's
flux linkage; equal in SI): calibrated as one, the back-emf constant keeps its
ratio to the torque constant in the file.  Apart, the torque constant would trade
off exactly with every inertia, damping and mesh value: only their ratios move
the motor.  The gear's mesh, the
inductance and the backlash are not calibrated unless the file gives a
tolerance: the mesh and the inductance act far above a 1 kHz record's band, and
a clearance is the ``backlash`` effect's to find.

Not every value can be told from a record.  With the voltage as input and only
an angle measured, the motor is seen through three combinations, ``k/(J L)``,
``R/L + b/J`` and ``(b R + k^2)/(J L)`` (``J``, ``b`` at the motor): torque
constant, resistance, inertia and damping cannot all be calibrated.  :func:`plan` asks
the record before fitting: at the file's values it takes the sensitivity ``J_j``
of the noise-weighted residuals to each value (central differences, 0.1 % steps,
the replay's angles moved at the seams where the file's values move them, as a fit
holds them) and the standard error the record would give it at its noise floors,
``sigma_j = sqrt((J^T J)^-1_jj)`` (the Cramer-Rao bound), with every other
value gearbench can fit (the inductance, the mesh, the backlash: never exact
either) free beside it, so that a value told apart from the others only by an
exactly known inductance or mesh does not count as resolved.  A value whose
``sigma_j`` exceeds :data:`RESOLVE` of its tolerance half-width is held at the
file's value: the record does not pin it down better than the datasheet does.
The report says which were held, why, and the value each trades off with most
(the combination the record does see).  With only the output angle measured none
of the bench rig's six values is calibrated (``tests/test_calibration.py``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..blas import single_threaded
from ..errors import ReplayError
from ..plant.components import FITTABLE, Plant
from .fit import FitResult, Free, bounds_of, fit, get_value, param_value, set_values
from .scoring import Scorer
from .replay import Replay
from . import search
from .timing import Cost, costed
from .uncertainty import central_jacobian, correlation, standard_errors

DATASHEET_TOLERANCE_PCT = {
    "motor.resistance": 20.0, "motor.torque_constant": 20.0, "motor.back_emf_constant": 20.0,
    "motor.inertia": 20.0, "motor.damping": 20.0, "load.inertia": 20.0, "load.damping": 20.0,
    "leadscrew.mass": 20.0, "leadscrew.damping": 20.0,
}
"""Tolerance (%) of the datasheet values a plant file gives none for: the top of the 5-20 % that
resistance (winding temperature alone: 0.39 %/K), torque constant, inertias and dampings are
typically off by."""

RESOLVE = 0.25
"""A value is calibrated when the record would give it a standard error below this fraction of its
tolerance half-width (at the noise floors); else it is held at the file's value."""

STEP = 1e-3  # relative step of the central differences (1e-2 hid an exact trade-off under the mesh's nonlinearity)


@dataclass
class Plan:
    """What calibration moves: ``frees`` (bounded by the tolerances), ``held`` (each with why),
    and the file's value of each (``nominal``, by :attr:`Free.name`)."""
    frees: list[Free] = field(default_factory=list)
    held: list[tuple[Free, str]] = field(default_factory=list)
    nominal: dict = field(default_factory=dict)
    tolerance: dict = field(default_factory=dict)

    def report(self, plant: Plant, stderr: dict, done: bool = True, why: str = "") -> dict:
        """``calibration`` of ``diagnose --json``: per value its nominal (the file's), final
        value, standard error, unit, tolerance and status: ``calibrated``; ``held``, with why;
        ``file value`` when calibrating (``done`` False) did not pay, or was not tried (``why``)."""
        out = {}
        for f in self.frees:
            out[f.label] = {"nominal": self.nominal[f.name], "value": param_value(plant, f),
                            "stderr": stderr.get(f.name, math.nan) if done else None, "unit": f.unit,
                            "tolerance_pct": self.tolerance[f.name],
                            "status": "calibrated" if done else "file value"}
            if not done:
                out[f.label]["message"] = why or ("kept: calibrating the datasheet values did not pay by the "
                                                  "criterion that adds an effect")
        for f, why in self.held:
            out[f.label] = {"nominal": self.nominal[f.name], "value": param_value(plant, f), "stderr": None,
                            "unit": f.unit, "tolerance_pct": self.tolerance[f.name], "status": "held",
                            "message": why}
        return out


def _present(plant: Plant) -> list[str]:
    """The values gearbench can fit (``FITTABLE``) that this plant has, nonzero (0: nothing to scale)."""
    out = []
    for path in FITTABLE:
        section, key = path.split(".")
        comp = getattr(plant, section)
        if comp is not None and getattr(comp, key, None):
            out.append(path)
    return out


def tolerances(plant: Plant) -> dict[str, float]:
    """The tolerance (%) of every value that calibration may move: the file's, else the
    datasheet default; values of 0 (nothing to scale) and tolerances of 0 are left out."""
    out = {}
    for path in _present(plant):
        pct = plant.tolerance_pct(path)
        pct = DATASHEET_TOLERANCE_PCT.get(path) if pct is None else pct
        if pct:
            out[path] = pct
    return out


def _others(plant: Plant, tol: dict[str, float]) -> list[str]:
    """The values gearbench can fit that calibration leaves alone (no tolerance), nonzero,
    and not held exactly by the file (``tolerance_pct: 0``)."""
    return [p for p in _present(plant) if p not in tol and plant.tolerance_pct(p) != 0]


def _frees(plant: Plant, tol: dict[str, float]) -> list[Free]:
    """One bounded Free per value; the back-emf constant moves with the torque constant."""
    m = plant.motor
    tie = "motor.torque_constant" in tol and "motor.back_emf_constant" in tol
    out = []
    for path, pct in tol.items():
        if tie and path == "motor.back_emf_constant":
            continue
        f = Free.plant(plant, path)
        v = param_value(plant, f)
        tied = ((("motor.back_emf_constant", m.back_emf_constant / m.torque_constant),)
                if tie and path == "motor.torque_constant" else ())
        out.append(Free(f.key, None, v * (1 - pct / 100), v * (1 + pct / 100), v, f.unit, tied=tied))
    return out


def plan(plant: Plant, replay: Replay, scorer: Scorer) -> Plan:
    """The values this record can calibrate (module docstring: the rule and why)."""
    tol = tolerances(plant)
    frees = _frees(plant, tol)
    p = Plan(nominal={f.name: param_value(plant, f) for f in frees},
             tolerance={f.name: tol[f.key] for f in frees})
    if not frees:
        return p
    nuisance = [Free.plant(plant, path) for path in _others(plant, tol)]
    x0 = np.array([param_value(plant, f) for f in frees + nuisance])
    try:
        # A reset that flipped between two steps 0.1 % apart would read as sensitivity: on the
        # bench rig with only the output angle it made the motor constant look resolved.
        seams = replay.run(plant).seams
        jac = central_jacobian(
            lambda x: scorer.weighted(replay.run(set_values(plant, frees + nuisance, x), seams=seams)),
            x0, STEP * x0) * x0  # per relative change: better conditioned
    except ReplayError as exc:
        p.held = [(f, f"not calibrated: the plant does not simulate 0.1 % away from the file's values ({exc})")
                  for f in frees]
        return p
    rel, corr = _bound(jac)
    keep = []
    for i, f in enumerate(frees):
        ratio = rel[i] / (tol[f.key] / 100)
        if ratio <= RESOLVE:
            keep.append(i)
            continue
        why = (f"held at the file's value: this record would give it a standard error of "
               f"{rel[i] * x0[i]:.3g} {f.unit} at its noise floors, {ratio:.3g}x its tolerance "
               f"(+-{tol[f.key]:g} %)" if math.isfinite(rel[i]) else
               "held at the file's value: this record does not see it apart from the others")
        others = [j for j in range(len(x0)) if j != i and math.isfinite(corr[i, j])]
        if others:
            j = max(others, key=lambda j: abs(corr[i, j]))
            if abs(corr[i, j]) > 0.5:
                why += f"; it trades off with {(frees + nuisance)[j].label} (correlation {corr[i, j]:+.3f})"
        p.held.append((f, why))
    p.frees = [frees[i] for i in keep]
    return p


def _bound(jac: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Standard errors ``sqrt(diag((J^T J)^-1))`` and correlations at unit residual variance
    (NaN where ``J^T J`` is singular or a variance comes out negative)."""
    k = jac.shape[1]
    try:
        cov = np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return np.full(k, math.nan), np.full((k, k), math.nan)
    return standard_errors(cov), correlation(cov)


def starts(replay: Replay, scorer: Scorer, plant: Plant, frees: list[Free], calibrated: int,
           n: int | None = None, pool=None, spent=None, until=None) -> list[np.ndarray] | None:
    """Where a calibration's local fit starts again when the one from the current values
    stopped short of the noise: the ``search.LOCAL_STARTS`` best of ``n`` (default
    ``search.point_count``) scrambled Sobol points spread uniformly over the tolerance box of
    the first ``calibrated`` of ``frees`` (the rest held at ``plant``'s values), best first.

    Why: stick-slip makes the residual jump between branches as the values move (whether the
    load sticks at a reversal), and a local fit from a datasheet's values can end in the wrong
    one (module docstring of ``tests/test_datasheet.py``).  ``pool``: an
    :meth:`Executor.pool <gearbench.identify.executor.Executor.pool>` the scan's jobs are submitted
    to, each one's cost given to ``spent``, and None as soon as ``until()`` is true
    (``search.scan_in``); without it, here."""
    low, high = bounds_of(frees[:calibrated])
    points = search.around([get_value(plant, f) for f in frees],
                           low + search.unit_points(calibrated, n) * (high - low))
    ranked = (search.scan(replay, scorer, plant, frees, points) if pool is None
              else search.scan_in(pool, replay, scorer, plant, frees, points, spent, until))
    return None if ranked is None else [x for _, x in ranked[:search.LOCAL_STARTS]]


SPLIT_STEP = 0.01
"""Step of :func:`split_points`, a share of the rotor's inertia.  On practice record p08 the true
basin is a notch about 1 % wide in that valley: from the wrong basin's other values, the true split
gave a weighted RSS of 2.8e5, 0.5 % off it 3.9-4.1e5, 1 % off 0.9-1.2e6, the wrong basin 2.2e6
(2026-11-29), so a 1 % step lands in it from any offset."""


def split_points(frees: list[Free], x, ratio: float) -> list[np.ndarray]:
    """Points along the valley of one reflected inertia, around fit coordinates ``x``: the rotor's
    inertia ``J_m`` (``motor.inertia``) stepped by :data:`SPLIT_STEP` of its value across its
    bounds, the load's ``J_l`` (``load.inertia``) moved to keep ``J_m + J_l / N^2`` (``N`` the gear
    ``ratio``), every other coordinate held; ``x`` itself first; none without both inertias free.

    Why: a record's rigid-body motion fixes the inertia the motor drives, ``J_m + J_l / N^2``,
    sharply; how it splits between the two sides shows only in the clearance's transits and the
    load's own modes, a narrow notch in that valley, which a local fit slides past and a scan of
    the whole tolerance box rarely hits."""
    names = [f.name for f in frees]
    if "motor.inertia" not in names or "load.inertia" not in names:
        return []
    x = np.asarray(x, dtype=float)
    im, il = names.index("motor.inertia"), names.index("load.inertia")
    total = x[im] + x[il] / ratio ** 2
    out = [x]
    steps = int(math.ceil((frees[im].high - frees[im].low) / (SPLIT_STEP * x[im])))
    for k in range(-steps, steps + 1):
        jm = x[im] * (1.0 + k * SPLIT_STEP)
        jl = (total - jm) * ratio ** 2
        if k and frees[im].low <= jm <= frees[im].high and frees[il].low <= jl <= frees[il].high:
            y = x.copy()
            y[im], y[il] = jm, jl
            out.append(y)
    return out


@single_threaded
def fit_from(job) -> tuple[FitResult, Cost]:
    """A calibration's fit from one of :func:`starts`' points, as one job tuple ``(replay, scorer,
    plant, frees, start, restarts)`` (what an :class:`~gearbench.identify.executor.Executor` maps):
    its end's Jacobian by central differences (``fit``'s ``central``), ``restarts`` as ``fit``'s,
    the standard errors not sharpened (the caller sharpens the fit it keeps, ``fit.sharpen``);
    with what it cost where it ran."""
    replay, scorer, plant, frees, start, restarts = job
    return costed(fit, replay, plant, frees, scorer, start=start, central=True, restarts=restarts, sharp=False)
