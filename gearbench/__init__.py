"""gearbench: geartrains with backlash under control; models against measurements.

The compiled core is cached on disk by numba.  Numba only checks the file of
the function it compiles, not the functions it calls in other modules, so a
stale cache could survive an edit of the physics.  The cache folder is
therefore keyed by :func:`gearbench.physics_hash.physics_digest`, the hash of
the physics source (the one a sweep's resume keys use too).
"""
import os
from pathlib import Path

from .physics_hash import physics_digest as _physics_digest

__version__ = "0.1.0"


def _cache_dir() -> str:
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    return str(base / "gearbench" / f"numba-{_physics_digest()}")


if "NUMBA_CACHE_DIR" not in os.environ:
    os.environ["NUMBA_CACHE_DIR"] = _cache_dir()
    import sys as _sys
    if "numba" in _sys.modules:  # numba read its config already
        _sys.modules["numba"].config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]


# ---------------------------------------------------------------- public API
# Names are imported on first use (module __getattr__), so ``import gearbench``
# stays cheap: the solver, numba, pandas and matplotlib load with the first call.
import importlib as _importlib
import sys as _sys
import types as _types

_EXPORTS = {
    # build or load
    "load_plant": ".experiment.files", "load_experiment": ".experiment.files",
    "load_profile": ".profiles", "Profile": ".profiles", "setpoint": ".api",
    "Controller": ".control.controllers", "Segments": ".simulate", "SolverOptions": ".simulate",
    "load_measurement": ".api",
    # run and judge
    "simulate": ".api", "run_experiment": ".api", "compare": ".api", "diagnose": ".api", "fit": ".api",
    "tune": ".tuning.tune",
    # results
    "Simulation": ".api", "Comparison": ".api", "DiagnosisReport": ".api", "FitReport": ".api",
    "TuneResult": ".tuning.result",
    # errors (gearbench.errors: GearbenchError is the base of every one)
    "GearbenchError": ".errors", "ConfigError": ".errors", "MeasurementError": ".errors", "SolverError": ".errors",
    "ReplayError": ".errors", "FitError": ".errors", "ProfileError": ".errors",
}

__all__ = list(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(_importlib.import_module(_EXPORTS[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'gearbench' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))


class _Package(_types.ModuleType):
    """The package, guarding its exported names: importing the submodule
    ``gearbench.simulate`` sets the package attribute ``simulate`` to that
    module, which would hide the API function ``gearbench.simulate``.  The
    submodule stays importable (``from gearbench.simulate import Segments``)."""

    def __setattr__(self, name, value):
        if name in _EXPORTS and isinstance(value, _types.ModuleType):
            return
        super().__setattr__(name, value)


_sys.modules[__name__].__class__ = _Package
