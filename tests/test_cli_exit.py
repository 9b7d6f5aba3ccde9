"""Exit codes, --json on every command, untruncated piped tables, and Ctrl-C (status 130).

Exit status: 0 all asked for succeeded, 1 ran but something failed (named), 2 bad input,
130 interrupted.  JSON is the whole of stdout; the human text goes to stderr.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from gearbench import cli_common
from gearbench.cli import main
from gearbench.simulate import SolverError, SolverOptions, failure_message, simulate

REPO = Path(__file__).resolve().parents[1]
PLANTS = REPO / "experiments" / "plants"
PLANT = PLANTS / "thesis_gear.yaml"
RIG = PLANTS / "bench_rig.yaml"


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def only_json(res) -> dict:
    """stdout must be exactly one JSON document (what `| jq .` needs)."""
    return json.loads(res.stdout)


def experiment(tmp_path: Path, plant: Path = PLANT, name: str = "mini", duration: float = 0.5,
               solver: str = "{method: rodas4, rtol: 1.0e-6}", controllers: str = "[{kind: p, kp: 50}]",
               shift: str = "[off, on]", profiles: str = "[profile2]") -> Path:
    exp = tmp_path / f"{name}.yaml"
    exp.write_text(f"name: {name}\nplant: {plant}\nduration_s: {duration}\nsolver: {solver}\n"
                   f"profiles: {profiles}\ncontrollers: {controllers}\nshift: {shift}\n")
    return exp


def stiff_plant(tmp_path: Path, k: str = "1.0e13") -> Path:
    path = tmp_path / "stiff_gear.yaml"
    text = PLANT.read_text()
    assert "mesh_stiffness: 2.38e7" in text
    path.write_text(text.replace("mesh_stiffness: 2.38e7", f"mesh_stiffness: {k}"))
    return path


# --------------------------------------------------------------- failed runs: exit 1, a cause that fits

def test_failed_runs_exit_1_naming_each_run_and_the_stiff_mesh(tmp_path):
    """The issue's case: a 1e13 N m/rad mesh, 'step budget exhausted' on both runs.  The
    explicit method must follow the ~71 MHz mesh; the budget runs out."""
    exp = experiment(tmp_path, stiff_plant(tmp_path), name="stiff",
                     solver="{method: dopri5, rtol: 1.0e-6, max_steps: 20000}")
    out = tmp_path / "res"
    res = invoke("run", exp, "--results", out)
    assert res.exit_code == 1, res.output
    assert "error: 2 of 2 runs failed: profile2_p_kp50_shift-off, profile2_p_kp50_shift-on" in res.stderr
    assert res.stderr.count("the mesh is very stiff (k = 1e+13 N m/rad, f = 7.14e+07 Hz)") == 2
    assert "chattering" not in res.stderr
    assert "Traceback" not in res.output
    # the tables are still written, with each run's status
    runs = pd.read_csv(out / "stiff_runs.csv")
    assert list(runs["status"]) == ["step budget exhausted"] * 2

    res = invoke("run", exp, "--results", out, "--json")
    assert res.exit_code == 1
    data = only_json(res)
    assert data["failed"] == ["profile2_p_kp50_shift-off", "profile2_p_kp50_shift-on"]
    assert all("mesh is very stiff" in r["message"] for r in data["runs"])


def test_the_thesis_mesh_under_an_explicit_method_is_named_too():
    from gearbench.experiment.files import load_plant
    from gearbench.profiles import load_profile
    plant = load_plant(PLANT)
    seg = load_profile("profile2", REPO / "profiles").segments()
    from gearbench.control.controllers import Controller
    run = simulate(plant, Controller("p", kp=50), seg, 0.5,
                   SolverOptions(method="dopri5", max_steps=2000), label="explicit")
    assert not run.ok
    msg = failure_message(run, plant.name)
    assert "too stiff for the explicit method dopri5" in msg and "f = 1.1e+05 Hz" in msg, msg
    # a starved budget under the stiff method is not put down to the mesh
    run = simulate(plant, Controller("p", kp=50), seg, 0.5, SolverOptions(max_steps=20), label="starved")
    msg = failure_message(run, plant.name)
    assert not run.ok and "mesh" not in msg and "raise max_steps" in msg, msg
    with pytest.raises(SolverError, match="run 'starved' failed"):
        simulate(plant, Controller("p", kp=50), seg, 0.5, SolverOptions(max_steps=20), label="starved",
                 raise_on_failure=True)


def test_a_sweep_with_failed_points_exits_1_also_when_they_are_stored(tmp_path):
    exp = experiment(tmp_path, shift="[off]")
    args = ["sweep", exp, "--param", "solver.max_steps=20,1000000", "--results", tmp_path / "res",
            "--workers", "1"]
    res = invoke(*args)
    assert res.exit_code == 1, res.output
    assert "failed: point solver.max_steps=20 (profile2)" in res.stderr and "step budget exhausted" in res.stderr
    assert "error: 1 of 2 points failed" in res.stderr
    again = invoke(*args, "--json")                  # all reused: still a failed point
    assert again.exit_code == 1
    data = only_json(again)
    assert data["solved"] == 0 and data["reused"] == 2 and data["failed"] == ["solver.max_steps=20 (profile2)"]
    assert {r["status"] for r in data["rows"]} == {"ok", "step budget exhausted"}
    assert "stored failures stay until --fresh" in again.stderr


def test_fail_exits_1_for_a_run_the_solver_could_not_finish_and_2_for_bad_input():
    from gearbench.experiment.files import ConfigError
    from gearbench.identify.replay import ReplayError, ReplayRunError
    from gearbench.synth import SynthError, SynthRunError
    for exc, code in [(ReplayRunError("run 'x' failed"), 1), (SynthRunError("run 'y' failed"), 1),
                      (ReplayError("no set point column"), 2), (SynthError("bad excitation"), 2),
                      (ConfigError("plant.yaml", ["gear.ratio: must be > 0"]), 2), (ValueError("--at"), 2)]:
        with pytest.raises(SystemExit) as info:
            cli_common.fail(exc)
        assert info.value.code == code, exc


@pytest.fixture
def fake_checks(monkeypatch):
    import gearbench.validation as V

    def use(*checks):
        monkeypatch.setattr(V, "run_all", lambda *a, **k: [V.check(*c) for c in checks])
    return use


def test_validate_exits_1_only_for_a_failure_the_report_does_not_explain(fake_checks, tmp_path):
    known = "Table I IAE with vs without the shaft (max over cells)"   # documented in WHY_IT_FAILS
    fake_checks(("energy kept", True, 1e-9, 1e-6, "-"), (known, False, 0.04, 0.01, "relative"))
    res = invoke("validate", "--results", tmp_path, "--json")
    assert res.exit_code == 0, res.output
    checks = only_json(res)["checks"]
    assert [c["failure_explained"] for c in checks] == [False, True]
    assert invoke("validate", "--results", tmp_path, "--strict").exit_code == 1

    fake_checks(("energy kept", False, 1e-3, 1e-6, "-"), (known, False, 0.04, 0.01, "relative"))
    res = invoke("validate", "--results", tmp_path)
    assert res.exit_code == 1
    assert "error: 1 check(s) failed: energy kept" in res.stderr
    assert "| energy kept | FAIL |" in (tmp_path / "validation.md").read_text()


# --------------------------------------------------------------- --json on every command

@pytest.fixture(scope="module")
def record(tmp_path_factory):
    """1.5 s of the bench rig with a hidden load-side Coulomb friction, written by `synth --json`."""
    path = tmp_path_factory.mktemp("rec") / "rig.csv"
    res = invoke("synth", RIG, "--effect", "coulomb_friction location=load torque=0.8", "--duration", "1.5",
                 "--seed", "2", "-o", path, "--json")
    assert res.exit_code == 0, res.output
    data = only_json(res)
    assert data["output"] == str(path) and data["samples"] == 1501 and data["truth"].endswith("rig.truth.yaml")
    assert data["hidden"] == [{"effect": "coulomb_friction", "location": "load", "torque": 0.8}]
    assert "wrote" in res.stderr and "wrote" not in res.stdout
    return path


def test_run_json(tmp_path):
    res = invoke("run", experiment(tmp_path), "--results", tmp_path / "res", "--json")
    assert res.exit_code == 0, res.output
    data = only_json(res)
    assert data["experiment"] == "mini" and data["failed"] == []
    assert [r["status"] for r in data["runs"]] == ["ok", "ok"] and data["runs"][0]["iae_deg_s"] > 0
    assert data["table"][0]["thesis_iae_deg_s"] is None                 # NaN -> null: strict JSON
    assert all(Path(f).is_file() for f in data["files"])


def test_sweep_json(tmp_path):
    res = invoke("sweep", experiment(tmp_path, shift="[off]"), "--param", "controller.kp=5,50",
                 "--results", tmp_path / "res", "--workers", "1", "--json")
    assert res.exit_code == 0, res.output
    data = only_json(res)
    assert data["points"] == 2 and data["solved"] == 2 and data["failed"] == [] and data["lost"] == []
    assert [r["controller.kp"] for r in data["rows"]] == [5, 50]
    assert all(Path(f).is_file() for f in data["files"])


@pytest.mark.parametrize("args", [["info", PLANT], ["stability", PLANT, "--at", "50"]])
def test_info_and_stability_json(args):
    res = invoke(*args, "--json")
    assert res.exit_code == 0, res.output
    assert only_json(res)


def test_compare_diagnose_fit_json(record, tmp_path):
    res = invoke("compare", RIG, record, "--results", tmp_path, "--json")
    assert res.exit_code == 0, res.output
    assert {s["signal"] for s in only_json(res)["signals"]} >= {"load_angle_deg"}

    res = invoke("diagnose", RIG, record, "--only", "bias_torque", "--max-steps", "1", "--workers", "1",
                 "--results", tmp_path, "--json")
    assert res.exit_code == 0, res.output
    assert {"baseline_error", "noise_floor", "candidates", "verdict", "ladder", "numerical", "refined"} <= set(only_json(res))

    new = tmp_path / "fitted.yaml"
    res = invoke("fit", RIG, record, "--effect", "coulomb_friction location=load", "-o", new, "--json")
    assert res.exit_code == 0, res.output
    data = only_json(res)
    assert data["converged"] and data["output"] == str(new) and new.is_file()
    assert data["values"]["effects[0].torque"] == pytest.approx(0.8, rel=0.05)
    assert data["error_after"] < data["error_before"] and data["error_signal"] == "load_angle_deg"
    assert set(data["numerical"]) == set(data["values"])  # the solver tolerance's shift of each value

    never = tmp_path / "never.yaml"
    res = invoke("fit", RIG, record, "--effect", "coulomb_friction location=load torque=0.01",
                 "--max-evals", "1", "-o", never, "--json")
    assert res.exit_code == 1
    assert only_json(res)["converged"] is False and not never.exists()


def test_import_emps_json(tmp_path):
    out = tmp_path / "emps.csv"
    res = invoke("import", "emps", REPO / "data" / "emps" / "DATA_EMPS_PULSES.mat", "-o", out, "--json")
    assert res.exit_code == 0, res.output
    data = only_json(res)
    assert data["rows"] == 24841 and data["output"] == str(out) and "time_s" in data["columns"]


def test_jsonable_is_strict():
    import numpy as np
    obj = {"a": np.float64("nan"), "b": [np.int64(3), float("inf")], "c": Path("x"), 1: np.bool_(True)}
    assert json.loads(json.dumps(cli_common.jsonable(obj), allow_nan=False)) == \
        {"a": None, "b": [3, None], "c": "x", "1": True}


# --------------------------------------------------------------- piped output is not truncated

def test_piped_tables_are_not_cut(tmp_path):
    """CliRunner's stdout is not a terminal: rich used to fold to 80 columns ('14.1…')."""
    res = invoke("run", experiment(tmp_path, name="wide", duration=1.0), "--results", tmp_path / "res")
    assert res.exit_code == 0, res.output
    assert "…" not in res.stdout
    header = next(line for line in res.stdout.splitlines() if "controller" in line)
    for col in ("profile", "controller", "IAE deg s", "thesis", "ratio", "impacts", "switches", "status"):
        assert col in header
    assert max(len(line) for line in res.stdout.splitlines()) > 80
    assert cli_common.stdout().width == cli_common.PIPED_WIDTH


