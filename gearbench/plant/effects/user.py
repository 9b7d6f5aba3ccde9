"""Effects from outside the package: one Python file each, in the same
contract as the built-in ones (``base.py``), named in a plant file::

    effect_modules: [my_effects/cogging.py]     # relative to the plant file

Loading a file runs it once per process under a module name made from its
path and contents; its :func:`~.base.register` decorators add its effects to
the registry, and the compiled model then includes their terms
(``codegen.py``).  A process that receives a plant from another (a pool or
Dask worker) loads the file again by its path (``AddedEffect.source``).
"""
from __future__ import annotations

import hashlib
import importlib.util
import sys
from pathlib import Path

from .registry import REGISTRY, REVISION


def module_name(path: Path) -> str:
    """A stable module name for the file at ``path``: its stem and a hash of
    its absolute path and contents."""
    digest = hashlib.sha256(str(path).encode() + b"\0" + path.read_bytes()).hexdigest()[:12]
    stem = "".join(c if c.isalnum() else "_" for c in path.stem)
    return f"gearbench_effect_{stem}_{digest}"


def load(path: str | Path):
    """Import the effect module at ``path`` (once per process and contents);
    returns the module.  Raises ValueError naming the file when it is missing
    or fails to import."""
    path = Path(path).expanduser().resolve()
    if not path.is_file():
        raise ValueError(f"effect module {str(path)!r} does not exist")
    name = module_name(path)
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except Exception as exc:
        del sys.modules[name]
        raise ValueError(f"effect module {str(path)!r} failed to import: "
                         f"{type(exc).__name__}: {exc}") from exc
    return module


def unload(path: str | Path) -> list[str]:
    """Forget the effect module at ``path``: its effects leave the registry and
    its module ``sys.modules`` (a test's throwaway effect); returns their names.
    A compiled model already generated with them stays on disk."""
    path = Path(path).expanduser().resolve()
    names = [n for n, e in REGISTRY.items() if e.source and Path(e.source).resolve() == path]
    for n in names:
        del REGISTRY[n]
    REVISION[0] += 1
    for name in [m for m, mod in sys.modules.items()
                 if m.startswith("gearbench_effect_") and getattr(mod, "__file__", None)
                 and Path(mod.__file__).resolve() == path]:
        del sys.modules[name]
    return names
