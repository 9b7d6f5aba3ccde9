"""The effects' compiled terms, laid out and bundled into one compiled model.

From the registered effects' declarations (``base.py``: ``term``, ``places``,
``slots``) this module derives

* the **layout**: each compiled effect gets, at each of its places, a block
  of ``1 + len(slots)`` slots of the parameter vector after the plant's and
  controller's (``layout.P_SIZE``): a count of the instances there (0 =
  absent), then the numbers its term reads.  Blocks follow the registry's
  order, so loading an effect module only appends blocks;
* the **sums**: one numba function per place that adds the torques of the
  effects present there (``motor``, ``load``), composes the voltage maps
  (``voltage``), adds the mesh offsets (``mesh``) or the winding's voltage
  drops (``winding``), generated as Python source with the offsets as constants;
* the **effect states**: each block of an effect with a ``state`` owns one
  state after the plant's (``layout.N_STATE + k``); ``rates`` writes their
  derivatives and ``n_state`` counts them.  Only a plant with such an effect
  needs them, and every state costs each step, so there are two compiled
  models: one with the states and one without (those effects' blocks left out);
* the **compiled model**: a module with ``plant.model``'s contract, those
  sums as its ``args``, and its entry points ``integrate`` and
  ``derivative``, compiled and cached by numba.

The generated module is a file under numba's cache folder, named by a hash
of gearbench's physics sources and the effects it holds (their modules'
sources), so numba can cache its entry points on disk, an edit anywhere
makes a new one, and a process that needs the same effects (a worker)
imports the same file.
"""
from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
import threading
from dataclasses import dataclass
from pathlib import Path

from ... import layout as L
from .base import REGISTRY, REVISION, registered

VERSION = "1"  # of the generated source's shape

_MODELS: dict = {}
_LOCK = threading.Lock()


@dataclass(frozen=True)
class Block:
    name: str     # the effect
    place: str    # "motor", "load", "voltage", "mesh", "winding" or a stick-slip law's "motor_stick", "load_stick"
    offset: int   # its count slot; its numbers follow
    size: int     # numbers after the count
    state: int = -1  # the index of its own state in x, -1 for none


def term_of(effect):
    """The compiled term of ``effect`` (None when it has none), read from its
    class: a numba dispatcher read through an instance is bound as a method,
    a new object at every read."""
    return type(effect).term


def compiled_effects() -> list:
    """The registered effects with a compiled term, in registry order."""
    return [e for e in REGISTRY.values() if term_of(e) is not None]


def _per_revision(fn):
    """Cache ``fn()`` for the registry's current revision (simulate calls these per run)."""
    memo: dict = {}

    def wrapper():
        rev = REVISION[0]
        if rev not in memo:
            memo.clear()
            memo[rev] = fn()
        return memo[rev]
    wrapper.__doc__ = fn.__doc__
    return wrapper


def friction_of(effect):
    """The stick-slip law of ``effect`` (None when it has none), read from its class."""
    return type(effect).friction


STICK = {"motor": "motor_stick", "load": "load_stick"}  # the blocks a stick-slip law reads
STICK_FLAG = {"motor": L.P_STICK_M, "load": L.P_STICK_L}


@_per_revision
def blocks() -> dict[tuple[str, str], Block]:
    """The layout of the effects' slots, keyed by (effect, place); an effect
    with a stick-slip law has a second block at each of its shafts
    (``motor_stick``, ``load_stick``), read by that law."""
    out, offset, state = {}, L.P_SIZE, L.N_STATE
    for e in compiled_effects():
        places = list(e.places)
        if friction_of(e) is not None:
            places += [STICK[q] for q in e.places]
        for place in places:
            out[(e.name, place)] = Block(e.name, place, offset, len(e.slots), state if e.state else -1)
            offset += 1 + len(e.slots)
            state += bool(e.state)
    return out


