"""`gearbench validate`: each modelling claim of the thesis as a check with evidence.

Every check is a small function returning ``{name, passed, measured, expected,
unit, note}``; :func:`run_all` runs them all from ``experiments/validation/``.
Figures go to ``results/validation/``.  Units SI unless a check says otherwise.
"""
from __future__ import annotations

import math
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from . import layout as L
from .control.controllers import Controller
from .experiment.files import load_experiment, load_plant, read_yaml
from .plant.linear import plant_info
from .simulate import Segments, SolverOptions, simulate, simulate_packed

ZERO = Segments(t=np.array([0.0]), v=np.array([0.0]), s=np.array([0.0]))


def check(name, passed, measured, expected, unit, note=""):
    return {"name": name, "passed": bool(passed), "measured": measured, "expected": expected,
            "unit": unit, "note": note}


# ------------------------------------------------------------ free impact pair
# Two free inertias through the clearance (torque input held at 0, no electrics).
N_GEAR, JM, JL, K_MESH = 100.0, 1e-6, 5e-5, 2.38e7
H = math.radians(0.05)
J_EFF = 1.0 / (1.0 / JL + 1.0 / (JM * N_GEAR ** 2))
W_N = math.sqrt(K_MESH / J_EFF)


def free_pair(jm, jl, n, h, k, d, law=L.LAW_DUBOWSKY, vmax=1.0, bl=0.0):
    p = np.zeros(L.P_SIZE)
    p[[L.P_R, L.P_L, L.P_KT, L.P_KE]] = 1.0
    p[L.P_JM], p[L.P_VMAX], p[L.P_N], p[L.P_H] = jm, vmax, n, h
    p[L.P_KMESH], p[L.P_DMESH], p[L.P_LAW], p[L.P_JL], p[L.P_BL] = k, d, law, jl, bl
    p[L.P_CTRL], p[L.P_TF], p[L.P_TORQUE_IN] = L.CTRL_OPEN, 1.0, 1.0
    p[L.P_PWL] = 1.0  # no effects: the right-hand side is affine in each contact mode
    return p


def _scales(v, n=N_GEAR, wn=W_N):
    sc = np.ones(L.N_STATE)
    sc[L.X_WM] = sc[L.X_WP] = n * v
    sc[L.X_WL] = v
    sc[L.X_DELTA] = v / wn
    return sc


def _single_impact(zeta, law, v=1.0, dt=1e-10):
    d = 2.0 * zeta * math.sqrt(K_MESH * J_EFF)
    x0 = np.zeros(L.N_STATE)
    t_hit = 1e-6
    x0[L.X_WM] = N_GEAR * v
    x0[L.X_DELTA] = H - v * t_hit
    run = simulate_packed(free_pair(JM, JL, N_GEAR, H, K_MESH, d, law), _scales(v), ZERO, 2.5e-5,
                          x0, SolverOptions(rtol=1e-8, max_step_s=1e-3, output_dt_s=dt))
    xe = run.meta["x_end"]
    e = -(xe[L.X_WM] / N_GEAR - xe[L.X_WL]) / v
    on = np.flatnonzero(run.outputs[:, L.O_TORQUE] != 0.0)
    dur = run.time_s[on[-1]] - run.time_s[on[0]] + dt if on.size else float("nan")
    return e, dur, run


def _reference_clipped(zeta, v=1.0):
    """Tight-tolerance reference: J p'' + d p' + k p = 0 from p=0, p'=v until k p + d p' = 0."""
    d = 2.0 * zeta * math.sqrt(K_MESH * J_EFF)

    def f(t, y):
        return [y[1], -(K_MESH * y[0] + d * y[1]) / J_EFF]

    def sep(t, y):
        return K_MESH * y[0] + d * y[1]
    sep.terminal, sep.direction = True, -1
    sol = solve_ivp(f, (0.0, 10.0 / W_N), [0.0, v], method="DOP853", rtol=1e-13, atol=1e-20,
                    events=sep)
    te, ye = sol.t_events[0][0], sol.y_events[0][0]
    return -ye[1] / v, te


