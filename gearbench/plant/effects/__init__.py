"""Physical effects a plant file adds under ``effects:`` (SPEC section 5).

One module per effect, each registered by name in ``base.REGISTRY``; see
``base.py`` for what an effect declares and how to add one.
"""
from . import (amplifier_deadzone, backlash, bias_torque, coulomb_friction,  # noqa: F401
               encoder_quantization, load_spring, sensor_delay, shaft_compliance,
               stribeck_friction, viscous_friction)
from .base import REGISTRY, AddedEffect, Effect, Param, register  # noqa: F401

NAMES = tuple(REGISTRY)
