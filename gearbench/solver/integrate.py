"""The integration loop, compiled: step-size control, events, output, scores.

The input (set point, or the open-loop voltage) is a table of segments:
on ``[seg_t[k], seg_t[k+1])`` it is ``seg_v[k] + seg_s[k] (t - seg_t[k])``.
The loop integrates segment by segment, so a step never straddles a corner
or a jump of the input, and locates every mode switch inside a segment as an
event (``events.py``): it finds the guard's root on the step's cubic Hermite
interpolant, re-takes the step to land on it, switches the mode and restarts.
"""
import math

import numba as nb
import numpy as np

from ..control.laws import saturate
from ..layout import (COMP_THESIS, CTRL_BANGBANG, CTRL_OPEN, CTRL_SAMPLED_PV, P_REF_SLOPE, P_CTRL_GAIN, P_DELAY, P_KP, P_KV, P_N, P_COMP, P_SHIFT, G_BB_A, G_BB_B, G_ENTER_NEG, G_ENTER_POS, G_KINK, G_LEAVE, G_SAT, G_SHIFT, M_BB, M_CONTACT, M_SAT, M_SHIFT,
                      METHOD_DOPRI, METHOD_RODAS4, METHOD_ROSENBROCK, N_GUARDS, N_MODES,
                      N_OUT, N_STATE, N_STATS, O_CURRENT, O_DELTA, O_LOAD,
                      O_MOTOR, O_SETPOINT, O_TORQUE, O_VOLTAGE, O_WL, O_WM,
                      P_CTRL, P_VMAX, S_EVENTS, S_FEVALS, S_IAE, S_IMPACTS,
                      S_ISE, S_MAX_ERR, S_REJECTED, S_STATUS, S_STEPS,
                      S_SWITCHES, S_T_FAIL, S_T_SAT, STATUS_MAX_STEPS,
                      STATUS_NONFINITE, STATUS_STEP_TOO_SMALL, X_I, X_IAE,
                      X_ISE, X_DELTA, X_THM, X_WL, X_WM)
from ..plant.rhs import (applied_input, feedback_states, linear_region, load_angle, mesh_rate, mesh_torque,
                         piecewise_linear, quadrature_rows, rhs)
from .events import (apply_event, classify, classify_controller, classify_damping, continuous_law,
                     direction_of_segment, guards, saturation_reach)
from .steppers import WS_ROWS, dopri5, hermite, jacobian, rodas4, rosenbrock23


@nb.njit(cache=True, inline="always", _nrt=False)
def _root_inv(err, order_exp):
    """``err ** -order_exp``; the fourth root (RODAS) by square roots, which
    cost a fraction of ``pow`` in the step-size control of every step."""
    if order_exp == 0.25:
        return 1.0 / math.sqrt(math.sqrt(err))
    return err ** (-order_exp)


@nb.njit(cache=True, _nrt=False)
def _sign(v):
    return 1 if v > 0.0 else (-1 if v < 0.0 else 0)


@nb.njit(cache=True, _nrt=False)
def _step(method, t, x, f, h, p, modes, ref_t, s, rtol, atol, ws, lin, xn, fn, s0, s1):
    """One step of the chosen method (``layout.METHOD_*``): (error norm, rhs evaluations)."""
    if method == METHOD_RODAS4:
        return rodas4(t, x, f, h, p, modes, ref_t, s, rtol, atol, ws, lin, xn, fn, s0, s1)
    if method == METHOD_DOPRI:
        return dopri5(t, x, f, h, p, modes, ref_t, s, rtol, atol, ws, lin, xn, fn, s0, s1)
    return rosenbrock23(t, x, f, h, p, modes, ref_t, s, rtol, atol, ws, lin, xn, fn, s0, s1)


@nb.njit(cache=True, _nrt=False)
def _write_output(row, x, p, modes, ref, setpoint):
    row[O_SETPOINT] = setpoint
    row[O_LOAD] = load_angle(x, p)
    row[O_MOTOR] = x[X_THM]
    row[O_VOLTAGE] = applied_input(x, p, modes, ref)
    row[O_CURRENT] = x[X_I]
    row[O_WM] = x[X_WM]
    row[O_WL] = x[X_WL]
    row[O_TORQUE] = mesh_torque(x, p, modes)
    row[O_DELTA] = x[X_DELTA]


