"""Where a diagnosis spends its time: wall time, replays, solver steps and fits, per stage and per candidate.

A :class:`Cost` counts one piece of work: the replays it ran (calls of
:meth:`~gearbench.identify.replay.Replay.run`), the solver's accepted steps summed over their
windows (:attr:`~gearbench.identify.replay.ReplayRun.steps`), the fits
(calls of :func:`~gearbench.identify.fit.fit`) and its wall time.  A replay counts into the
``meter`` it carries (:meth:`Replay.metered`), so nothing is global: the diagnosis meters its own
replay with its :class:`Timing` (what runs in this process counts into the current stage), and
each candidate's or pair's fit (``candidates.try_candidate``, ``try_pair``) meters a copy with a
fresh :class:`Cost` of its own, which comes back on its result (``Tried.cost``, ``Pair.cost``)
from whichever process or Dask worker ran it, and is added to the stage that launched it
(:class:`~gearbench.identify.progress.StageCounter`).  A replay pickled to another process leaves
its meter behind.

The counts are exact; the wall times are the clock's.  A stage's wall time is the time it was the
stage in progress in this process (the next rung's screen made during a rung's pairs, the
look-ahead, counts to its own stages, not to the pairs: :meth:`Timing.nested`), so the stages' sum
is at most the diagnosis's; a candidate's is the wall time of its own fits wherever they ran,
summed over its places and rungs, so with several workers the candidates' sum exceeds the stages'.
They are diagnostics: nothing here changes what is fitted.
"""
from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Callable, Iterator


@dataclass
class Cost:
    """What one piece of work cost: wall time (s), replays, solver steps, fits."""
    wall_s: float = 0.0
    replays: int = 0
    solver_steps: int = 0
    fits: int = 0

    def replayed(self, steps: int) -> None:
        """One replay, of ``steps`` accepted solver steps."""
        self.replays += 1
        self.solver_steps += int(steps)

    def fitted(self) -> None:
        """One call of ``fit``."""
        self.fits += 1

    def add(self, other: "Cost | None", wall: bool = True) -> None:
        """Add ``other``'s counts (and its wall time, with ``wall``)."""
        if other is None:
            return
        if wall:
            self.wall_s += other.wall_s
        self.replays += other.replays
        self.solver_steps += other.solver_steps
        self.fits += other.fits


@contextmanager
def timed(cost: Cost, clock: Callable[[], float] = time.perf_counter) -> Iterator[Cost]:
    """Add the wall time of the ``with`` block to ``cost``."""
    t0 = clock()
    try:
        yield cost
    finally:
        cost.wall_s += clock() - t0


def costed(fn: Callable, replay, *args, **kwargs) -> tuple:
    """``fn(replay, *args, **kwargs)`` with ``replay`` metered by a fresh :class:`Cost` (its replays,
    steps and fits), and that cost with the call's wall time: what a job run on a worker carries
    back to the diagnosis (``candidates.try_candidate``, ``search.scan_chunk``, ``calibration.fit_from``)."""
    spent = Cost()
    with timed(spent):
        out = fn(replay.metered(spent), *args, **kwargs)
    return out, spent


class Timing:
    """A diagnosis's :class:`Cost` per stage (in the order they first came) and per candidate effect.

    It is the meter of the diagnosis's own replay: :meth:`replayed` and :meth:`fitted` count into
    the stage in progress (:meth:`switch`); the fits made elsewhere come back as costs
    (:meth:`add_job`).  :meth:`report` is the ``timing`` block of ``diagnose --json``."""

    def __init__(self, clock: Callable[[], float] = time.perf_counter):
        self.clock = clock
        self.t0 = clock()
        self.current: str | None = None
        self.since = self.t0
        self.stages: dict[str, Cost] = {}
        self.candidates: dict[str, Cost] = {}
        self.unstaged = Cost()  # what ran in this process outside any stage

    def _now(self) -> Cost:
        return self.stages.setdefault(self.current, Cost()) if self.current is not None else self.unstaged

    def switch(self, name: str | None) -> None:
        """Stage ``name`` is in progress from now (None: none); the one before ends."""
        now = self.clock()
        if self.current is not None:
            self._now().wall_s += now - self.since
        self.current, self.since = name, now
        if name is not None:
            self.stages.setdefault(name, Cost())

    @contextmanager
    def nested(self) -> Iterator[None]:
        """The stages switched to inside the ``with`` block end with it, and the one in progress before
        goes on (the look-ahead's screen inside a rung's pairs)."""
        before = self.current
        try:
            yield
        finally:
            self.switch(before)

    def replayed(self, steps: int) -> None:
        self._now().replayed(steps)

    def fitted(self) -> None:
        self._now().fitted()

    def add_job(self, stage: str, effect: str, cost: Cost | None) -> None:
        """A candidate's (or pair's, ``effect`` "a+b") fit made for stage ``stage``: its counts to the
        stage (its wall time is the stage's own clock), all of it to the effect."""
        if cost is None:
            return
        self.stages.setdefault(stage, Cost()).add(cost, wall=False)
        self.candidates.setdefault(effect, Cost()).add(cost)

    def add_here(self, cost: Cost | None) -> None:
        """A fit made elsewhere for the stage in progress (a calibration's start): its counts to that
        stage (its wall time is the stage's own clock)."""
        self._now().add(cost, wall=False)

    def wall_s(self) -> float:
        return self.clock() - self.t0

    def report(self) -> dict:
        """``{"wall_s", "stages": [{stage, wall_s, replays, solver_steps, fits}], "candidates":
        [{effect, wall_s, replays, fits}]}``; a stage still in progress counts to now."""
        now = self.clock()
        running = now - self.since if self.current is not None else 0.0
        stages = [{"stage": name, "wall_s": c.wall_s + (running if name == self.current else 0.0),
                   "replays": c.replays, "solver_steps": c.solver_steps, "fits": c.fits}
                  for name, c in self.stages.items()]
        cands = [{"effect": name, "wall_s": c.wall_s, "replays": c.replays, "fits": c.fits}
                 for name, c in self.candidates.items()]
        return {"wall_s": now - self.t0, "stages": stages, "candidates": cands}


__all__ = ["Cost", "Timing", "timed"]
