"""Where a diagnosis is, for a progress display: events, and the clock that sends them."""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

from .timing import Timing

STAGES = ("baseline", "calibration plan", "candidates", "second starts", "joint refit", "calibration",
          "without resets", "pairs", "pair second starts", "simplify", "prune", "numerical check")
"""The stages of one rung, in order (``ProgressEvent.stage``); the first two come once, before the
first, and the last once, after the last (``ladder.refined``)."""


@dataclass(frozen=True)
class ProgressEvent:
    """Where a diagnosis is, for a progress display: ``diagnose(progress=f)`` calls ``f(event)``
    when a stage starts (``done`` 0) and after each fit of it.

    step: the ladder step being decided (1 = the first rung); stage: one of :data:`STAGES`;
    done, total: fits finished and to do in this stage; label: the fit just finished, e.g.
    ``"coulomb_friction (load)"``; best: the best fit of this stage so far, its label and
    weighted RMS (x the noise floors), "" before the first; elapsed_s: since the diagnosis
    started, s.  The next step's "candidates" and "joint refit" may come inside a step's "pairs"
    (the look-ahead, ``ladder``), and then not again at that step."""
    step: int
    stage: str
    done: int
    total: int
    label: str = ""
    best: str = ""
    elapsed_s: float = 0.0


class Tracker:
    """Sends :class:`ProgressEvent` s to a callback (none: sends nothing), keeps the clock, and keeps
    the diagnosis's :class:`~gearbench.identify.timing.Timing` (which stage is in progress, what each
    cost)."""

    def __init__(self, callback: Callable[[ProgressEvent], None] | None):
        self.callback, self.t0 = callback, time.perf_counter()
        self.timing = Timing()

    @property
    def elapsed_s(self) -> float:
        return time.perf_counter() - self.t0

    def stage(self, name: str, step: int, total: int = 1) -> "StageCounter":
        """Announce stage ``name`` of ladder step ``step``, ``total`` fits (the timing's stage in
        progress from now); returns the callback an executor calls with each finished fit."""
        self.timing.switch(name)
        if self.callback is not None:
            self.callback(ProgressEvent(step, name, 0, total, "", "", self.elapsed_s))
        return StageCounter(self, name, step, total)


class StageCounter:
    """Counts one stage's finished fits (each a ``Tried`` or a ``Pair``), keeps its best by BIC, and
    adds what each cost where it ran (``Tried.cost``, ``Pair.cost``) to the timing, to this stage and
    to its effect (a pair's ``"a+b"``)."""

    def __init__(self, tracker: Tracker, name: str, step: int, total: int):
        self.tracker, self.name, self.step, self.total = tracker, name, step, total
        self.done, self.best = 0, None

    def __call__(self, item) -> None:
        self.done += 1
        self.tracker.timing.add_job(self.name, item.effect(), item.cost)
        if item.ok and (self.best is None or item.result.bic < self.best[0]):
            self.best = (item.result.bic, f"{item.label()} at {item.result.weighted_rms:.3g}x noise")
        if self.tracker.callback is not None:
            self.tracker.callback(ProgressEvent(self.step, self.name, self.done, self.total, item.label(),
                                                self.best[1] if self.best else "", self.tracker.elapsed_s))


class PlainLines:
    """A progress callback for a stream that is not a terminal (a CI log, ``| tee``): one plain line
    per change of step or stage, and otherwise at most one every ``every_s`` seconds, as tqdm and
    rich do off a terminal, e.g. ``diagnose: step 1 candidates 3/7 (coulomb_friction (load)), 41 s``.
    ``write`` takes each line (without its newline)."""

    def __init__(self, write: Callable[[str], None], every_s: float = 5.0,
                 clock: Callable[[], float] = time.monotonic):
        self.write, self.every_s, self.clock = write, every_s, clock
        self.last: tuple | None = None   # (step, stage) of the last line
        self.last_t = -float("inf")

    def __call__(self, e: ProgressEvent) -> None:
        now = self.clock()
        if (e.step, e.stage) == self.last and now - self.last_t < self.every_s:
            return
        self.last, self.last_t = (e.step, e.stage), now
        self.write(line(e))


def line(e: ProgressEvent) -> str:
    """One plain progress line of ``e``."""
    what = f"diagnose: step {e.step} {e.stage} {e.done}/{e.total}"
    if e.label:
        what += f" ({e.label})"
    what += f", {e.elapsed_s:.0f} s"
    return what + (f"; best so far {e.best}" if e.best else "")