@nb.njit(cache=True, _nrt=False)
def _locate(j, g0j, t, hh, x, f, xn, fn, p, modes, ref_t, slope, xi, gt, hi0, lo0=0.0):
    """Root of guard ``j`` on the step's interpolant in ``(lo0, hi0]`` (Illinois),
    where the guard is ``g0j`` < 0 at ``lo0`` and >= 0 at ``hi0``; returns theta."""
    lo, hi = lo0, hi0
    glo, ghi = g0j, 1.0  # only the sign of ghi matters for bracketing
    if hi0 >= 1.0:
        guards(xn, p, modes, ref_t + slope * hh, gt)
    else:
        hermite(hi0, hh, x, f, xn, fn, xi)
        guards(xi, p, modes, ref_t + slope * hi0 * hh, gt)
    ghi = gt[j]
    tol = max(1e-13 * max(1.0, abs(t)) / hh, 1e-15)
    side = 0
    for _ in range(200):
        if hi - lo <= tol:
            break
        denom = ghi - glo
        th = hi - ghi * (hi - lo) / denom if denom != 0.0 else 0.5 * (lo + hi)
        if not (lo < th < hi):
            th = 0.5 * (lo + hi)
        hermite(th, hh, x, f, xn, fn, xi)
        guards(xi, p, modes, ref_t + slope * th * hh, gt)
        gm = gt[j]
        if gm >= 0.0:
            hi, ghi = th, gm
            if side == 1:
                glo *= 0.5
            side = 1
        else:
            lo, glo = th, gm
            if side == -1:
                ghi *= 0.5
            side = -1
    return hi


@nb.njit(cache=True, _nrt=False)
def _extrema(hh, x, f, xn, fn, idx, target, out, n):
    """Append to ``out[n:]`` the theta in (0, 1) where the slope of component
    ``idx`` on the step's cubic Hermite interpolant equals ``target``
    (``d y / d theta``, a quadratic); returns the new count (at most n + 2)."""
    dy = x[idx] - xn[idx]
    d0 = hh * f[idx]
    d1 = hh * fn[idx]
    a = 6.0 * dy + 3.0 * (d0 + d1)
    b = -6.0 * dy - 4.0 * d0 - 2.0 * d1
    c = d0 - target
    scale = abs(a) + abs(b) + abs(c)
    if scale == 0.0:
        return n
    if abs(a) <= 1e-12 * scale:
        if b != 0.0:
            r = -c / b
            if 0.0 < r < 1.0:
                out[n] = r
                n += 1
        return n
    disc = b * b - 4.0 * a * c
    if disc < 0.0:
        return n
    sq = math.sqrt(disc)
    q = -0.5 * (b + sq) if b >= 0.0 else -0.5 * (b - sq)
    r1 = q / a
    r2 = c / q if q != 0.0 else r1
    if 0.0 < r1 < 1.0:
        out[n] = r1
        n += 1
    if 0.0 < r2 < 1.0 and r2 != r1:
        out[n] = r2
        n += 1
    return n


@nb.njit(cache=True, _nrt=False)
def _resolved_impact(x, p, modes, atol):
    """1 if the contact that just began closed at an approach speed the error
    control resolves (above the load speed's absolute tolerance), else 0.

    While the train settles on a flank at zero force the teeth re-touch at
    approach speeds of ~1e-12 rad/s, rounding noise; those are not impacts.
    """
    return 1 if modes[M_CONTACT] * mesh_rate(x, p) > atol[X_WL] else 0


@nb.njit(cache=True, _nrt=False)
def _stale_contact(x, p, modes, ref, g):
    """Fill ``g`` with the guards at ``x``; return the contact guard that is
    already past zero in the current mode (the mode is stale), else -1."""
    guards(x, p, modes, ref, g)
    if modes[M_CONTACT] != 0:
        return G_LEAVE if g[G_LEAVE] > 0.0 else -1
    if g[G_ENTER_POS] > 0.0:
        return G_ENTER_POS
    if g[G_ENTER_NEG] > 0.0:
        return G_ENTER_NEG
    return -1


