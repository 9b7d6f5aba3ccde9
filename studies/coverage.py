"""Do the reported standard errors hold?  Coverage of +-2 standard errors over noise seeds.

For each seed: a record of the bench rig (experiments/plants/bench_rig.yaml) with three
effects hidden -- stick-slip Coulomb friction at the load (0.3 N m), a load spring
(1.5 N m/rad, rest 5 deg) and viscous friction at the load (0.02 N m s/rad) -- made by
``synthesize`` at a tighter solver tolerance (``SYNTH_RTOL``) than the fit's replay
(``FIT_RTOL``, the CLI's default), so the fit does not replay the very simulation that made
the data (no inverse crime).  Noise: synth's defaults (0.01 deg on the angles, 0.005 A on
the current), white or AR(1) with lag-1 correlation ``RHO`` (the same marginal standard
deviation).  The model holds the three effects at values 1-10 % off the truth and the
motor resistance 10 % off (up on odd seeds, down on even); one joint least-squares fit
(``fit.fit``) frees the four effect parameters and ``motor.resistance``
(``Free.plant``: a calibrated plant parameter), and its replay's numerical error is taken out
where it exceeds 0.3 standard errors, the fit finished at a hundredth of its tolerance as
``gearbench.fit`` does (``identify.numerics.refine``); the values as the least squares left them
are reported beside (``unrefined``).

A parameter is covered when ``|fitted - truth| <= 2 SE``; its coverage is the fraction of
seeds covered, for the standard errors ``fit`` reports (:mod:`gearbench.identify.uncertainty`)
and, beside them, for the white-residual formula ``s^2 (J^T J)^-1`` they replace.  The
``steps`` excitation is the one ``tests/test_uncertainty.py`` asserts on (coverage >= 90 %
for every parameter and noise); ``mixed`` (the practice cases' input) is reported too.

Then the tutorial's two fits (docs/tutorial.md), as a user makes them, on its record made again with
other seeds (:func:`tutorial_one`): 10 s of steps, a load spring of 2 N m/rad relaxed at 0 deg
and stick-slip Coulomb friction of 0.96 N m at the load hidden (``TUTORIAL``), made at
``SYNTH_RTOL``; ``gearbench.fit`` of the spring alone from the plant file, then of the friction
with ``refit=True``.  Its rest angle of 0 is what the first part's 5 deg did not try: a
finite-difference step relative to the value (scipy's ``1e-3 |z|``) fell to the replay's solver
error there, and its standard error with it (:func:`gearbench.identify.fit.fd_step`).

    python -m studies.coverage --results results
"""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

import click
import numpy as np

from gearbench.experiment.files import load_plant
from gearbench import synth as S
from gearbench.identify.fit import Free, fit, get_value, set_values
from gearbench.identify.numerics import refine
from gearbench.identify.replay import Replay, solver_options
from gearbench.identify.scoring import Scorer
from gearbench.plant.effects import AddedEffect
from gearbench.report.io import write_text_atomic
from gearbench.simulate import SolverOptions

PLANT = Path(__file__).resolve().parents[1] / "experiments" / "plants" / "bench_rig.yaml"
HIDDEN = (("coulomb_friction", {"location": "load", "torque": 0.3}),
          ("load_spring", {"stiffness": 1.5, "rest_angle_deg": 5.0}),
          ("viscous_friction", {"location": "load", "coefficient": 0.02}))
CALIBRATED = "motor.resistance"
DURATION_S = 4.0
RHO = 0.9
SYNTH_RTOL = 1e-8
FIT_RTOL = 1e-6
SEEDS = 60
TUTORIAL = (("coulomb_friction", {"location": "load", "torque": 0.96}),
            ("load_spring", {"stiffness": 2.0, "rest_angle_deg": 0.0}))
TUTORIAL_DURATION_S = 10.0
TUTORIAL_SEEDS = 30
START_OFF = (0.01, 0.10)   # effect parameters start this fraction off the truth (uniform, random sign)
PLANT_OFF = 0.10           # the calibrated plant parameter starts 10 % off
COVERED_SE = 2.0


def truth_plant():
    plant = load_plant(PLANT)
    return plant.with_effects(*(AddedEffect(n, dict(v)) for n, v in HIDDEN))


def frees_of(plant) -> list[Free]:
    return [Free.plant(plant, CALIBRATED)] + [f for i in range(len(plant.effects))
                                              for f in Free.effect(plant, i)]


def record(seed: int, rho: float, excitation: str, hidden=HIDDEN, duration_s: float = DURATION_S):
    """The synthetic record of ``seed`` (excitation and noise) with ``hidden`` effects, white
    (``rho`` 0) or AR(1) noise."""
    plant = load_plant(PLANT)
    t, u = S.excitation(excitation, plant, duration_s, 1e-3, seed)
    return S.synthesize(plant, [AddedEffect(n, dict(v)) for n, v in hidden], t, u, seed=seed,
                        noise_ar1=rho, options=SolverOptions(rtol=SYNTH_RTOL, max_step_s=1e-3))


