"""Plants drawn from what an identification left uncertain.

Two sources, independent of each other:

* a fit's estimates (:class:`Uncertainty`): the fitted values with their standard errors
  and correlations, as ``gb.fit`` / ``gearbench fit --json`` give them, drawn from the
  multivariate normal they define (values that must be positive are reflected at 0);
* the datasheet tolerances of the values the fit did not estimate
  (:func:`gearbench.identify.calibration.tolerances`: the plant file's ``tolerance_pct``,
  else the datasheet default), each drawn uniformly within its +-tolerance.  The back-emf
  constant moves with the torque constant (one value in SI), as calibration ties them.

The draws come from one seeded generator, so every candidate of a search is judged on the
same plants (common random numbers: the search compares controllers, not draws).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..errors import ConfigError, FitError
from ..identify.calibration import tolerances
from ..identify.fit import Free, set_values
from ..plant.components import Plant

_EFFECT = re.compile(r"^effects\[(\d+)\]\.(\w+)$")


@dataclass(frozen=True)
class Uncertainty:
    """Fitted values (``names``, ``mean``) and their covariance ``cov`` (units of each value)."""
    names: tuple
    mean: np.ndarray
    cov: np.ndarray

    @staticmethod
    def of(source: Any) -> "Uncertainty":
        """From a :class:`gearbench.FitReport` or a mapping with its ``values``, ``stderr`` and
        (optional) ``correlation`` (``gearbench fit --json``'s object).  Values whose standard
        error is missing or not finite are left out (they were not estimated)."""
        get = (lambda k: source.get(k)) if isinstance(source, Mapping) else (lambda k: getattr(source, k, None))
        values, stderr, corr = get("values"), get("stderr"), get("correlation") or {}
        if not isinstance(values, Mapping) or not isinstance(stderr, Mapping):
            raise ConfigError("tune", ["uncertainty must be a FitReport or a mapping with 'values' and 'stderr' "
                                       f"(gearbench fit --json), got {type(source).__name__}"])
        names = tuple(n for n in values if isinstance(stderr.get(n), (int, float))
                      and math.isfinite(stderr[n]) and stderr[n] >= 0)
        se = np.array([float(stderr[n]) for n in names])
        r = np.array([[1.0 if a == b else float((corr.get(a) or {}).get(b) or 0.0) for b in names] for a in names])
        return Uncertainty(names, np.array([float(values[n]) for n in names]), r * np.outer(se, se))


def _free(plant: Plant, name: str) -> Free:
    """The value ``name`` of ``plant`` (``effects[0].torque``, ``load.inertia``) with its lower
    bound as a fit has it (-inf for a value of any sign, such as a spring's rest angle)."""
    m = _EFFECT.match(name)
    if m:
        i, key = int(m.group(1)), m.group(2)
        if i >= len(plant.effects) or key not in plant.effects[i].values:
            raise ConfigError("tune", [f"uncertainty names {name}, which the plant {plant.name!r} does not have "
                                       f"(its effects: {[e.name for e in plant.effects]}); give the fitted plant"])
        low = next((f.low for f in Free.effect(plant, i) if f.key == key), -math.inf)
        return Free(key, i, low, math.inf, 1.0, "")
    try:
        return Free.plant(plant, name)
    except FitError as exc:
        raise ConfigError("tune", [f"uncertainty names {name}: {exc}"]) from None


def draw_plants(plant: Plant, n: int, *, uncertainty: Uncertainty | None = None, use_tolerances: bool = True,
                seed: int = 0) -> list[Plant]:
    """``n`` plants drawn around ``plant`` (module docstring: how).

    Parameters
    ----------
    plant : Plant
        The identified plant (its values are the draws' centre for what ``uncertainty``
        does not cover).
    n : int
        Number of plants (>= 1).
    uncertainty : Uncertainty, optional
        The fit's estimates; their names must be values of ``plant``.
    use_tolerances : bool
        Draw the datasheet values the fit did not estimate within their tolerances.
    seed : int
        Seed of the generator (the same seed, the same plants).
    """
    rng = np.random.default_rng(seed)
    frees, centre, cov = [], np.zeros(0), np.zeros((0, 0))
    if uncertainty is not None and uncertainty.names:
        frees = [_free(plant, name) for name in uncertainty.names]
        centre, cov = uncertainty.mean, uncertainty.cov
    fitted = set(uncertainty.names) if uncertainty is not None else set()
    tol = {p: pct for p, pct in tolerances(plant).items() if p not in fitted} if use_tolerances else {}
    if "motor.torque_constant" in tol:
        tol.pop("motor.back_emf_constant", None)
    out = []
    for _ in range(n):
        p = plant
        if frees:
            values = rng.multivariate_normal(centre, cov, method="eigh")
            low = np.array([f.low for f in frees])
            p = set_values(plant, frees, np.where(values < low, 2 * low - values, values))  # reflected at a bound
        factors = {path: 1.0 + rng.uniform(-pct, pct) / 100.0 for path, pct in tol.items()}
        p = _scaled(p, factors, tie="motor.back_emf_constant" not in fitted)
        out.append(p)
    return out


def _scaled(plant: Plant, factors: Mapping[str, float], tie: bool) -> Plant:
    """``plant`` with each datasheet value ``path`` multiplied by its factor; the back-emf
    constant with the torque constant's when ``tie``."""
    if not factors:
        return plant
    frees, values = [], []
    for path, f in factors.items():
        section, key = path.split(".")
        free = Free(path, None, 0.0, math.inf, 1.0, "")
        if tie and path == "motor.torque_constant":
            m = plant.motor
            free = Free(path, None, 0.0, math.inf, 1.0, "",
                        tied=(("motor.back_emf_constant", m.back_emf_constant / m.torque_constant),))
        frees.append(free)
        values.append(float(getattr(getattr(plant, section), key)) * f)
    return set_values(plant, frees, values)


__all__ = ["Uncertainty", "draw_plants"]
