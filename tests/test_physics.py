"""Physics of the geartrain tested as physics (SPEC section 2).

Each test states a physical law or a closed-form result and checks the
simulator against it: the contact never pulls and is silent inside the
clearance, the coefficient of restitution of the damped mesh, conservation of
energy (and its decay with damping), convergence as the tolerance tightens,
two independent integrators agreeing, and the motor's steady state.

Units are SI throughout (rad, rad/s, N m, kg m^2, V, A).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from conftest import (Controller, Segments, SolverOptions, free_pair, free_pair_scales,
                      penetration, ramp_hold_ramp_profile, reversal_profile, run_free_pair,
                      small_plant)
from gearbench import layout as L
from gearbench.plant.contact import clipped_torque
from gearbench.simulate import simulate

# ---------------------------------------------------------------------------
# 1. The contact law: never pulls, silent in the clearance
# ---------------------------------------------------------------------------

LAWS = [L.LAW_DUBOWSKY, L.LAW_ELASTO]


def _pen(delta: float, h: float) -> float:
    return delta - h if delta > h else (delta + h if delta < -h else 0.0)


finite = dict(allow_nan=False, allow_infinity=False)
half_clearances = st.floats(1e-4, 0.5, **finite)
stiffnesses = st.floats(1e2, 1e9, **finite)
dampings = st.floats(0.0, 1e3, **finite)
rates = st.floats(-1e3, 1e3, **finite)


@st.composite
def mesh_states(draw):
    """(delta, ddelta, h, k, d): anywhere, often right at or near a flank."""
    h = draw(half_clearances)
    where = draw(st.sampled_from(["anywhere", "near_flank", "on_flank"]))
    if where == "anywhere":
        delta = draw(st.floats(-3.0 * h, 3.0 * h, **finite))
    elif where == "near_flank":
        side = draw(st.sampled_from([-1.0, 1.0]))
        delta = side * (h + draw(st.floats(-1e-3 * h, 1e-3 * h, **finite)))
    else:
        delta = draw(st.sampled_from([-h, h]))
    return delta, draw(rates), h, draw(stiffnesses), draw(dampings)


@pytest.mark.parametrize("law", LAWS, ids=["dubowsky", "elasto"])
@settings(max_examples=400, deadline=None)
@given(state=mesh_states())
def test_contact_law_never_pulls_and_is_zero_in_dead_zone(law, state):
    delta, dd, h, k, d = state
    t = clipped_torque(delta, dd, h, k, d, law)
    p = _pen(delta, h)
    if abs(delta) <= h:
        assert t == 0.0, f"torque {t} N m inside the clearance (delta={delta}, h={h})"
    # the teeth push apart, never pull: torque has the sign of the penetration
    assert t * p >= 0.0, f"pulling torque {t} N m at penetration {p} rad"


@pytest.mark.parametrize("law", LAWS, ids=["dubowsky", "elasto"])
@settings(max_examples=400, deadline=None)
@given(state=mesh_states())
def test_contact_law_is_odd(law, state):
    """Mirror symmetry of the mesh: T(-delta, -delta') = -T(delta, delta'), exactly."""
    delta, dd, h, k, d = state
    assert clipped_torque(-delta, -dd, h, k, d, law) == -clipped_torque(delta, dd, h, k, d, law)


@settings(max_examples=400, deadline=None)
@given(state=mesh_states())
def test_dubowsky_is_spring_plus_damper_while_pushing(state):
    """SPEC: T = k p + d d(delta)/dt while the teeth push, else 0."""
    delta, dd, h, k, d = state
    p = _pen(delta, h)
    t = clipped_torque(delta, dd, h, k, d, L.LAW_DUBOWSKY)
    raw = k * p + d * dd
    if p != 0.0 and raw * p > 0.0:
        assert t == raw
    else:
        assert t == 0.0


@settings(max_examples=400, deadline=None)
@given(h=half_clearances, k=stiffnesses, d=dampings, dd=rates,
       frac=st.floats(0.0, 1e-3, **finite), side=st.sampled_from([-1.0, 1.0]))
def test_elasto_backlash_is_continuous_at_contact_onset(h, k, d, dd, frac, side):
    """Modelica ElastoBacklash limits the damper torque to the spring torque, so
    |T| <= 2 k |p|: the torque goes to 0 as the penetration does, whatever the
    approach speed (Dubowsky's law jumps to d*v instead)."""
    delta = side * (h + frac * h)
    p = abs(_pen(delta, h))                  # the penetration as represented
    t = clipped_torque(delta, dd, h, k, d, L.LAW_ELASTO)
    assert abs(t) <= 2.0 * k * p * (1.0 + 1e-12)
    # and it never exceeds the unclipped spring + damper torque (damping only limited)
    raw = side * (k * p) + d * dd
    assert abs(t) <= abs(raw) * (1.0 + 1e-12)


@settings(max_examples=200, deadline=None)
@given(h=half_clearances, k=stiffnesses, d=st.floats(1e-2, 1e3, **finite),
       v=st.floats(1e-2, 1e3, **finite))
def test_dubowsky_jumps_by_damper_torque_at_onset(h, k, d, v):
    """The no-pull clip makes Dubowsky's contact torque jump to d*v at onset
    (the discontinuity the solver must locate as an event)."""
    eps = 1e-12 * h
    t = clipped_torque(h + eps, v, h, k, d, L.LAW_DUBOWSKY)
    assert t == pytest.approx(d * v, rel=1e-6, abs=k * eps * 2.0)


# A sine set point (20 deg, 1 Hz) as a piecewise-linear table: many reversals
_tt = np.linspace(0.0, 2.0, 101)
_vv = math.radians(20.0) * np.sin(2.0 * math.pi * _tt)
SINE = Segments(t=_tt[:-1], v=_vv[:-1], s=np.diff(_vv) / np.diff(_tt))

# (name, controller, set point, run length s, output interval s)
CLOSED_LOOP_CASES = [
    ("p50-reversal", Controller("p", kp=50), reversal_profile(), 2.0, 1e-5),
    ("bangbang-reversal", Controller("bang_bang", band_deg=0.25), reversal_profile(), 2.0, 1e-5),
    ("p500-reversal", Controller("p", kp=500), reversal_profile(), 2.0, 1e-5),  # grazes in a step
    ("p50-sine", Controller("p", kp=50), SINE, 2.0, 1e-5),
    # 10 s, with a 2 s hold at zero force on a flank before the reversal
    ("p20-ramp-hold-ramp", Controller("p", kp=20), ramp_hold_ramp_profile(), 10.0, 5e-5),
    ("p100-ramp-hold-ramp", Controller("p", kp=100), ramp_hold_ramp_profile(), 10.0, 5e-5),
]
CASE_IDS = [c[0] for c in CLOSED_LOOP_CASES]


_AUDITS: dict = {}


def _contact_audit(law_name: str, ctrl, prof, t_end=2.0, dt=1e-5):
    key = (law_name, ctrl, prof.t.tobytes(), prof.v.tobytes(), prof.s.tobytes(), t_end, dt)
    if key not in _AUDITS:
        _AUDITS[key] = _run_contact_audit(law_name, ctrl, prof, t_end, dt)
    return _AUDITS[key]


def _run_contact_audit(law_name: str, ctrl, prof, t_end, dt):
    plant = small_plant(law_name)
    g = plant.gear
    rtol = SolverOptions().rtol
    run = simulate(plant, ctrl, prof, t_end, SolverOptions(output_dt_s=dt))
    assert run.ok, run.status
    o = run.outputs
    torque, delta = o[:, L.O_TORQUE], o[:, L.O_DELTA]
    h = g.half_clearance
    ddelta = o[:, L.O_WM] / g.ratio - o[:, L.O_WL]
    law = L.LAW_ELASTO if law_name == "elasto_backlash" else L.LAW_DUBOWSKY
    memoryless = np.array([clipped_torque(a, b, h, g.mesh_stiffness, g.mesh_damping, law)
                           for a, b in zip(delta, ddelta)])
    pen = penetration(delta, h)
    pull = np.where(torque * pen < 0.0, np.abs(torque), 0.0)
    in_gap = np.abs(delta) < h
    # torque the error control resolves: k * atol(delta) = rtol * stall torque at the output
    t_res = rtol * plant.motor.stall_torque * g.ratio
    return dict(run=run, torque=torque, pull=pull, in_gap=in_gap, t_res=t_res,
                mismatch=np.abs(torque - memoryless), t_peak=np.abs(torque).max())


@pytest.mark.parametrize("law", ["dubowsky", "elasto_backlash"])
@pytest.mark.parametrize("name,ctrl,prof,t_end,dt", CLOSED_LOOP_CASES, ids=CASE_IDS)
def test_closed_loop_contact_never_pulls_and_dead_zone_is_silent(name, ctrl, prof, t_end, dt, law):
    """At every output sample: no torque while the teeth are apart, and
    torque * penetration >= 0 (the teeth push, never pull).

    Tolerance: the torque the error control resolves, k * atol(delta) =
    rtol * stall torque at the output (9.6e-6 N m here, 1e-7 of the peak).  Only
    while the train settles on a flank at zero force does the state sit that
    close to the contact's switching surface; the worst values measured there
    are ~1.5e-7 N m, and exactly 0 everywhere else.  Both contact laws: with
    ElastoBacklash the kink of ``Tc + min(Tc, Td)`` is a located event (before
    it was, the law sustained a spurious ~3 kHz oscillation while settling on a
    flank, pulling with ~6e-3 N m at rtol 1e-6).
    """
    a = _contact_audit(law, ctrl, prof, t_end, dt)
    assert a["run"].impacts >= 2 and a["t_peak"] > 1.0, "the run must actually use the mesh"
    gap_torque = np.abs(a["torque"][a["in_gap"]]).max(initial=0.0)
    assert gap_torque <= a["t_res"], (
        f"{name}: torque {gap_torque:.3g} N m across the open clearance")
    worst = a["pull"].max()
    assert worst <= a["t_res"], (
        f"{name}: teeth pull with {worst:.3g} N m (peak contact torque {a['t_peak']:.3g} N m)")


@pytest.mark.parametrize("law", ["dubowsky", "elasto_backlash"])
@pytest.mark.parametrize("name,ctrl,prof,t_end,dt", CLOSED_LOOP_CASES, ids=CASE_IDS)
def test_closed_loop_torque_is_the_spec_law_of_the_state(name, ctrl, prof, t_end, dt, law):
    """The solver's mode-based torque equals the law's memoryless form T(delta,
    delta') at every sample (for ElastoBacklash also the piece of its min(Tc,
    Td)): no impact is missed (teeth passing through each other with no torque,
    e.g. a graze that opens and closes inside one step), and no contact
    outlives its separation (teeth stuck together, pulling).  Same tolerance as
    above, k * atol(delta)."""
    a = _contact_audit(law, ctrl, prof, t_end, dt)
    worst = a["mismatch"].max()
    i = int(a["mismatch"].argmax())
    assert worst <= a["t_res"], (
        f"{name}: contact torque differs from the SPEC law by {worst:.3g} N m at "
        f"t = {a['run'].time_s[i]:.6f} s (resolution {a['t_res']:.2g} N m)")


# ---------------------------------------------------------------------------
# 2. Coefficient of restitution of the damped mesh (closed form)
# ---------------------------------------------------------------------------

N_GEAR, JM, JL, K_MESH = 100.0, 1e-6, 5e-5, 2.4e7
H_SMALL = math.radians(0.05)
J_EFF = 1.0 / (1.0 / JL + 1.0 / (JM * N_GEAR ** 2))   # reduced inertia at the output
W_N = math.sqrt(K_MESH / J_EFF)


def damped_impact(zeta: float, v: float):
    """Impact of the relative coordinate J p'' + d p' + k p = 0, p(0)=0, p'(0)=v.

    With the no-pull clip the teeth separate when k p + d p' = 0 (before p
    returns to 0).  Returns (t_sep, e_clipped, t_linear, e_linear): contact
    time and restitution with the clip, and without it (separation at p = 0).
    """
    wd = W_N * math.sqrt(1.0 - zeta ** 2)
    d = 2.0 * zeta * math.sqrt(K_MESH * J_EFF)
    p = lambda t: v / wd * math.exp(-zeta * W_N * t) * math.sin(wd * t)
    dp = lambda t: v * math.exp(-zeta * W_N * t) * (math.cos(wd * t) - zeta * W_N / wd * math.sin(wd * t))
    # k p + d p' starts at d v > 0 and first returns to zero inside (pi/2, pi)/wd
    t_sep = brentq(lambda t: K_MESH * p(t) + d * dp(t), 0.5 * math.pi / wd, math.pi / wd,
                   xtol=1e-22, rtol=1e-15)
    return t_sep, -dp(t_sep) / v, math.pi / wd, math.exp(-zeta * math.pi / math.sqrt(1.0 - zeta ** 2))


def test_damped_impact_reference_is_self_consistent():
    """The reference itself: separation at T = 0 is at (pi - 2 asin(zeta))/wd,
    and separating at p = 0 instead gives the textbook exp(-zeta pi / sqrt(1-zeta^2))."""
    for zeta in (0.05, 0.3, 0.6):
        t_sep, e, t_lin, e_lin = damped_impact(zeta, 1.0)
        wd = W_N * math.sqrt(1.0 - zeta ** 2)
        assert t_sep == pytest.approx((math.pi - 2.0 * math.asin(zeta)) / wd, rel=1e-12)
        p_lin = math.exp(-zeta * W_N * t_lin) * math.sin(wd * t_lin)
        assert abs(p_lin) < 1e-12
        dp_lin = math.exp(-zeta * W_N * t_lin) * (math.cos(wd * t_lin))
        assert -dp_lin == pytest.approx(e_lin, rel=1e-12)
        assert e > e_lin and t_sep < t_lin  # the clip ends the contact early, losing less


@pytest.mark.parametrize("zeta", [0.05, 0.3, 0.6])
def test_coefficient_of_restitution_matches_closed_form(zeta):
    v = 1.0                                  # relative approach speed at the output, rad/s
    d = 2.0 * zeta * math.sqrt(K_MESH * J_EFF)
    t_sep, e_ref, t_lin, e_lin = damped_impact(zeta, v)
    p = free_pair(JM, JL, N_GEAR, H_SMALL, K_MESH, d)
    x0 = np.zeros(L.N_STATE)
    t_hit = 1e-6
    x0[L.X_WM] = N_GEAR * v                  # the motor side runs into the load, at rest
    x0[L.X_DELTA] = H_SMALL - v * t_hit      # touches the flank at t = 1 us
    dt = 1e-10
    run = run_free_pair(p, free_pair_scales(v, N_GEAR, K_MESH, J_EFF), x0, 2e-5, rtol=1e-8,
                        output_dt=dt)
    assert run.impacts == 1
    xe = run.meta["x_end"]
    v_after = xe[L.X_WM] / N_GEAR - xe[L.X_WL]
    e_sim = -v_after / v
    assert e_sim == pytest.approx(e_ref, rel=1e-4), (
        f"zeta={zeta}: e simulated {e_sim:.8f}, closed form {e_ref:.8f}, "
        f"linear (no clip) {e_lin:.8f}")
    # contact duration: samples with a contact torque
    on = np.flatnonzero(run.outputs[:, L.O_TORQUE] != 0.0)
    t_on, t_off = run.time_s[on[0]], run.time_s[on[-1]]
    assert t_on == pytest.approx(t_hit, abs=2 * dt)
    duration = t_off - t_on
    assert duration == pytest.approx(t_sep, rel=1e-4, abs=2 * dt), (
        f"zeta={zeta}: contact lasted {duration:.6e} s, closed form {t_sep:.6e} s "
        f"(pi/wd = {t_lin:.6e} s without the clip)")
    assert duration < t_lin and e_sim > e_lin
    # angular momentum N Jm wm + Jl wl is exchanged, never created
    mom0 = N_GEAR * JM * x0[L.X_WM]
    mom1 = N_GEAR * JM * xe[L.X_WM] + JL * xe[L.X_WL]
    assert mom1 == pytest.approx(mom0, rel=1e-9)


# ---------------------------------------------------------------------------
# 3. Energy
# ---------------------------------------------------------------------------

def _energy(wm, wl, delta, h):
    pen = penetration(delta, h)
    return 0.5 * JM * wm ** 2 + 0.5 * JL * wl ** 2 + 0.5 * K_MESH * pen ** 2


def _bouncing_pair(d, law=L.LAW_DUBOWSKY, v=1.0):
    """Zero-momentum pair: all the energy is in the relative motion."""
    p = free_pair(JM, JL, N_GEAR, H_SMALL, K_MESH, d, law)
    wm0 = v / (1.0 / N_GEAR + N_GEAR * JM / JL)
    x0 = np.zeros(L.N_STATE)
    x0[L.X_WM] = wm0
    x0[L.X_WL] = -N_GEAR * JM * wm0 / JL
    return p, x0


def test_energy_conserved_without_damping_over_100_impacts():
    """d = 0, no bearing damping, no drive: the pair bounces between the flanks
    forever.  ode23s is L-stable and so slightly dissipative on the undamped
    contact (measured drift over 110 impacts: 1.9e-4 at rtol 1e-6, 2.7e-6 at
    1e-8, 3.4e-8 at 1e-10), so this test runs at rtol = 1e-10."""
    v = 1.0
    p, x0 = _bouncing_pair(0.0, v=v)
    e0 = _energy(x0[L.X_WM], x0[L.X_WL], x0[L.X_DELTA], H_SMALL)
    t_end = 110 * 2.0 * H_SMALL / v
    run = run_free_pair(p, free_pair_scales(v, N_GEAR, K_MESH, J_EFF), x0, t_end, rtol=1e-10,
                        output_dt=1e-6)
    assert run.stats[L.S_IMPACTS] >= 100
    o, xe = run.outputs, run.meta["x_end"]
    e_samples = _energy(o[:, L.O_WM], o[:, L.O_WL], o[:, L.O_DELTA], H_SMALL)
    e_end = _energy(xe[L.X_WM], xe[L.X_WL], xe[L.X_DELTA], H_SMALL)
    drift = max(abs(e_end / e0 - 1.0), np.abs(e_samples / e0 - 1.0).max())
    assert drift <= 1e-6, f"energy drift {drift:.3e} over {run.impacts} impacts"


@pytest.mark.parametrize("law", LAWS, ids=["dubowsky", "elasto"])
@pytest.mark.parametrize("zeta", [0.02, 0.3])
def test_energy_never_rises_with_damping(law, zeta):
    """With mesh damping the mechanical energy (kinetic + mesh spring) only falls:
    dE/dt = -d delta'^2 (Dubowsky) or -min(tc, td) delta' <= 0 (ElastoBacklash)."""
    v = 1.0
    d = 2.0 * zeta * math.sqrt(K_MESH * J_EFF)
    p, x0 = _bouncing_pair(d, law, v)
    e0 = _energy(x0[L.X_WM], x0[L.X_WL], x0[L.X_DELTA], H_SMALL)
    run = run_free_pair(p, free_pair_scales(v, N_GEAR, K_MESH, J_EFF), x0, 5e-3, rtol=1e-9,
                        output_dt=1e-8)
    assert run.impacts >= 2
    o = run.outputs
    e = _energy(o[:, L.O_WM], o[:, L.O_WL], o[:, L.O_DELTA], H_SMALL) / e0
    rise = (e - np.minimum.accumulate(e)).max()
    assert rise <= 1e-9, f"energy rose by {rise:.3e} of its initial value"
    assert e[-1] < 0.9  # and damping did dissipate


# ---------------------------------------------------------------------------
# 4. Convergence as the tolerance tightens
# ---------------------------------------------------------------------------

# ode23s: error per step ~ h^3 is held to rtol, so h ~ rtol^(1/3) and the
# second-order global error ~ h^2 ~ rtol^(2/3): 10^(2/3) = 4.64x per decade.
RATE_PER_DECADE = 10.0 ** (2.0 / 3.0)
RTOLS = [1e-4, 1e-5, 1e-6, 1e-7, 1e-8]
CONVERGENCE_CTRLS = [Controller("bang_bang", band_deg=0.25), Controller("p", kp=500)]


def _iae_series(ctrl, method, rtols):
    plant = small_plant()
    iae = []
    for rtol in rtols:
        run = simulate(plant, ctrl, reversal_profile(), 1.5,
                       SolverOptions(method=method, rtol=rtol, output_dt_s=0.01))
        assert run.ok, run.status
        iae.append(run.stats[L.S_IAE])
    return np.array(iae)


@pytest.mark.parametrize("ctrl", CONVERGENCE_CTRLS, ids=["bang_bang", "p500"])
def test_ode23s_iae_converges_at_its_order(ctrl):
    iae = _iae_series(ctrl, "rosenbrock23", RTOLS)
    diffs = np.abs(np.diff(iae))
    ratios = diffs[:-1] / diffs[1:]
    msg = (f"IAE (rad s) {['%.12g' % v for v in iae]}; successive differences "
           f"{['%.3g' % v for v in diffs]}; shrink ratios {['%.2f' % r for r in ratios]} "
           f"(ode23s asymptotic rate 10^(2/3) = {RATE_PER_DECADE:.2f})")
    assert np.all(ratios > 1.0), msg
    # asymptotic decades (from rtol 1e-5 on): the method's theoretical rate
    assert np.all(ratios[1:] >= 0.85 * RATE_PER_DECADE), msg


@pytest.mark.parametrize("ctrl", CONVERGENCE_CTRLS, ids=["bang_bang", "p500"])
def test_rodas4_iae_converges_tenfold_per_decade(ctrl):
    """rodas4 holds an error per step ~ h^4 (its third-order estimate) to rtol, so
    its fourth-order global error ~ h^4 ~ rtol: 10x per decade.  Against rtol 1e-11,
    the error must fall by >= 5x per decade on average and stay inside the envelope
    err(rtol) <= 10 err(1e-4) rtol / 1e-4.  Single decades of a non-smooth run are
    erratic (errors of either sign cancel: p500 fell 20000x from 1e-5 to 1e-6, then
    rose 30x), so they are not judged one by one."""
    iae = _iae_series(ctrl, "rodas4", RTOLS + [1e-11])
    err = np.abs(iae[:-1] - iae[-1])
    mean_rate = (err[0] / err[-1]) ** (1.0 / (len(err) - 1))
    envelope = 10.0 * err[0] * np.array(RTOLS) / RTOLS[0]
    msg = (f"IAE (rad s) {['%.13g' % v for v in iae]}; errors {['%.3g' % v for v in err]}; "
           f"envelope {['%.3g' % v for v in envelope]}; mean {mean_rate:.1f}x per decade")
    assert mean_rate >= 5.0, msg
    assert np.all(err <= envelope), msg


# ---------------------------------------------------------------------------
# 5. Two independent integrators agree
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("kp", [50.0, 500.0])
def test_rosenbrock_and_dormand_prince_agree(kp):
    plant = small_plant()
    res = {}
    for method in ("rodas4", "rosenbrock23", "dopri5"):
        run = simulate(plant, Controller("p", kp=kp), reversal_profile(), 2.0,
                       SolverOptions(method=method, output_dt_s=1e-3))
        assert run.ok, f"{method}: {run.status}"
        assert run.impacts >= 2
        res[method] = run.iae_deg_s
    for m in ("rodas4", "rosenbrock23"):
        rel = abs(res[m] / res["dopri5"] - 1.0)
        assert rel <= 5e-3, f"IAE {m} {res[m]:.9g} vs dopri5 {res['dopri5']:.9g} deg s"


# ---------------------------------------------------------------------------
# 6. Motor steady state with the load engaged
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("volts", [6.0, -9.0])
def test_open_loop_steady_state_matches_closed_form(volts):
    plant = small_plant()
    m, g, n = plant.motor, plant.gear, plant.gear.ratio
    b = m.damping + plant.load.damping / n ** 2            # damping seen at the rotor
    w = m.torque_constant * volts / (m.resistance * b + m.torque_constant * m.back_emf_constant)
    i = b * w / m.torque_constant
    run = simulate(plant, Controller("open"), Segments(t=np.array([0.0]), v=np.array([volts]),
                                                       s=np.array([0.0])), 0.1,
                   SolverOptions(output_dt_s=1e-3))
    assert run.ok, run.status
    xe = run.meta["x_end"]
    assert xe[L.X_WM] == pytest.approx(w, rel=1e-4)
    assert xe[L.X_I] == pytest.approx(i, rel=1e-4)
    assert xe[L.X_WL] == pytest.approx(w / n, rel=1e-4)
    # the load rides the driving flank, deflected by its drag torque bl*wl
    t_load = plant.load.damping * w / n
    side = math.copysign(1.0, volts)
    assert run.outputs[-1, L.O_TORQUE] == pytest.approx(t_load, rel=1e-4)
    assert xe[L.X_DELTA] == pytest.approx(side * g.half_clearance + t_load / g.mesh_stiffness,
                                          rel=1e-9)