def start_values(truth: np.ndarray, seed: int) -> np.ndarray:
    """The fit's start: the calibrated parameter ``PLANT_OFF`` off, the effects ``START_OFF`` off."""
    rng = np.random.default_rng(1000 + seed)
    off = rng.uniform(*START_OFF, size=truth.size) * rng.choice([-1.0, 1.0], size=truth.size)
    off[0] = PLANT_OFF if seed % 2 else -PLANT_OFF
    return truth * (1.0 + off)


def one(seed: int, rho: float, excitation: str) -> dict:
    """Fit one record; the truth, the fitted values (refined, and as the fit left them) and both
    standard errors by parameter."""
    data = record(seed, rho, excitation)
    truth_p = truth_plant()
    frees = frees_of(truth_p)
    truth = np.array([get_value(truth_p, f) for f in frees])
    model = set_values(truth_p, frees, start_values(truth, seed))
    replay = Replay(data, None, 1.0, solver_options(FIT_RTOL))
    t0 = time.perf_counter()
    loose = fit(replay, model, frees)
    res = refine(replay, Scorer(replay), loose)
    return {"seed": seed, "converged": res.converged, "wall_s": time.perf_counter() - t0,
            "truth": dict(zip(res.values, truth.tolist())), "fitted": res.values, "unrefined": loose.values,
            "stderr": res.stderr, "stderr_white": res.stderr_white}


def z_scores(rows: list[dict], key: str, values: str = "fitted") -> dict[str, np.ndarray]:
    """Per parameter, ``(row[values] - truth) / row[key]`` over the rows."""
    return {n: np.array([(r[values][n] - r["truth"][n]) / r[key][n] for r in rows]) for n in rows[0]["fitted"]}


def coverage(rows: list[dict], key: str, values: str = "fitted") -> dict[str, float]:
    """Per parameter, the fraction of fits with ``|fitted - truth| <= 2 * row[key]``."""
    return {n: float(np.mean(np.abs(z) <= COVERED_SE)) for n, z in z_scores(rows, key, values).items()}


def rms_z(rows: list[dict], key: str, values: str = "fitted") -> dict[str, float]:
    """Per parameter, ``sqrt(mean(((fitted - truth) / SE)^2))``: 1 for calibrated errors."""
    return {n: float(math.sqrt(np.mean(z ** 2))) for n, z in z_scores(rows, key, values).items()}


def mean_z(rows: list[dict], key: str, values: str = "fitted") -> dict[str, float]:
    """Per parameter, the mean of ``(fitted - truth) / SE``: a bias, in standard errors."""
    return {n: float(np.mean(z)) for n, z in z_scores(rows, key, values).items()}


def figures(rows: list[dict]) -> dict:
    """Coverage, RMS z and mean z of the reported standard errors, for the fitted values and the unrefined."""
    return {f"{name}{tail}": fn(rows, "stderr", values) for values, tail in (("fitted", ""), ("unrefined", "_unrefined"))
            for name, fn in (("coverage", coverage), ("rms_z", rms_z), ("mean_z", mean_z))}


def run(excitation: str, rho: float, seeds: int = SEEDS, workers: int | None = 1) -> dict:
    """:func:`one` over ``seeds`` seeds (0, 1, ...) on ``workers`` processes (None: every core); each
    fit is the same wherever it runs."""
    from functools import partial

    from gearbench.identify.executor import Executor
    with Executor(workers) as here:
        rows = here.map(partial(one, rho=rho, excitation=excitation), list(range(seeds)))
    return {"excitation": excitation, "noise": "white" if rho == 0 else f"AR(1) rho {rho:g}",
            "rho": rho, "seeds": seeds, "converged": sum(r["converged"] for r in rows),
            **figures(rows), "coverage_white_formula": coverage(rows, "stderr_white"),
            "rms_z_white_formula": rms_z(rows, "stderr_white"),
            "fit_wall_s": float(sum(r["wall_s"] for r in rows)), "fits": rows}


def tutorial_one(seed: int) -> dict:
    """The tutorial's two fits (the spring alone, then the friction with ``refit``) on the record of
    ``seed``; the truth, the fitted values (``gearbench.fit``'s, refined, and as its least squares
    left them) and the standard errors by parameter."""
    import gearbench as gb
    data = record(seed, 0.0, "steps", TUTORIAL, TUTORIAL_DURATION_S)
    t0 = time.perf_counter()
    spring = gb.fit(load_plant(PLANT), data, "load_spring", rtol=FIT_RTOL)
    both = gb.fit(spring.plant, data, "coulomb_friction", options={"location": "load"}, refit=True,
                  rtol=FIT_RTOL)
    hidden = dict(TUTORIAL)
    truth = {"effects[0].stiffness": hidden["load_spring"]["stiffness"],
             "effects[0].rest_angle_deg": hidden["load_spring"]["rest_angle_deg"],
             "effects[1].torque": hidden["coulomb_friction"]["torque"]}
    return {"seed": seed, "wall_s": time.perf_counter() - t0, "truth": truth,
            "fitted": {n: both.values[n] for n in truth},
            "unrefined": {n: both.values[n] - both.refined * both.numerical[n] for n in truth},
            "stderr": {n: both.stderr[n] for n in truth}}