# --------------------------------------------------------------- Ctrl-C: 130, no traceback, nothing half-written

def test_keyboard_interrupt_anywhere_in_a_command_is_130_without_aborted(tmp_path, monkeypatch):
    import gearbench.runner as runner

    def interrupted_in_compiled_code(*args, **kwargs):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise SystemError("CPUDispatcher(<function integrate>) returned a result with an exception set") \
                from exc

    for fake in (interrupted_in_compiled_code, lambda *a, **k: (_ for _ in ()).throw(KeyboardInterrupt)):
        monkeypatch.setattr(runner, "run_experiment", fake)
        res = invoke("run", experiment(tmp_path), "--results", tmp_path / "res")
        assert res.exit_code == 130, res.output
        assert "interrupted: 0 of 2 runs of mini finished; no table written" in res.stderr
        assert "Aborted" not in res.output and "Traceback" not in res.output
        assert not (tmp_path / "res").exists()


def _start(cmd: list[str]) -> subprocess.Popen:
    """A command in its own process group, with the default SIGINT handler (a shell or a test
    runner in the background may pass SIGINT down ignored)."""
    return subprocess.Popen(cmd, cwd=REPO, start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONPATH": str(REPO)},
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def _interrupt_when(proc: subprocess.Popen, ready, timeout: float = 120) -> tuple[str, str]:
    """Send SIGINT to the process group (as a terminal's Ctrl-C does) once ``ready()``."""
    deadline = time.monotonic() + timeout
    while not ready():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "the command never got going"
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGINT)
    return proc.communicate(timeout=120)


