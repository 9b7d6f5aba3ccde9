"""Exact steps of an affine model (``solver/exponential.py``, method ``rodas4-exp``), tested as
physics: the step's matrices against scipy's matrix exponential, a held input through a linear
plant against its exact discretisation, energy kept where nothing dissipates, and a record full
of events (stick-slip, a clearance) against RODAS at a far tighter tolerance."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.linalg import expm

import gearbench.layout as L
from conftest import DATA
from gearbench.api import _replay
from gearbench.plant.effects import AddedEffect
from gearbench.plant.pack import pack_plant, tolerance_scales
from gearbench.simulate import Segments, SolverOptions, simulate_packed
from gearbench.solver.exponential import phi
from test_stick_slip import body, friction, geartrain, simulate


def _blocks(A, h):
    """``h phi1(hA)``, ``h^2 phi2(hA)`` from scipy's exponential of ``[[A, I, 0], [0, 0, I], [0, 0, 0]] h``."""
    n = len(A)
    M = np.zeros((3 * n, 3 * n))
    M[:n, :n] = A
    M[:n, n:2 * n] = M[n:2 * n, 2 * n:] = np.eye(n)
    E = expm(M * h)
    return E[:n, n:2 * n], E[:n, 2 * n:]


def _mesh_like():
    """A motor and a load through a stiff, lightly damped mesh (2.4 kHz, damping ratio 0.08), an
    inductive winding (0.25 ms) and an angle nothing reads back (a zero column)."""
    J1, J2, k, c, R, L_, kt = 6e-6 * 18 ** 2, 1.2e-3, 2.64e5, 2.8, 1.1, 2.8e-4, 0.043 * 18
    A = np.zeros((6, 6))  # theta_1, w_1, theta_2, w_2, i, an unread angle
    A[0, 1] = A[2, 3] = 1.0
    A[1, 0], A[1, 1], A[1, 2], A[1, 3], A[1, 4] = -k / J1, -c / J1, k / J1, c / J1, kt / J1
    A[3, 0], A[3, 1], A[3, 2], A[3, 3] = k / J2, c / J2, -k / J2, -c / J2
    A[4, 1], A[4, 4] = -kt / L_, -R / L_
    A[5, 3] = 1.0
    return A


@pytest.mark.parametrize("name", ["random", "mesh"])
def test_the_steps_matrices_are_scipys_exponential(name):
    """``phi`` (series and doublings) gives ``P1``, ``P2`` at h and h/2 as scipy's Pade exponential of the
    augmented matrix does, for a well-scaled matrix and for a stiff one (norm 1e10 s^-1 at a 1 ms step:
    33 doublings)."""
    rng = np.random.default_rng(7)
    A = rng.normal(size=(5, 5)) * 300.0 - 400.0 * np.eye(5) if name == "random" else _mesh_like()
    n, h = len(A), 1e-3
    P, T = np.empty((4, n, n)), np.empty((4, n, n))
    phi(A, h, P, T, n)
    for got, want in ((P[0], _blocks(A, h)[0]), (P[1], _blocks(A, h)[1]),
                      (P[2], _blocks(A, h / 2)[0]), (P[3], _blocks(A, h / 2)[1])):
        assert np.max(np.abs(got - want)) <= 1e-9 * np.max(np.abs(want))


