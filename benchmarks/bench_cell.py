"""One Table I cell solved again and again for a few seconds: the spread of its run time.

``python benchmarks/bench_cell.py KIND SHIFT SECONDS`` (KIND ``p`` at Kp = 50 V/deg or
``bang_bang``; SHIFT 0 or 1) solves profile 1 for 10 s at rtol 1e-6, scores only (as
``benchmarks/bench_table1.py``'s cells), for SECONDS of wall time after one warm-up run,
and prints the run count and the minimum, 10th percentile and median run time.  Best of
5 (``make bench``) moves by 5-10 % between runs of the same code on this machine; the
median of hundreds does not, so comparisons of two versions of the code (run each, in
turn, in the same session) use this.
"""
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

from gearbench.control.controllers import Controller
from gearbench.experiment.files import load_experiment
from gearbench.profiles import load_profile
from gearbench.simulate import simulate

REPO = Path(__file__).resolve().parents[1]


def main(kind: str, shift: bool, seconds: float) -> None:
    exp = load_experiment(REPO / "experiments" / "table1.yaml")
    opts = replace(exp.solver, rtol=1e-6, output_dt_s=10.0)
    seg = load_profile("profile1").segments()
    ctrl = Controller(kind, shift=shift) if kind == "bang_bang" else Controller(kind, kp=50.0, shift=shift)
    simulate(exp.plant, ctrl, seg, 10.0, opts)
    times = []
    deadline = time.perf_counter() + seconds
    while time.perf_counter() < deadline:
        t = time.perf_counter()
        simulate(exp.plant, ctrl, seg, 10.0, opts)
        times.append(time.perf_counter() - t)
    times.sort()
    print(f"{kind} shift={int(shift)} runs={len(times)} min={times[0] * 1e3:.3f} ms "
          f"p10={times[len(times) // 10] * 1e3:.3f} ms median={statistics.median(times) * 1e3:.3f} ms")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2] == "1", float(sys.argv[3]))
