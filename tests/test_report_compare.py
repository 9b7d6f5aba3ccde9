"""Comparison figures: each is a Figure with the expected panels and saves as a PNG."""
from __future__ import annotations

import numpy as np
import pytest
from matplotlib.figure import Figure

from gearbench.measure.phases import classify_phases
from gearbench.identify.residuals import residual_test
from gearbench.report.compare import comparison_figure, ladder_figure, residual_figure, residual_tests_figure
from gearbench.report.io import save_figure_atomic

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def record():
    """A back-and-forth motion (deg, deg/s) and a model that lacks Coulomb friction."""
    t = np.arange(0.0, 4.0, 2e-3)
    v = 20.0 * np.sin(np.pi * t / 2)
    y = np.concatenate(([0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))))
    simulated = y + 0.3 * np.tanh(v / 0.5)
    return t, y, simulated, v


def saved(fig, path) -> bytes:
    save_figure_atomic(fig, path)
    return path.read_bytes()


def test_comparison_figure(record, tmp_path):
    t, y, simulated, _ = record
    fig = comparison_figure(t, y, simulated, classify_phases(t, y), "load angle", "deg", title="run 1")
    assert isinstance(fig, Figure)
    assert len(fig.axes) == 2
    top, bottom = fig.axes
    assert top.get_title() == "run 1" and "deg" in top.get_ylabel()
    np.testing.assert_allclose(bottom.lines[0].get_ydata(), y - simulated)
    legend = [text.get_text() for text in bottom.get_legend().get_texts()]
    assert "direction reversal" in legend and "steady motion" in legend
    assert saved(fig, tmp_path / "c.png").startswith(PNG_MAGIC)


def test_comparison_without_phases(record, tmp_path):
    t, y, simulated, _ = record
    fig = comparison_figure(t, y, simulated, None, "load angle", "deg")
    assert len(fig.axes) == 2 and fig.axes[1].get_legend() is None
    assert saved(fig, tmp_path / "c.png").startswith(PNG_MAGIC)


def test_comparison_figure_with_inputs_and_reinitialisations(record, tmp_path):
    """The input panel under the signals (voltage left, set point right), and a thin
    vertical line at each re-initialisation on every time panel."""
    t, y, simulated, v = record
    volts = np.sign(v) * 6.0
    fig = comparison_figure(t, y, simulated, classify_phases(t, y), "load angle", "deg", title="a.yaml against b.csv",
                            inputs=[("voltage_V", volts, "V"), ("setpoint_deg", y + 1, "deg")], reinit_s=[1.0, 2.5])
    top, bottom, ax_u, ax_sp = fig.axes
    assert top.get_title() == "a.yaml against b.csv"
    assert ax_u.get_ylabel() == "voltage_V (V)" and ax_sp.get_ylabel() == "setpoint_deg (deg)"
    np.testing.assert_allclose(ax_u.lines[0].get_ydata(), volts)
    np.testing.assert_allclose(ax_sp.lines[0].get_ydata(), y + 1)
    assert ax_u.get_xlabel() == "time (s)" and bottom.get_xlabel() == ""
    for ax in (top, bottom, ax_u):
        vertical = [ln.get_xdata() for ln in ax.lines if len(ln.get_xdata()) == 2]
        marks = [x[0] for x in vertical if x[0] == x[1]]
        assert marks == [1.0, 2.5]
    assert any("re-initialised" in txt.get_text() and "(2)" in txt.get_text() for txt in top.get_legend().get_texts())
    assert saved(fig, tmp_path / "c.png").startswith(PNG_MAGIC)
    with pytest.raises(ValueError, match="at most two input columns"):
        comparison_figure(t, y, simulated, None, "x", "deg", inputs=[("a", y, "V")] * 3)


def test_residual_tests_figure(tmp_path):
    rng = np.random.default_rng(0)
    u = rng.standard_normal(3000)
    tests = {"white": residual_test(rng.standard_normal(3000), u, "white", "voltage_V", lags=10),
             "delayed": residual_test(np.r_[np.zeros(4), u[:-4]], u, "delayed", "voltage_V", lags=10)}
    fig = residual_tests_figure(tests, "residual tests: p.yaml against d.csv")
    assert len(fig.axes) == 4 and fig._suptitle.get_text() == "residual tests: p.yaml against d.csv"
    (acf_w, xc_w), (acf_d, xc_d) = fig.axes[0:2], fig.axes[2:4]
    assert "white" in acf_w.get_title(loc="left") and "independent of voltage_V" in xc_w.get_title(loc="left")
    assert "CORRELATED with voltage_V" in xc_d.get_title(loc="left")
    (band,) = xc_d.patches                               # the shaded 99 % band
    assert (band.get_y(), band.get_y() + band.get_height()) == pytest.approx(
        (-tests["delayed"].cross_band, tests["delayed"].cross_band))
    red = [ln for ln in xc_d.lines if ln.get_color() == "C3"][0]
    assert list(red.get_xdata()) == tests["delayed"].cross_outside_lags and 4 in red.get_xdata()
    assert saved(fig, tmp_path / "rt.png").startswith(PNG_MAGIC)
    with pytest.raises(ValueError, match="at least one signal"):
        residual_tests_figure({})


def test_residual_figure(record, tmp_path):
    t, y, simulated, v = record
    fig = residual_figure(y - simulated, v, y, "load angle", "deg", "deg/s", "deg")
    assert isinstance(fig, Figure)
    assert len(fig.axes) == 3
    assert fig.axes[0].get_xlabel() == "speed (deg/s)"
    assert fig.axes[1].get_xlabel() == "position (deg)"
    ticks = [tick.get_text() for tick in fig.axes[2].get_xticklabels()]
    assert [tick.split("\n")[0] for tick in ticks] == ["negative", "standstill", "positive"]
    assert saved(fig, tmp_path / "r.png").startswith(PNG_MAGIC)


def test_residual_figure_with_one_direction_only(tmp_path):
    v = np.linspace(1.0, 2.0, 50)
    fig = residual_figure(np.zeros(50), v, np.cumsum(v), "x", "mm", "mm/s", "mm")
    assert len(fig.axes) == 3
    assert saved(fig, tmp_path / "r.png").startswith(PNG_MAGIC)


@pytest.mark.parametrize("noise_floor", [None, 0.05])
def test_ladder_figure(tmp_path, noise_floor):
    steps = [{"effect": "baseline", "error": 2.0}, {"effect": "coulomb_friction", "error": 0.4},
             {"effect": "viscous_friction", "error": 0.1}]
    fig = ladder_figure(steps, noise_floor=noise_floor, unit="deg s")
    assert isinstance(fig, Figure)
    assert len(fig.axes) == 1
    ax = fig.axes[0]
    assert ax.get_ylabel() == "error (deg s)"
    assert [p.get_height() for p in ax.patches] == [2.0, 0.4, 0.1]
    assert [tick.get_text() for tick in ax.get_xticklabels()] == ["baseline", "+ coulomb_friction",
                                                                   "+ viscous_friction"]
    assert (ax.get_legend() is not None) == (noise_floor is not None)
    assert saved(fig, tmp_path / "l.png").startswith(PNG_MAGIC)


def test_ladder_needs_a_baseline():
    with pytest.raises(ValueError, match="baseline"):
        ladder_figure([])
