"""The hash of the source that decides a run's numbers, written once.

Two things are keyed by it: numba's on-disk cache folder (``gearbench/__init__.py``;
numba checks only the file of the function it compiles, not the ones it calls,
so a stale cache could survive an edit of the physics) and a sweep's resume keys
(``gearbench/sweep.py``; results computed by other physics are not reused).

The file set, :data:`PHYSICS_FOLDERS` and :data:`PHYSICS_FILES`: every ``.py``
under ``plant/``, ``control/`` and ``solver/``, plus ``layout.py`` and
``simulate.py``.  Each file enters with its path relative to the package, so a
file moved or renamed changes the digest too.

Imports nothing but the standard library: ``import gearbench`` calls it and must
stay cheap (no numba).
"""
from __future__ import annotations

import hashlib
from pathlib import Path

PHYSICS_FOLDERS = ("plant", "control", "solver")
PHYSICS_FILES = ("layout.py", "simulate.py")
PACKAGE = Path(__file__).resolve().parent


def physics_files(package: Path = PACKAGE) -> list[Path]:
    """The hashed files of ``package`` (the gearbench folder), sorted by path."""
    package = Path(package)
    out = []
    for path in sorted(package.rglob("*.py")):
        rel = path.relative_to(package)
        if rel.parts[0] in PHYSICS_FOLDERS or str(rel) in PHYSICS_FILES:
            out.append(path)
    return out


def physics_digest(package: Path = PACKAGE) -> str:
    """sha256 (first 16 hex digits) over each of :func:`physics_files`' relative
    path and content."""
    package = Path(package)
    h = hashlib.sha256()
    for path in physics_files(package):
        h.update(str(path.relative_to(package)).encode() + b"\0" + path.read_bytes())
    return h.hexdigest()[:16]
