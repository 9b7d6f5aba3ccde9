"""Tuning studies: from a measurement back to control, and the thesis's gains revisited.

Run from the repository's root (``make run`` does)::

    python -m studies.tuning --results results

1. **The tutorial's rig** (``rig_study``).  ``experiments/data/bench_rig_hidden.csv`` is a
   record of the bench rig with a load-side Coulomb friction and a load spring that its plant
   file (``experiments/plants/bench_rig.yaml``) lacks; its truth file says what they are.
   ``diagnose`` finds them, and ``fit`` (the last rung's effect refitted jointly with the
   earlier ones) gives the values' covariance.  A PI controller is tuned on profile 1, without
   and with each compensator, (a) on the nominal plant and (b) on the identified plant, robustly
   (the mean over plants drawn from the fit's covariance and the datasheet tolerances).  Both
   tunings are then run on the true plant.
2. **The thesis's plant** (``thesis_study``).  P and PI tuned on profiles 1-3 of
   ``experiments/plants/thesis_gear.yaml`` (no compensator, and the thesis's set-point shift),
   beside Table I's gains (Kp = 50 and 200 V/deg, Ki = 0.005 1/s): their IAE as gearbench
   simulates them and as the thesis reports it.

Both under limits (``RIG_LIMITS``, ``THESIS_LIMITS``): without a limit on the voltage's sign
changes, the least IAE is found at gains where the motor hunts inside the clearance.
Writes ``results/tuning.md``, ``results/tuning.json`` and figures under ``results/tuning/``.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import click
import pandas as pd
import yaml

import gearbench as gb
from gearbench.experiment.files import load_plant
from gearbench.plant.effects import AddedEffect
from gearbench.report.io import save_figure_atomic, write_text_atomic
from gearbench.report.tuning import response_figure, slices_figure
from gearbench.tuning.result import spread

REPO = Path(__file__).resolve().parents[1]
RIG = REPO / "experiments" / "plants" / "bench_rig.yaml"
RECORD = REPO / "experiments" / "data" / "bench_rig_hidden.csv"
TRUTH = REPO / "experiments" / "data" / "bench_rig_hidden.truth.yaml"
THESIS = REPO / "experiments" / "plants" / "thesis_gear.yaml"
TABLE1 = REPO / "experiments" / "thesis_table1.csv"
COMPENSATORS = ("none", "thesis_shift", "setpoint_direction", "direction_feedforward", "damped_feedforward")
RIG_LIMITS = {"voltage_sign_changes": 20, "saturated_fraction": 0.25}
"""On the rig: no chatter, and no more than a quarter of the run at the supply's limit."""
THESIS_LIMITS = {"voltage_sign_changes": 20}
"""On the thesis's plant, chatter only: profile 3 outruns the motor (its load is limited to ~33
deg/s at 12 V), so every controller that follows it is saturated a third of the time."""
ROBUST = 8


def true_plant():
    """The rig as the record was made: its plant file plus the truth file's hidden effects."""
    truth = yaml.safe_load(TRUTH.read_text(encoding="utf-8"))
    effects = [AddedEffect(e["type"], {k: v for k, v in e.items() if k != "type"}) for e in truth["hidden_effects"]]
    return load_plant(RIG).with_effects(*effects)


def identified(workers: int):
    """The diagnosed plant and the fit of its last effect refitted with the others (covariance)."""
    d = gb.diagnose(RIG, RECORD, workers=workers)
    final = d.plant
    last = final.effects[-1]
    before = load_plant(RIG).with_effects(*final.effects[:-1])
    options = {k: v for k, v in last.values.items() if k == "location"}
    f = gb.fit(before, RECORD, last.name, options=options, refit=True)
    return d, f


def on_truth(controller, truth, profile: str) -> float:
    return gb.simulate(truth, controller, profile).scores["iae_deg_s"]


