"""Effects with a state of their own, tested as physics: LuGre friction (presliding) and a winding
that warms up.

LuGre against an independent solver (scipy's Radau on the same equations), its steady sliding
against Stribeck's curve, its hold below breakaway as the bristles' spring, its breakaway at the
static level and its convergence to the event-driven stick-slip law as the bristles stiffen.  The
winding against scipy and against its analytic steady state on a stalled rotor.  A state runs on
through a replay's window seams.  Both fitted on records with AR(1) noise (the fit assumes white
noise), the truth within four standard errors.  A user's effect file with a state, against its
analytic answer.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import gearbench.layout as L
from conftest import REPO
from gearbench import api as gb
from gearbench.experiment.files import load_plant
from gearbench.identify.replay import Replay
from gearbench.plant.effects import REGISTRY, AddedEffect
from gearbench.plant.effects.codegen import n_state
from gearbench.plant.pack import rest_state
from gearbench.synth import excitation, synthesize
from test_stick_slip import body, friction, geartrain, simulate

RIG = REPO / "experiments" / "plants" / "bench_rig.yaml"
J = 1e-2        # kg m^2, the body's inertia
TC, TS, WS = 1.0, 1.5, 0.1  # N m, N m, rad/s


def lugre(s0=1e4, **more) -> AddedEffect:
    """LuGre friction at the body (the load of a rigid train), damped at half critical."""
    return AddedEffect("lugre_friction", {"location": "load", "coulomb_torque": TC, "static_torque": TS,
                                          "stribeck_speed": WS, "bristle_stiffness": s0,
                                          "bristle_damping": math.sqrt(s0 * J), **more})


def run(plant, t, v, s=None, t_end=1.0, rtol=1e-8):
    return simulate(plant, t, v, s, t_end=t_end, x0=rest_state(plant), rtol=rtol)


def bristles(result) -> float:
    """The load's bristle deflection at the end of a run, rad."""
    x = result.meta["x_end"]
    assert len(x) == n_state()
    return float(x[L.N_STATE + 1])  # the blocks: lugre at the motor, then at the load


def g(w):
    return TC + (TS - TC) * math.exp(-abs(w) / WS)


def test_lugre_agrees_with_an_independent_solver():
    """A torque 1.8 sin(2 pi t) N m on the body (linear between 1 ms samples): gearbench's
    Rosenbrock run and scipy's Radau on J dw/dt = T - (s0 z + s1 dz/dt),
    dz/dt = w - s0 |w| z / g(w) agree."""
    s0 = 1e4
    s1 = math.sqrt(s0 * J)
    t = np.arange(0.0, 2.0, 1e-3)
    torque = 1.8 * np.sin(2 * np.pi * t)
    time_s, out, _ = run(body(lugre(s0), inertia=J), t, torque, np.append(np.diff(torque) / 1e-3, 0.0),
                         t_end=1.99, rtol=1e-9)

    def f(tt, y):
        th, w, z = y
        zd = w - s0 * abs(w) * z / g(w)
        return [w, (np.interp(tt, t, torque) - s0 * z - s1 * zd) / J, zd]
    with np.errstate(over="ignore"):  # Radau's difference Jacobian probes steps of the idle angle
        ref = solve_ivp(f, (0.0, 1.99), [0.0, 0.0, 0.0], method="Radau", rtol=1e-10, atol=1e-12,
                        t_eval=time_s, max_step=1e-3 / 4)
    peak = np.abs(ref.y[1]).max()
    assert peak > 5.0  # it slides: breakaway and sliding both ways, not only presliding
    assert np.abs(out[:, L.O_WL] - ref.y[1]).max() < 1e-4 * peak
    assert np.abs(out[:, L.O_LOAD] - ref.y[0]).max() < 1e-4 * np.abs(ref.y[0]).max()


def test_lugre_slides_on_stribecks_curve_plus_its_viscous_term():
    """A steady 1.5 N m on the body with sigma2 = 0.1 N m s/rad: it settles where
    g(w) + sigma2 w = 1.5 N m, the bristles at g(w) / sigma0."""
    _, out, res = run(body(lugre(viscous_coefficient=0.1), inertia=J), [0.0], [1.5], t_end=3.0)
    w = brentq(lambda w: g(w) + 0.1 * w - 1.5, 1e-3, 100.0)
    assert out[-1, L.O_WL] == pytest.approx(w, rel=1e-6)
    assert bristles(res) == pytest.approx(g(w) / 1e4, rel=1e-6)


