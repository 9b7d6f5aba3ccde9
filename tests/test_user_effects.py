"""A user's own effect: one Python file outside the package, named in a plant
file (``effect_modules:``), used by ``synth``, ``fit``, ``diagnose``, ``compare``
like a built-in (issue 15).

* a throwaway effect written to a temporary file goes through ``gearbench synth``
  and ``gearbench fit``, and the fit finds the value it hid; a missing module or
  one that fails to import is a ConfigError naming the key and the file;
* each example effect (``examples/effects/``) hidden in a record (the bench
  rig, 3 s of open-loop steps as ``tests/test_diagnose.py``) is named by
  ``diagnose`` given the file, against competing candidates, with its
  parameters within 10 %; ``gearbench compare`` replays a record with it.

The throwaway effect is structural (it adds inertia to the load), so it needs
no compiled model of its own.  The example effects are compiled terms: they
run in one subprocess (one compiled model), which keeps them out of this
process's registry; its numba cache is the suite's, and the last test checks
that a process using another set of effects still reads that cache (numba's
index of the solver's functions once named the generated models, and such a
process failed with ModuleNotFoundError).
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from click.testing import CliRunner

from gearbench.cli import main
from gearbench.experiment.files import ConfigError, load_plant
from gearbench.plant.effects import REGISTRY
from gearbench.plant.effects.user import unload

REPO = Path(__file__).resolve().parents[1]
RIG = REPO / "experiments" / "plants" / "bench_rig.yaml"
EXAMPLES = REPO / "examples" / "effects"

THROWAWAY = '''
"""extra_load_inertia: something bolted to the output shaft (kg m^2 added to the load)."""
from dataclasses import replace

from gearbench.plant.effects import Effect, Param, register


@register
class ExtraLoadInertia(Effect):
    """Inertia added to the output shaft."""
    name = "extra_load_inertia"
    signature = "acceleration"
    acts_on = "plant structure"
    params = (Param("inertia", "kg m^2", 0.0, 10.0, 1e-3, "inertia added at the output shaft"),)

    def apply(self, values, plant):
        return replace(plant, load=replace(plant.load, inertia=plant.load.inertia + float(values["inertia"])))
'''


def rig_with(modules: list[str], folder: Path, name: str = "rig.yaml") -> Path:
    """The bench rig's plant file in ``folder`` with ``effect_modules: modules``."""
    path = folder / name
    path.write_text(f"effect_modules: {json.dumps(modules)}\n" + RIG.read_text())
    return path


@pytest.fixture
def throwaway(tmp_path):
    module = tmp_path / "my_effects" / "extra_inertia.py"
    module.parent.mkdir()
    module.write_text(THROWAWAY)
    yield module
    unload(module)


def test_a_throwaway_effect_goes_through_synth_and_fit(tmp_path, throwaway):
    plant_file = rig_with(["my_effects/extra_inertia.py"], tmp_path)  # relative to the plant file
    record = tmp_path / "rec.csv"
    r = CliRunner().invoke(main, ["synth", str(plant_file), "--effect", "extra_load_inertia inertia=4e-3",
                                  "--duration", "3", "--seed", "2", "-o", str(record)])
    assert r.exit_code == 0, r.output
    assert REGISTRY["extra_load_inertia"].source == str(throwaway.resolve())
    new = tmp_path / "fitted.yaml"
    r = CliRunner().invoke(main, ["fit", str(plant_file), str(record), "--effect", "extra_load_inertia",
                                  "-o", str(new), "--json"])
    assert r.exit_code == 0, r.output
    out, _ = json.JSONDecoder().raw_decode(r.output[r.output.index("{"):])
    assert out["converged"] and out["values"]["effects[0].inertia"] == pytest.approx(4e-3, rel=0.05), out
    assert out["error_after"] < 0.1 * out["error_before"]
    # the fitted plant file still names the module, and loads with the effect in it
    fitted = load_plant(new)
    assert [e.name for e in fitted.effects] == ["extra_load_inertia"]
    assert fitted.effects[0].values["inertia"] == pytest.approx(4e-3, rel=0.05)


def test_a_missing_module_is_a_config_error_naming_the_key_and_the_file(tmp_path):
    plant_file = rig_with(["my_effects/nowhere.py"], tmp_path)
    with pytest.raises(ConfigError) as err:
        load_plant(plant_file)
    text = str(err.value)
    assert "effect_modules[0]" in text and str(tmp_path / "my_effects" / "nowhere.py") in text, text
    assert "does not exist" in text


def test_a_module_that_fails_to_import_names_the_file_and_the_error(tmp_path):
    bad = tmp_path / "broken.py"
    bad.write_text("import math\nraise RuntimeError('no such gear in stock')\n")
    plant_file = rig_with(["broken.py"], tmp_path)
    with pytest.raises(ConfigError) as err:
        load_plant(plant_file)
    text = str(err.value)
    assert "effect_modules[0]" in text and str(bad) in text, text
    assert "RuntimeError: no such gear in stock" in text, text
    assert not any(m.startswith("gearbench_effect_broken") for m in sys.modules)


