"""What an effect is, and the registry that names them (SPEC section 5).

An effect is one small piece of physics a plant file adds under ``effects:``
as ``{type: NAME, <parameters>}``.  Its module -- one file, in this package or
anywhere (``effect_modules:`` in a plant file, see ``user.py``) -- declares
everything the rest of gearbench needs:

* ``name``: the SPEC's name, the key of the registry;
* ``acts_on``: where it acts, in words (``"motor or load torque"``,
  ``"voltage"``, ``"mesh angle"``, ``"measured signal"``, ``"plant structure"``);
* ``params``: its numeric parameters (:class:`Param`: unit, bounds for fitting,
  typical scale), and ``options``: its string choices (``location``, ``signal``);
* ``signature``: what a record shows when the model lacks it, a key of
  :data:`gearbench.identify.evidence.SIGNATURES` (``"sign of the speed"`` for
  Coulomb friction, ``"a lag"`` for a delay, ...): diagnose's explanations measure it;
* ``confounders`` (optional): names of effects whose signature this one's mimics
  in part, so that either alone explains some of the other's residual (a bias
  and Coulomb friction are both a constant while the load turns one way).
  Diagnose refits such a pair jointly whatever the members rank alone; the
  relation goes both ways, so one side declaring it is enough;

and acts in one of three ways:

* **compiled**: ``term``, a numba function the right-hand side calls, and
  ``places``, where it may act; ``compiled(values, plant)`` returns
  ``(place, numbers)``: the place of this instance and the numbers (SI) its
  term reads as ``p[o], p[o + 1], ...``.  By place, the term is

  - ``"motor"``/``"load"``: ``term(p, o, theta, w, eps)``, the torque (N m)
    on the rotor or the output shaft at angle ``theta`` (rad) and speed ``w``
    (rad/s); ``eps`` is the solver's friction smoothing speed there (rad/s);
  - ``"voltage"``: ``term(p, o, u)``, the voltage (V) the motor sees for
    command ``u`` (V);
  - ``"winding"``: ``term(p, o, i)``, a voltage (V) lost in the winding at
    current ``i`` (A) beyond the datasheet's ``R i`` (a brush drop, a resistance
    that has warmed up): ``L di/dt = u - R i - term - ke w``;
  - ``"mesh"``: ``term(p, o, theta_l)``, ``(e, de/dtheta_l)``: an offset (rad)
    of the mesh's relative angle as the contact sees it, at output angle
    ``theta_l`` (rad), and its slope.

  A friction effect at ``"motor"``/``"load"`` may also declare
  ``friction(p, o, s, w)``, its **stick-slip law**: ``(L, B)``, the size (N m)
  of the torque opposing slip in direction ``s`` (+1 or -1) at speed ``w``
  (rad/s), and of the largest torque it holds at rest pushed in direction
  ``s``, from the same numbers.  An instance then acts by that law, with
  stick and slip as located events (``plant/friction.py``), unless its values
  say ``model: regularized`` (its ``term``, smoothed by ``eps``):
  ``settings`` declares that choice.

  An effect with a **state** of its own (a bristle deflection, a winding's
  temperature) names it in ``state`` (``"name, unit"``) and declares ``rate``,
  its derivative, a numba function like the term: at ``"motor"``/``"load"``
  ``rate(p, o, theta, w, z)`` and ``term(p, o, theta, w, eps, z)``, at
  ``"winding"`` ``rate(p, o, i, z)`` and ``term(p, o, i, z)``, ``z`` the
  state's value; ``state_scale(values, plant)`` is its typical size (the
  solver's absolute tolerance scales with it).  The state starts at 0 and runs
  on through a replay's window seams; each place holds one instance.

  It also declares ``piecewise_linear(values)`` (the term is affine in the
  state, so the solver may reuse a Jacobian; the default says no),
  ``linear(values, plant)`` (its stiffness and damping where it is linear,
  for the linearised plant) and ``steady_drag(values, plant)`` (what it
  resists steady forward motion with, for ``info`` and the top speed; None
  for none).  The parameter layout, packing, the Jacobian reuse, the
  linearisation and the steady drag are derived from these declarations
  (``codegen.py``, ``pack.py``, ``linear.py``).
* **structural**: ``apply(values, plant)`` returns a changed plant;
* **sensor**: ``measure(values, name, y, time_s, plant)`` distorts a measured signal;
  ``shifts`` says it only adds a constant, which a replay's window reset takes into the
  model's signal before measuring its drift (``identify.replay.Replay._reset_angles``).

``on_request`` marks an effect that ``diagnose`` tries only when asked for (``also``,
``--also NAME``; or named in ``only``): one that refines physics the library has at a cost
every record would pay (LuGre friction refines Stribeck friction with presliding).

To add an effect: write a module with a subclass decorated with
:func:`register`; a built-in one is imported in ``effects/__init__.py`` (its
one registration line).  ``docs/writing-an-effect.md`` walks through one.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from . import user
from .registry import REGISTRY, REVISION


@dataclass(frozen=True)
class Param:
    """A named parameter of an effect.

    unit: its unit; low/high: physical bounds (also the fit's bounds);
    scale: a typical magnitude on the plant it acts on (a callable of the plant,
    or a number), the fit's starting point and step; integer: whole numbers only;
    fit_high: where a record cannot tell larger values from the limit the parameter
    tends to, ``fit_high(plant, values, sample_time_s)`` bounds a fit to a record
    sampled every ``sample_time_s`` s (a file may still hold more, up to ``high``);
    fit_low: ``fit_low(plant, values)``, a fit's lower bound above ``low`` where smaller values
    are not physical and only make the model stiff (a file may still hold less, down to ``low``).
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
    carriage: str | None = None  # its name with ``location: carriage`` (a force, N), if it differs
    fit_high: Any = None
    fit_low: Any = None

    def fit_floor(self, plant, values: dict) -> float:
        """The fit's lower bound on ``plant`` (``low`` without a ``fit_low``)."""
        return self.low if self.fit_low is None else max(self.low, float(self.fit_low(plant, values)))

    def fit_bound(self, plant, values: dict, sample_time_s: float | None) -> float:
        """The fit's upper bound on ``plant`` for a record sampled every ``sample_time_s`` s
        (None: ``high``)."""
        if self.fit_high is None or sample_time_s is None:
            return self.high
        return min(self.high, float(self.fit_high(plant, values, sample_time_s)))

    def typical(self, plant, values: dict) -> float:
        """A typical value on ``plant`` (the effect's options in ``values``)."""
        return float(self.scale(plant, values) if callable(self.scale) else self.scale)


class Effect:
    """Base class of the effects; see the module docstring."""
    name: ClassVar[str] = ""
    acts_on: ClassVar[str] = ""
    signature: ClassVar[str] = ""
    confounders: ClassVar[tuple[str, ...]] = ()  # effects fitted with this one in pairs whatever their rank
    params: ClassVar[tuple[Param, ...]] = ()
    options: ClassVar[dict[str, tuple[str, ...]]] = {}
    settings: ClassVar[dict[str, tuple[str, ...]]] = {}  # string choices diagnose does not try; first = default
    defaults: ClassVar[dict[str, Any]] = {}
    term: ClassVar[Any] = None
    friction: ClassVar[Any] = None  # the stick-slip law, for a friction effect (see the module docstring)
    places: ClassVar[tuple[str, ...]] = ()
    slots: ClassVar[tuple[str, ...]] = ()  # what the term reads at p[o], p[o + 1], ... (SI)
    source: ClassVar[str | None] = None  # the file of an effect from outside the package
    state: ClassVar[str] = ""  # "name, unit" of the effect's own state, "" for none
    rate: ClassVar[Any] = None  # the state's derivative (see the module docstring)
    on_request: ClassVar[bool] = False  # diagnose tries it only when asked for (also, --also)
    rounds: ClassVar[bool] = False  # a sensor effect that rounds its signal to a grid (no noise below it)
    shifts: ClassVar[bool] = False  # a sensor effect that adds a constant: a window's reset sees through it
    causal: ClassVar[bool] = False  # its measure of a record's first samples is the first of its measure

    def fit_params(self, values: dict) -> tuple[Param, ...]:
        """The parameters a fit adjusts (the given optional ones too)."""
        return tuple(q for q in self.params if not q.optional or q.name in values)

    def compiled(self, values: dict, plant) -> tuple[str, tuple[float, ...]]:
        """``(place, numbers)``: where this instance's ``term`` acts, one of
        ``places``, and the numbers it reads there (SI); raise ValueError for
        a plant it cannot act on."""
        raise NotImplementedError(f"effect {self.name!r} has a term but no compiled()")

    def state_scale(self, values: dict, plant) -> float:
        """Typical size of this instance's state on ``plant``, in its unit (the solver's
        absolute tolerance is ``rtol`` times it)."""
        return 1.0

    def piecewise_linear(self, values: dict) -> bool:
        """True when this instance's term is affine in the state (a spring, a
        constant, a symmetric viscous term): the solver may then reuse a
        Jacobian while the modes stay."""
        return False

    def linear(self, values: dict, plant) -> tuple[str, float, float] | None:
        """``(shaft, k, c)``: where its term is linear, this instance adds
        ``-k theta - c w`` to the torque on ``shaft`` (``"motor"`` or ``"load"``;
        ``theta`` its angle, rad, ``w`` its speed, rad/s; k in N m/rad, c in
        N m s/rad), which the linearised plant takes in; None otherwise."""
        return None

    def steady_drag(self, values: dict, plant) -> tuple[str, float, float] | None:
        """``(shaft, b, t0)``: in steady forward motion this instance resists
        with ``b w + t0`` at ``shaft`` (``"motor"`` or ``"load"``; b in
        N m s/rad, t0 in N m); None when it has no single steady drag."""
        return None

    def apply(self, values: dict, plant):
        """A structural effect returns the changed plant; others return it unchanged."""
        return plant

    def applicable(self, plant, signals) -> bool:
        """Whether this effect can be added to ``plant`` for a record measuring ``signals``
        (by default: when :meth:`inapplicable` gives no reason)."""
        return not self.inapplicable(plant, signals)

    def inapplicable(self, plant, signals) -> str:
        """Why this effect cannot be added to ``plant`` for a record measuring ``signals``, "" when
        it can: ``diagnose`` lists it among the effects it did not try, ``fit`` stops with it."""
        return ""

    def estimate(self, values: dict, measured: dict, plant) -> dict | None:
        """Parameters read straight from the measured signals, for effects a
        least-squares fit cannot move (integer counts); None = fit instead."""
        return None

    def guesses(self, plant, record) -> list[dict]:
        """Values of this effect's parameters read from ``record`` (a
        :class:`~gearbench.measure.data.Measurement`) for ``plant``, which diagnose's scan
        tries beside its own points (one replay each; a local fit starts from one only where it
        ranks among the scan's best); none by default."""
        return []

    def simpler(self, values: dict) -> tuple[str, dict] | None:
        """A nested simpler effect (fewer parameters) this one reduces to, as
        ``(name, values)`` from these values; None when there is none."""
        return None

    def measure(self, values: dict, name: str, y: np.ndarray, time_s: np.ndarray, plant) -> np.ndarray:
        """A sensor effect distorts measured signal ``name``; others leave it.  Declare ``causal``
        when each output sample depends only on ``y`` up to its time (a delay, a rounding, an
        offset): a scan may then stop a replay part-way (``Replay.run(stop=...)``)."""
        return y

    def measures_causally(self) -> bool:
        """Whether :meth:`measure` of a record's first samples is the first samples of its
        measure: it is not overridden, or the effect declares ``causal``."""
        return self.causal or type(self).measure is Effect.measure

    def describe(self) -> str:
        """One line: what it is, where it acts, its parameters with units."""
        doc = (type(self).__doc__ or "").strip().splitlines()[0]
        pars = ", ".join(f"{q.name} ({q.unit})" for q in self.params)
        opts = ", ".join(f"{k}: {'|'.join(v)}" for k, v in {**self.options, **self.settings}.items())
        return f"{self.name}: {doc} Acts on the {self.acts_on}; parameters {pars}" + (
            f"; {opts}" if opts else "")


ROTOR_MIN_SHARE = 1e-3
"""Below this share of the inertia it drives (its own plus the load's, reflected), a plant's rotor
is a placeholder: servo sizing keeps the load-to-rotor inertia ratio under about 10:1 (100:1 with a
stiff coupling), so 1000:1 is a file that lumped the rotor into the load (EMPS's: 1e-5)."""


def lumped_rotor(plant) -> str:
    """Why a clearance or a spring between the rotor and the load cannot go into ``plant`` (resolved),
    "" when it can: with the rotor lumped into the load, the side of the clearance or the spring the
    drive acts on would carry next to no inertia, a split the file does not state (and the free
    rotor in a closed loop would chatter at the solver's smallest steps)."""
    jm, total = plant.motor_inertia_total, plant.driven_inertia
    if jm >= ROTOR_MIN_SHARE * total:
        return ""
    return (f"the rotor (motor.inertia {jm:.3g} kg m^2) is {jm / total:.2g} of the inertia it drives "
            f"({total:.3g} kg m^2 at the motor with the load's): the plant file lumps the rotor into the load, "
            f"and a clearance or a shaft between them needs the rotor's own inertia; to try one, give "
            f"motor.inertia the rotor's value and take it out of the load's")


PLACES = ("motor", "load", "voltage", "mesh", "winding")
STATE_PLACES = ("motor", "load", "winding")  # where an effect with a state may act


def register(cls):
    """Class decorator: put one instance of an effect class in the registry under its name.

    An effect module outside the package (``user.load``) registers with its
    file as ``source``; loading the same file again replaces its effects."""
    import sys
    module = sys.modules.get(cls.__module__)
    path = getattr(module, "__file__", None)
    inside = cls.__module__.startswith(__package__ + ".")
    if not cls.name:
        raise ValueError(f"effect class {cls.__qualname__} has no name")
    old = REGISTRY.get(cls.name)
    if old is not None and (inside or old.source != path):
        raise ValueError(f"effect name {cls.name!r} is registered twice "
                         f"({old.source or type(old).__module__} and {path or cls.__module__})")
    if cls.term is not None:
        bad = [q for q in cls.places if q not in PLACES] or ([] if cls.places else ["(none)"])
        if bad:
            raise ValueError(f"effect {cls.name!r}: places {bad} must be among {PLACES}")
    if cls.friction is not None and (cls.term is None or set(cls.places) - {"motor", "load"}):
        raise ValueError(f"effect {cls.name!r}: a stick-slip law (friction) needs a term acting at "
                         f"'motor' or 'load' only, as its regularized form")
    if bool(cls.state) != (cls.rate is not None) or (cls.state and (
            cls.term is None or cls.friction is not None or set(cls.places) - set(STATE_PLACES))):
        raise ValueError(f"effect {cls.name!r}: a state needs both its name (state) and its derivative (rate), "
                         f"a term acting at {STATE_PLACES} only, and no stick-slip law")
    if isinstance(cls.confounders, str) or not all(isinstance(n, str) for n in cls.confounders):
        # a bare string would be taken letter by letter
        raise ValueError(f"effect {cls.name!r}: confounders must be a tuple of effect names, "
                         f"not {cls.confounders!r}")
    cls.source = None if inside else path
    REGISTRY[cls.name] = cls()
    REVISION[0] += 1
    return cls


def registered(name: str, source: str | None = None) -> Effect:
    """The registered effect ``name``, loading its file ``source`` first when it
    is not registered yet (a worker that received it from another process)."""
    if name not in REGISTRY and source:
        user.load(source)
    try:
        return REGISTRY[name]
    except KeyError:
        raise KeyError(f"effect {name!r} is not registered; name its module in the plant "
                       f"file's effect_modules") from None


@dataclass(frozen=True)
class AddedEffect:
    """An effect in a plant: its registered name and its parameter values
    (numbers in the units of its :class:`Param` entries, strings for options).

    ``source``: the file of an effect from outside the package, taken from the
    registry, so that a process that unpickles it (a worker) can load it."""
    name: str
    values: dict
    source: str | None = field(default=None, compare=False, repr=False)

    def __post_init__(self):
        if self.source is None and self.name in REGISTRY:
            object.__setattr__(self, "source", REGISTRY[self.name].source)

    @property
    def effect(self) -> Effect:
        return registered(self.name, self.source)

    def to_dict(self) -> dict:
        return {"type": self.name, **self.values}