@nb.njit(cache=True)
def integrate(p, seg_t, seg_v, seg_s, seg_d, t_end, x0, t_out, rtol, atol, hmax, method, max_steps):
    """Integrate from rest state ``x0`` at t = 0 to ``t_end``.

    With the sampled controller (``CTRL_SAMPLED_PV``) the segments are its
    samples: ``seg_v`` the set point (rad), ``seg_d`` a disturbance added to its
    output after the saturation (V).  At each sample it reads the motor angle
    referred to the output, ``y = theta_m/N``, and computes (EMPS's law)

        yf_k = (y_k + y_{k-1})/2,   v_k = (yf_k - yf_{k-1})/Ts,
        c_k = Kv (Kp (r_k - y_k) - v_k)

    and holds ``G (sat(c_{k-1}) + d_k)`` until the next sample (with
    ``P_DELAY`` = 1; ``c_k`` without the delay; saturation at ``P_VMAX`` V,
    ``G = P_CTRL_GAIN`` input units per V).  Before t = 0 it is taken to have
    seen the initial speed, so a record that starts moving starts smoothly.

    Returns ``(outputs, stats, x_end, seg_u)``: ``outputs[len(t_out), N_OUT]``
    sampled on ``t_out`` (NaN past a failure), ``stats[N_STATS]``
    (``layout.S_*``), and the input held on each segment (the sampled
    controller's commands).
    """
    n = N_STATE
    outputs = np.full((t_out.size, N_OUT), np.nan)
    stats = np.zeros(N_STATS)
    x = x0.copy()
    order, na = feedback_states(p)
    lin = (np.empty((na, n)), np.empty((na, 2 * na)), order, np.empty(n))
    vecs = np.empty((6, n))
    work = (np.zeros(N_MODES, dtype=np.int64), np.empty((WS_ROWS, n)), np.empty((4, N_GUARDS)),
            np.empty(6), np.zeros(seg_t.size))
    _run(p, seg_t, seg_v, seg_s, seg_d, t_end, x0, x, t_out, rtol, atol, atol / rtol, hmax, method, max_steps,
         outputs, stats, lin, vecs[0], vecs[1], vecs[2], vecs[3], vecs[4], vecs[5], work)
    return outputs, stats, x, work[4]


