"""The settings a tuning searches: a controller kind's gains and a compensator's shift.

Each setting is searched on the unit interval: gains on a log scale between their
bounds (a gain's effect is multiplicative: 50 -> 100 V/deg matters as 500 -> 1000
does), the compensator's shift on a linear one between 0 and the clearance.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from ..control.controllers import COMPENSATORS, SETTING_UNITS, Controller
from ..errors import ConfigError

TUNED = {"p": ("kp",), "pi": ("kp", "ki"), "pid": ("kp", "ki", "kd")}
"""The gains tuned for each controller kind (``derivative_filter_s`` stays at its 1 ms)."""

DEFAULT_RANGES = {"kp": (0.1, 1.0e4), "ki": (1.0e-4, 10.0), "kd": (1.0e-5, 0.1)}
"""Default search bounds of each gain, in its unit (``SETTING_UNITS``): Kp in V/deg of
motor-side error, Ki in 1/s, Kd in s (the thesis's form ``Kp (e + Ki int e + Kd de/dt)``)."""


@dataclass(frozen=True)
class Setting:
    """One searched setting: a :class:`~gearbench.control.controllers.Controller` field
    between ``low`` and ``high`` (``unit``), searched on a log scale when ``log``."""
    name: str
    low: float
    high: float
    unit: str
    log: bool = True

    def value(self, u: float) -> float:
        """The setting at ``u`` in [0, 1] (clipped)."""
        u = min(max(float(u), 0.0), 1.0)
        if self.log:
            return float(math.exp(math.log(self.low) + u * (math.log(self.high) - math.log(self.low))))
        return float(self.low + u * (self.high - self.low))

    def unit_of(self, v: float) -> float:
        """Where ``v`` lies in [0, 1] (the inverse of :meth:`value`)."""
        if self.log:
            return (math.log(v) - math.log(self.low)) / (math.log(self.high) - math.log(self.low))
        return (v - self.low) / (self.high - self.low)


def space(kind: str, compensator: str, backlash_deg: float,
          ranges: Mapping[str, Sequence[float]] | None = None) -> tuple[Setting, ...]:
    """The settings tuned for ``kind`` (``p``, ``pi``, ``pid``) with ``compensator``.

    Parameters
    ----------
    kind : str
        Controller kind; its gains are :data:`TUNED`.
    compensator : str
        A compensator of ``COMPENSATORS``; any but ``none`` adds ``shift_deg`` (deg),
        searched between 0 and ``backlash_deg``.
    backlash_deg : float
        The plant's clearance (output deg), the shift's upper bound.
    ranges : Mapping, optional
        ``{name: (low, high)}`` replacing :data:`DEFAULT_RANGES` (same units; ``shift_deg``
        in deg).

    Raises
    ------
    ConfigError
        Naming the kind, compensator or range that is wrong, with its unit.
    """
    problems: list[str] = []
    if kind not in TUNED:
        problems.append(f"controller must be one of {', '.join(TUNED)} (the kinds with gains), got {kind!r}")
    if compensator not in COMPENSATORS:
        problems.append(f"compensator must be one of {', '.join(COMPENSATORS)}, got {compensator!r}")
    names = TUNED.get(kind, ()) + (("shift_deg",) if compensator not in ("none",) else ())
    bounds = {**DEFAULT_RANGES, "shift_deg": (0.0, float(backlash_deg))}
    for name, pair in (ranges or {}).items():
        unit = "deg" if name == "shift_deg" else SETTING_UNITS.get(name, ("",))[0]
        if name not in bounds:
            problems.append(f"range {name}: not a tuned setting; choose from {', '.join(bounds)}")
        elif (len(pair) != 2 or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in pair)
              or not 0 <= pair[0] < pair[1] or (name != "shift_deg" and pair[0] <= 0)):
            problems.append(f"range {name}: expected LOW,HIGH in {unit} with 0 < LOW < HIGH "
                            f"(0 <= LOW for shift_deg), got {pair!r}")
        else:
            bounds[name] = (float(pair[0]), float(pair[1]))
    if problems:
        raise ConfigError("tune", problems)
    return tuple(Setting(n, *bounds[n], "deg" if n == "shift_deg" else SETTING_UNITS[n][0], log=n != "shift_deg")
                 for n in names)


def controller_at(kind: str, compensator: str, settings: Sequence[Setting], u: Sequence[float]) -> Controller:
    """The controller at the point ``u`` (one coordinate in [0, 1] per setting)."""
    values = {s.name: s.value(x) for s, x in zip(settings, np.asarray(u, dtype=float))}
    return Controller(kind, compensator=compensator, **values)


def settings_of(controller: Controller, settings: Sequence[Setting]) -> dict[str, float]:
    """The searched settings' values of ``controller``, by name (units of each :class:`Setting`)."""
    return {s.name: float(getattr(controller, s.name)) for s in settings}


__all__ = ["TUNED", "DEFAULT_RANGES", "Setting", "space", "controller_at", "settings_of"]