def _plots(folder: Path) -> list[Path]:
    """Finished plots (pathlib's * also matches the writer's hidden temporary files)."""
    return [p for p in folder.glob("*.png") if not p.name.startswith(".")] if folder.is_dir() else []


def _leftovers(folder: Path) -> list[Path]:
    """Temporary files of the atomic writers (.NAME.XXXX.tmp / .png)."""
    return [p for p in folder.rglob(".*") if p.is_file()]


def test_ctrl_c_in_run_exits_130_writes_no_table_and_no_partial_file(tmp_path):
    out = tmp_path / "res"
    plots = out / "table1" / "plots"
    proc = _start([sys.executable, "-m", "gearbench.cli", "run", "experiments/table1.yaml", "--results",
                   str(out), "--workers", "1", "--plot"])
    _, err = _interrupt_when(proc, lambda: bool(_plots(plots)))
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "Aborted" not in err, err
    assert "interrupted:" in err and "of 30 runs of table1 finished; no table written" in err, err
    assert not list(out.glob("table1*.*")), list(out.iterdir())
    assert _leftovers(out) == []
    assert 1 <= len(_plots(plots)) < 30


def test_ctrl_c_in_a_sweep_exits_130_keeps_the_points_and_resumes(tmp_path):
    exp = experiment(tmp_path, duration=1.5, shift="[off]")
    out = tmp_path / "res"
    store = out / "mini" / "sweep.csv"
    cmd = [sys.executable, "-m", "gearbench.cli", "sweep", str(exp), "--param",
           "controller.kp=geomspace(2000,9000,12)", "--results", str(out), "--workers", "1"]
    proc = _start(cmd)
    _, err = _interrupt_when(proc, lambda: store.exists() and store.read_text().count("\n") >= 3)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "Aborted" not in err, err
    assert "points are stored in" in err and "run the same command again to resume" in err, err
    assert not (out / "mini" / "sweep.md").exists() and _leftovers(out) == []
    stored = pd.read_csv(store)
    assert 2 <= len(stored) < 12 and set(stored["status"]) == {"ok"}   # no point stored as failed
    res = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=300,
                         env={**os.environ, "PYTHONPATH": str(REPO)})
    assert res.returncode == 0, res.stderr
    final = pd.read_csv(store)
    assert len(final) == 12 and final["key"].is_unique and set(final["status"]) == {"ok"}