def tutorial_run(seeds: int = TUTORIAL_SEEDS, workers: int | None = None) -> dict:
    """:func:`tutorial_one` over ``seeds`` seeds (1, 2, ...; the shipped record is seed 1), on
    ``workers`` processes."""
    from gearbench.identify.executor import Executor
    with Executor(workers) as here:
        rows = here.map(tutorial_one, list(range(1, seeds + 1)))
    return {"seeds": seeds, **figures(rows), "fit_wall_s": float(sum(r["wall_s"] for r in rows)), "fits": rows}


def markdown(cases: list[dict], tutorial: dict) -> str:
    names = list(cases[0]["coverage"])
    md = ["# Coverage of the reported standard errors", "",
          f"`python -m studies.coverage --results results`. Bench rig, {DURATION_S:g} s records; hidden: "
          + "; ".join(f"{n} {v}" for n, v in HIDDEN) + f"; {CALIBRATED} calibrated (start "
          f"{PLANT_OFF:.0%} off). Synth rtol {SYNTH_RTOL:g}, fit rtol {FIT_RTOL:g}. Covered: truth within "
          f"+-{COVERED_SE:g} SE. 'white formula': s^2 (J^T J)^-1, the formula the sandwich replaced. "
          "rms z: RMS of (fitted - truth) / SE over the seeds (1 when the SE is right); mean z: their "
          "mean (0 when unbiased). Fitted: finished at a hundredth of the fit's rtol where that moves a value "
          "by more than 0.3 SE, as `gearbench.fit` does (`gearbench.identify.numerics`); 'unrefined': as the least squares at "
          f"rtol {FIT_RTOL:g} left them.", "",
          "| excitation | noise | seeds | parameter | coverage | rms z | mean z | coverage, unrefined | "
          "rms z, unrefined | mean z, unrefined | coverage, white formula | rms z, white formula |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in cases:
        for n in names:
            md.append(f"| {c['excitation']} | {c['noise']} | {c['seeds']} | {n} | {c['coverage'][n]:.0%} | "
                      f"{c['rms_z'][n]:.2f} | {c['mean_z'][n]:+.2f} | {c['coverage_unrefined'][n]:.0%} | "
                      f"{c['rms_z_unrefined'][n]:.2f} | {c['mean_z_unrefined'][n]:+.2f} | "
                      f"{c['coverage_white_formula'][n]:.0%} | {c['rms_z_white_formula'][n]:.2f} |")
    md += ["", "## The tutorial's two fits", "",
           f"{TUTORIAL_DURATION_S:g} s steps records of the bench rig, hidden: "
           + "; ".join(f"{n} {v}" for n, v in TUTORIAL) + f"; seeds 1-{tutorial['seeds']} (1 is the "
           "shipped record's excitation and noise, here made at the synth rtol). `gearbench.fit` of "
           "load_spring alone, then of coulomb_friction at the load with `refit=True`, fit rtol "
           f"{FIT_RTOL:g}.", "",
           "| seeds | parameter | coverage | rms z | mean z | coverage, unrefined | rms z, unrefined | "
           "mean z, unrefined |", "|---|---|---|---|---|---|---|---|"]
    t = tutorial
    for n in t["coverage"]:
        md.append(f"| {t['seeds']} | {n} | {t['coverage'][n]:.0%} | {t['rms_z'][n]:.2f} | {t['mean_z'][n]:+.2f} | "
                  f"{t['coverage_unrefined'][n]:.0%} | {t['rms_z_unrefined'][n]:.2f} | {t['mean_z_unrefined'][n]:+.2f} |")
    return "\n".join(md) + "\n"


@click.command()
@click.option("--results", "results_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("results"), show_default=True)
@click.option("--seeds", type=int, default=SEEDS, show_default=True, help="Noise seeds per case.")
def main(results_dir: Path, seeds: int) -> None:
    cases = []
    for excitation in ("steps", "mixed"):
        for rho in (0.0, RHO):
            c = run(excitation, rho, seeds, workers=None)
            cases.append(c)
            click.echo(f"{excitation}, {c['noise']}: coverage "
                       + ", ".join(f"{n} {v:.0%}" for n, v in c["coverage"].items())
                       + f" (white formula: " + ", ".join(f"{v:.0%}" for v in c["coverage_white_formula"].values())
                       + f"); fits {c['fit_wall_s']:.0f} s")
    tutorial = tutorial_run()
    click.echo("the tutorial's fits: coverage " + ", ".join(f"{n} {v:.0%}" for n, v in tutorial["coverage"].items())
               + f"; fits {tutorial['fit_wall_s']:.0f} s")
    write_text_atomic(results_dir / "coverage.md", markdown(cases, tutorial))
    write_text_atomic(results_dir / "coverage.json", json.dumps({"cases": cases, "tutorial": tutorial}, indent=1) + "\n")


if __name__ == "__main__":
    main()
