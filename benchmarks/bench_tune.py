"""Speed of a tuning (``gb.tune``): runs per second and wall time, here, on 2 local processes and
on a Dask ``LocalCluster`` of 2 single-threaded workers bound to the loopback interface.

The case: PI on the thesis's plant, profile 1 (10 s), no compensator, voltage sign changes
<= 20 (a Sobol sample of 32 points, two Nelder-Mead polishes, the slices), and the same tuned
robustly on 8 plants drawn within the datasheet tolerances, whose runs spread over the workers
at every step of the polish.  The answer must be the same everywhere (checked); the ratios
compare the runs in this one session.

Keys (merged into ``results/bench.json``): ``tune_runs_per_s_<where>``, ``tune_wall_s_<where>``
for where in local_1, local_2, dask_2, and the same with ``tune_robust_``; ``tune_speedup_local_2``,
``tune_robust_speedup_local_2``, ``tune_robust_dask_over_local_2``; the case.
"""
from __future__ import annotations

import time
from pathlib import Path

import gearbench as gb
from gearbench.workers import default_workers

from bench_store import merge

PLANT = Path(__file__).resolve().parents[1] / "experiments" / "plants" / "thesis_gear.yaml"
CASE = dict(profile="profile1", limits={"voltage_sign_changes": 20})


def once(label: str, **kw) -> tuple[dict, tuple]:
    t0 = time.perf_counter()
    r = gb.tune(PLANT, "pi", **CASE, **kw)
    wall = time.perf_counter() - t0
    print(f"{label}: {r.runs} runs in {wall:.1f} s ({r.runs / wall:.0f}/s), best {r.best.best.settings}", flush=True)
    return {"wall": wall, "runs": r.runs}, (r.best.best.settings, r.best.best.objective)


def main() -> None:
    from distributed import LocalCluster
    gb.simulate(PLANT, {"kind": "pi", "kp": 50, "ki": 0.005}, "profile1", duration_s=0.1)  # compile/load once
    out = {}
    for prefix, extra in (("tune", {}), ("tune_robust", {"robust": 8})):
        res, answer = {}, None
        for n in (1, 2):
            res[f"local_{n}"], a = once(f"{prefix}, {n} local process(es)", workers=n, **extra)
            answer = answer or a
            assert a == answer, "another answer with more processes"
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address=None) as cluster:
            res["dask_2"], a = once(f"{prefix}, Dask LocalCluster of 2", scheduler=cluster.scheduler_address, **extra)
        assert a == answer, "another answer on the cluster"
        for k, v in res.items():
            out[f"{prefix}_runs_per_s_{k}"] = v["runs"] / v["wall"]
            out[f"{prefix}_wall_s_{k}"] = v["wall"]
        out[f"{prefix}_speedup_local_2"] = res["local_1"]["wall"] / res["local_2"]["wall"]
        out[f"{prefix}_dask_over_local_2"] = res["local_2"]["wall"] / res["dask_2"]["wall"]
        out[f"{prefix}_runs"] = res["local_1"]["runs"]
    out["tune_cpu_count"] = default_workers()
    out["tune_case"] = (f"gb.tune({PLANT.name}, 'pi', profile1, voltage_sign_changes <= 20); robust: 8 plants "
                        "within the datasheet tolerances, mean IAE")
    merge(out)
    for key, value in out.items():
        print(f"{key:>36}: {value:.4g}" if isinstance(value, float) else f"{key:>36}: {value}")


if __name__ == "__main__":
    main()