def rig_study(results: Path, workers: int) -> dict:
    truth = true_plant()
    d, f = identified(workers)
    kw = dict(profile="profile1", compensator=COMPENSATORS, limits=RIG_LIMITS, workers=workers)
    nominal = gb.tune(RIG, "pi", **kw)
    robust = gb.tune(f.plant, "pi", robust=ROBUST, uncertainty=f, **kw)
    rows = []
    for label, r in (("nominal plant", nominal), (f"identified plant, robust ({ROBUST} draws)", robust)):
        for t in r.tuned:
            rows.append({"tuned on": label, "compensator": t.compensator, "settings": t.best.settings,
                         "iae_tuning_deg_s": t.best.objective, "iae_truth_deg_s": on_truth(t.controller, truth,
                                                                                            "profile1"),
                         "spread": spread(t.best), "limits": t.best.limits, "feasible": t.best.feasible})
    for name, r in (("nominal", nominal), ("identified", robust)):
        save_figure_atomic(response_figure(r), results / "tuning" / f"rig_{name}_response.png")
        save_figure_atomic(slices_figure(r), results / "tuning" / f"rig_{name}_slices.png")
    return {"diagnosis": {"verdict": d.verdict, "model": [e.name for e in d.plant.effects],
                          "fit": {k: [f.values[k], f.stderr[k], f.units.get(k, "")] for k in f.values}},
            "baseline_truth_deg_s": on_truth(nominal.baseline_controller, truth, "profile1"),
            "rows": rows, "wall_s": {"nominal": nominal.wall_s, "robust": robust.wall_s},
            "runs": {"nominal": nominal.runs, "robust": robust.runs}}


def thesis_study(results: Path, workers: int) -> list[dict]:
    ref = pd.read_csv(TABLE1)
    rows = []
    for profile in (1, 2, 3):
        for kind in ("p", "pi"):
            r = gb.tune(THESIS, kind, profile=f"profile{profile}", compensator=("none", "thesis_shift"),
                        limits=THESIS_LIMITS, workers=workers, solver={"rtol": 1e-7})
            for t in r.tuned:
                col = "iae_deg_s" if t.compensator == "none" else "iae_shifted_deg_s"
                thesis = ref[(ref.profile == profile) & (ref.controller == kind)]
                sims = {}
                for kp in (50.0, 200.0):
                    c = gb.Controller(kind, kp=kp, compensator=t.compensator, **({"ki": 0.005} if kind == "pi" else {}))
                    run = gb.simulate(THESIS, c, f"profile{profile}", solver={"rtol": 1e-7})
                    sims[kp] = (run.iae_deg_s, run.scores["switchings"])
                rows.append({"profile": profile, "controller": kind, "compensator": t.compensator,
                             "tuned": t.best.settings, "iae_tuned_deg_s": t.best.objective, "limits": t.best.limits,
                             "feasible": t.best.feasible,
                             "kp50_sim_deg_s": sims[50.0][0], "kp50_sign_changes": sims[50.0][1],
                             "kp200_sim_deg_s": sims[200.0][0], "kp200_sign_changes": sims[200.0][1],
                             "kp50_thesis_deg_s": float(thesis[thesis.kp == 50][col].iloc[0]),
                             "kp200_thesis_deg_s": float(thesis[thesis.kp == 200][col].iloc[0])})
            if profile == 3 and kind == "pi":
                save_figure_atomic(response_figure(r), results / "tuning" / "thesis_profile3_pi_response.png")
                save_figure_atomic(slices_figure(r), results / "tuning" / "thesis_profile3_pi_slices.png")
    return rows


def _settings(s: dict) -> str:
    units = {"kp": "V/deg", "ki": "1/s", "kd": "s", "shift_deg": "deg"}
    return ", ".join(f"{k}={v:.4g} {units[k]}" for k, v in s.items())