def check_contact_law(zeta=0.05):
    out = []
    wd = W_N * math.sqrt(1.0 - zeta ** 2)
    e_lin, dur_lin, _ = _single_impact(zeta, L.LAW_LINEAR)
    e_cf = math.exp(-zeta * math.pi / math.sqrt(1.0 - zeta ** 2))
    out.append(check(f"restitution, unclipped spring-damper (zeta={zeta})",
                     abs(e_lin / e_cf - 1) <= 1e-4, e_lin, e_cf, "-",
                     "closed form exp(-zeta pi/sqrt(1-zeta^2)); contact law 'linear' (may pull)"))
    out.append(check(f"contact duration, unclipped (zeta={zeta})",
                     abs(dur_lin * wd / math.pi - 1) <= 1e-3, dur_lin, math.pi / wd, "s",
                     "closed form pi/omega_d; measured on a 1e-10 s output grid"))
    e_clip, dur_clip, _ = _single_impact(zeta, L.LAW_DUBOWSKY)
    e_ref, t_ref = _reference_clipped(zeta)
    out.append(check(f"restitution, Dubowsky law with no-pull clip (zeta={zeta})",
                     abs(e_clip / e_ref - 1) <= 1e-4, e_clip, e_ref, "-",
                     "reference: scipy DOP853 at rtol 1e-13 to the zero of k p + d p'"))
    out.append(check(f"contact duration, with clip (zeta={zeta})",
                     abs(dur_clip / t_ref - 1) <= 1e-3, dur_clip, t_ref, "s",
                     "reference integration; pi/omega_d would be %.4e s" % (math.pi / wd)))
    return out


DUBOWSKY = dict(jin=1.0, jout=5e-5, h=math.radians(1.0), amp=math.radians(3.0), freq=5.0, t_end=0.6)


def dubowsky_trace(output_dt_s: float = 2e-5, fine_dt_s: float = 1e-7) -> dict:
    """Appendix A's impact pair, solved, with a trace that shows every contact.

    A contact lasts about pi/omega_n (4.6 us here), under a quarter of the 20 us
    output grid, so sampled on that grid alone the contact torque is caught nonzero
    at only a few contacts (2 of the 8 the solver counts).  The run is therefore
    solved again with a ``fine_dt_s`` grid over 40 us either side of each turn of
    delta at the clearance (an impact reverses the relative speed there); the output
    is interpolated from the same steps, so the count and the motion are unchanged.

    Returns ``run`` (the traced run), ``impacts`` (the solver's count of contact
    onsets), ``onsets``/``ends`` (indices into the trace where the torque becomes /
    stops being nonzero), ``peaks`` (index of each contact's largest |torque|),
    ``visible_on_grid`` (contacts with a nonzero torque sample on the plain grid) and
    ``contact_s`` (pi/omega_n, s).
    """
    c = DUBOWSKY
    jin, jout, h, amp, freq, t_end = c["jin"], c["jout"], c["h"], c["amp"], c["freq"], c["t_end"]
    k = K_MESH
    jeff = 1.0 / (1.0 / jout + 1.0 / jin)
    d = 2.0 * 0.05 * math.sqrt(k * jeff)
    w = 2 * math.pi * freq
    t = np.linspace(0.0, t_end, 1201)
    torque = -jin * amp * w ** 2 * np.sin(w * t)
    seg = Segments(t=t[:-1], v=torque[:-1], s=np.diff(torque) / np.diff(t))
    p = free_pair(jin, jout, 1.0, h, k, d, vmax=1e6, bl=1e-4)
    x0 = np.zeros(L.N_STATE)
    x0[L.X_WM] = amp * w
    x0[L.X_WL] = 0.0
    sc = _scales(amp * w, 1.0, math.sqrt(k / jeff))
    opts = SolverOptions(rtol=1e-7, output_dt_s=output_dt_s)
    coarse = simulate_packed(p, sc, seg, t_end, x0, opts)
    dl = coarse.outputs[:, L.O_DELTA]
    slope = np.sign(np.diff(dl))
    turns = np.flatnonzero(slope[1:] != slope[:-1]) + 1
    turns = turns[np.abs(dl[turns]) > 0.9 * h]
    fine = [np.arange(coarse.time_s[i] - 4e-5, coarse.time_s[i] + 4e-5, fine_dt_s) for i in turns]
    t_out = np.unique(np.clip(np.concatenate([coarse.time_s, *fine]), 0.0, t_end))
    run = simulate_packed(p, sc, seg, t_end, x0, opts, output_times=t_out)
    in_contact = run.outputs[:, L.O_TORQUE] != 0.0
    onsets = np.flatnonzero(in_contact[1:] & ~in_contact[:-1]) + 1
    ends = np.flatnonzero(in_contact[:-1] & ~in_contact[1:]) + 1
    ends = np.array([ends[ends > i][0] if np.any(ends > i) else len(in_contact) for i in onsets], dtype=int)
    peaks = np.array([i + int(np.argmax(np.abs(run.outputs[i:j, L.O_TORQUE]))) for i, j in zip(onsets, ends)],
                     dtype=int)
    on_grid = coarse.outputs[:, L.O_TORQUE] != 0.0
    return {"run": run, "impacts": coarse.impacts, "impacts_traced_run": run.impacts, "onsets": onsets,
            "ends": ends, "peaks": peaks, "visible_on_grid": int(np.sum(on_grid[1:] & ~on_grid[:-1])),
            "contact_s": math.pi / math.sqrt(k / jeff), "h": h}


