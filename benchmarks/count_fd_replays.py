"""Where a diagnosis' replays go: how many are finite-difference Jacobians, in the calibration and
elsewhere (issue 38: is an exact Jacobian, forward sensitivities, worth building?).

Diagnoses a practice case of ``data/cases`` in this process with one worker (so every replay is
counted here) and counts each ``Replay.run`` by whether scipy's ``approx_derivative`` made it (a
fresh forward-difference Jacobian of a fit's steps, the central one at a fit's end, a sharpened
one) and whether a frame of ``identify/calibration.py`` is on the stack.  Prints the counts; writes
nothing.  The totals equal the ``timing`` block's replays of the same diagnosis.

    python benchmarks/count_fd_replays.py p04
"""
from __future__ import annotations

import collections
import sys
import time
import traceback
from pathlib import Path

import gearbench as gb
from gearbench.identify import fit as F
from gearbench.identify.replay import Replay

CASES = Path(__file__).resolve().parents[1] / "data" / "cases"


def main(case: str) -> None:
    counts: collections.Counter = collections.Counter()
    depth = [0]
    run, derivative = Replay.run, F.approx_derivative

    def counted_run(self, *args, **kwargs):
        calibration = any(f.filename.endswith("calibration.py") for f in traceback.extract_stack(limit=40))
        counts[("calibration" if calibration else "elsewhere", "jacobian" if depth[0] else "step")] += 1
        return run(self, *args, **kwargs)

    def counted_derivative(*args, **kwargs):
        depth[0] += 1
        try:
            return derivative(*args, **kwargs)
        finally:
            depth[0] -= 1

    Replay.run, F.approx_derivative = counted_run, counted_derivative
    t0 = time.perf_counter()
    d = gb.diagnose(CASES / case / "nominal.yaml", CASES / case / "data.csv", workers=1)
    wall = time.perf_counter() - t0
    total = sum(counts.values())
    print(f"{case}: verdict {d.verdict}, {wall:.0f} s in one process, {total} replays")
    for where in ("calibration", "elsewhere"):
        jac, steps = counts[(where, "jacobian")], counts[(where, "step")]
        print(f"  {where}: {jac + steps} replays, {jac} of them finite-difference Jacobians "
              f"({100 * jac / max(jac + steps, 1):.0f} %)")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "p04")
