"""What a notebook shows for a result (``_repr_html_``): one table and one small figure, the
figure an embedded PNG that decodes, for a simulation, a comparison, a diagnosis and a fit."""
from __future__ import annotations

import base64
import io
import re

import pandas as pd
import pytest

import gearbench as gb
from conftest import REPO

RIG = REPO / "experiments" / "plants" / "bench_rig.yaml"
HIDDEN = REPO / "experiments" / "data" / "bench_rig_hidden.csv"
IMG = re.compile(r'<img src="data:image/png;base64,([A-Za-z0-9+/=]+)"')


@pytest.fixture(scope="module")
def first_3s():
    return pd.read_csv(HIDDEN).iloc[:3000]


def check_card(html: str, table_id: str, needles=()) -> None:
    """One table (``table_id``), one decodable PNG, no document around it, and the ``needles``."""
    from matplotlib.image import imread
    assert html.startswith('<div class="card">') and "<html" not in html and "<script" not in html
    assert html.count("<table") == 1 and f'<table id="{table_id}">' in html
    (b64,) = IMG.findall(html)
    pixels = imread(io.BytesIO(base64.b64decode(b64, validate=True)), format="png")
    h, w = pixels.shape[:2]
    assert 100 < w <= 700 and 100 < h <= 700, "a small figure"
    assert float(pixels[..., :3].var()) > 0
    assert len(html) < 150_000
    for n in needles:
        assert n in html, n


def test_a_simulation_shows_its_scores_and_a_plot():
    run = gb.simulate(REPO / "experiments/plants/thesis_gear.yaml", {"kind": "p", "kp": 50}, "profile1",
                      duration_s=2.0)
    check_card(run._repr_html_(), "simulation", ["thesis_gear", "iae_deg_s", "deg s", "profile1"])


def test_a_comparison_shows_its_signals_and_the_primary(first_3s):
    c = gb.compare(RIG, first_3s)
    check_card(c._repr_html_(), "signals", ["load_angle_deg", "current_A", "noise floor", "open loop"])


def test_a_diagnosis_shows_its_ladder(first_3s):
    d = gb.diagnose(RIG, first_3s, only=("coulomb_friction",), max_steps=1)
    check_card(d._repr_html_(), "ladder", ["verdict <b>coulomb_friction</b>", "error before", "torque ="])
    # one rung of two hidden effects ends above the noise: the diagnosis holds the torque it misses
    assert d.diagnosis.missing is not None
    d.replay = None  # a report without its record: its tables, the ladder figure and the missing torque's
    text = d.to_html()
    assert '<table id="ladder">' in text and "Residual tests" in text
    assert text.count("<img ") == 2 and "The torque the model misses" in text


def test_a_fit_shows_its_values(first_3s):
    f = gb.fit(RIG, first_3s, "coulomb_friction", options={"location": "load"})
    check_card(f._repr_html_(), "values", ["effects[0].torque", "standard error", "N m"])


def test_a_result_writes_its_page(first_3s, tmp_path):
    c = gb.compare(RIG, first_3s)
    text = c.to_html(tmp_path / "c.html")
    assert (tmp_path / "c.html").read_text(encoding="utf-8") == text
    assert text.startswith("<!DOCTYPE html>") and '<table id="signals">' in text and len(IMG.findall(text)) >= 3
    assert "bench_rig.yaml" in text and "&lt;DataFrame&gt;" in text
