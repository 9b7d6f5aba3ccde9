"""Recognise a Ctrl-C that arrived inside numba-compiled code.

Python raises ``KeyboardInterrupt`` at the next Python bytecode; inside compiled
code that is the first Python callback the code makes (e.g. numba unpickling a
constant), and numba reports it as a ``SystemError`` chained (``__cause__`` or
``__context__``, possibly through several SystemErrors) to the interrupt.
"""
from __future__ import annotations


def is_interrupt(exc: BaseException | None) -> bool:
    """True if ``exc`` is a KeyboardInterrupt or was caused by one, however deep in its chain."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False
