"""Routh-Hurwitz on the engaged loop: exact polynomials, stable gain intervals, and the
eigenvalues of the closed-loop matrix agreeing with them."""
from __future__ import annotations

import json
import math
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from gearbench.cli import main
from gearbench.control import polynomials as poly
from gearbench.control.stability import (DEG_PER_RAD, CharPoly, analyse, characteristic_polynomial,
                                         closed_loop, eigen_scan, hurwitz_determinants,
                                         linear_stable, rhp_roots_routh, rigid_p_bound,
                                         stable_intervals)
from gearbench.experiment.files import load_plant

REPO = Path(__file__).resolve().parents[1]
PLANT_FILE = REPO / "experiments" / "plants" / "thesis_gear.yaml"


@pytest.fixture(scope="module")
def plant():
    return load_plant(PLANT_FILE)


def fr(*xs):
    return [Fraction(x) for x in xs]


def test_polynomial_tools():
    p = fr(1, -1003, 3002, -2000)                      # (x-1)(x-2)(x-1000)
    assert poly.positive_roots(p) == pytest.approx([1, 2, 1000], rel=1e-12)
    assert poly.positive_roots(fr(1, 0, 1)) == []      # x^2 + 1
    assert poly.positive_roots(fr(1, -2, 1, 0)) == pytest.approx([1])  # x (x-1)^2
    a = [[Fraction(2), Fraction(1)], [Fraction(1), Fraction(3)]]
    assert poly.charpoly(a) == fr(1, -5, 5)
    assert poly.determinant(a) == 5
    assert poly.interpolate(fr(0, 1, 2), fr(1, 2, 5)) == fr(1, 0, 1)


def test_textbook_third_order_loop():
    # G = 1/(s (s+1)(s+2)):  s^3 + 3 s^2 + 2 s + K, stable for 0 < K < 6 (V/rad here)
    cp = CharPoly(den=fr(1, 3, 2, 0), num=fr(1))
    (iv,) = stable_intervals(cp)
    assert iv.low == 0 and iv.high * DEG_PER_RAD == pytest.approx(6.0, rel=1e-12)
    assert rhp_roots_routh(cp.coefficients(Fraction(5))) == 0
    assert rhp_roots_routh(cp.coefficients(Fraction(7))) == 2
    assert rhp_roots_routh(cp.coefficients(Fraction(6))) is None   # on the imaginary axis


def test_a_lower_gain_bound_needs_an_unstable_open_loop():
    # (s-1)(s+1) closed by K (s+2): s^2 + K s + (2K - 1): stable only for K > 1/2
    cp = CharPoly(den=fr(1, 0, -1), num=fr(1, 2))
    (iv,) = stable_intervals(cp)
    assert iv.low * DEG_PER_RAD == pytest.approx(0.5, rel=1e-12) and iv.high is None
    assert iv.low_by == "Delta_2"


@pytest.mark.parametrize("kind, ki, kd", [("p", 0.0, 0.0), ("pi", 0.005, 0.0), ("pi", 50.0, 0.0),
                                          ("pid", 0.005, 0.001)])
def test_routh_hurwitz_interval_equals_the_eigenvalue_scan(plant, kind, ki, kd):
    rep = analyse(plant, kind, ki=ki, kd=kd)
    assert len(rep.intervals) == 1
    iv = rep.intervals[0]
    assert iv.low == 0.0 and iv.high is not None
    # 200 gains over 1e-3 ... 1e6 V/deg: eigenvalues and Hurwitz give the same verdict
    assert rep.scan_agrees == 200
    # and either side of the upper end, within 1e-6 of it
    loop = closed_loop(plant, kind, ki, kd)
    below, above = eigen_scan(loop, [iv.high * (1 - 1e-6), iv.high * (1 + 1e-6)])
    assert below < 0 < above
    for c in rep.checks:
        assert c["rhp_roots_routh"] == c["rhp_roots_eig"]


def test_characteristic_polynomial_matches_the_eigenvalues(plant):
    loop = closed_loop(plant, "pid", 0.005, 0.001)
    cp = characteristic_polynomial(loop)
    k = 50 * DEG_PER_RAD
    coeffs = np.array([float(c) for c in cp.coefficients(Fraction(k))])
    lam = np.linalg.eigvals(loop.matrix(k))
    assert len(coeffs) == len(lam) + 1 == 8
    assert np.allclose(np.polyval(coeffs, lam) / np.polyval(np.abs(coeffs), np.abs(lam)), 0, atol=1e-9)
    assert len(hurwitz_determinants(cp)) == 7


def test_thesis_plant_p_range_and_the_rigid_gear_bound(plant):
    rep = analyse(plant, "p")
    high = rep.intervals[0].high
    assert 1000 < high < 2000                      # 500 stable, 5000 not (thesis's scan values)
    assert rigid_p_bound(plant) == pytest.approx(high, rel=1e-2)   # the mesh hardly matters
    assert linear_stable(plant, "p", 500) and not linear_stable(plant, "p", 5000)
    assert linear_stable(plant, "p", 0.5) and linear_stable(plant, "p", 1e-3)  # no lower bound


def test_teeth_apart_loop_has_the_motor_alone_bound(plant):
    # inside the clearance the motor is a rigid rotor: the cubic's bound with J = Jm, b = bm
    m, n = plant.motor, plant.gear.ratio
    el, r, kt, ke, j, b = (m.inductance, m.resistance, m.torque_constant, m.back_emf_constant,
                           m.inertia, m.damping)
    closed_form = n * (el * b + r * j) * (r * b + kt * ke) / (el * j * kt) / DEG_PER_RAD
    rep = analyse(plant, "p")
    (iv,) = rep.free_intervals
    assert iv.low == 0 and iv.high == pytest.approx(closed_form, rel=1e-9)
    assert iv.high < rep.intervals[0].high / 10      # the load's damping is gone
    assert rep.free_scan_agrees == 200
    assert closed_loop(plant, "pi", 0.005, contact=False).states == ("i", "theta_m", "w_m", "z")


def test_stability_cli_json_and_markdown(tmp_path):
    md = tmp_path / "notes.md"
    md.write_text("# Notes\n")
    res = CliRunner().invoke(main, ["stability", str(PLANT_FILE), "--controller", "p", "--json",
                                    "--markdown", str(md)])
    assert res.exit_code == 0, res.output
    data = json.loads(res.output)
    (iv,) = data["stable_kp_v_per_deg"]
    assert iv["low"] == 0 and 1000 < iv["high"] < 2000 and iv["high_by"].startswith("Delta_")
    assert data["eigen_scan"]["agree"] == 200
    assert 50 < data["teeth_apart_stable_kp_v_per_deg"][0]["high"] < 200
    text = md.read_text()
    assert text.startswith("# Notes") and "gearbench:stability p begin" in text
    assert f"0 < Kp < {iv['high']:.6g} V/deg" in text
    res = CliRunner().invoke(main, ["stability", str(PLANT_FILE), "--controller", "pi"])
    assert res.exit_code == 0 and "stable (Routh-Hurwitz)" in res.output
    assert math.isfinite(iv["high"])