@pytest.mark.parametrize("torque", [0.3, 0.75, 0.95])
def test_lugre_holds_below_breakaway_on_the_bristles_spring(torque):
    """A step of torque below the sliding level: the body comes to rest with the bristles
    carrying it, sigma0 z = T (to the solver's tolerance), turned by more than T / sigma0 (the
    bristles' spring and what slipped while they loaded) but no more than a few T_s / sigma0, and
    still from 1 s on; the bristles never go past T_s / sigma0.  Released, they unload and the
    body springs back by up to z."""
    s0 = 1e4
    t, out, res = run(body(lugre(s0), inertia=J), [0.0], [torque], t_end=2.0)
    z = bristles(res)
    assert z == pytest.approx(torque / s0, rel=1e-6) and abs(out[-1, L.O_WL]) < 1e-9
    held = out[t >= 1.0, L.O_LOAD]
    assert torque / s0 < held[0] < 3 * TS / s0 and np.ptp(held) < 1e-9 * held[0]  # presliding, no creep
    for t_end in (0.005, 0.01, 0.02, 0.05):
        assert 0.0 <= bristles(run(body(lugre(s0), inertia=J), [0.0], [torque], t_end=t_end)[2]) <= TS / s0
    _, back, res = run(body(lugre(s0), inertia=J), [0.0, 2.0], [torque, 0.0], t_end=4.0)
    assert abs(bristles(res)) < 1e-6 * torque / s0
    assert 0.5 * z < out[-1, L.O_LOAD] - back[-1, L.O_LOAD] <= z  # less what slips as they unload


def test_lugre_breaks_away_at_the_static_level_as_the_bristles_stiffen():
    """A slow torque ramp of 0.3 N m/s: the body breaks away (speed past 0.01 rad/s) below T_s,
    closer to it as sigma0 grows, within 0.5 % of it at sigma0 = 1e5 N m/rad."""
    gaps = []
    for s0 in (1e3, 1e4, 1e5):
        t, out, _ = run(body(lugre(s0), inertia=J), [0.0], [0.0], s=[0.3], t_end=6.0)
        moving = np.flatnonzero(out[:, L.O_WL] > 0.01)
        gaps.append(TS - 0.3 * t[moving[0]])
    assert 0.0 < gaps[2] < gaps[1] < gaps[0] and gaps[2] < 0.005 * TS


def test_lugre_tends_to_the_event_driven_stick_slip_law():
    """The same pushes (2 N m for 1 s, -0.5 N m for 1 s) on LuGre and on the stick-slip
    Stribeck law (located events, no bristles): the speeds' gap shrinks as sigma0 grows, to
    under 2e-4 of the peak speed at sigma0 = 1e6 N m/rad."""
    pushes = ([0.0, 1.0, 2.0], [2.0, -0.5, 0.0])
    _, ref, _ = run(body(friction("stribeck_friction", location="load", static_torque=TS, coulomb_torque=TC,
                                  stribeck_speed=WS), inertia=J), *pushes, t_end=3.0)
    gaps = [np.abs(run(body(lugre(s0), inertia=J), *pushes, t_end=3.0)[1][:, L.O_WL] - ref[:, L.O_WL]).max()
            for s0 in (1e3, 1e4, 1e5, 1e6)]
    assert all(b < a for a, b in zip(gaps, gaps[1:])) and gaps[-1] < 2e-4 * np.abs(ref[:, L.O_WL]).max()


R, LH, U = 2.0, 1e-3, 6.0  # the stalled train's winding (ohm, H) and voltage (V)


def stalled(rth, tau):
    """The small train's rotor held by 1 N m of stick-slip friction (its stall torque is 0.09 N m)."""
    heat = AddedEffect("winding_heating", {"thermal_resistance": rth, "time_constant": tau})
    return geartrain(heat, friction("coulomb_friction", location="motor", torque=1.0))


