"""Figures drawn from traces show what the runs did: the compensator traces figure gets
real traces when the experiment was solved for its scores only, and the Dubowsky pair's
torque panel shows every impact the solver counts."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gearbench import layout as L
from gearbench.experiment.files import load_experiment
from gearbench.report.variants import compensator_trace_figure, trace_cell
from gearbench.runner import retrace, run_experiment
from gearbench.validation import dubowsky_pair, dubowsky_trace

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def mini(tmp_path_factory):
    path = tmp_path_factory.mktemp("exp") / "mini_comp.yaml"
    path.write_text(f"""
name: mini_comp
plant: {REPO / 'experiments/plants/thesis_gear.yaml'}
duration_s: 2.5
profiles: [profile1]
controllers: [{{kind: p, kp: 50}}]
compensator: [thesis_shift, damped_feedforward]
""")
    exp = load_experiment(path)
    return exp, run_experiment(exp, workers=1, keep_traces=False)


def test_scores_only_runs_cannot_be_drawn_silently(mini):
    exp, records = mini
    assert all(len(r.result.time_s) == 2 for r in records)       # what keep_traces=False keeps
    with pytest.raises(ValueError, match="carry no trace"):
        compensator_trace_figure(records, exp.plant)


def test_retrace_gives_the_same_scores_with_the_trace(mini):
    exp, records = mini
    _, shown = trace_cell(records)
    traced = retrace(exp, shown)
    for before, after in zip(shown, traced):
        assert after.label == before.label
        assert after.result.scores() == before.result.scores()    # same steps: the grid is interpolated
        t = after.result.time_s
        assert len(t) == round(exp.duration_s / exp.solver.output_dt_s) + 1
        # the trace moves: the output follows profile 1's steps and ramps
        assert np.ptp(np.degrees(after.result.outputs[:, L.O_LOAD])) > 10.0
    fig, cell = compensator_trace_figure(traced, exp.plant)
    assert cell == ("profile1", "p", 50)
    volts = fig.axes[1].lines[0].get_ydata()
    assert len(volts) == len(traced[0].result.time_s) and np.ptp(volts) > 1.0
    assert "sampled every 1 ms" in fig._suptitle.get_text()


def test_run_draws_traces_of_the_shown_cell(tmp_path, monkeypatch):
    """`gearbench run` on a compensator experiment without --plot/--traces: the
    traces figure is drawn from retraced runs (its voltage lines have every sample)."""
    from click.testing import CliRunner

    from gearbench.cli import main
    from gearbench.report import variants
    exp = tmp_path / "mini_comp.yaml"
    exp.write_text(f"""
name: mini_comp
plant: {REPO / 'experiments/plants/thesis_gear.yaml'}
duration_s: 1.0
profiles: [profile1]
controllers: [{{kind: p, kp: 50}}]
compensator: [thesis_shift, damped_feedforward]
""")
    drawn = []
    real = variants.compensator_trace_figure

    def spy(records, plant, title=""):
        drawn.append([len(r.result.time_s) for r in records])
        return real(records, plant, title)
    monkeypatch.setattr(variants, "compensator_trace_figure", spy)
    res = CliRunner().invoke(main, ["run", str(exp), "--results", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    assert drawn == [[1001, 1001]]
    assert (tmp_path / "out" / "mini_comp_traces.png").stat().st_size > 20_000


def test_dubowsky_torque_panel_shows_every_impact(tmp_path):
    tr = dubowsky_trace()
    run = tr["run"]
    torque = run.outputs[:, L.O_TORQUE]
    assert tr["impacts"] == tr["impacts_traced_run"] == 8
    assert len(tr["onsets"]) == tr["impacts"]                    # every counted contact is in the trace
    assert tr["visible_on_grid"] < tr["impacts"]                 # the cause: 20 us grid, 4.6 us contacts
    durations = run.time_s[tr["ends"]] - run.time_s[tr["onsets"]]
    assert np.all(np.abs(durations - tr["contact_s"]) < 0.5e-6)
    assert np.all(np.abs(torque[tr["peaks"]]) > 5.0)             # N m: each peak drawn, not a sample beside it
    (c,) = dubowsky_pair(tmp_path)
    assert c["passed"] and c["measured"] == 8 and "8 contacts in the traced torque" in c["note"]
    assert (tmp_path / "validation" / "dubowsky_pair.png").stat().st_size > 20_000