def markdown(rig: dict, thesis: list[dict], wall_s: float) -> str:
    lim = ", ".join(f"{k} <= {v:g}" for k, v in RIG_LIMITS.items())
    dg = rig["diagnosis"]
    md = ["# Tuning on the identified plant", "",
          "Made by `python -m studies.tuning --results results` (`make run`). Objective: IAE (deg s).", "",
          "## The tutorial's rig: tuned on the nominal plant and on the identified one, run on the truth", "",
          f"`diagnose` on `bench_rig_hidden.csv`: verdict {dg['verdict']}, model {' + '.join(dg['model'])}; "
          "the last effect refitted jointly with the earlier ones: "
          + "; ".join(f"{k} = {v[0]:.5g} +- {v[1]:.2g} {v[2]}" for k, v in dg["fit"].items()) + ".", "",
          f"Tuned on profile 1 with the limits {lim} on every run (on every drawn plant when robust). The "
          "record was made by gearbench's own simulator, so the fit's standard errors are ~1e-7 of the values: "
          "the robust spread is that of the datasheet tolerances (20 % on the motor's and load's values).", "",
          f"Untuned PI (Kp = 50 V/deg, Ki = 0.005 1/s) on the true plant: {rig['baseline_truth_deg_s']:.4g} deg s.", "",
          "| tuned on | compensator | settings | IAE where tuned | IAE on the truth | spread p10-p90 (draws) | limits (worst) |",
          "|---|---|---|---:|---:|---|---|"]
    for r in rig["rows"]:
        s = r["spread"]
        band = f"{s['p10']:.4g}-{s['p90']:.4g}" if s.get("plants", 1) > 1 else "-"
        lim_v = ", ".join(f"{k} {v:.3g}" for k, v in r["limits"].items())
        ok = "" if r["feasible"] else " (breaks a limit)"
        md.append(f"| {r['tuned on']} | {r['compensator']}{ok} | {_settings(r['settings'])} | "
                  f"{r['iae_tuning_deg_s']:.4g} | {r['iae_truth_deg_s']:.4g} | {band} | {lim_v} |")
    best = {k: min((r for r in rig["rows"] if r["tuned on"].startswith(k) and r["feasible"]),
                   key=lambda r: r["iae_tuning_deg_s"]) for k in ("nominal", "identified")}
    md += ["", "Best of each (least IAE where tuned): on the nominal plant "
           f"{best['nominal']['compensator']}, {best['nominal']['iae_truth_deg_s']:.4g} deg s on the truth; "
           f"on the identified plant {best['identified']['compensator']}, "
           f"{best['identified']['iae_truth_deg_s']:.4g} deg s on the truth. Best without a compensator: "
           + ", ".join(f"{k} {next(r['iae_truth_deg_s'] for r in rig['rows'] if r['tuned on'].startswith(k) and r['compensator'] == 'none'):.4g}"
                       for k in ("nominal", "identified")) + " deg s.",
           "", f"Runs: {rig['runs']['nominal']} (nominal, {rig['wall_s']['nominal']:.1f} s), {rig['runs']['robust']} "
           f"(robust, {rig['wall_s']['robust']:.1f} s).", "",
           "![nominal](tuning/rig_nominal_response.png)", "![identified](tuning/rig_identified_response.png)",
           "![slices](tuning/rig_identified_slices.png)", "",
           "## The thesis's plant: tuned gains beside Table I's", "",
           "IAE (deg s) over 10 s, rtol 1e-7, limit: voltage_sign_changes <= "
           f"{THESIS_LIMITS['voltage_sign_changes']}. Table I's gains are Kp = 50 and 200 V/deg (Ki = 0.005 1/s for PI); "
           "'sim' is gearbench's run at that gain (its voltage sign changes in brackets), 'thesis' the value Table I "
           "reports.", "",
           "| profile | controller | compensator | tuned | IAE tuned | Kp=50 sim | Kp=50 thesis | Kp=200 sim | Kp=200 thesis |",
           "|---|---|---|---|---:|---:|---:|---:|---:|"]
    for r in thesis:
        md.append(f"| {r['profile']} | {r['controller'].upper()} | {r['compensator']} | {_settings(r['tuned'])} | "
                  f"{r['iae_tuned_deg_s']:.4g} | {r['kp50_sim_deg_s']:.4g} ({r['kp50_sign_changes']}) | "
                  f"{r['kp50_thesis_deg_s']:.4g} | {r['kp200_sim_deg_s']:.4g} ({r['kp200_sign_changes']}) | "
                  f"{r['kp200_thesis_deg_s']:.4g} |")
    md += ["", "![thesis profile 3](tuning/thesis_profile3_pi_response.png)", "",
           f"Wall time of the study: {wall_s:.0f} s."]
    return "\n".join(md) + "\n"


@click.command()
@click.option("--results", "results_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("results"), show_default=True, help="Output folder.")
@click.option("--workers", type=int, default=None, help="Local processes (default: all cores).")
def main(results_dir: Path, workers: int | None) -> None:
    t0 = time.perf_counter()
    rig = rig_study(results_dir, workers)
    thesis = thesis_study(results_dir, workers)
    wall = time.perf_counter() - t0
    write_text_atomic(results_dir / "tuning.md", markdown(rig, thesis, wall))
    write_text_atomic(results_dir / "tuning.json", json.dumps({"rig": rig, "thesis": thesis, "rig_limits": RIG_LIMITS,
                                                               "thesis_limits": THESIS_LIMITS,
                                                               "wall_s": wall}, indent=1, default=float) + "\n")
    print((results_dir / "tuning.md").read_text(encoding="utf-8"))


if __name__ == "__main__":
    main()