def dubowsky_pair(results_dir: Path | None):
    """Appendix A: input gear forced along a sine (a massive input, driven by the torque
    that gives it theta = A sin(w t)), output gear free; count impacts, draw delta(t)
    and the contact torque with every contact the solver counts
    (:func:`dubowsky_trace`)."""
    tr = dubowsky_trace()
    run, n_imp, onsets, peaks, h = tr["run"], tr["impacts"], tr["onsets"], tr["peaks"], tr["h"]
    seen = len(onsets)
    if results_dir is not None:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from .report.io import save_figure_atomic
        torque_out = run.outputs[:, L.O_TORQUE]
        fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
        a1.plot(run.time_s, np.degrees(run.outputs[:, L.O_DELTA]), lw=0.7)
        for s in (-1, 1):
            a1.axhline(s * math.degrees(h), color="k", ls="--", lw=0.8)
        a1.plot(run.time_s[onsets], np.degrees(run.outputs[onsets, L.O_DELTA]), "v", ms=5, color="C3",
                label=f"contact onsets ({seen})")
        a1.legend(loc="lower right", fontsize=8)
        a1.set_ylabel("relative position delta (deg)")
        a1.set_title(f"Dubowsky impact pair: input on a {DUBOWSKY['freq']:g} Hz sine, output free; "
                     f"{n_imp} impacts")
        a2.plot(run.time_s, torque_out, lw=0.7, color="C3")
        a2.plot(run.time_s[peaks], torque_out[peaks], "o", ms=3, color="k",
                label=f"peak of each contact (~{tr['contact_s'] * 1e6:.1f} us long)")
        a2.legend(loc="lower right", fontsize=8)
        a2.set_ylabel("contact torque (N m)")
        a2.set_xlabel("time (s)")
        fig.tight_layout()
        save_figure_atomic(fig, results_dir / "validation" / "dubowsky_pair.png")
        plt.close(fig)
    return [check("Dubowsky impact pair: repeated impacts and chatter (Appendix A)",
                  run.ok and n_imp >= 2 * 3 and seen == n_imp, n_imp, ">= 6 (2 per input period)",
                  "impacts in 0.6 s (3 periods)",
                  f"the solver's count; {seen} contacts in the traced torque (the 20 us grid alone catches "
                  f"{tr['visible_on_grid']}: a contact lasts {tr['contact_s'] * 1e6:.1f} us); "
                  f"figure validation/dubowsky_pair.png")]


# --------------------------------------------------------------------- energy
def _energy(wm, wl, delta):
    pen = np.where(delta > H, delta - H, np.where(delta < -H, delta + H, 0.0))
    return 0.5 * JM * wm ** 2 + 0.5 * JL * wl ** 2 + 0.5 * K_MESH * pen ** 2