def test_a_held_input_through_a_linear_plant_is_its_exact_discretisation():
    """A body on a spring and a viscous damper (J = 1, k = 50 N m/rad, c = 0.3 N m s/rad) driven by a
    torque held for each 1 ms sample: its samples are ``x[k+1] = Ad x[k] + Bd u[k]`` with Ad, Bd
    the zero-order hold's (scipy's exponential), to round-off, at any tolerance; RODAS at the
    same loose tolerance, its steps at most the sample time, by its truncation error (1.2e-11 of the
    motion, 750x as far, measured 2026-12-07)."""
    plant = body(AddedEffect("load_spring", {"stiffness": 50.0, "rest_angle_deg": 0.0}),
                 AddedEffect("viscous_friction", {"location": "load", "coefficient": 0.3}))
    rng = np.random.default_rng(3)
    t = np.arange(2000) * 1e-3
    u = rng.uniform(-1.0, 1.0, t.size)
    A = np.array([[0.0, 1.0], [-50.0, -0.3]])
    M = np.zeros((3, 3))
    M[:2, :2], M[1, 2] = A, 1.0
    E = expm(M * 1e-3)
    Ad, Bd = E[:2, :2], E[:2, 2]
    x, want = np.zeros(2), []
    for uk in u:
        want.append(x.copy())
        x = Ad @ x + Bd * uk
    want = np.array(want)
    errors = {}
    for method in ("rodas4-exp", "rodas4"):
        _, out, run = simulate(plant, t, u, t_end=2.0, rtol=1e-3, method=method)
        got = out[:t.size, [L.O_LOAD, L.O_WL]]
        errors[method] = float(np.max(np.abs(got - want) / np.max(np.abs(want), axis=0)))
    assert errors["rodas4-exp"] < 1e-11, errors
    assert errors["rodas4"] > 100 * errors["rodas4-exp"], errors


def test_nothing_dissipates_and_no_energy_is_lost():
    """An undamped body on a spring (7.07 rad/s), set spinning and left for 20 s, 22 periods, in exact
    steps: its energy stays within 1e-12 of itself (3.2e-14, measured 2026-12-07), where L-stable RODAS
    at the same tolerance and step loses some (5.8e-12)."""
    plant = body(AddedEffect("load_spring", {"stiffness": 50.0, "rest_angle_deg": 0.0}))
    x0 = np.zeros(L.N_STATE)
    x0[L.X_WM] = x0[L.X_WL] = 10.0
    drift = {}
    for method in ("rodas4-exp", "rodas4"):
        _, out, _ = simulate(plant, [0.0], [0.0], t_end=20.0, x0=x0, rtol=1e-6, method=method)
        energy = 0.5 * out[:, L.O_WL] ** 2 + 0.5 * 50.0 * out[:, L.O_LOAD] ** 2
        drift[method] = float(np.max(np.abs(energy / energy[0] - 1.0)))
    assert drift["rodas4-exp"] < 1e-12, drift
    assert drift["rodas4"] > 10 * drift["rodas4-exp"], drift


def _sampled_voltage():
    """``test_stick_slip``'s sampled, sloped voltage (V; N m on a torque-driven body): 1,500 samples
    of 1 ms, each with its slope to the next (V/s)."""
    t = np.arange(1500) * 1e-3
    v = 4.0 * np.sin(2 * np.pi * 1.3 * t) + 2.0 * np.sin(2 * np.pi * 4.1 * t + 1.0)
    return t, v, np.append(np.diff(v) / 1e-3, 0.0)


def _against_rodas(plant, t, v, slope, share: float) -> np.ndarray:
    """1.5 s of ``plant`` under the sampled input ``v`` (``slope`` per s on each sample) by
    ``rodas4-exp`` and ``rodas4`` at rtol 1e-6 and by ``rodas4`` at 1e-11: the exact steps' angles are
    as close to the last as RODAS's at the same rtol (within 2x), with its events, in less than
    ``share`` of RODAS's right-hand sides.  Returns the reference's motor and load angles (rad)."""
    runs = {}
    for method, rtol in (("rodas4", 1e-11), ("rodas4", 1e-6), ("rodas4-exp", 1e-6)):
        _, out, run = simulate(plant, t, v, slope, t_end=1.5, rtol=rtol, method=method)
        runs[method, rtol] = out[:, [L.O_MOTOR, L.O_LOAD]], run.stats
    ref = runs["rodas4", 1e-11][0]
    err = {key: float(np.max(np.abs(runs[key][0] - ref))) for key in (("rodas4", 1e-6), ("rodas4-exp", 1e-6))}
    assert err["rodas4-exp", 1e-6] < 2.0 * err["rodas4", 1e-6], err
    events = {key: int(stats[L.S_EVENTS]) for key, (_, stats) in runs.items()}
    assert events["rodas4-exp", 1e-6] == events["rodas4", 1e-11] > 10, events
    fevals = {key: int(stats[L.S_FEVALS]) for key, (_, stats) in runs.items()}
    assert fevals["rodas4-exp", 1e-6] < share * fevals["rodas4", 1e-6], fevals
    return ref


