"""gearbench sweep: grids, validation before solving, the resumable store, failures,
a hard kill in the middle, and a Dask cluster giving the local numbers exactly."""
from __future__ import annotations

import csv
import io
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

import gearbench.sweep as sw
from gearbench.cli import main
from gearbench.experiment.files import ConfigError

REPO = Path(__file__).resolve().parents[1]
PLANT = REPO / "experiments" / "plants" / "thesis_gear.yaml"


def mini(tmp_path: Path, duration: float = 0.5, extra: str = "") -> Path:
    """A short experiment: profile 2 (it moves from t = 0), one P controller."""
    exp = tmp_path / "mini.yaml"
    exp.write_text(f"""
name: mini
plant: {PLANT}
duration_s: {duration}
profiles: [profile2]
controllers:
  - {{kind: p, kp: 50}}
shift: [off]
{extra}""")
    return exp


def rows(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


# ------------------------------------------------------------------ grid parsing

@pytest.mark.parametrize("text, values", [
    ("controller.kp=0.5,5,50", (0.5, 5, 50)),
    ("controller.kp=linspace(0,1,11)", tuple(round(0.1 * i, 12) for i in range(11))),
    ("controller.kp=logspace(-1,2,4)", (0.1, 1.0, 10.0, 100.0)),
    ("controller.kp=geomspace(2,32,5)", (2.0, 4.0, 8.0, 16.0, 32.0)),
    ("controller.kp=1, linspace(2,3,2)", (1, 2.0, 3.0)),
    ("controller.shift=off,on", (False, True)),
    ("plant.gear.backlash_deg=1e-1,2", (0.1, 2)),
])
def test_grid_values(text, values):
    assert sw.parse_param(text).values == values


@pytest.mark.parametrize("text, words", [
    ("controller.kp", "KEY=VALUES"),
    ("controller.kp=", "no values"),
    ("controller.kp=1,,2", "empty value"),
    ("controller.kp=linspace(1,2)", "3 arguments"),
    ("controller.kp=linspace(1,2,x)", "must be numbers"),
    ("controller.kp=linspace(1,2,2.5)", "whole number"),
    ("controller.kp=range(1,2,3)", "unknown function"),
    ("controller.kp=linspace(1,2,3", "unbalanced"),
    ("controller.kp=geomspace(0,2,3)", "a, b > 0"),
    ("controller.kp=logspace(1,400,3)", "overflows"),
    ("controller.kp=1,1.0", "given twice"),
    ("controller..kp=1", "dotted key path"),
    ("controller.kp=[1", "not a number"),
])
def test_bad_grid_syntax_is_a_clear_error(text, words):
    """A clear error, and no numpy warning on the way (an overflow of logspace is the error)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(sw.SweepError, match=words.replace("(", r"\(").replace("+", r"\+")):
            sw.parse_param(text)


def test_same_key_twice_is_an_error():
    with pytest.raises(sw.SweepError, match="given twice"):
        sw.parse_params(["controller.kp=1", "controller.kp=2"])


def test_grid_is_the_product_and_keys_are_stable(tmp_path):
    exp = mini(tmp_path)
    params = sw.parse_params(["controller.kp=5,50", "controller.shift=off,on",
                              "plant.gear.backlash_deg=2,3"])
    plan = sw.plan_sweep(exp, params)
    assert len(plan.points) == 8
    p = plan.points[-1]
    assert p.params == {"controller.kp": 50, "controller.shift": True, "plant.gear.backlash_deg": 3}
    plant, ctrl = p.job[0], p.job[1]
    assert ctrl.kp == 50 and ctrl.shift and plant.gear.backlash_deg == 3
    again = sw.plan_sweep(exp, sw.parse_params(["controller.kp=5.0,50", "controller.shift=off,on",
                                                "plant.gear.backlash_deg=2,3"]))
    assert [q.key for q in again.points] == [q.key for q in plan.points]  # 5 and 5.0: one point
    assert len({q.key for q in plan.points}) == 8


# --------------------------------------------------------------- validation

def test_bad_swept_value_fails_before_any_solving(tmp_path, monkeypatch):
    calls = []
    monkeypatch.setattr(sw, "simulate", lambda *a, **k: calls.append(a))
    exp = mini(tmp_path)
    with pytest.raises(ConfigError) as err:
        sw.plan_sweep(exp, sw.parse_params(["controller.kp=5,-1"]))
    text = str(err.value)
    assert "controller.kp=-1" in text and "V/deg" in text and "controllers[0].kp" in text
    assert "controller.kp=5:" not in text  # only the bad point is named

    res = CliRunner().invoke(main, ["sweep", str(exp), "--param", "controller.kp=5,-1",
                                    "--param", "duration_s=0,1", "--results", str(tmp_path / "r")])
    assert res.exit_code == 2
    said = " ".join(res.output.split())  # rich wraps long lines
    assert "with controller.kp=-1, duration_s=1: controllers[0].kp must be a positive number " \
           "in V/deg, got -1" in said
    assert "duration_s must be a positive number in s" in said
    assert calls == [] and not (tmp_path / "r").exists()


# ------------------------------------------------------- store, resume, failures

def counting(monkeypatch) -> list:
    calls = []
    real = sw.simulate

    def counted(*args, **kwargs):
        calls.append(args[1].kp)
        return real(*args, **kwargs)

    monkeypatch.setattr(sw, "simulate", counted)
    return calls


def test_resume_skips_finished_points(tmp_path, monkeypatch):
    calls = counting(monkeypatch)
    exp = mini(tmp_path)
    out = tmp_path / "res"
    first = sw.run_sweep(sw.plan_sweep(exp, sw.parse_params(["controller.kp=5,50"])), out, workers=1)
    assert (first.solved, first.reused, sorted(calls)) == (2, 0, [5, 50])
    bigger = sw.plan_sweep(exp, sw.parse_params(["controller.kp=5,50,500"]))
    second = sw.run_sweep(bigger, out, workers=1)
    assert (second.solved, second.reused, calls[2:]) == (1, 2, [500])
    third = sw.run_sweep(bigger, out, workers=1)
    assert (third.solved, third.reused, len(calls)) == (0, 3, 3)
    stored = rows(out / "mini" / "sweep.csv")
    assert [r["controller.kp"] for r in stored] == ["5", "50", "500"]
    assert all(r["status"] == "ok" and r["message"] == "" for r in stored)
    # a different experiment file content is a different point
    exp.write_text(exp.read_text().replace("duration_s: 0.5", "duration_s: 0.4"))
    fourth = sw.run_sweep(sw.plan_sweep(exp, sw.parse_params(["controller.kp=5"])), out, workers=1)
    assert fourth.solved == 1


def test_torn_last_line_is_cut_and_solved_again(tmp_path):
    exp = mini(tmp_path)
    plan = sw.plan_sweep(exp, sw.parse_params(["controller.kp=5,50"]))
    out = tmp_path / "res"
    sw.run_sweep(plan, out, workers=1)
    path = out / "mini" / "sweep.csv"
    whole = path.read_bytes()
    path.write_bytes(whole[: len(whole) - 25])  # the last line lost its end in a crash
    store = sw.SweepStore(path, plan.columns)
    assert len(store.open()) == 1 and store.repaired_bytes > 0
    store.close()
    again = sw.run_sweep(plan, out, workers=1)
    assert (again.solved, again.reused) == (1, 1)
    assert len(rows(path)) == 2


def test_store_of_another_sweep_is_refused(tmp_path):
    exp = mini(tmp_path)
    out = tmp_path / "res"
    sw.run_sweep(sw.plan_sweep(exp, sw.parse_params(["controller.kp=5"])), out, workers=1)
    other = sw.plan_sweep(exp, sw.parse_params(["controller.kp=5", "duration_s=0.3"]))
    with pytest.raises(sw.SweepError, match="--fresh"):
        sw.run_sweep(other, out, workers=1)
    assert sw.run_sweep(other, out, workers=1, fresh=True).solved == 1


def test_failed_points_are_recorded_and_the_sweep_goes_on(tmp_path, monkeypatch):
    real = sw.simulate

    def flaky(plant, ctrl, *args, **kwargs):
        if ctrl.kp == 7:
            raise RuntimeError("boom\nsecond line")
        return real(plant, ctrl, *args, **kwargs)

    monkeypatch.setattr(sw, "simulate", flaky)
    exp = mini(tmp_path)
    plan = sw.plan_sweep(exp, sw.parse_params(["controller.kp=5,7", "solver.max_steps=20,1000000"]))
    outcome = sw.run_sweep(plan, tmp_path / "res", workers=1)
    assert outcome.solved == 4
    got = {(r["controller.kp"], r["solver.max_steps"]): r for r in rows(outcome.csv_path)}
    assert got[("5", "1000000")]["status"] == "ok"
    starved = got[("5", "20")]
    assert starved["status"] == "step budget exhausted"
    assert "failed at t =" in starved["message"] and "max_steps" in starved["message"]
    assert float(starved["iae_deg_s"]) >= 0  # scores of the part it solved
    for steps in ("20", "1000000"):
        r = got[("7", steps)]
        assert r["status"] == "error" and r["message"] == "RuntimeError: boom | second line"


# ----------------------------------------------------------------- the CLI

def test_cli_writes_csv_summary_figure_and_keeps_prose(tmp_path):
    exp = mini(tmp_path)
    out = tmp_path / "res"
    summary = tmp_path / "notes.md"
    summary.write_text("# My notes\n\nProse that stays.\n")
    args = ["sweep", str(exp), "--param", "controller.kp=5,500", "--param", "controller.shift=off,on",
            "--results", str(out), "--workers", "1", "--summary", str(summary)]
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 0, res.output
    assert "4 solved, 0 reused" in res.output
    table = pd.read_csv(out / "mini" / "sweep.csv")
    assert len(table) == 4 and set(table["status"]) == {"ok"}
    assert {"controller.kp", "controller.shift", "iae_deg_s", "rms_deg", "max_deg", "saturated_s",
            "impacts", "status", "message", "wall_s"} <= set(table.columns)
    md = (out / "mini" / "sweep.md").read_text()
    assert "| 500 | on | profile2 |" in md and "Least IAE" in md
    assert (out / "mini" / "sweep.png").stat().st_size > 1000
    text = summary.read_text()
    assert text.startswith("# My notes\n\nProse that stays.") and "<!-- gearbench:sweep mini controller.kp=5,500 controller.shift=off,on begin -->" in text
    res = CliRunner().invoke(main, args)          # again: nothing solved, block replaced
    assert "0 solved, 4 reused" in res.output
    assert summary.read_text().count("gearbench:sweep mini") == 2  # begin + end: one block


# ------------------------------------------------------------ kill -9, resume

def test_sigkill_loses_no_finished_point_and_resumes(tmp_path):
    exp = mini(tmp_path, duration=1.5)
    out = tmp_path / "res"
    path = out / "mini" / "sweep.csv"
    # high gains chatter at the voltage limit: each point takes a good fraction of a second
    cmd = [sys.executable, "-m", "gearbench.cli", "sweep", str(exp), "--param",
           "controller.kp=geomspace(2000,9000,12)", "--results", str(out), "--workers", "1"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if path.exists() and path.read_text().count("\n") >= 3:  # header + 2 points
                break
            time.sleep(0.02)
        os.killpg(proc.pid, signal.SIGKILL)
    finally:
        proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL
    before = path.read_text()
    finished = before[: before.rfind("\n") + 1]
    # a kill can land mid-write: only complete lines count as stored points
    kept = list(csv.DictReader(io.StringIO(finished)))
    assert 2 <= len(kept) < 12, "the kill should land in the middle of the sweep"
    assert all(r["status"] == "ok" and float(r["iae_deg_s"]) > 0 for r in kept)

    res = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert f"{len(kept)} already stored" in res.stderr, res.stderr
    after = path.read_text()
    assert after.startswith(finished)             # earlier rows unchanged
    final = rows(path)
    assert len(final) == 12 and len({r["key"] for r in final}) == 12
    plan = sw.plan_sweep(exp, sw.parse_params(["controller.kp=geomspace(2000,9000,12)"]))
    assert {r["key"] for r in final} == {p.key for p in plan.points}


# ------------------------------------------------------------------- Dask

def test_dask_cluster_gives_the_local_numbers_exactly(tmp_path):
    distributed = pytest.importorskip("distributed")
    exp = mini(tmp_path)
    plan = sw.plan_sweep(exp, sw.parse_params(["controller.kp=5,50,500", "controller.shift=off,on"]))
    local = sw.run_sweep(plan, tmp_path / "local", workers=2)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as cluster:
        remote = sw.run_sweep(plan, tmp_path / "dask", scheduler=cluster.scheduler_address)
    assert (local.solved, remote.solved, remote.lost) == (6, 6, [])

    def frame(o):
        return pd.read_csv(o.csv_path, dtype=str).drop(columns="wall_s").sort_values("key") \
            .reset_index(drop=True)

    pd.testing.assert_frame_equal(frame(local), frame(remote))  # exact: same text, same floats