def _bouncing(d, v=1.0):
    p = free_pair(JM, JL, N_GEAR, H, K_MESH, d)
    wm0 = v / (1.0 / N_GEAR + N_GEAR * JM / JL)
    x0 = np.zeros(L.N_STATE)
    x0[L.X_WM] = wm0
    x0[L.X_WL] = -N_GEAR * JM * wm0 / JL
    return p, x0


def check_energy(tol=1e-6):
    p, x0 = _bouncing(0.0)
    e0 = _energy(x0[L.X_WM], x0[L.X_WL], x0[L.X_DELTA])
    run = simulate_packed(p, _scales(1.0), ZERO, 110 * 2 * H, x0,
                          SolverOptions(rtol=1e-10, output_dt_s=1e-6))
    o, xe = run.outputs, run.meta["x_end"]
    e = _energy(o[:, L.O_WM], o[:, L.O_WL], o[:, L.O_DELTA]) / e0
    drift = float(max(np.abs(e - 1).max(), abs(_energy(xe[L.X_WM], xe[L.X_WL], xe[L.X_DELTA]) / e0 - 1)))
    out = [check("energy kept without damping (rtol 1e-10)", run.impacts >= 100 and drift <= tol,
                 drift, tol, "relative drift", f"{run.impacts} impacts")]
    d = 2.0 * 0.05 * math.sqrt(K_MESH * J_EFF)
    p, x0 = _bouncing(d)
    run = simulate_packed(p, _scales(1.0), ZERO, 5e-3, x0, SolverOptions(rtol=1e-9, output_dt_s=1e-8))
    o = run.outputs
    e = _energy(o[:, L.O_WM], o[:, L.O_WL], o[:, L.O_DELTA]) / e0
    rise = float((e - np.minimum.accumulate(e)).max())
    out.append(check("energy never rises with mesh damping (zeta 0.05)", rise <= 1e-9 and e[-1] < 0.9,
                     rise, 1e-9, "largest rise / E0",
                     f"{run.impacts} impacts, energy fell to {e[-1]:.3g} of E0"))
    return out


# ----------------------------------------------------------- Table I helpers
def _table(exp, quick, cells, method=None, plant=None, rtol=None):
    from .runner import load_profiles
    profiles = load_profiles(exp)
    specs = exp.runs()
    if quick:
        specs = [s for s in specs if s[0] in quick["profiles"]][:cells]
    solver = replace(exp.solver, method=method or exp.solver.method, output_dt_s=exp.duration_s,
                     rtol=rtol or exp.solver.rtol)
    out = []
    for prof, ctrl in specs:
        t0 = time.perf_counter()
        r = simulate(plant or exp.plant, ctrl, profiles[prof].segments(), exp.duration_s, solver)
        out.append(((prof, ctrl.kind, ctrl.kp, ctrl.shift), r, time.perf_counter() - t0))
    return out


def check_frequencies(cfg, base, exp, quick):
    tol = cfg["expected"]["frequency_tolerance"]
    info = plant_info(load_plant(base / cfg["plant"]))
    info_s = plant_info(load_plant(base / cfg["plant_with_shaft"]))
    fm, fs = info["mesh_frequency_hz"], info_s["shaft_frequency_hz"]
    em, es = cfg["expected"]["mesh_frequency_hz"], cfg["expected"]["shaft_frequency_hz"]
    out = [check("mesh mode of the engaged plant (eigenvalues)", abs(fm / em - 1) <= tol, fm, em, "Hz",
                 f"within {tol:.0%}"),
           check("shaft mode of the engaged plant with shaft", abs(fs / es - 1) <= tol, fs, es, "Hz",
                 f"within {tol:.0%}; mesh mode with shaft {info_s['mesh_frequency_hz']:.4g} Hz")]
    shaft_plant = load_plant(base / cfg["plant_with_shaft"])
    a = _table(exp, quick, quick and quick["cells"])
    b = _table(exp, quick, quick and quick["cells"], plant=shaft_plant)
    rel = [abs(rb.iae_deg_s / ra.iae_deg_s - 1) for (_, ra, _), (_, rb, _) in zip(a, b)]
    worst = int(np.argmax(rel))
    lim = cfg["expected"]["shaft_iae_tolerance"]
    out.append(check("Table I IAE with vs without the shaft (max over cells)",
                     max(rel) < lim and all(r.ok for _, r, _ in a + b), max(rel), lim, "relative",
                     f"{len(rel)} cells; worst {a[worst][0]}; median {np.median(rel):.2e}"))
    return out, a


