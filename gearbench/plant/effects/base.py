"""What an effect is, and the registry that names them (SPEC section 5).

An effect is one small piece of physics a plant file adds under ``effects:``
as ``{type: NAME, <parameters>}``.  It declares

* ``name``: the SPEC's name, the key of the registry;
* ``acts_on``: where it acts (``"motor torque"``, ``"load torque"``,
  ``"voltage"``, ``"measured signal"``, ``"plant structure"``);
* ``params``: its numeric parameters (:class:`Param`: unit, bounds for fitting,
  typical scale), and ``options``: its string choices (``location``, ``signal``);
* ``signature``: what a record shows when the model lacks it, a key of
  :data:`gearbench.identify.evidence.SIGNATURES` (``"sign of the speed"`` for
  Coulomb friction, ``"a lag"`` for a delay, ...): diagnose's explanations measure it;

and implements one of

* ``pack(values, p, plant)``: write its slots of the compiled parameter vector
  (``layout.P_*``); its equation lives in a ``@njit(inline="always")`` function
  in the same module, called by ``effects/compiled.py`` from the right-hand side;
* ``apply(values, plant)``: return a changed plant (structural effects);
* ``measure(values, name, y, time_s, plant)``: distort a simulated measured signal.

To add an effect: write a module in this package with a subclass decorated
with :func:`register`, import it in ``effects/__init__.py``; if it acts in the
compiled path, give it parameter slots in ``layout.py`` and one call in
``compiled.py``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np


@dataclass(frozen=True)
class Param:
    """A named parameter of an effect.

    unit: its unit; low/high: physical bounds (also the fit's bounds);
    scale: a typical magnitude on the plant it acts on (a callable of the plant,
    or a number), the fit's starting point and step; integer: whole numbers only.
    """
    name: str
    unit: str
    low: float
    high: float
    scale: Any
    description: str = ""
    integer: bool = False
    optional: bool = False
    start: float | None = None  # where a fit starts (default: the typical value)

    def typical(self, plant, values: dict) -> float:
        """A typical value on ``plant`` (the effect's options in ``values``)."""
        return float(self.scale(plant, values) if callable(self.scale) else self.scale)


class Effect:
    """Base class of the effects; see the module docstring."""
    name: ClassVar[str] = ""
    acts_on: ClassVar[str] = ""
    signature: ClassVar[str] = ""
    params: ClassVar[tuple[Param, ...]] = ()
    options: ClassVar[dict[str, tuple[str, ...]]] = {}
    defaults: ClassVar[dict[str, Any]] = {}

    def fit_params(self, values: dict) -> tuple[Param, ...]:
        """The parameters a fit adjusts (the given optional ones too)."""
        return tuple(q for q in self.params if not q.optional or q.name in values)

    def pack(self, values: dict, p: np.ndarray, plant) -> None:
        """Write this effect's slots of the compiled parameter vector."""

    def apply(self, values: dict, plant):
        """A structural effect returns the changed plant; others return it unchanged."""
        return plant

    def applicable(self, plant, signals) -> bool:
        """Whether this effect can be added to ``plant`` for a record measuring ``signals``."""
        return True

    def estimate(self, values: dict, measured: dict, plant) -> dict | None:
        """Parameters read straight from the measured signals, for effects a
        least-squares fit cannot move (integer counts); None = fit instead."""
        return None

    def simpler(self, values: dict) -> tuple[str, dict] | None:
        """A nested simpler effect (fewer parameters) this one reduces to, as
        ``(name, values)`` from these values; None when there is none."""
        return None

    def measure(self, values: dict, name: str, y: np.ndarray, time_s: np.ndarray, plant) -> np.ndarray:
        """A sensor effect distorts measured signal ``name``; others leave it."""
        return y

    def describe(self) -> str:
        """One line: what it is, where it acts, its parameters with units."""
        doc = (type(self).__doc__ or "").strip().splitlines()[0]
        pars = ", ".join(f"{q.name} ({q.unit})" for q in self.params)
        opts = ", ".join(f"{k}: {'|'.join(v)}" for k, v in self.options.items())
        return f"{self.name}: {doc} Acts on the {self.acts_on}; parameters {pars}" + (
            f"; {opts}" if opts else "")


REGISTRY: dict[str, Effect] = {}


def register(cls):
    """Class decorator: put one instance of an effect class in the registry under its name."""
    if not cls.name or cls.name in REGISTRY:
        raise ValueError(f"effect name {cls.name!r} missing or registered twice")
    REGISTRY[cls.name] = cls()
    return cls


@dataclass(frozen=True)
class AddedEffect:
    """An effect in a plant: its registered name and its parameter values
    (numbers in the units of its :class:`Param` entries, strings for options)."""
    name: str
    values: dict

    @property
    def effect(self) -> Effect:
        return REGISTRY[self.name]

    def to_dict(self) -> dict:
        return {"type": self.name, **self.values}