@_per_revision
def n_state() -> int:
    """Length of the state vector of the model with the effects' states: the plant's
    (``layout.N_STATE``) and one per block of an effect with a state of its own."""
    return L.N_STATE + sum(b.state >= 0 for b in blocks().values())


def state_count(effects) -> int:
    """Length of the state vector for a plant with ``effects``: :func:`n_state` when one of them
    has a state of its own, else the plant's ``layout.N_STATE``."""
    return n_state() if any(term_of(a.effect) is not None and a.effect.state for a in effects) else L.N_STATE


def needs_states(p) -> bool:
    """Whether packed vector ``p`` holds an effect with a state of its own."""
    return any(b.state >= 0 and b.offset < len(p) and p[b.offset] != 0.0 for b in blocks().values())


@_per_revision
def size() -> int:
    """Length of the parameter vector with every registered effect's blocks."""
    return max((b.offset + 1 + b.size for b in blocks().values()), default=L.P_SIZE)


def stick_slip(added) -> bool:
    """Whether an effect of a plant acts by its event-driven stick-slip law
    (``model: stick_slip``, the default for an effect that has one)."""
    return friction_of(added.effect) is not None and added.values.get("model", "stick_slip") == "stick_slip"


def pack_effects(effects, plant, p) -> tuple[bool, set]:
    """Add each compiled effect of ``effects`` to its block of ``p``; two of a
    kind at one place add their numbers; a stick-slip law's blocks raise its
    shaft's flag (``layout.P_STICK_M``, ``P_STICK_L``).  Returns whether the
    others all keep the right-hand side piecewise-linear, and the places of the
    stick-slip laws that do not (their sliding level curves with the speed alone)."""
    table = blocks()
    linear, curved = True, set()
    for added in effects:
        e = added.effect
        if term_of(e) is None:
            continue
        place, numbers = e.compiled(added.values, plant)
        if place not in e.places:
            raise ValueError(f"effect {e.name!r}: compiled() named place {place!r}, which is not among "
                             f"its places {e.places}; return one of them or declare it")
        stick = stick_slip(added)
        b = table[(e.name, STICK[place] if stick else place)]
        if b.state >= 0 and p[b.offset] != 0.0:
            raise ValueError(f"effect {e.name!r} has a state of its own, so one instance acts at "
                             f"{place!r}: merge the two into one")
        if stick:
            p[STICK_FLAG[place]] = 1.0
        if len(numbers) != b.size:
            raise ValueError(f"effect {e.name!r} gave {len(numbers)} numbers for its {b.size} slots {e.slots}")
        p[b.offset] += 1.0
        p[b.offset + 1:b.offset + 1 + b.size] += numbers
        if not e.piecewise_linear(added.values):
            if stick:
                curved.add(place)
            else:
                linear = False
    return linear, curved


def state_scales(effects, plant, sc) -> None:
    """Write the typical size of each effect's own state (``Effect.state_scale``) into ``sc``."""
    table = blocks()
    for added in effects:
        e = added.effect
        if e.state and term_of(e) is not None:
            place, _ = e.compiled(added.values, plant)
            sc[table[(e.name, place)].state] = e.state_scale(added.values, plant)