@nb.njit(cache=True, _nrt=False)
def _run(p, seg_t, seg_v, seg_s, seg_d, t_end, x0, x, t_out, rtol, atol, scale, hmax, method, max_steps,
         outputs, stats, lin, f, xn, fn, s0, s1, xi, work):
    """The loop of ``integrate``, on arrays it allocated: compiled without
    numba's reference-counting runtime, whose atomic increments on every array
    view and call were 40 % of a step's time.  ``x`` (a copy of ``x0``) is
    advanced in place; ``s0``/``s1`` are the end slopes of each step's
    interpolant (``hermite``)."""
    n = N_STATE
    modes, ws, gg, thq, seg_u = work
    g0 = gg[0]
    g1 = gg[1]
    gt = gg[2]
    g2 = gg[3]
    jac = lin[0]
    order = lin[2]
    tdot = lin[3]
    na = lin[1].shape[0]
    # The Jacobian is taken again only when it may have changed: never for a
    # step re-taken from the same point (after a rejection, or to land on an
    # event), and for a piecewise-linear right-hand side only when the mode,
    # the segment or the saturation side changes (it is constant in between).
    implicit = method != METHOD_DOPRI
    linear = piecewise_linear(p)
    jac_ok = False
    jac_region = 0
    shift_on = p[P_SHIFT] > 0.0 and p[P_CTRL] != CTRL_OPEN and p[P_COMP] == COMP_THESIS
    bangbang = p[P_CTRL] == CTRL_BANGBANG
    sat_events = continuous_law(p)
    skip = -1  # a guard refused where it stands, ignored until time moves on
    vmax = p[P_VMAX]
    sampled = p[P_CTRL] == CTRL_SAMPLED_PV
    closed = p[P_CTRL] != CTRL_OPEN and not sampled
    # the sampled controller's memory, as if it had run before t = 0 at the initial speed
    ts0 = seg_t[1] - seg_t[0] if seg_t.size > 1 else 1.0
    w0 = x0[X_WM] / p[P_N]
    y_prev = x0[X_THM] / p[P_N] - w0 * ts0
    yf_prev = y_prev - 0.5 * w0 * ts0
    c_prev = 0.0
    keyed = closed and p[P_SHIFT] > 0.0 and p[P_COMP] != COMP_THESIS
    # step-size exponent: 1 / (order of the error estimate + 1)
    order_exp = 1.0 / 3.0 if method == METHOD_ROSENBROCK else (0.25 if method == METHOD_RODAS4 else 0.2)

    t = 0.0
    u0 = p[P_CTRL_GAIN] * seg_d[0] if sampled else seg_v[0]
    classify(x, p, modes, u0)
    io = 0
    while io < t_out.size and t_out[io] <= t:
        _write_output(outputs[io], x, p, modes, u0, seg_v[0])
        io += 1
    last_sign = _sign(applied_input(x, p, modes, u0))
    u_res = rtol * vmax
    h = min(hmax, 1e-5)
    max_err = 0.0
    t_sat = 0.0
    switches = 0
    impacts = 0
    nsteps = 0
    nrej = 0
    nev = 0
    nfe = 0
    status = 0
    nseg = seg_t.size
    for k in range(nseg):
        ta = seg_t[k]
        if ta >= t_end:
            break
        tb = seg_t[k + 1] if k + 1 < nseg else t_end
        tb = min(tb, t_end)
        if tb <= ta:
            continue
        v0 = seg_v[k]
        s = seg_s[k]
        r0 = v0
        t = ta
        if sampled:
            y = x[X_THM] / p[P_N]
            yf = 0.5 * (y + y_prev)
            ts = seg_t[k] - seg_t[k - 1] if k > 0 else (seg_t[1] - seg_t[0] if nseg > 1 else 1.0)
            c = p[P_KV] * (p[P_KP] * (v0 - y) - (yf - yf_prev) / ts)
            c_held = c_prev if p[P_DELAY] > 0.0 else c
            v0 = p[P_CTRL_GAIN] * (saturate(c_held, vmax) + seg_d[k])
            s = 0.0
            y_prev, yf_prev, c_prev = y, yf, c
        seg_u[k] = v0
        if keyed:
            # set-point-direction compensator: the shift's sign follows the
            # profile, known ahead segment by segment; it switches only here
            modes[M_SHIFT] = direction_of_segment(k, seg_t, seg_v, seg_s, modes[M_SHIFT])
        p[P_REF_SLOPE] = s  # the feedforward's set-point speed (the loop owns this slot)
        if closed:
            classify_controller(x, p, modes, v0)
            max_err = max(max_err, abs(v0 - load_angle(x, p)))
        rhs(x, p, modes, v0, f)
        nfe += 1
        jac_ok = False
        while t < tb:
            if nsteps + nrej + nev > max_steps:  # events too: no loop may spin without end
                status = STATUS_MAX_STEPS
                break
            hh = min(h, hmax)
            if sat_events:
                hh = saturation_reach(x, f, p, modes, v0 + s * (t - ta), s, hh, xi)
            last = hh >= (tb - t) * (1.0 - 1e-12)
            if last:
                hh = tb - t
            ref_t = v0 + s * (t - ta)
            if implicit:
                # a continuous law's side of the limit is its mode (on the limit
                # itself, after a saturation event, the side it is heading to)
                region = modes[M_SAT] if sat_events else linear_region(x, p, modes, ref_t)
                if not jac_ok or region != jac_region:
                    nfe += jacobian(t, x, f, p, modes, ref_t, s, scale, region, lin, ws[0], ws[1], ws[2])
                    jac_ok = True
                    jac_region = region
                quadrature_rows(x, p, ref_t, s, order, na, jac, tdot)
            err, ne = _step(method, t, x, f, hh, p, modes, ref_t, s, rtol, atol, ws, lin, xn, fn, s0, s1)
            nfe += ne
            if not (err <= 1.0):
                nrej += 1
                fac = 0.2 if not math.isfinite(err) else max(0.2, 0.9 * _root_inv(err, order_exp))
                h = hh * fac
                if h < 1e-14 * max(1.0, abs(t)):
                    status = STATUS_STEP_TOO_SMALL if math.isfinite(err) else STATUS_NONFINITE
                    break
                continue
            # the step is acceptable: did a guard fire inside it?
            guards(x, p, modes, ref_t, g0)
            guards(xn, p, modes, ref_t + s * hh, g1)
            which = -1
            theta = 1.0
            for j in range(N_GUARDS):
                if j != skip and g0[j] < 0.0 and g1[j] >= 0.0:
                    th = _locate(j, g0[j], t, hh, x, s0, xn, s1, p, modes, ref_t, s, xi, gt, 1.0)
                    if which < 0 or th < theta:
                        theta = th
                        which = j
                elif j != skip and g0[j] == 0.0 and g1[j] > 0.0:
                    # Already reached where the step starts: a step re-taken to
                    # land on a root can end a round-off short of it (-4e-19),
                    # and the set point recomputed for the next step puts the
                    # guard at exactly 0, which "< 0 to >= 0" would never see
                    # (profile 3, bang-bang, rtol 3e-7: the first switch went
                    # unseen for 22 ms, 0.06 deg s of IAE).
                    theta = 0.0
                    which = j
                elif j == skip and g1[j] >= 0.0:
                    # Refused where the step starts (at zero, turning back), the
                    # guard may still cross later in the step: find where it is
                    # back below zero and locate the crossing after that.
                    lo = 0.5
                    for _ in range(40):
                        hermite(lo, hh, x, s0, xn, s1, xi)
                        guards(xi, p, modes, ref_t + s * lo * hh, gt)
                        if gt[j] < 0.0:
                            break
                        lo *= 0.5
                    if gt[j] < 0.0:
                        th = _locate(j, gt[j], t, hh, x, s0, xn, s1, p, modes, ref_t, s, xi, gt, 1.0, lo)
                        if which < 0 or th < theta:
                            theta = th
                            which = j
            # A guard can cross and cross back inside one step: a graze (the
            # motor swings into a flank and back out: the teeth would pass
            # through each other), a motor speed that dips through zero (a
            # missed shift flip), an error that pokes out of the bang-bang
            # band.  Each guard is monotone in one state between that state's
            # extrema, so also test the guards at the interior extrema of
            # delta, of the motor speed and of the control error.
            nq = 0
            if modes[M_CONTACT] == 0:
                nq = _extrema(hh, x, s0, xn, s1, X_DELTA, 0.0, thq, nq)
            if shift_on:
                nq = _extrema(hh, x, s0, xn, s1, X_WM, 0.0, thq, nq)
            if bangbang:
                nq = _extrema(hh, x, s0, xn, s1, X_THM, s * hh * p[P_N], thq, nq)
            for q in range(nq):
                tq = thq[q]
                if which >= 0 and tq >= theta:
                    continue
                hermite(tq, hh, x, s0, xn, s1, xi)
                guards(xi, p, modes, ref_t + s * tq * hh, g2)
                for j in range(N_GUARDS):
                    if j != skip and g0[j] < 0.0 and g1[j] < 0.0 and g2[j] >= 0.0:
                        th = _locate(j, g0[j], t, hh, x, s0, xn, s1, p, modes, ref_t, s, xi, gt, tq)
                        if which < 0 or th < theta:
                            theta = th
                            which = j
                    elif j != skip and g0[j] == 0.0 and g2[j] > 0.0:
                        theta = 0.0  # reached where the step starts (as above)
                        which = j
            h_next = hh * min(5.0, max(0.2, 0.9 * _root_inv(max(err, 1e-10), order_exp)))
            if which >= 0:
                hs = theta * hh
                if hs < 1e-13 * max(1.0, abs(t)):
                    hs = 0.0
                elif theta < 1.0:
                    err, ne = _step(method, t, x, f, hs, p, modes, ref_t, s, rtol, atol, ws, lin, xn, fn, s0, s1)
                    nfe += ne
                    # The root was found on the long step's interpolant, whose
                    # error is not controlled; the re-taken step can end short
                    # of the crossing (teeth still apart by up to ~1e-8 rad).
                    # Switching the mode there engages the contact across an
                    # open gap (a torque in the dead zone, or a pull).  Then
                    # retry with the shorter step as a plain one: the next step
                    # finds the crossing again, from much closer.
                    guards(xn, p, modes, ref_t + s * hs, gt)
                    if gt[which] < 0.0:
                        nrej += 1
                        h = hs
                        continue
                hh = hs
                last = last and theta >= 1.0
                h_next = max(h, 1e-12 * max(1.0, abs(t)))
            if hh > 0.0:
                t1 = tb if last else t + hh
                # sample the outputs on (t, t1]
                while io < t_out.size and t_out[io] <= t1:
                    th = (t_out[io] - t) / hh
                    hermite(th, hh, x, s0, xn, s1, xi)
                    _write_output(outputs[io], xi, p, modes, v0 + s * (t_out[io] - ta),
                                  r0 if sampled else v0 + s * (t_out[io] - ta))
                    io += 1
                if closed and (modes[M_SAT] != 0 or modes[M_BB] != 0):
                    t_sat += hh  # the limit's crossings are events: a step is on one side
                for i in range(n):
                    x[i] = xn[i]
                    f[i] = fn[i]
                t = t1
                nsteps += 1
                jac_ok = jac_ok and linear
                ok = True
                for i in range(n):
                    if not math.isfinite(x[i]):
                        ok = False
                if not ok:
                    status = STATUS_NONFINITE
                    break
                if closed:
                    max_err = max(max_err, abs(ref_t + s * hh - load_angle(x, p)))
            if hh > 0.0:
                skip = -1
            if which >= 0:
                nev += 1
                m_contact, m_bb, m_shift = modes[M_CONTACT], modes[M_BB], modes[M_SHIFT]
                if apply_event(which, x, p, modes, v0 + s * (t - ta), xi):
                    impacts += _resolved_impact(x, p, modes, atol)
                rhs(x, p, modes, v0 + s * (t - ta), f)
                nfe += 1
                jac_ok = False
                if (hh == 0.0 and modes[M_CONTACT] == m_contact and modes[M_BB] == m_bb
                        and modes[M_SHIFT] == m_shift):
                    # Refused where it stands (a separation whose torque rate
                    # points back into contact) with no time gained: the same
                    # root would be found again forever.  Take the next step
                    # without this guard; the re-arm check below judges the
                    # contact again once time has moved.
                    skip = which
            # Re-arm the contact guards.  A guard fires only on a crossing from
            # < 0, so a guard of the current contact mode that is already > 0
            # here never fires: after a refused separation (the leave guard is
            # left at or just above 0) or an event applied a hair before its
            # root, the teeth would stay stuck pulling, or pass through each
            # other.  Such a mode is stale: switch it now (a separation still
            # goes through apply_event's refusal test, now at every step).
            # Only after a step that advanced time: an event applied where it
            # stands (hs = 0) is judged after the next step, else the two
            # could undo each other forever.
            ref_now = v0 + s * (t - ta)
            stale = _stale_contact(x, p, modes, ref_now, g2) if hh > 0.0 else -1
            cm = modes[M_CONTACT]
            if stale >= 0:
                if apply_event(stale, x, p, modes, ref_now, xi):
                    impacts += _resolved_impact(x, p, modes, atol)
                if modes[M_CONTACT] != cm:
                    nev += 1
                    rhs(x, p, modes, ref_now, f)
                    nfe += 1
                    jac_ok = False
            elif hh > 0.0 and g2[G_KINK] > 0.0:
                # ElastoBacklash's damping piece, stale the same way
                classify_damping(x, p, modes)
                nev += 1
                rhs(x, p, modes, ref_now, f)
                nfe += 1
                jac_ok = False
            # The controller's modes go stale the same way (a bang-bang switch
            # or a shift flip whose crossing a step hid): a bang-bang stuck on
            # drives the motor away at full voltage.  Their right mode follows
            # from the state alone, so re-derive it.
            # (a saturation side only past the solver's resolution, rtol Vmax: a
            # step landed on the limit is on it within round-off)
            if hh > 0.0 and (g2[G_BB_A] > 0.0 or g2[G_BB_B] > 0.0 or g2[G_SHIFT] > 0.0 or g2[G_SAT] > u_res):
                if g2[G_SHIFT] > 0.0:
                    apply_event(G_SHIFT, x, p, modes, ref_now, xi)  # flips, re-derives the bang-bang
                else:
                    classify_controller(x, p, modes, ref_now)
                nev += 1
                rhs(x, p, modes, ref_now, f)
                nfe += 1
                jac_ok = False
            u_now = applied_input(x, p, modes, v0 + s * (t - ta))
            if closed and not bangbang:
                # A continuous law at rest hovers at a voltage of round-off size
                # whose sign means nothing: count a change of sign only once the
                # voltage is past what the solver resolves, rtol * Vmax.
                sg = 1 if u_now > u_res else (-1 if u_now < -u_res else last_sign)
            else:
                sg = _sign(u_now)
            if sg != last_sign:
                switches += 1
                last_sign = sg
            h = h_next
        if status != 0:
            break
    stats[S_STATUS] = status
    stats[S_T_FAIL] = t
    stats[S_IAE] = x[X_IAE]
    stats[S_ISE] = x[X_ISE]
    stats[S_MAX_ERR] = max_err
    stats[S_T_SAT] = t_sat
    stats[S_IMPACTS] = impacts
    stats[S_SWITCHES] = switches
    stats[S_STEPS] = nsteps
    stats[S_REJECTED] = nrej
    stats[S_EVENTS] = nev
    stats[S_FEVALS] = nfe
