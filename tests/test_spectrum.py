"""The record's FRF and the two-mass resonance read from it (``gearbench.measure.spectrum``), and
the coupling ``shaft_compliance`` guesses from it for diagnose's scan.

The two-mass records here are made by ``scipy.signal.lsim`` from the equations of motion, not by
gearbench's simulator; the real ones are the FdiTools bench's (``data/twomass``) and the
independent simulator's practice cases (``data/cases``)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from conftest import DATA, REPO
from gearbench.experiment.files import load_plant
from gearbench.measure.data import from_arrays, read_measurement
from gearbench.measure.spectrum import frf, resonance_pair
from gearbench.plant.effects import REGISTRY

FS = 2500.0
J_M, J_L, K, D = 0.005, 0.004, 600.0, 0.05  # kg m^2, N m/rad, N m s/rad


def two_mass_record(k: float = K, seconds: float = 8.0, seed: int = 1):
    """Motor angle (deg) of ``J_M`` driven by a white torque, coupled to ``J_L`` by ``k``, ``D``
    (``k`` None: rigid), with white angle noise; and the true anti-resonance and resonance (Hz)."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * FS)) / FS
    u = rng.normal(0.0, 1.0, t.size)
    if k is None:
        sys = signal.StateSpace([[0, 1], [0, -0.01 / (J_M + J_L)]], [[0], [1 / (J_M + J_L)]], [[1, 0]], [[0]])
        pair = None
    else:
        a = [[0, 1, 0, 0], [-k / J_M, -D / J_M, k / J_M, D / J_M], [0, 0, 0, 1], [k / J_L, D / J_L, -k / J_L, -D / J_L]]
        sys = signal.StateSpace(a, [[0], [1 / J_M], [0], [0]], [[1, 0, 0, 0]], [[0]])
        pair = (math.sqrt(k / J_L) / (2 * math.pi), math.sqrt(k * (J_M + J_L) / (J_M * J_L)) / (2 * math.pi))
    _, y, _ = signal.lsim(sys, u, t)
    y = np.degrees(y) + rng.normal(0.0, 1e-4, t.size)
    return from_arrays(t, "drive_torque_Nm", u, {"motor_angle_deg": y}), pair


def resolution_hz(m) -> float:
    f, *_ = frf(m.input, m.signals["motor_angle_deg"], m.sample_time_s)
    return float(f[1] - f[0])


def test_the_pair_of_a_two_mass_train_is_its_anti_resonance_and_resonance():
    m, truth = two_mass_record()
    got = resonance_pair(*frf(m.input, m.signals["motor_angle_deg"], m.sample_time_s))
    assert got is not None
    assert got == pytest.approx(truth, abs=2 * resolution_hz(m))  # a Hann window's main lobe: 2 bins each side


def test_a_rigid_train_shows_no_pair():
    m, _ = two_mass_record(k=None)
    assert resonance_pair(*frf(m.input, m.signals["motor_angle_deg"], m.sample_time_s)) is None


@pytest.mark.parametrize("name", ["twomass_A.csv", "twomass_B.csv"])
def test_the_fditools_bench_shows_the_sources_pair(name):
    # the source's motor side: anti-resonance 52.4 Hz, resonance 76.6 Hz (read off its figure, +-1 Hz)
    m = read_measurement(DATA / "twomass" / name)
    got = resonance_pair(*frf(m.input, np.radians(m.signals["motor_angle_deg"]), m.sample_time_s))
    assert got == pytest.approx((52.4, 76.6), abs=1.0 + resolution_hz(m))


@pytest.mark.parametrize("case", [f"p{i:02d}" for i in range(1, 14)])
def test_the_practice_cases_rigid_trains_show_none_from_their_drive(case):
    m = read_measurement(DATA / "cases" / case / "data.csv")
    assert resonance_pair(*frf(m.input, np.radians(m.signals["motor_angle_deg"]), m.sample_time_s)) is None
    assert REGISTRY["shaft_compliance"].guesses(load_plant(DATA / "cases" / case / "nominal.yaml"), m) == []


def test_the_guessed_coupling_is_the_trains():
    m, (f_ar, f_r) = two_mass_record()
    bare = load_plant(REPO / "experiments" / "plants" / "twomass_bare.yaml")  # one inertia, torque drive
    relative, absolute = REGISTRY["shaft_compliance"].guesses(bare, m)
    df = resolution_hz(m)
    for g, total in ((relative, bare.motor.inertia + bare.load.inertia), (absolute, None)):
        if total is None:  # the record's own inertia, from the level above the resonance
            total = g["motor.inertia"] + bare.load.inertia
            assert total == pytest.approx(J_M + J_L, rel=0.1)
        j_l = g["pinion_inertia"] + bare.load.inertia
        j_m = total - j_l
        assert math.sqrt(g["stiffness"] / j_l) / (2 * math.pi) == pytest.approx(f_ar, abs=2 * df)
        assert math.sqrt(g["stiffness"] * total / (j_m * j_l)) / (2 * math.pi) == pytest.approx(f_r, abs=2 * df)
    assert absolute["stiffness"] == pytest.approx(K, rel=0.15)