_TORQUE = '''
@nb.njit(inline="always", _nrt=False)
def {place}(p, x, theta, w, eps):
    """Torque of the effects on the {body} at angle theta (rad), speed w (rad/s), N m
    (an effect with a state reads it from x)."""
    t = 0.0
{lines}    return t
'''
_FRICTION = '''
@nb.njit(inline="always", _nrt=False)
def {place}_friction(p, s, w):
    """Stick-slip friction on the {body} slipping in direction s (+1/-1) at speed w (rad/s):
    its sliding and breakaway levels, N m."""
    lv = 0.0
    br = 0.0
{lines}    return lv, br
'''
_VOLTAGE = '''
@nb.njit(inline="always", _nrt=False)
def voltage(p, u):
    """The voltage (V) the motor sees for command u (V)."""
{lines}    return u
'''
_WINDING = '''
@nb.njit(inline="always", _nrt=False)
def winding(p, x, i):
    """Voltage (V) the effects lose in the winding at current i (A), beyond R i."""
    v = 0.0
{lines}    return v
'''
_RATES = '''
@nb.njit(inline="always", _nrt=False)
def rates(p, x, theta_m, w_m, theta_l, w_l, out):
    """Write the derivatives of the effects' own states into out (0 where an effect is absent)."""
{lines}    return


@nb.njit(inline="always", _nrt=False)
def effect_states(p, used):
    """Mark the effects' states that are present (their rates read them)."""
{marks}    return
'''
_MESH = '''
@nb.njit(inline="always", _nrt=False)
def mesh(p, theta):
    """Offset of the mesh's relative angle (rad) at output angle theta (rad), and its slope."""
    e = 0.0
    de = 0.0
{lines}    return e, de
'''
_TAIL = '''
MODEL = sys.modules[__name__]  # this module is the model (solver.model's contract) ...
args = MODEL                   # ... and its args: the sums above (fx in plant/rhs.py)


@nb.njit(cache=True)
def integrate(p, seg_t, seg_v, seg_s, seg_d, t_end, x0, t_out, rtol, atol, hmax, method, max_steps):
    return _solver.integrate(MODEL, p, seg_t, seg_v, seg_s, seg_d, t_end, x0, t_out, rtol, atol, hmax,
                             method, max_steps)


@nb.njit(cache=True)
def derivative(p, x, modes, ref):
    """dx/dt at state x in the given modes and input ref."""
    out = np.empty_like(x)
    rhs(args, x, p, modes, ref, out)
    return out


@nb.njit(cache=True)
def feedback_order(p):
    """The states the right-hand side reads, first, and their count."""
    return feedback(args, p)


@nb.njit(cache=True)
def jacobian(t, x, f0, p, modes, ref, slope, scale, region, lin, ytmp, ftmp, fb):
    """The solver's difference Jacobian of this model (``solver.steppers.jacobian``)."""
    return _steppers.jacobian(MODEL, t, x, f0, p, modes, ref, slope, scale, region, lin, ytmp, ftmp, fb,
                              np.zeros(1, dtype=np.int64), -1)
'''


def term_module(name: str, source_file: str | None, kind: str = "term"):
    """The module that holds effect ``name``'s ``term`` (or its ``friction``
    law), loading a file first when the effect is not registered, and the
    function's name there."""
    effect = registered(name, source_file)
    fn = getattr(type(effect), kind)
    module = sys.modules[type(effect).__module__]
    for attr, value in vars(module).items():
        if value is fn:
            return module, attr
    raise ValueError(f"effect {name!r}: its {kind} must be a function defined at the top of its module "
                     f"{module.__name__}")


