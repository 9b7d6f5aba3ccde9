"""gearbench: geartrains with backlash under control; models against measurements.

The compiled core is cached on disk by numba.  Numba only checks the file of
the function it compiles, not the functions it calls in other modules, so a
stale cache could survive an edit of the physics.  The cache folder is
therefore keyed by a hash of every compiled module's source.
"""
import hashlib
import os
from pathlib import Path

__version__ = "0.1.0"


def _cache_dir() -> str:
    here = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for path in sorted(here.rglob("*.py")):
        parts = set(path.relative_to(here).parts)
        if parts & {"plant", "control", "solver"} or path.name == "layout.py":
            digest.update(path.read_bytes())
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    return str(base / "gearbench" / f"numba-{digest.hexdigest()[:16]}")


if "NUMBA_CACHE_DIR" not in os.environ:
    os.environ["NUMBA_CACHE_DIR"] = _cache_dir()
    import sys as _sys
    if "numba" in _sys.modules:  # numba read its config already
        _sys.modules["numba"].config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]
