"""``gearbench tune`` / ``gb.tune``: a tuned run is reproduced by ``gearbench run`` from the file
it writes, the limits hold, the optimum is one, robust draws follow the fit's covariance, bad
input is named, and a Dask cluster gives the local answer."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import gearbench as gb
from gearbench.cli import main
from gearbench.errors import ConfigError
from gearbench.experiment.files import load_plant
from gearbench.plant.effects import AddedEffect
from gearbench.tuning.draws import Uncertainty, draw_plants

REPO = Path(__file__).resolve().parents[1]
THESIS = str(REPO / "experiments" / "plants" / "thesis_gear.yaml")
RIG = REPO / "experiments" / "plants" / "bench_rig.yaml"


@pytest.fixture(scope="module")
def cli_tuned(tmp_path_factory):
    out = tmp_path_factory.mktemp("tune")
    r = CliRunner().invoke(main, ["tune", THESIS, "--controller", "p", "--profile", "1",
                                  "--limit", "voltage_sign_changes=20", "--results", str(out), "--json", "--workers", "2"])
    assert r.exit_code == 0, r.output
    return out, json.loads(r.stdout)


def test_the_tuned_run_is_reproduced_by_run_from_the_written_file(cli_tuned):
    out, summary = cli_tuned
    (run,) = gb.run_experiment(summary["experiment"])
    best = summary["best"]
    assert run.controller.kp == pytest.approx(best["settings"]["kp"], rel=1e-12)
    assert run.scores["iae_deg_s"] == pytest.approx(best["objective"], rel=1e-9)
    assert run.scores["switchings"] <= 20
    assert summary["baseline"]["objective"] > best["objective"]
    folder = out / "tune_thesis_gear_profile1"
    assert {p.name for p in folder.iterdir()} >= {"tune.md", "tune.json", "tuned.yaml", "response.png", "slices.png"}


def test_the_limit_holds_and_binds(cli_tuned):
    """Without it the P loop chatters in the clearance (Kp above the teeth-apart limit of 87.8 V/deg
    lowers the IAE): the best gain sits at the limit, and a gain a little higher breaks it."""
    _, summary = cli_tuned
    best = summary["best"]
    assert best["limit_values"]["voltage_sign_changes"] <= 20 and best["feasible"]
    assert best["settings"]["kp"] > 87.8
    higher = gb.simulate(THESIS, {"kind": "p", "kp": 1.5 * best["settings"]["kp"]}, "profile1")
    assert higher.scores["switchings"] > 20


def test_the_optimum_is_a_minimum_along_every_setting():
    r = gb.tune(THESIS, "pi", profile="profile1", compensator="setpoint_direction", duration_s=4.0,
                limits={"voltage_sign_changes": 20}, workers=2)
    t = r.best
    assert t.best.feasible and set(t.slices) == {"kp", "ki", "shift_deg"}
    for name, points in t.slices.items():
        feasible = [e.objective for _, e in points if e.feasible]
        assert feasible and min(feasible) >= t.best.objective * (1 - 1e-3), (name, feasible, t.best.objective)


def test_no_candidate_within_an_impossible_limit_exits_1(tmp_path):
    """Profile 1 jumps by 5.1 deg: no controller keeps the error under 0.1 deg."""
    r = CliRunner().invoke(main, ["tune", THESIS, "--controller", "p", "--limit", "max_deg=0.1",
                                  "--results", str(tmp_path), "--workers", "1"])
    assert r.exit_code == 1
    assert "no candidate holds the limits" in r.output


@pytest.mark.parametrize("kwargs, message", [
    (dict(objective="ise"), "objective must be one of iae, rms, max"),
    (dict(limits="chatter=3"), "limit 'chatter': unknown; choose from voltage_sign_changes"),
    (dict(limits="saturated_fraction=-1"), "limit saturated_fraction: expected a number >= 0"),
    (dict(ranges={"kp": (10, 1)}), "range kp: expected LOW,HIGH in V/deg"),
    (dict(robust=-2), "robust must be a whole number of plants >= 0"),
    (dict(uncertainty={"values": {}, "stderr": {}}), "uncertainty is used by robust tuning only"),
    (dict(compensator="magic"), "compensator must be one or more of none"),
    (dict(robust_stat="median"), "robust_stat must be one of mean, p90, max"),
])
def test_bad_arguments_are_named_before_anything_is_solved(kwargs, message):
    with pytest.raises(ConfigError, match=message.replace("(", r"\(").replace(")", r"\)")):
        gb.tune(THESIS, "pi", **kwargs)


def test_a_kind_without_gains_is_refused():
    with pytest.raises(ConfigError, match="controller must be one of p, pi, pid"):
        gb.tune(THESIS, "bang_bang")


def _fitted_rig():
    plant = load_plant(RIG)
    return plant.with_effects(AddedEffect("load_spring", {"stiffness": 2.0, "rest_angle_deg": 0.0}),
                              AddedEffect("coulomb_friction", {"location": "load", "torque": 0.96}))


def test_draws_follow_the_fit_covariance():
    """4000 plants drawn from a fit's estimates: mean, standard errors and correlation as given
    (each within 4 of its own sampling standard error), the rest of the plant untouched."""
    plant = _fitted_rig()
    fit = {"values": {"effects[0].stiffness": 2.0, "effects[1].torque": 0.96},
           "stderr": {"effects[0].stiffness": 0.1, "effects[1].torque": 0.05},
           "correlation": {"effects[0].stiffness": {"effects[1].torque": -0.6},
                           "effects[1].torque": {"effects[0].stiffness": -0.6}}}
    n = 4000
    plants = draw_plants(plant, n, uncertainty=Uncertainty.of(fit), use_tolerances=False, seed=1)
    x = np.array([[p.effects[0].values["stiffness"], p.effects[1].values["torque"]] for p in plants])
    se = np.array([0.1, 0.05])
    assert np.all(np.abs(x.mean(axis=0) - [2.0, 0.96]) < 4 * se / math.sqrt(n))
    assert np.all(np.abs(x.std(axis=0, ddof=1) / se - 1) < 4 / math.sqrt(2 * n))
    r = np.corrcoef(x.T)[0, 1]
    assert abs(r + 0.6) < 4 * (1 - 0.36) / math.sqrt(n)
    assert all(p.motor == plant.motor and p.load == plant.load for p in plants[:20])


def test_tolerance_draws_stay_within_the_datasheet_and_keep_kt_equal_to_ke():
    plant = load_plant(RIG)
    plants = draw_plants(plant, 400, seed=2)
    kt = np.array([p.motor.torque_constant for p in plants])
    assert np.all(np.abs(kt / plant.motor.torque_constant - 1) <= 0.20 + 1e-12)
    assert np.ptp(kt) > 0.3 * plant.motor.torque_constant  # spread over the band, not a point
    assert all(p.motor.back_emf_constant == pytest.approx(p.motor.torque_constant, rel=1e-12) for p in plants)
    assert draw_plants(plant, 3, seed=2)[2] == draw_plants(plant, 3, seed=2)[2]


def test_robust_tuning_judges_every_candidate_on_the_same_drawn_plants():
    kw = dict(profile="profile1", duration_s=3.0, limits={"voltage_sign_changes": 10}, robust=4, seed=5, workers=2)
    r = gb.tune(THESIS, "p", **kw)
    b = r.best.best
    assert r.plants == 4 and len(b.values) == 4 and len(set(b.values)) == 4
    assert b.objective == pytest.approx(np.mean(b.values), rel=1e-12)
    assert b.limits["voltage_sign_changes"] <= 10  # the worst plant within the limit
    again = gb.tune(THESIS, "p", **kw)
    assert again.best.best.settings == b.settings and again.best.best.values == b.values
    assert r.best.nominal.values != b.values and len(r.best.nominal.values) == 1


def test_a_dask_cluster_gives_the_local_answer():
    distributed = pytest.importorskip("distributed")
    kw = dict(profile="profile2", duration_s=3.0, limits={"voltage_sign_changes": 10})
    local = gb.tune(THESIS, "p", workers=1, **kw)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        remote = gb.tune(THESIS, "p", scheduler=cluster.scheduler_address, **kw)
    assert remote.best.best.settings == local.best.best.settings
    assert remote.best.best.objective == local.best.best.objective
