"""Benchmark: points per second of a 100-point Kp sweep on 1 and on 2 local workers.

The sweep: P control, Kp log-spaced over 0.5 ... 5000 V/deg (the thesis's scan
range, 100 values), profile 2 for 2 s (profile 1 dwells at zero for its first
2 s, which would make every point trivial), the thesis plant, the stiff
Rosenbrock solver.  Each measurement solves every point into a fresh results
folder, through :func:`gearbench.sweep.run_sweep` (storing included, fsync per
point), after the compiled core is loaded; planning and validation are not timed.

* ``sweep_points_per_s_1`` / ``sweep_points_per_s_2``: points / wall s;
* ``sweep_scaling_2_over_1``: their ratio (2 at best; the machine's other load
  and the unequal cost of the points keep it lower);
* ``sweep_points``, ``sweep_cpu_count``.

Merges into ``results/bench.json`` (read-modify-write, atomic).
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

from gearbench.sweep import default_workers, parse_params, plan_sweep, run_sweep, solve_point

from bench_store import merge

REPO = Path(__file__).resolve().parents[1]
PLANT = REPO / "experiments" / "plants" / "thesis_gear.yaml"
PARAM = "controller.kp=geomspace(0.5,5000,100)"


def experiment(folder: Path) -> Path:
    path = folder / "bench_sweep.yaml"
    path.write_text(f"""name: bench_sweep
plant: {PLANT}
duration_s: 2.0
solver: {{method: rosenbrock23, rtol: 1.0e-6, max_step_s: 1.0e-3}}
profiles: [profile2]
controllers:
  - {{kind: p, kp: 50}}
shift: [off]
""")
    return path


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        plan = plan_sweep(experiment(tmp), parse_params([PARAM]))
        solve_point(plan.points[0].job)  # load the compiled core before timing
        figures = {}
        for workers in (1, 2):
            t0 = time.perf_counter()
            outcome = run_sweep(plan, tmp / f"results_{workers}", workers=workers)
            wall = time.perf_counter() - t0
            assert outcome.solved == len(plan.points), "a fresh folder must solve every point"
            bad = [r["status"] for r in outcome.rows if r["status"] != "ok"]
            assert not bad, f"failed points in the benchmark: {bad}"
            figures[f"sweep_points_per_s_{workers}"] = len(plan.points) / wall
            figures[f"sweep_wall_s_{workers}"] = wall
    figures["sweep_scaling_2_over_1"] = figures["sweep_points_per_s_2"] / figures["sweep_points_per_s_1"]
    figures["sweep_points"] = len(plan.points)
    figures["sweep_cpu_count"] = default_workers()
    figures["sweep_case"] = f"P control, {PARAM}, profile2 for 2 s, thesis_gear"
    merge(figures)
    for key, value in figures.items():
        print(f"{key:>24}: {value:.4g}" if isinstance(value, float) else f"{key:>24}: {value}")


if __name__ == "__main__":
    main()