def test_ctrl_c_with_pool_workers_prints_no_worker_traceback(tmp_path):
    """The workers ignore SIGINT (gearbench.workers); the parent alone reports the interrupt."""
    pytest.importorskip("gearbench.workers")
    out = tmp_path / "res"
    plots = out / "table1" / "plots"
    proc = _start([sys.executable, "-m", "gearbench.cli", "run", "experiments/table1.yaml", "--results",
                   str(out), "--workers", "2", "--plot"])
    _, err = _interrupt_when(proc, lambda: bool(_plots(plots)))
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    assert not list(out.glob("table1*.*")) and _leftovers(out) == []


def test_a_ctrl_c_that_a_finalizer_swallows_is_still_an_interrupt(capsys):
    """Python prints "Exception ignored" for a KeyboardInterrupt raised inside a finalizer and goes on
    (matplotlib runs weakref callbacks as it closes a figure: ``run --plot`` with two workers once
    wrote its table and exited 0 after a Ctrl-C, the test above failing once in five runs).  Within
    ``interrupts.remembered`` (every command) it is not printed, ``check`` raises it, and leaving
    the block restores the handler and forgets it."""
    from gearbench import interrupts

    class Finalized:
        def __del__(self):
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(1.0)  # the handler runs here, inside the finalizer, at once

    before = signal.signal(signal.SIGINT, signal.default_int_handler)  # a test runner may ignore it
    try:
        with interrupts.remembered():
            interrupts.check()  # nothing yet
            Finalized()  # collected at once: its __del__ swallows the interrupt
            with pytest.raises(KeyboardInterrupt):
                interrupts.check()
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
        interrupts.check()  # forgotten on leaving
    finally:
        signal.signal(signal.SIGINT, before)
    err = capsys.readouterr().err
    assert "KeyboardInterrupt" not in err and "Exception ignored" not in err, err


def test_command_modules_take_their_helpers_from_cli_common_not_cli():
    """No import circle cli <-> cli_*: the command modules never import gearbench.cli."""
    import ast
    package = Path(cli_common.__file__).parent
    modules = sorted(package.glob("cli_*.py"))
    assert {m.stem for m in modules} >= {"cli_common", "cli_identify", "cli_import", "cli_synth", "cli_sweep"}
    for path in modules:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                absolute = node.module if node.level == 0 else f"gearbench.{node.module}" if node.module else "gearbench"
                names = {absolute} | {f"{absolute}.{a.name}" for a in node.names}
            elif isinstance(node, ast.Import):
                names = {a.name for a in node.names}
            else:
                continue
            assert "gearbench.cli" not in names, f"{path.name}:{node.lineno} imports gearbench.cli"
    code = ("import sys, gearbench.cli_identify, gearbench.cli_import, gearbench.cli_synth, gearbench.cli_sweep, "
            "gearbench.cli_validate; print('gearbench.cli' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=package.parent).stdout
    assert out.strip() == "False"
