"""The registry of effects: each registered effect by name, and a revision counter.

Filled by :func:`gearbench.plant.effects.base.register` and emptied of a file's effects by
:func:`gearbench.plant.effects.user.unload`; it lives in its own module so that those two
modules share it without importing each other (``base`` imports ``user`` to load an effect's
file on demand).  ``base`` re-exports both names, where the package has always read them.
"""
from __future__ import annotations

REGISTRY: dict[str, "Effect"] = {}  # noqa: F821 - gearbench.plant.effects.base.Effect
REVISION = [0]  # bumped at every registration: what is derived from the registry is cached by it
