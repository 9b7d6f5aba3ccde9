"""Physical effects a plant file adds under ``effects:`` (SPEC section 5).

One module per effect, each registered by name in ``base.REGISTRY``; see
``base.py`` for what an effect declares and how to add one.  The import order
is the registry's, which is the order in which the compiled sums add the
effects' terms at one place (``codegen.py``): friction first, then the
position-dependent and constant torques, as the compiled core always summed
them (round-off, and the fits that start from it, stay as they were).
Listings use the names in alphabetical order (``NAMES``).
"""
from . import (coulomb_friction, stribeck_friction, viscous_friction, load_spring,  # noqa: F401
               bias_torque, amplifier_deadzone, backlash, encoder_quantization, sensor_delay,
               sensor_offset, shaft_compliance, lugre_friction, winding_heating)
from .base import REGISTRY, AddedEffect, Effect, Param, register  # noqa: F401


def names() -> tuple[str, ...]:
    """The registered effects' names, alphabetical (effects loaded from files included)."""
    return tuple(sorted(REGISTRY))