def test_confounders_given_as_one_string_are_named(tmp_path):
    """``confounders = "bias_torque"`` (a string, not a tuple) would be read letter by letter."""
    bad = tmp_path / "stringy.py"
    bad.write_text("from gearbench.plant.effects.base import Effect, register\n\n"
                   "@register\nclass Stringy(Effect):\n    name = 'stringy'\n    signature = 'a constant'\n"
                   "    confounders = 'bias_torque'\n")
    with pytest.raises(ConfigError) as err:
        load_plant(rig_with(["stringy.py"], tmp_path))
    assert "confounders must be a tuple of effect names" in str(err.value) and str(bad) in str(err.value)


# ------------------------------------------------------------ the example effects

ONLY = ("cogging", "transmission_error", "load_spring", "bias_torque")
TRUTH = {
    "cogging": {"location": "load", "amplitude": 0.3, "periods_per_rev": 9, "phase_deg": 40.0},
    "transmission_error": {"amplitude_deg": 0.015, "teeth": 20, "phase_deg": -60.0},
}

SCRIPT = textwrap.dedent('''
    import json, sys, time
    from pathlib import Path
    from click.testing import CliRunner
    from gearbench.cli import main
    from gearbench.experiment.files import load_plant
    from gearbench.identify.diagnose import diagnose
    from gearbench.identify.replay import Replay
    from gearbench.measure.data import write_measurement
    from gearbench.plant.effects import AddedEffect
    from gearbench.synth import excitation, synthesize

    def record(plant, hidden, seed):  # 3 s of open-loop steps: the user effects show in it
        t, u = excitation("steps", plant, duration_s=3.0, seed=seed)
        noise = {"motor_angle_deg": 0.02, "load_angle_deg": 0.015, "current_A": 0.008}
        return synthesize(plant, hidden, t, u, noise=noise, seed=seed)

    work = Path(sys.argv[1])
    truth, only = json.loads(sys.argv[2]), tuple(json.loads(sys.argv[3]))
    plant_file = work / "rig.yaml"
    plant = load_plant(plant_file)
    out = {}
    for name, values in truth.items():
        t0 = time.perf_counter()
        data = record(plant, [AddedEffect(name, values)], seed=3)
        t1 = time.perf_counter()
        d = diagnose(plant, Replay(data), max_steps=1, only=only)
        out[name] = {"verdict": d.verdict, "reason": d.reason, "noise_floor": d.noise_floor,
                     "baseline_error": d.baseline_error,
                     "step": d.ladder[0].params if d.ladder else None,
                     "options": d.ladder[0].options if d.ladder else None,
                     "error": d.ladder[0].error if d.ladder else None,
                     "tried": [t.candidate.label() for t in d.tried],
                     "synth_s": t1 - t0, "diagnose_s": time.perf_counter() - t1}
        csv = work / f"{name}.csv"
        write_measurement(data, csv)
    # compare: the plant file with the cogging in it replays the cogging record
    r = CliRunner().invoke(main, ["compare", str(work / "rig_cogging.yaml"), str(work / "cogging.csv"),
                                  "--results", str(work / "results"), "--json"])
    out["compare"] = {"exit_code": r.exit_code, "output": r.output}
    # run: a closed-loop experiment on the plant file with the cogging, and on the one without
    runs = {}
    for plant_name in ("rig_cogging.yaml", "rig.yaml"):
        exp = work / f"run_{plant_name}"
        exp.write_text(f"name: run\\nduration_s: 1.0\\nplant: {plant_name}\\nprofiles: [profile1]\\n"
                       "controllers: [{kind: p, kp: 5}]\\nsolver: {rtol: 1.0e-6}\\n")
        r = CliRunner().invoke(main, ["run", str(exp), "--results", str(work / f"out_{plant_name}")])
        runs[plant_name] = {"exit_code": r.exit_code, "output": r.output[-2000:],
                            "csv": (work / f"out_{plant_name}" / "run.csv").read_text()
                            if (work / f"out_{plant_name}" / "run.csv").exists() else ""}
    out["run"] = runs
    print("RESULT " + json.dumps(out))
''')


@pytest.fixture(scope="module")
def examples(tmp_path_factory):
    """Both example effects hidden in a record each, diagnosed, and one compare: one
    subprocess (one compiled model)."""
    work = tmp_path_factory.mktemp("examples")
    modules = [os.path.relpath(EXAMPLES / f, work) for f in ("cogging.py", "transmission_error.py")]
    rig_with(modules, work)
    text = (work / "rig.yaml").read_text()
    assert text.count("\neffects: []\n") == 1  # the rig has no effects of its own
    (work / "rig_cogging.yaml").write_text(text.replace("\neffects: []\n", "\neffects:\n  - {type: cogging, "
                                                        "location: load, amplitude: 0.3, periods_per_rev: 9, "
                                                        "phase_deg: 40}\n"))
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.run([sys.executable, "-c", SCRIPT, str(work), json.dumps(TRUTH), json.dumps(ONLY)],
                          cwd=REPO, env=env, capture_output=True, text=True, timeout=1200)
    assert proc.returncode == 0, proc.stderr[-4000:]
    line = next(s for s in proc.stdout.splitlines() if s.startswith("RESULT "))
    return json.loads(line[len("RESULT "):])