def _agreement(a, b, lim):
    rel = [abs(ra.iae_deg_s / rb.iae_deg_s - 1) for (_, ra, _), (_, rb, _) in zip(a, b)]
    fails = [f"{k[0]} {k[1]}{'' if k[1] == 'bang_bang' else ' %g' % k[2]} shift-{'on' if k[3] else 'off'}: {r:.2%}"
             for (k, _, _), r in zip(a, rel) if r > lim]
    ok = max(rel) <= lim and all(r.ok for _, r, _ in a + b)
    return ok, max(rel), a[int(np.argmax(rel))][0], fails


def check_solvers(cfg, exp, quick, stiff=None):
    """Both stiff methods against dopri5 on every Table I cell, at ``solver_rtol``
    (tight enough that each method resolves the shifted cells' small speed
    reversals) and, informational, at the experiment's own rtol; run times at the
    experiment's rtol (the thesis's claim: ODE23s much faster than ODE45)."""
    cells = quick and quick["cells"]
    lim = cfg["expected"]["solver_iae_tolerance"]
    rt = cfg["expected"]["solver_rtol"]
    method = exp.solver.method
    out = []
    explicit = _table(exp, quick, cells, method="dopri5", rtol=rt)
    for name, m in ((f"{method} (stiff, default)", method), ("rosenbrock23 (ode23s)", "rosenbrock23")):
        ok, worst, cell, fails = _agreement(_table(exp, quick, cells, method=m, rtol=rt), explicit, lim)
        out.append(check(f"{name} vs dopri5 (ode45) at rtol {rt:g}, every Table I cell", ok, worst, lim,
                         "relative IAE", f"{'%d cells' % (cells or 30)}; worst {cell}; over the limit: {fails or 'none'}"))
    a = stiff or _table(exp, quick, cells)
    b = _table(exp, quick, cells, method="dopri5")
    c = _table(exp, quick, cells, method="rosenbrock23")
    ok, worst, cell, fails = _agreement(a, b, lim)
    out.append(check(f"{method} vs dopri5 at the experiment's rtol {exp.solver.rtol:g} (informational)", ok, worst,
                     lim, "relative IAE",
                     f"worst {cell}; over the limit: {fails or 'none'}; at this rtol a shifted, chattering cell "
                     f"turns on speed reversals the explicit method resolves differently (noise-driven flips)"))
    ta, tb, tc = (sum(w for *_, w in t) for t in (a, b, c))
    steps = [sum(r.steps for _, r, _ in t) for t in (a, b, c)]
    out.append(check("run time: ode23s faster than ode45 (thesis)", tc < tb, tc, tb, "s (ode23s vs ode45, total)",
                     f"at rtol {exp.solver.rtol:g}: ode45 / ode23s = {tb / tc:.1f}x; {method}: {ta:.2f} s "
                     f"({tb / ta:.1f}x faster than ode45); steps {method} {steps[0]}, ode23s {steps[2]}, "
                     f"ode45 {steps[1]}"))
    return out


def _converge(exp, cfg, rtols, method):
    from .runner import load_profiles
    c = cfg["convergence"]
    prof = load_profiles(replace(exp, profiles=(c["profile"],)))[c["profile"]]
    ctrl = Controller(**c["controller"])
    iae = []
    for rt in rtols:
        r = simulate(exp.plant, ctrl, prof.segments(), exp.duration_s,
                     replace(exp.solver, rtol=rt, method=method, output_dt_s=exp.duration_s))
        iae.append(r.iae_deg_s)
    d = np.abs(np.diff(iae))
    return iae, d, d[:-1] / np.maximum(d[1:], 1e-300)


