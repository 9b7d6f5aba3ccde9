"""The HTML reports of ``compare``, ``diagnose`` and ``fit`` on the tutorial (the bench rig with
its hidden spring and friction), opened in a real headless Chromium (Debian's ``chromium``,
driven by Playwright: ``tools/browser.py``): the page loads from its file with no console
error and no request but its own file and its embedded images, every figure decodes, the main
table is there, and the first screen is not blank.

Without ``/usr/bin/chromium`` (or Playwright) the browser tests skip and say why, unless
``GEARBENCH_REQUIRE_BROWSER=1`` (CI's ``.ci/run`` sets it), where they fail.
"""
from __future__ import annotations

import base64
import io
import json
import os
import re

import numpy as np
import pytest
from click.testing import CliRunner

from conftest import REPO
from gearbench.cli import main
from tools.browser import VIEWPORT, available, browser

PLANT = REPO / "experiments" / "plants" / "bench_rig.yaml"
RECORD = REPO / "experiments" / "data" / "bench_rig_hidden.csv"
IMG = re.compile(r'<img src="data:image/png;base64,([A-Za-z0-9+/=]+)"')


def run(*args) -> str:
    r = CliRunner().invoke(main, [str(a) for a in args])
    assert r.exit_code == 0, r.output
    return r.output


@pytest.fixture(scope="module")
def reports(tmp_path_factory) -> dict:
    """The three reports of the tutorial: compare and diagnose written beside their figures (the
    default), fit with --html.  The diagnosis (about 25 s) is made once for the module."""
    out = tmp_path_factory.mktemp("reports")
    run("compare", PLANT, RECORD, "--results", out)
    run("diagnose", PLANT, RECORD, "--results", out, "--workers", "2", "--quiet")
    run("fit", PLANT, RECORD, "--effect", "load_spring", "-o", out / "spring.yaml", "--html", out / "fit.html")
    return {"compare": out / "compare_bench_rig_bench_rig_hidden" / "report.html",
            "diagnose": out / "diagnose_bench_rig_bench_rig_hidden" / "report.html",
            "fit": out / "fit.html"}


MAIN_TABLE = {"compare": "#signals", "diagnose": "#ladder", "fit": "#values"}


# ------------------------------------------------------------ the documents

@pytest.mark.parametrize("kind", list(MAIN_TABLE))
def test_a_report_stands_alone(reports, kind):
    text = reports[kind].read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>") and text.rstrip().endswith("</html>")
    assert MAIN_TABLE[kind].lstrip("#") in re.findall(r'<table id="([^"]+)"', text)
    # nothing outside the file: no script, no external style sheet, font or image
    assert "<script" not in text and "@import" not in text and "url(" not in text
    assert not re.search(r'(src|href)="(?!data:)', text), "a reference to something outside the page"
    images = IMG.findall(text)
    assert len(images) == text.count("<img ") >= 3
    for b64 in images:
        data = base64.b64decode(b64, validate=True)
        assert data.startswith(b"\x89PNG\r\n\x1a\n")


def test_the_diagnosis_report_holds_the_whole_diagnosis(reports):
    text = reports["diagnose"].read_text(encoding="utf-8")
    j = json.loads((reports["diagnose"].parent / "diagnose.json").read_text())
    assert j["verdict"] == "load_spring"
    for needle in ("bench_rig.yaml", "bench_rig_hidden.csv", "Noise floors", "load_spring", "coulomb_friction",
                   "error before", "error after", "standard error", "Correlated estimates", "Residual tests",
                   "Calibration of the plant", "Not tried", "backlash", "the gear already has a clearance",
                   "before (the panel above) and after"):
        assert needle in text, needle
    for step in j["ladder"]:  # every explanation sentence, escaped as HTML escapes it
        assert step["explanation"].replace("'", "&#x27;").replace("<", "&lt;").replace(">", "&gt;") in text
    assert ("Timing" in text) == ("timing" in j)


def test_timing_is_a_table_when_the_diagnosis_has_it():
    from gearbench.report.html import timing_block
    timing = {"wall_s": 21.5, "stages": [{"stage": "candidates", "wall_s": 12.25, "replays": 840,
                                          "solver_steps": 123456, "fits": 30}],
              "candidates": [{"effect": "load_spring", "wall_s": 1.5, "replays": 40, "fits": 1}]}
    block = timing_block(timing)
    assert '<table id="timing">' in block and "candidates" in block and "123456" in block and "12.2" in block
    assert "load_spring" in block and timing_block(None) == "" and timing_block({}) == ""


def test_the_fit_report_says_before_and_after(reports):
    text = reports["fit"].read_text(encoding="utf-8")
    for needle in ("load_spring", "effects[0].stiffness", "standard error", "Correlations of the estimates",
                   "Before the fit", "The fitted model against the record", "spring.yaml"):
        assert needle in text, needle


def test_html_option_and_default_place(reports, tmp_path):
    assert (reports["fit"].parent / "spring.yaml").is_file() and not (reports["fit"].parent / "spring.html").exists()
    run("fit", PLANT, RECORD, "--effect", "coulomb_friction location=load", "-o", tmp_path / "f.yaml")
    assert (tmp_path / "f.html").read_text(encoding="utf-8").startswith("<!DOCTYPE html>")


# --------------------------------------------------------------- the browser

@pytest.fixture(scope="module")
def chromium():
    why = available()
    if why:
        if os.environ.get("GEARBENCH_REQUIRE_BROWSER") == "1":
            pytest.fail(f"GEARBENCH_REQUIRE_BROWSER=1 but {why}")
        pytest.skip(why)
    with browser() as b:
        yield b


def _pixels(png: bytes) -> np.ndarray:
    from matplotlib.image import imread
    return imread(io.BytesIO(png), format="png")


@pytest.mark.parametrize("kind", list(MAIN_TABLE))
def test_the_report_opens_in_chromium(chromium, reports, kind):
    page = chromium.new_page(viewport=VIEWPORT)
    errors, failed, requests = [], [], []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("requestfailed", lambda r: failed.append(r.url[:80]))
    page.on("request", lambda r: requests.append(r.url))
    try:
        page.goto(reports[kind].as_uri(), wait_until="load")
        page.wait_for_load_state("networkidle")
        assert not errors, f"console errors: {errors}"
        assert not failed, f"failed requests: {failed}"
        outside = [u[:80] for u in requests if not u.startswith(("file:", "data:"))]
        assert not outside, f"requests outside the file: {outside}"
        images = page.eval_on_selector_all(
            "img", "els => els.map(e => [e.complete, e.naturalWidth, e.naturalHeight])")
        assert len(images) >= 3
        assert all(done and w > 0 and h > 0 for done, w, h in images), images
        assert page.locator(f"table{MAIN_TABLE[kind]} tbody tr").count() >= 1
        assert page.locator("h1").inner_text().startswith(kind)
        shot = _pixels(page.screenshot())
        assert shot.shape[:2] == (VIEWPORT["height"], VIEWPORT["width"])
        assert float(shot[..., :3].var()) > 0, "the first screen is blank"
    finally:
        page.close()
