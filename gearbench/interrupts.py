"""Recognise a Ctrl-C that arrived inside numba-compiled code, or inside a finalizer.

Python raises ``KeyboardInterrupt`` at the next Python bytecode; inside compiled
code that is the first Python callback the code makes (e.g. numba unpickling a
constant), and numba reports it as a ``SystemError`` chained (``__cause__`` or
``__context__``, possibly through several SystemErrors) to the interrupt.

Where that bytecode is a finalizer's (a ``__del__``, a weakref callback: matplotlib
runs them as it closes a figure), Python prints "Exception ignored" and goes on, and
the interrupt is lost: ``gearbench run --plot`` once wrote its table after a Ctrl-C
(``tests/test_cli_exit.py``).  :func:`remembered` makes a Ctrl-C also leave a mark that
:func:`check` turns back into the interrupt where a command commits its results.
"""
from __future__ import annotations

import signal
import sys
import threading
from contextlib import contextmanager

_received = False


def is_interrupt(exc: BaseException | None) -> bool:
    """True if ``exc`` is a KeyboardInterrupt or was caused by one, however deep in its chain."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def _remember(signum, frame):
    global _received
    _received = True
    raise KeyboardInterrupt


@contextmanager
def remembered():
    """Within the block a Ctrl-C (SIGINT) raises ``KeyboardInterrupt`` as Python's default
    handler does, and is remembered for :func:`check`; one a finalizer swallows is not printed
    (``sys.unraisablehook``).  Nothing changes where SIGINT is not
    Python's default (ignored, as a shell passes it to a job in the background, or handled by
    someone else) or outside the main thread; the handler before is restored on leaving."""
    global _received
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield
        return
    _received = False
    hook = sys.unraisablehook

    def quiet(unraisable):  # the swallowed interrupt is remembered, not printed as a traceback
        if not (_received and isinstance(unraisable.exc_value, KeyboardInterrupt)):
            hook(unraisable)

    signal.signal(signal.SIGINT, _remember)
    sys.unraisablehook = quiet
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)
        sys.unraisablehook = hook
        _received = False


def check() -> None:
    """Raise ``KeyboardInterrupt`` if a Ctrl-C came within :func:`remembered` but was swallowed
    (a finalizer's "Exception ignored"): call it before a command writes what it finished."""
    if _received:
        raise KeyboardInterrupt