def test_winding_heating_agrees_with_scipy_and_its_steady_state():
    """6 V on the stalled rotor: the current falls as the winding warms, as scipy's Radau gives it
    from L di/dt = u - R (1 + alpha dT) i, tau d dT/dt = R_th R (1 + alpha dT) i^2 - dT; after
    10 time constants at dT = (sqrt(1 + 4 alpha R_th u^2 / R) - 1) / (2 alpha)."""
    rth, tau, alpha = 20.0, 0.5, 0.00393
    t, out, res = run(stalled(rth, tau), [0.0], [U], t_end=5.0, rtol=1e-10)
    assert np.all(out[:, L.O_WM] == 0.0)

    def f(_, y):
        i, dt = y
        r = R * (1 + alpha * dt)
        return [(U - r * i) / LH, (rth * r * i * i - dt) / tau]
    ref = solve_ivp(f, (0.0, 5.0), [0.0, 0.0], method="Radau", rtol=1e-11, atol=1e-12, t_eval=t, max_step=1e-3)
    assert np.abs(out[:, L.O_CURRENT] - ref.y[0]).max() < 1e-8 * U / R
    steady = (math.sqrt(1 + 4 * alpha * rth * U * U / R) - 1) / (2 * alpha)
    assert res.meta["x_end"][-1] == pytest.approx(steady, rel=1e-4)  # e^-10 of the way left
    assert out[-1, L.O_CURRENT] == pytest.approx(U / (R * (1 + alpha * steady)), rel=1e-4)


def test_an_effects_state_runs_on_through_window_seams():
    """A replay with 1 s windows carries the winding's temperature across its seams: on the
    noise-free record of the same plant it leaves no residual, as the replay without windows."""
    plant = load_plant(RIG)
    t, u = excitation("mixed", plant, duration_s=6.0, seed=0)
    heat = AddedEffect("winding_heating", {"thermal_resistance": 8.0, "time_constant": 20.0})
    rec = synthesize(plant, [heat], t, u, noise={"motor_angle_deg": 0.0, "load_angle_deg": 0.0, "current_A": 0.0})
    truth = plant.with_effects(heat)
    for window in (None, 1.0):
        res = Replay(rec, window_s=window).residuals(Replay(rec, window_s=window).run(truth))
        # A; without the heating the residual reaches 0.61 A, with the temperature zeroed at
        # every seam 0.29 A (both measured, 2026-11-29)
        assert np.abs(res["current_A"]).max() < 1e-4


@pytest.mark.parametrize("hidden", [
    AddedEffect("winding_heating", {"thermal_resistance": 8.0, "time_constant": 20.0}),
    AddedEffect("lugre_friction", {"location": "load", "coulomb_torque": 0.2, "static_torque": 0.35,
                                   "stribeck_speed": 0.5, "bristle_stiffness": 200.0, "bristle_damping": 1.1}),
], ids=lambda e: e.name)
def test_fitted_on_coloured_noise_the_truth_lies_within_four_standard_errors(hidden):
    """16 s of the rig's mixed excitation with the effect hidden, AR(1) noise of lag-1
    correlation 0.9 on every signal: ``fit`` finds every parameter within 4 standard errors of
    the truth, and ends at the noise."""
    plant = load_plant(RIG)
    t, u = excitation("mixed", plant, duration_s=16.0, seed=3)
    noise = {"motor_angle_deg": 0.02, "load_angle_deg": 0.02, "current_A": 0.005}
    rec = synthesize(plant, [hidden], t, u, noise=noise, seed=1, noise_ar1=0.9)
    r = gb.fit(plant, rec, hidden.name, options={k: v for k, v in hidden.values.items() if k == "location"})
    for name, true in hidden.values.items():
        if name != "location":
            got, se = r.values[f"effects[0].{name}"], r.stderr[f"effects[0].{name}"]
            assert abs(got - true) < 4 * se, (name, got, se, true)
    assert r.error_after < 1.1 * noise[r.signal]