def phase_error_deg(a: float, b: float) -> float:
    """The distance of two phases, deg, modulo a turn."""
    return abs((a - b + 180.0) % 360.0 - 180.0)


@pytest.mark.parametrize("name", sorted(TRUTH))
def test_diagnose_names_the_example_effect_with_its_parameters(examples, name):
    got, truth = examples[name], TRUTH[name]
    # the true effect and at least two others were fitted
    assert len({t.split(" ")[0] for t in got["tried"]}) >= 3 and name in got["tried"][0], got["tried"]
    assert got["verdict"] == name, (got["verdict"], got["reason"], got["tried"])
    params = got["step"]
    for k, v in truth.items():
        if k == "location":
            assert got["options"] == {"location": v}
        elif k == "phase_deg":  # within 10 deg (modulo a turn)
            assert phase_error_deg(params[k], v) <= 10.0, params
        elif k in ("periods_per_rev", "teeth"):  # a count: exactly
            assert params[k] == v, params
        else:
            assert params[k] == pytest.approx(v, rel=0.10), params
    assert got["error"] <= 1.5 * got["noise_floor"], got
    assert got["error"] < got["baseline_error"], got  # it was hidden, and adding it pays


def test_compare_replays_a_record_with_the_user_effect_in_the_plant(examples):
    c = examples["compare"]
    assert c["exit_code"] == 0, c["output"]
    summary, _ = json.JSONDecoder().raw_decode(c["output"][c["output"].index("{"):])
    rows = {r["signal"]: r for r in summary["signals"]}
    assert rows["load_angle_deg"]["ratio_to_noise"] < 1.5, rows


def test_a_process_with_other_effects_reads_the_same_cache(examples):
    """After the examples' model is cached, a fresh process that simulates with the
    built-in effects only (another generated model) runs from the same cache folder."""
    code = ("import numpy as np; from gearbench.experiment.files import load_plant; "
            "from gearbench.control.controllers import Controller; "
            "from gearbench.simulate import Segments, simulate; "
            "r = simulate(load_plant('experiments/plants/bench_rig.yaml'), Controller('p', kp=1.0), "
            "Segments(np.array([0.0]), np.array([0.1]), np.array([0.0])), 0.1); print(r.ok)")
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=600,
                          env={**os.environ, "PYTHONPATH": str(REPO)})
    assert proc.returncode == 0 and proc.stdout.strip() == "True", proc.stderr[-2000:]


def test_run_uses_the_user_effect(examples):
    """`gearbench run` of an experiment whose plant file names the cogging (and its
    module) succeeds, and its IAE differs from the same experiment without it."""
    runs = examples["run"]
    assert all(r["exit_code"] == 0 for r in runs.values()), {k: r["output"] for k, r in runs.items()}
    import io

    import pandas as pd
    iae = {k: pd.read_csv(io.StringIO(r["csv"]))["iae_deg_s"].iloc[0] for k, r in runs.items()}
    assert iae["rig_cogging.yaml"] != pytest.approx(iae["rig.yaml"], rel=1e-6)


def test_a_term_at_an_undeclared_place_is_named(tmp_path):
    """An effect whose compiled() names a place it did not declare gets a ValueError
    naming the effect, the place and its places, when the plant is packed."""
    from gearbench.plant.effects import AddedEffect
    from gearbench.plant.pack import pack_plant
    module = tmp_path / "misplaced.py"
    module.write_text(textwrap.dedent('''
        import numba as nb
        from gearbench.plant.effects import Effect, Param, register

        @nb.njit
        def torque(p, o, theta, w, eps):
            return p[o]

        @register
        class Misplaced(Effect):
            """A constant torque that says load but packs for the motor."""
            name = "misplaced_torque"
            signature = "a constant"
            acts_on = "load torque"
            params = (Param("torque", "N m", -1.0, 1.0, 0.1),)
            term = torque
            places = ("load",)
            slots = ("torque, N m",)

            def compiled(self, values, plant):
                return "motor", (float(values["torque"]),)
    '''))
    from gearbench.plant.effects.user import load
    load(module)
    try:
        plant = load_plant(RIG).with_effects(AddedEffect("misplaced_torque", {"torque": 0.1}))
        with pytest.raises(ValueError, match=r"misplaced_torque.*'motor'.*\('load',\)"):
            pack_plant(plant)
    finally:
        unload(module)
    assert "misplaced_torque" not in REGISTRY