def check_convergence(cfg, exp, rtols, rtols_low, results_dir, with_dopri=True):
    target = cfg["expected"]["convergence_ratio"]
    method = exp.solver.method
    # Judged as the test suite judges it (tests/test_physics.py): against a
    # reference two decades tighter, by the mean rate and an envelope, because a
    # single decade of a non-smooth run is erratic (errors of either sign cancel,
    # and the last difference nears the floor of event location and round-off).
    ref_rtol = rtols[-1] * 1e-2
    (*iae, ref), d, _ = _converge(exp, cfg, list(rtols) + [ref_rtol], method)
    d = d[:-1]
    err = np.abs(np.array(iae) - ref)
    mean_rate = float((err[0] / err[-1]) ** (1.0 / (len(err) - 1)))
    envelope = 10.0 * err[0] * np.array(rtols) / rtols[0]
    detail = (f"rtols {list(rtols)} against {ref_rtol:g}; IAE {[round(v, 10) for v in iae]} (reference "
              f"{ref:.10f}) deg s; errors {['%.2g' % e for e in err]}, per decade "
              f"{[round(float(r), 2) for r in err[:-1] / err[1:]]}")
    out = [check(f"convergence of profile-3 bang-bang IAE, {method}, mean >= 5x per decade of rtol",
                 mean_rate >= target, round(mean_rate, 3), target, "mean shrink ratio per decade",
                 f"{detail}; a 4th-order method whose error estimate controls h^4: global error ~ rtol, "
                 f"nominally 10x per decade"),
           check(f"convergence of profile-3 bang-bang IAE, {method}, inside the envelope 10 err(rtol0) rtol/rtol0",
                 bool(np.all(err <= envelope)), round(float(np.max(err / envelope)), 4), 1.0,
                 "largest error / envelope", detail)]
    iae2, d2, ratios2 = _converge(exp, cfg, rtols_low, "rosenbrock23")
    order = 10 ** (2 / 3)
    out.append(check("same with ode23s, against its order bound 10^(2/3) (x0.85), after the first decade",
                     bool(np.all(ratios2[1:] >= 0.85 * order)) and bool(np.all(ratios2 > 1)),
                     [round(float(r), 3) for r in ratios2], round(0.85 * order, 3), "shrink ratio per decade",
                     f"rtols {rtols_low}; IAE {[round(v, 8) for v in iae2]} deg s; ode23s is 2nd order with an "
                     f"error estimate controlling h^3, so its global error ~ rtol^(2/3): at most {order:.2f}x "
                     f"per decade, never the 5x above; the first decade is pre-asymptotic"))
    series = {method: (rtols, d), "ode23s": (rtols_low, d2)}
    if with_dopri:
        iae5, d5, r5 = _converge(exp, cfg, rtols_low, "dopri5")
        series["ode45"] = (rtols_low, d5)
        out.append(check("same with dopri5 (5th order): >= 5x per decade",
                         bool(np.all(r5 >= target)), [round(float(r), 3) for r in r5], target,
                         "shrink ratio per decade", f"rtols {rtols_low}; IAE {[round(v, 8) for v in iae5]} deg s"))
    if results_dir is not None:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from .report.io import save_figure_atomic
        fig, ax = plt.subplots(figsize=(6, 4))
        for name, (rt, dd) in series.items():
            ax.loglog(rt[1:], np.maximum(dd, 1e-16), "o-", label=name)
        ax.loglog(rtols[1:], d[0] * np.array(rtols[1:]) / rtols[1], "k--", label="rtol^1")
        ax.loglog(rtols_low[1:], d2[0] * (np.array(rtols_low[1:]) / rtols_low[1]) ** (2 / 3), "k:",
                  label="rtol^(2/3)")
        ax.set_xlabel("rtol")
        ax.set_ylabel("|IAE(rtol) - IAE(rtol*10)| (deg s)")
        ax.set_title("profile 3, bang-bang: convergence")
        ax.legend()
        ax.grid(alpha=0.3, which="both")
        fig.tight_layout()
        save_figure_atomic(fig, results_dir / "validation" / "convergence.png")
        plt.close(fig)
    return out


