"""Which report an experiment gets is the library's choice (runner.experiment_report);
``gearbench run`` writes what it returns."""
from __future__ import annotations

from pathlib import Path

import matplotlib
import pytest
import yaml
from click.testing import CliRunner

from gearbench.cli import main
from gearbench.experiment.files import experiment_from_dict
from gearbench.report import tables, variants
from gearbench.runner import experiment_report, run_experiment

matplotlib.use("Agg")
REPO = Path(__file__).resolve().parents[1]
EXPERIMENTS = REPO / "experiments"


def short(name: str, tmp_path: Path) -> Path:
    """experiments/<name>.yaml cut to 0.3 s of profile 1 under its first controller."""
    raw = yaml.safe_load((EXPERIMENTS / f"{name}.yaml").read_text())
    raw.update(duration_s=0.3, profiles=["profile1"], controllers=raw["controllers"][:1])
    raw["plant"] = str(EXPERIMENTS / raw["plant"])
    raw.pop("reference", None)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


@pytest.mark.parametrize("name, kind, columns, figures", [
    ("table1", "table1", tables.TABLE1_COLUMNS, []),
    ("table1_translational", "translational", variants.TRANSLATIONAL_COLUMNS, []),
    ("compensators", "compensators", variants.COMPENSATOR_COLUMNS, ["compensators.png", "compensators_traces.png"]),
])
def test_each_experiment_gets_its_report_and_run_writes_it(tmp_path, name, kind, columns, figures):
    path = short(name, tmp_path)
    exp = experiment_from_dict(yaml.safe_load(path.read_text()), base_dir=tmp_path, name=name)
    records = run_experiment(exp, workers=1, keep_traces=False)
    rep = experiment_report(exp, records)
    assert rep.kind == kind and rep.columns == columns and sorted(rep.figures) == figures
    assert len(rep.runs) == len(records) and set(columns) <= set(rep.runs.columns)
    assert rep.title in rep.markdown
    res = CliRunner().invoke(main, ["run", str(path), "--results", str(tmp_path / "r")])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "r" / f"{exp.name}.md").read_text() == rep.markdown
    assert sorted(p.name for p in (tmp_path / "r").glob("*.png")) == figures


def test_compensator_traces_are_solved_again_only_when_the_runs_kept_none(tmp_path, monkeypatch):
    import gearbench.runner as runner
    exp = experiment_from_dict(yaml.safe_load(short("compensators", tmp_path).read_text()),
                               base_dir=tmp_path, name="compensators")
    calls = []
    real = runner.retrace
    monkeypatch.setattr(runner, "retrace", lambda *a, **k: calls.append(1) or real(*a, **k))
    experiment_report(exp, run_experiment(exp, workers=1, keep_traces=False))
    assert calls == [1]
    experiment_report(exp, run_experiment(exp, workers=1, keep_traces=True), traced=True)
    assert calls == [1]