def test_tried_only_when_asked_for_from_the_command_line(tmp_path):
    """``diagnose`` leaves the on-request effects out, saying how to ask for them; with
    ``--also winding_heating`` it finds a warming winding in 6 s of the rig's steps."""
    from click.testing import CliRunner

    from gearbench.cli import main
    from gearbench.measure.data import write_measurement
    plant = load_plant(RIG)
    t, u = excitation("steps", plant, duration_s=6.0, seed=2)
    heat = AddedEffect("winding_heating", {"thermal_resistance": 8.0, "time_constant": 20.0})
    path = tmp_path / "warm.csv"
    write_measurement(synthesize(plant, [heat], t, u, seed=2), path)

    def diagnose(*more):
        r = CliRunner().invoke(main, ["diagnose", str(RIG), str(path), "--only", "bias_torque", "--max-steps", "1",
                                      "--results", str(tmp_path), "--json", *more], catch_exceptions=False)
        assert r.exit_code == 0, r.output
        return json.loads(r.output)
    plain = diagnose()
    assert {c["effect"] for c in plain["candidates"]} == {"bias_torque"}
    asked = diagnose("--also", "winding_heating")
    assert asked["verdict"] == "winding_heating" and "winding_heating" not in asked["not_tried"]
    assert asked["ladder"][0]["params"]["thermal_resistance"] == pytest.approx(8.0, rel=0.15)
    r = CliRunner().invoke(main, ["diagnose", str(RIG), str(path), "--also", "lugre"], catch_exceptions=False)
    assert r.exit_code != 0 and "also: unknown effect 'lugre'" in r.output


def test_without_only_the_library_names_what_is_tried_on_request():
    """With neither ``only`` nor ``also`` the on-request effects are among ``not_tried``, each saying
    how to ask for it; the library's others are candidates."""
    from gearbench.identify.candidates import candidates, not_tried
    plant = load_plant(RIG)
    t, u = excitation("steps", plant, duration_s=1.0, seed=2)
    replay = Replay(synthesize(plant, [], t, u, seed=2))
    why = not_tried(plant, replay)
    assert {n for n, e in REGISTRY.items() if e.on_request} == {"lugre_friction", "winding_heating"}
    assert all(f"--also {n}" in why[n] for n in ("lugre_friction", "winding_heating"))
    names = {c.name for c in candidates(plant, replay)}
    assert not names & {"lugre_friction", "winding_heating"} and "coulomb_friction" in names
    assert {c.name for c in candidates(plant, replay, also=("lugre_friction",))} == names | {"lugre_friction"}


LAGGED = '''"""A torque on the load that builds up to ``torque`` (N m) with time constant ``tau`` (s):
dT/dt = (torque - T) / tau, its value the effect's own state."""
import numba as nb

from gearbench.plant.effects import Effect, Param, register


@nb.njit(cache=True)
def rate(p, o, theta, w, z):
    return (p[o] - z) / p[o + 1]


@nb.njit(cache=True)
def term(p, o, theta, w, eps, z):
    return z


@register
class LaggedTorque(Effect):
    """A torque that builds up with a lag."""
    name = "lagged_torque"
    signature = "a constant"
    acts_on = "load torque"
    params = (Param("torque", "N m", -1e3, 1e3, 0.1), Param("tau", "s", 1e-6, 1e3, 0.1))
    term = term
    rate = rate
    state = "torque built up, N m"
    places = ("load",)
    slots = ("torque, N m", "tau, s")

    def compiled(self, values, plant):
        return "load", (float(values["torque"]), float(values["tau"]))
'''


def test_an_effect_with_a_state_written_outside_the_package(tmp_path):
    """A user's effect file declares a state like the built-in ones: a torque building up as
    T0 (1 - exp(-t/tau)) on a free body, whose speed is then (T0/J) (t - tau (1 - exp(-t/tau)))."""
    from gearbench.plant.effects.user import load, unload
    module = tmp_path / "lagged.py"
    module.write_text(LAGGED)
    load(module)
    try:
        plant = body(AddedEffect("lagged_torque", {"torque": 0.5, "tau": 0.2}), inertia=J)
        t, out, _ = run(plant, [0.0], [0.0], t_end=1.0, rtol=1e-10)
        exact = 0.5 / J * (t - 0.2 * (1.0 - np.exp(-t / 0.2)))
        assert np.abs(out[:, L.O_WL] - exact).max() < 1e-7 * exact.max()
    finally:
        unload(module)