def check_motor(plant, volts=6.0):
    m = plant.motor
    b = plant.driven_damping
    w = m.torque_constant * volts / (m.resistance * b + m.torque_constant * m.back_emf_constant)
    i = b * w / m.torque_constant
    run = simulate(plant, Controller("open"), Segments(np.array([0.0]), np.array([volts]), np.array([0.0])),
                   0.1, SolverOptions(output_dt_s=1e-3))
    xe = run.meta["x_end"]
    return [check(f"motor steady speed at {volts:g} V", abs(xe[L.X_WM] / w - 1) <= 1e-4, float(xe[L.X_WM]), w,
                  "rad/s", "w = kt V / (R b + kt ke), b = bm + bl/N^2"),
            check(f"motor steady current at {volts:g} V", abs(xe[L.X_I] / i - 1) <= 1e-4, float(xe[L.X_I]), i,
                  "A", "i = b w / kt")]


def run_all(config: Path, results_dir: Path | None, quick: bool = False, progress=None) -> list[dict]:
    cfg = read_yaml(config)
    base = Path(config).parent
    exp = load_experiment(base / cfg["table1"])
    q = cfg["quick"] if quick else None
    rtols = (q if quick else cfg["convergence"])["rtols"]
    rtols_low = (q if quick else cfg["convergence"])["rtols_low_order"]
    say = progress or (lambda s: None)
    checks = []
    say("contact law")
    checks += check_contact_law()
    say("Dubowsky pair")
    checks += dubowsky_pair(results_dir)
    say("energy")
    checks += check_energy(cfg["expected"]["energy_drift"])
    say("natural frequencies and the shaft")
    c3, stiff = check_frequencies(cfg, base, exp, q)
    checks += c3
    say("solver agreement (dopri5, ode23s)")
    checks += check_solvers(cfg, exp, q, stiff)
    say("convergence")
    checks += check_convergence(cfg, exp, rtols, rtols_low, results_dir, with_dopri=not quick)
    say("motor")
    checks += check_motor(exp.plant)
    return checks


def markdown(checks: list[dict], quick: bool) -> str:
    def fmt(v):
        if isinstance(v, float):
            return f"{v:.6g}"
        return str(v)
    lines = ["# gearbench validate", "",
             f"Set: {'quick (reduced)' if quick else 'full'}. Regenerate with `gearbench validate`"
             f"{' --quick' if quick else ''}.", "",
             "| check | passed | measured | expected | unit | note |", "|---|---|---|---|---|---|"]
    for c in checks:
        lines.append(f"| {c['name']} | {'PASS' if c['passed'] else 'FAIL'} | {fmt(c['measured'])} | "
                     f"{fmt(c['expected'])} | {c['unit']} | {c.get('note', '')} |")
    failed = [c["name"] for c in checks if not c["passed"]]
    notes = [text for prefix, text in WHY_IT_FAILS if any(n.startswith(prefix) for n in failed)]
    if notes:
        lines += ["", "## Why the failing checks fail", ""] + [f"- {t}" for t in notes]
    return "\n".join(lines) + "\n"


# What a failure of each check means; shown only for checks that failed (the
# numbers are in the table above, measured on this run).
WHY_IT_FAILS = [
    ("same with dopri5",
     "**Convergence with dopri5**: the IAE differences reach the event-location and round-off "
     "floor within a few decades, after which their ratios are noise."),
    ("rodas4 vs dopri5 at the experiment's rtol",
     "**Stiff vs explicit at the experiment's rtol**: with the thesis shift, a chattering cell turns on "
     "motor-speed reversals smaller than what either method resolves at this tolerance; the explicit method's "
     "noise near zero speed flips the shift where the stiff one does not. At the tight rtol of the "
     "row above both resolve them and agree."),
    ("rosenbrock23 (ode23s) vs dopri5",
     "**ode23s vs ode45 within 0.5%**: a cell whose IAE depends on chatter (a set-point shift "
     "flipping at every overshoot) is sensitive to any perturbation, the solver included."),
    ("Table I IAE with vs without the shaft",
     "**Table I with vs without the shaft < 1%**: cells that chatter under the set-point "
     "shift are sensitive to any change of the plant, the shaft's 600 Hz mode included; the "
     "note column names the worst cell and the median over all cells."),
]