def source(states: bool) -> str:
    """The generated module's source for the registered effects (without ``states``: the
    model without the effects' own states, their blocks left out).

    Terms are called as attributes of their modules (a module is nothing at
    run time, so the compiled entry points can be cached); the sums are plain
    functions, not numba-inlined (LLVM inlines what pays)."""
    table = {k: b for k, b in blocks().items() if states or b.state < 0}
    names = {}
    for b in table.values():
        names.setdefault(b.name, f"_e{len(names)}")
    head = ['"""Generated by gearbench.plant.effects.codegen: the gear model with these effects."""',
            "import sys", "", "import numba as nb", "import numpy as np", "",
            "from gearbench.plant.effects.codegen import term_module",
            "from gearbench.plant.model import *  # noqa: F401,F403  the model's contract (its __all__)",
            "from gearbench.solver import integrate as _solver",
            "from gearbench.solver import steppers as _steppers", ""]
    for name, var in names.items():
        head.append(f"{var}, _ = term_module({name!r}, {REGISTRY[name].source!r})")
    attrs = {name: term_module(name, REGISTRY[name].source)[1] for name in names}

    def lines(place, call, with_state=None):
        def one(b):
            form = with_state if b.state >= 0 else call
            return form.format(t=names[b.name] + "." + attrs[b.name], o=b.offset + 1, z=b.state)
        return "".join(f"    if p[{b.offset}] != 0.0:\n        {one(b)}\n" for b in table.values() if b.place == place)
    rates = {name: term_module(name, REGISTRY[name].source, "rate")[1] for name in names
             if REGISTRY[name].state}
    arg = {"motor": "theta_m, w_m", "load": "theta_l, w_l", "winding": f"x[{L.X_I}]"}
    rate_lines = "".join(f"    out[{b.state}] = {names[b.name]}.{rates[b.name]}(p, {b.offset + 1}, {arg[b.place]}, "
                         f"x[{b.state}]) if p[{b.offset}] != 0.0 else 0.0\n" for b in table.values() if b.state >= 0)
    marks = "".join(f"    used[{b.state}] = p[{b.offset}] != 0.0\n" for b in table.values() if b.state >= 0)
    frictions = {name: term_module(name, REGISTRY[name].source, "friction")[1] for name in names
                 if friction_of(REGISTRY[name]) is not None}

    def stick_lines(place):
        return "".join(f"    if p[{b.offset}] != 0.0:\n        a, c = {names[b.name]}.{frictions[b.name]}(p, "
                       f"{b.offset + 1}, s, w)\n        lv += a\n        br += c\n"
                       for b in table.values() if b.place == STICK[place])
    torque = ("t += {t}(p, {o}, theta, w, eps)", "t += {t}(p, {o}, theta, w, eps, x[{z}])")
    body = [_TORQUE.format(place="motor", body="rotor", lines=lines("motor", *torque)),
            _TORQUE.format(place="load", body="output shaft", lines=lines("load", *torque)),
            _FRICTION.format(place="motor", body="rotor", lines=stick_lines("motor")),
            _FRICTION.format(place="load", body="output shaft", lines=stick_lines("load")),
            _VOLTAGE.format(lines=lines("voltage", "u = {t}(p, {o}, u)")),
            _MESH.format(lines=lines("mesh", "a, b = {t}(p, {o}, theta)\n        e += a\n        de += b")),
            _WINDING.format(lines=lines("winding", "v += {t}(p, {o}, i)", "v += {t}(p, {o}, i, x[{z}])")),
            _RATES.format(lines=rate_lines, marks=marks)]
    return ("\n".join(head) + "\n" + "\n".join(body) + f"\nSIZE = {size()}  # length of the parameter vector\n"
            f"n_state = {n_state() if states else L.N_STATE}  # the plant's states and the effects' own\n" + _TAIL)


def _folder() -> Path:
    base = os.environ.get("NUMBA_CACHE_DIR") or str(Path.home() / ".cache" / "gearbench")
    return Path(base) / "models"


def compiled_model(states: bool = False):
    """The generated module for the effects registered now, with the effects' own states or
    without (written and imported once per set of effects; thread-safe: a Dask worker's
    threads would otherwise see one another's half-imported module)."""
    model = _MODELS.get((REVISION[0], states))
    if model is None:
        with _LOCK:
            key = (REVISION[0], states)
            model = _MODELS.get(key)
            if model is None:
                model = _MODELS[key] = _generate(states)
    return model


def _generate(states: bool):
    from ...physics_hash import physics_digest
    text = source(states)
    # named by everything its compiled code depends on: gearbench's physics (numba checks
    # only this file's date), the generated text and the outside effects' sources
    key = hashlib.sha256((VERSION + physics_digest() + text + "".join(
        Path(e.source).read_text() for e in compiled_effects() if e.source)).encode()).hexdigest()[:16]
    name = f"gearbench_model_{key}"
    if name in sys.modules:
        return sys.modules[name]
    path = _folder() / f"{name}.py"
    if not path.exists() or path.read_text() != text:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(text)
        os.replace(tmp, path)  # atomic: a concurrent process writes the same text
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