def test_events_are_located_as_the_rosenbrock_steps_locate_them():
    """The sampled, sloped voltage of ``test_stick_slip``'s Dormand-Prince test (1,500 segments)
    through a train with Coulomb friction at the load and a 4 deg clearance: with exact steps between
    the events, the angles at rtol 1e-6 are as close to RODAS at 1e-11 as RODAS at 1e-6 is (4.6e-6
    rad then; 4.61e-6 with exact steps), with as many events (52), in under half the right-hand sides
    (8,230 for 27,717; measured 2026-12-07)."""
    plant = geartrain(friction("coulomb_friction", location="load", torque=0.05))
    t, v, slope = _sampled_voltage()
    _against_rodas(plant, t, v, slope, 0.5)


def test_a_model_that_is_not_affine_takes_no_exact_step():
    """Regularized Stribeck friction (tanh of the speed) is affine in no mode: the method is RODAS's,
    step for step."""
    eff = friction("stribeck_friction", model="regularized", location="load", static_torque=3.0,
                   coulomb_torque=2.0, stribeck_speed=0.5)
    plant = body(AddedEffect("load_spring", {"stiffness": 50.0, "rest_angle_deg": 0.0}), eff)
    x0 = np.zeros(L.N_STATE)
    x0[L.X_WM] = x0[L.X_WL] = 10.0
    a = simulate(plant, [0.0], [0.0], t_end=3.0, x0=x0, rtol=1e-6, method="rodas4")
    b = simulate(plant, [0.0], [0.0], t_end=3.0, x0=x0, rtol=1e-6, method="rodas4-exp")
    assert np.array_equal(a[1], b[1]) and np.array_equal(a[2].stats, b[2].stats)
    assert math.isfinite(a[1][-1, L.O_LOAD])


def _stribeck(one_body: bool):
    """Stick-slip Stribeck friction at the load with a spring: on ``test_stick_slip``'s train
    (breakaway 0.08 N m, sliding 0.05, 0.5 rad/s; 0.5 N m/rad), or on its one rigid body driven by a
    torque, where the load's friction acts on the rotor's body (3 and 2 N m, 50 N m/rad)."""
    if one_body:
        eff = friction("stribeck_friction", location="load", static_torque=3.0, coulomb_torque=2.0,
                       stribeck_speed=0.5)
        return body(eff, AddedEffect("load_spring", {"stiffness": 50.0, "rest_angle_deg": 0.0}))
    eff = friction("stribeck_friction", location="load", static_torque=0.08, coulomb_torque=0.05,
                   stribeck_speed=0.5)
    return geartrain(eff, AddedEffect("load_spring", {"stiffness": 0.5, "rest_angle_deg": 0.0}))


@pytest.mark.parametrize("one_body", [False, True], ids=["train", "one body"])
def test_stribeck_friction_takes_again_only_its_speeds_column(one_body):
    """Stick-slip Stribeck friction curves with its body's speed alone (``layout.P_CURVED_L``): while
    the body slips the solver takes again only that column of a Jacobian it keeps, and the run is the
    one the whole Jacobian taken at every step gives (the packed flag cleared), event for event, to
    1e-7 rad of the angles, for fewer right-hand sides (the train, rtol 1e-8: 41 events, 66,363
    right-hand sides for 93,694, both 1.93e-8 rad from RODAS at 1e-11; measured 2026-12-07; the one
    body reads two states, so it saves less: 16,046 for 16,271).  The input is
    ``test_events_are_located_...``'s sampled voltage (a torque in N m on the body)."""
    plant = _stribeck(one_body)
    t, v, slope = _sampled_voltage()
    p = pack_plant(plant)
    assert p[L.P_CURVED_L] == 1.0 and p[L.P_PWL] == 0.0 and p[L.P_CURVED_M] == 0.0
    whole = pack_plant(plant)
    whole[L.P_CURVED_L] = 0.0
    runs = {}
    for name, packed in (("columns", p), ("whole", whole)):
        packed[L.P_CTRL] = L.CTRL_OPEN
        opts = SolverOptions(rtol=1e-8, max_step_s=1e-3, output_dt_s=1e-3, method="rodas4")
        r = simulate_packed(packed, tolerance_scales(plant), Segments(t, v, slope), 1.5, np.zeros(L.N_STATE), opts)
        assert r.ok, r.status
        runs[name] = r
    a, b = runs["columns"], runs["whole"]
    assert a.stats[L.S_EVENTS] == b.stats[L.S_EVENTS] > 5
    angles = [L.O_MOTOR, L.O_LOAD]
    assert np.max(np.abs(a.outputs[:, angles] - b.outputs[:, angles])) < 1e-7
    assert a.stats[L.S_FEVALS] < (1.0 if one_body else 0.8) * b.stats[L.S_FEVALS], (a.stats[L.S_FEVALS],
                                                                                 b.stats[L.S_FEVALS])


def test_a_stuck_stribeck_body_takes_exact_steps():
    """While the load is stuck the train is affine, so with ``rodas4-exp`` its steps there are exact.
    Voltage pulses with rests (3 V for 0.15 s in each half second, the sign flipping each second)
    through Stribeck friction at the load, no spring: the load stands still on 18 % of the samples.
    The angles at rtol 1e-6 are as close to RODAS at 1e-11 as RODAS's at 1e-6 (3.17e-6 rad for
    3.14e-6), with the same 41 events, in fewer right-hand sides (15,347 for 24,054; measured
    2026-12-07)."""
    eff = friction("stribeck_friction", location="load", static_torque=0.08, coulomb_torque=0.05,
                   stribeck_speed=0.5)
    plant = geartrain(eff)
    t = np.arange(1500) * 1e-3
    v = np.where((t % 0.5) < 0.15, 3.0, 0.0) * np.where((t % 1.0) < 0.5, 1.0, -1.0)
    ref = _against_rodas(plant, t, v, np.zeros(len(t)), 0.8)
    assert np.mean(np.diff(ref[:, 1]) == 0.0) > 0.1  # stuck for a tenth of the record at least


def test_a_window_whose_last_sample_is_a_round_off_short_of_its_end():
    """Practice record p04 (independent simulator) with its plant's clearance 0.1 % wider, as
    diagnose's calibration plan replays it: a step from one sample to the next ended 3e-14 s short
    of a window's end, where a contact guard stood at zero, and the sliver left over switched the
    contact back and forth until the run stopped (2026-12-07).  A sample a round-off short of a
    segment's end is now its end; the replay finishes with as many events as RODAS's, give or take
    its contacts' chatter."""
    case = DATA / "cases" / "p04"
    plant, _, replay = _replay(str(case / "nominal.yaml"), case / "data.csv", None, 1.0, 1e-6, "test")
    plant = replace(plant, gear=replace(plant.gear, backlash_deg=1.5015))
    runs = {m: replace(replay, options=replace(replay.options, method=m)).run(plant) for m in ("rodas4", "rodas4-exp")}
    assert replay.options.method == "rodas4-exp"
    assert runs["rodas4-exp"].steps < 0.6 * runs["rodas4"].steps
    assert abs(runs["rodas4-exp"].events - runs["rodas4"].events) <= 0.05 * runs["rodas4"].events
