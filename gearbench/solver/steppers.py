"""One-step methods, compiled.  Each takes one step and reports an error norm;
accepting, rejecting and choosing the next step is the controller's job
(``integrate.py``), as in diffrax.

* ``rosenbrock23``: the modified Rosenbrock triple of Shampine & Reichelt
  (1997), MATLAB/Simulink's ``ode23s``: second order, L-stable, a third-order
  error estimate.  L-stability lets it step straight over the stiff mesh mode
  while the teeth stay in contact.  Only the block of the states the
  right-hand side reads is inverted; the others (the error integrals, states
  this plant and controller never read) feed nothing back and are solved by
  substitution (``_solve``).
* ``rodas4``: the L-stable, stiffly accurate Rosenbrock method RODAS of
  Hairer & Wanner (Solving ODEs II, section IV.7; coefficients of their
  ``rodas.f``, method 1): fourth order, six stages, an embedded third-order
  solution for the error estimate.  Per step it costs the same Jacobian and one
  inverse as ``rosenbrock23`` and four more right-hand sides, but its error falls
  as h^4 instead of h^2, so it needs far fewer steps at tight tolerances and
  its global error shrinks nominally 10x per decade of tolerance (ode23s: 4.6x).
* ``dopri5``: Dormand & Prince 5(4), explicit, for cross-checks (it pays for
  the mesh frequency at every step).

All return the derivative at the step's end (the next step's first stage) and
the end slopes of a cubic interpolant over the step (``hermite``), on which the
integration loop locates events and samples the output.  The Jacobian is the
caller's (``jacobian``): the loop decides when it can be reused.
"""
import math

import numba as nb

from .model import state_count


EPS = 2.220446049250313e-16
WS_ROWS = 11  # scratch vectors every stepper fits in
D_ROS = 1.0 / (2.0 + math.sqrt(2.0))
E32 = 6.0 + math.sqrt(2.0)


@nb.njit(cache=True, _nrt=False)
def error_norm(err, y0, y1, rtol, atol):
    """Max over components of ``|err| / (atol + rtol max(|y0|, |y1|))``."""
    e = 0.0
    for i in range(err.shape[0]):
        sc = atol[i] + rtol * max(abs(y0[i]), abs(y1[i]))
        r = abs(err[i]) / sc
        if r > e:
            e = r
    return e


@nb.njit(cache=True, _nrt=False)
def hermite(theta, h, y0, f0, y1, f1, out):
    """Cubic Hermite interpolant at ``t0 + theta h`` with end slopes ``f0``, ``f1``
    (per unit time: the derivatives, or a method's own dense output recast)."""
    t2 = theta * theta
    t3 = t2 * theta
    h00 = 2.0 * t3 - 3.0 * t2 + 1.0
    h10 = t3 - 2.0 * t2 + theta
    h01 = -2.0 * t3 + 3.0 * t2
    h11 = t3 - t2
    for i in range(y0.shape[0]):
        out[i] = h00 * y0[i] + h10 * h * f0[i] + h01 * y1[i] + h11 * h * f1[i]


@nb.njit(_nrt=False)
def jacobian(m, t, y, f0, p, modes, ref0, slope, scale, region, lin, ytmp, ftmp, fb, states, count):
    """Forward-difference Jacobian over the feedback states ``order[:na]``
    (``m.feedback``): ``jac[a, i] = d f_i / d y_order[a]``.  The other states
    feed nothing back (the geartrain's quadratures, a shaft's twist without a
    shaft, the integrator of a P controller), so their columns are exactly zero
    and are not evaluated.  Also the time derivative ``tdot = d f / d t``
    through the input's slope.

    A difference never straddles a kink between two of the model's affine
    pieces (``m.region``; the geartrain's: the side of the amplifier's limit):
    where the forward point lies off ``region`` (the piece the step is on), the
    backward one is used, so a reused Jacobian never mixes two pieces.  On the
    kink itself, after a located event, ``region`` is the piece the solution is
    heading to and ``y`` may lie a round-off off it (a command of 12 + 8e-11 V
    clipped to 12 V while heading inside): then ``f0`` is of the other piece,
    and each difference is taken between two points on ``region``'s side,
    ``y + dy`` and ``y + 2 dy`` (profile 1, P Kp = 50, rtol 1e-7: ``f0``'s
    piece put a 1.4e-5 relative error into d(di/dt)/d(theta_m), and the reused
    Jacobian held the 3 s ramp to 0.5 ms steps, 6116 in all against 707 at
    rtol 3e-7).  Writes ``lin``'s ``jac`` and ``tdot``; ``ytmp``, ``ftmp``,
    ``fb``: scratch; returns the right-hand-side evaluations spent.

    With ``count`` >= 0 only the columns along ``states[:count]`` are taken
    again (the model's ``curved`` ones), the others and ``tdot`` kept."""
    na, order, tdot = lin[1].shape[0], lin[2], lin[3]
    base_off = m.region(m.args, y, p, modes, ref0) != region
    nfe = 0
    for a in range(na):
        if count < 0:
            nfe += _column(m, a, y, f0, p, modes, ref0, scale, region, base_off, lin, ytmp, ftmp, fb)
        else:
            for c in range(count):
                if order[a] == states[c]:
                    nfe += _column(m, a, y, f0, p, modes, ref0, scale, region, base_off, lin, ytmp, ftmp, fb)
    if count >= 0:
        return nfe
    n = state_count(m)
    if slope != 0.0:
        dt = math.sqrt(EPS) * max(abs(t), 1.0)
        if m.region(m.args, y, p, modes, ref0 + slope * dt) != region:
            dt = -dt
        m.rhs(m.args, y, p, modes, ref0 + slope * dt, ftmp)
        nfe += 1
        base = f0
        if base_off:
            for i in range(n):
                fb[i] = ftmp[i]
            base = fb
            m.rhs(m.args, y, p, modes, ref0 + 2.0 * slope * dt, ftmp)
            nfe += 1
        for i in range(n):
            tdot[i] = (ftmp[i] - base[i]) / dt
    else:
        for i in range(n):
            tdot[i] = 0.0
    return nfe


@nb.njit(inline="always", _nrt=False)
def _column(m, a, y, f0, p, modes, ref0, scale, region, base_off, lin, ytmp, ftmp, fb):
    """Column ``a`` of ``jacobian`` (the derivative along state ``order[a]``) by a difference on
    ``region``'s side; returns the right-hand-side evaluations spent."""
    jac, order = lin[0], lin[2]
    n = state_count(m)
    j = order[a]
    for i in range(n):
        ytmp[i] = y[i]
    dy = math.sqrt(EPS) * max(abs(y[j]), scale[j])
    ytmp[j] = y[j] + dy
    if m.region(m.args, ytmp, p, modes, ref0) != region:
        ytmp[j] = y[j] - dy
    dy = ytmp[j] - y[j]
    m.rhs(m.args, ytmp, p, modes, ref0, ftmp)
    nfe = 1
    base = f0
    if base_off:  # y + dy is the base, y + 2 dy the other point
        for i in range(n):
            fb[i] = ftmp[i]
        base = fb
        ytmp[j] = y[j] + 2.0 * dy
        m.rhs(m.args, ytmp, p, modes, ref0, ftmp)
        nfe += 1
    for i in range(n):
        jac[a, i] = (ftmp[i] - base[i]) / dy
    return nfe


@nb.njit(cache=True, _nrt=False)
def _factor(jac, order, diag, w):
    """Invert ``W = diag I - J`` restricted to the feedback states: ``w`` is
    na x 2 na, and Gauss-Jordan elimination with partial pivoting on ``[W | I]``
    leaves ``W^-1`` in ``w[:, na:]``.  An explicit inverse, because each of a
    step's six solves is then a matrix-vector product whose rows are
    independent; forward and back substitution would chain every operation
    of a solve, and the stages are already a chain of solves."""
    na = w.shape[0]
    m2 = 2 * na
    for a in range(na):
        for b in range(na):
            w[a, b] = -jac[b, order[a]]
            w[a, na + b] = 0.0
        w[a, a] += diag
        w[a, na + a] = 1.0
    for k in range(na):
        m = k
        big = abs(w[k, k])
        for i in range(k + 1, na):
            if abs(w[i, k]) > big:
                big = abs(w[i, k])
                m = i
        if m != k:
            for j in range(k, m2):
                tmp = w[k, j]
                w[k, j] = w[m, j]
                w[m, j] = tmp
        inv = 1.0 / w[k, k]  # singular: inf, and the step's error norm rejects it
        for j in range(k, m2):
            w[k, j] *= inv
        for i in range(na):
            if i != k:
                c = w[i, k]
                if c != 0.0:
                    for j in range(k, m2):
                        w[i, j] -= c * w[k, j]


@nb.njit(cache=True, inline="always", _nrt=False)
def _solve(w, jac, order, diag, b, zb, z, out, n):
    """Solve ``(diag I - J) out = b``.  The feedback block is ``W`` (inverted by
    ``_factor``); the other rows are ``diag out_q - sum_a J[q, a] out_a = b_q``
    (their own columns are zero), solved by substitution.  ``zb``, ``z``:
    scratch (``na`` entries); ``n`` the number of states (the model's, a
    compile-time constant, so the loops unroll)."""
    na = w.shape[0]
    for a in range(na):
        zb[a] = b[order[a]]
    for a in range(na):
        s = 0.0
        for c in range(na):
            s += w[a, na + c] * zb[c]
        z[a] = s
    # the substitution, over every row at once (contiguous, so it vectorises;
    # the feedback rows it also fills are overwritten just after)
    inv = 1.0 / diag
    for i in range(n):
        out[i] = b[i]
    for a in range(na):
        za = z[a]
        for i in range(n):
            out[i] += jac[a, i] * za
    for i in range(n):
        out[i] *= inv
    for a in range(na):
        out[order[a]] = z[a]


@nb.njit(_nrt=False)
def rosenbrock23(m, t, y, f0, h, p, modes, ref0, slope, rtol, atol, ws, lin, ynew, fnew, s0, s1):
    """One ode23s step from ``(t, y)`` with ``f0 = f(t, y)``.

    ``ref(t) = ref0 + slope (t - t_seg)`` enters through ``ref0`` (the value at
    ``t``) and ``slope``.  Writes the new state and its derivative into
    ``ynew``/``fnew``, the end slopes of the step's cubic interpolant into
    ``s0``/``s1`` (see ``hermite``; here the derivatives themselves), and
    returns ``(error norm, rhs evaluations)``.
    ``m`` is the model (``solver.model.Model``): ``m.rhs`` gives the derivative.
    ``ws`` is a (WS_ROWS, n) scratch array; ``lin = (jac, w, order,
    tdot)`` holds the Jacobian and ``d f/d t`` of ``jacobian`` (taken by the
    caller, who decides when it can be reused), the scratch for ``W``'s
    inverse and the states' order (``feedback_states``).
    """
    jac, w, order, tdot = lin
    n = state_count(m)
    hd = h * D_ROS
    ytmp = ws[0]
    ftmp = ws[1]
    k1 = ws[3]
    k2 = ws[4]
    k3 = ws[5]
    f1 = ws[6]
    rhsv = ws[7]
    z = ws[10]
    zb = ws[2]
    # W = I - h d J, written as (1/(h d)) I - J to share the solver with RODAS
    diag = 1.0 / hd
    _factor(jac, order, diag, w)
    # k1 = W^-1 (f0 + h d T)
    for i in range(n):
        rhsv[i] = (f0[i] + hd * tdot[i]) * diag
    _solve(w, jac, order, diag, rhsv, zb, z, k1, n)
    for i in range(n):
        ytmp[i] = y[i] + 0.5 * h * k1[i]
    m.rhs(m.args, ytmp, p, modes, ref0 + slope * 0.5 * h, f1)
    # k2 = W^-1 (f1 - k1) + k1
    for i in range(n):
        rhsv[i] = (f1[i] - k1[i]) * diag
    _solve(w, jac, order, diag, rhsv, zb, z, k2, n)
    for i in range(n):
        k2[i] += k1[i]
        ynew[i] = y[i] + h * k2[i]
    m.rhs(m.args, ynew, p, modes, ref0 + slope * h, fnew)
    # k3 = W^-1 (f2 - e32 (k2 - f1) - 2 (k1 - f0) + h d T)
    for i in range(n):
        rhsv[i] = (fnew[i] - E32 * (k2[i] - f1[i]) - 2.0 * (k1[i] - f0[i]) + hd * tdot[i]) * diag
    _solve(w, jac, order, diag, rhsv, zb, z, k3, n)
    for i in range(n):
        ftmp[i] = h / 6.0 * (k1[i] - 2.0 * k2[i] + k3[i])
        s0[i] = f0[i]
        s1[i] = fnew[i]
    return error_norm(ftmp, y, ynew, rtol, atol), 2


# RODAS (Hairer & Wanner, rodas.f, METH = 1), in the form W = I/(gamma h) - J:
# stage i solves W k_i = f(t + c_i h, y + sum_j a_ij k_j) + h d_i f_t + sum_j c_ij k_j / h,
# and y_new = y + sum_j a_6j k_j + k_6 (stiffly accurate); k_6 is the error estimate.
R_GAMMA = 0.25
R_C2, R_C3, R_C4 = 0.386, 0.21, 0.63
R_D1, R_D2, R_D3, R_D4 = 0.25, -0.1043, 0.1035, -0.03620000000000023
R_A21 = 1.544
R_A31, R_A32 = 0.9466785280815826, 0.2557011698983284
R_A41, R_A42, R_A43 = 3.314825187068521, 2.896124015972201, 0.9986419139977817
R_A51, R_A52, R_A53, R_A54 = 1.221224509226641, 6.019134481288629, 12.53708332932087, -0.687886036105895
R_C21 = -5.6688
R_C31, R_C32 = -2.430093356833875, -0.2063599157091915
R_C41, R_C42, R_C43 = -0.1073529058151375, -9.594562251023355, -20.47028614809616
R_C51, R_C52, R_C53, R_C54 = 7.496443313967647, -10.24680431464352, -33.99990352819905, 11.7089089320616
R_C61, R_C62, R_C63, R_C64, R_C65 = (8.083246795921522, -7.981132988064893, -31.52159432874371,
                                     16.31930543123136, -6.058818238834054)
# dense output (rodas.f's D21..D35)
R_D21, R_D22, R_D23, R_D24, R_D25 = (10.12623508344586, -7.487995877610167, -34.80091861555747,
                                     -7.992771707568823, 1.025137723295662)
R_D31, R_D32, R_D33, R_D34, R_D35 = (-0.6762803392801253, 6.087714651680015, 16.43084320892478,
                                     24.76722511418386, -6.594389125716872)


@nb.njit(_nrt=False)
def rodas4(m, t, y, f0, h, p, modes, ref0, slope, rtol, atol, ws, lin, ynew, fnew, s0, s1):
    """One RODAS step (order 4, embedded 3, L-stable); same contract as ``rosenbrock23``."""
    jac, w, order, tdot = lin
    n = state_count(m)
    ytmp = ws[0]
    ftmp = ws[1]
    k1 = ws[3]
    k2 = ws[4]
    k3 = ws[5]
    k4 = ws[6]
    k5 = ws[7]
    k6 = ws[8]
    rhsv = ws[9]
    z = ws[10]
    zb = ws[2]
    diag = 1.0 / (R_GAMMA * h)
    _factor(jac, order, diag, w)
    hinv = 1.0 / h
    for i in range(n):
        rhsv[i] = f0[i] + h * R_D1 * tdot[i]
    _solve(w, jac, order, diag, rhsv, zb, z, k1, n)
    # stage 2
    for i in range(n):
        ytmp[i] = y[i] + R_A21 * k1[i]
    m.rhs(m.args, ytmp, p, modes, ref0 + slope * R_C2 * h, ftmp)
    for i in range(n):
        rhsv[i] = ftmp[i] + h * R_D2 * tdot[i] + hinv * R_C21 * k1[i]
    _solve(w, jac, order, diag, rhsv, zb, z, k2, n)
    # stage 3
    for i in range(n):
        ytmp[i] = y[i] + R_A31 * k1[i] + R_A32 * k2[i]
    m.rhs(m.args, ytmp, p, modes, ref0 + slope * R_C3 * h, ftmp)
    for i in range(n):
        rhsv[i] = ftmp[i] + h * R_D3 * tdot[i] + hinv * (R_C31 * k1[i] + R_C32 * k2[i])
    _solve(w, jac, order, diag, rhsv, zb, z, k3, n)
    # stage 4
    for i in range(n):
        ytmp[i] = y[i] + R_A41 * k1[i] + R_A42 * k2[i] + R_A43 * k3[i]
    m.rhs(m.args, ytmp, p, modes, ref0 + slope * R_C4 * h, ftmp)
    for i in range(n):
        rhsv[i] = ftmp[i] + h * R_D4 * tdot[i] + hinv * (R_C41 * k1[i] + R_C42 * k2[i] + R_C43 * k3[i])
    _solve(w, jac, order, diag, rhsv, zb, z, k4, n)
    # stage 5 (at t + h)
    ref1 = ref0 + slope * h
    for i in range(n):
        ytmp[i] = y[i] + R_A51 * k1[i] + R_A52 * k2[i] + R_A53 * k3[i] + R_A54 * k4[i]
    m.rhs(m.args, ytmp, p, modes, ref1, ftmp)
    for i in range(n):
        rhsv[i] = ftmp[i] + hinv * (R_C51 * k1[i] + R_C52 * k2[i] + R_C53 * k3[i] + R_C54 * k4[i])
    _solve(w, jac, order, diag, rhsv, zb, z, k5, n)
    # stage 6: from the embedded (third-order) solution to the fourth-order one
    for i in range(n):
        ytmp[i] += k5[i]
    m.rhs(m.args, ytmp, p, modes, ref1, ftmp)
    for i in range(n):
        rhsv[i] = ftmp[i] + hinv * (R_C61 * k1[i] + R_C62 * k2[i] + R_C63 * k3[i] + R_C64 * k4[i]
                                    + R_C65 * k5[i])
    _solve(w, jac, order, diag, rhsv, zb, z, k6, n)
    for i in range(n):
        ynew[i] = ytmp[i] + k6[i]
    m.rhs(m.args, ynew, p, modes, ref1, fnew)
    _rodas_dense(n, y, ynew, k1, k2, k3, k4, k5, hinv, s0, s1)
    return error_norm(k6, y, ynew, rtol, atol), 6


@nb.njit(cache=True, inline="always", _nrt=False)
def _rodas_dense(n, y, ynew, k1, k2, k3, k4, k5, hinv, s0, s1):
    """RODAS's own dense output, y0 (1 - th) + th (y1 + (1 - th) (c3 + th c4)), written
    as a cubic Hermite: its end slopes are (y1 - y0 + c3)/h and (y1 - y0 - c3 - c4)/h.
    Unlike the Hermite cubic through f0 and f1 it stays accurate for the stiff
    components across steps much longer than their time constants."""
    for i in range(n):
        c3 = R_D21 * k1[i] + R_D22 * k2[i] + R_D23 * k3[i] + R_D24 * k4[i] + R_D25 * k5[i]
        c4 = R_D31 * k1[i] + R_D32 * k2[i] + R_D33 * k3[i] + R_D34 * k4[i] + R_D35 * k5[i]
        dy = ynew[i] - y[i]
        s0[i] = (dy + c3) * hinv
        s1[i] = (dy - c3 - c4) * hinv


# Dormand-Prince 5(4) tableau
A21 = 1.0 / 5.0
A31, A32 = 3.0 / 40.0, 9.0 / 40.0
A41, A42, A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
A51, A52, A53, A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
A61, A62, A63, A64, A65 = 9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0
B1, B3, B4, B5, B6 = 35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0
E1, E3, E4, E5, E6, E7 = (71.0 / 57600.0, -71.0 / 16695.0, 71.0 / 1920.0,
                          -17253.0 / 339200.0, 22.0 / 525.0, -1.0 / 40.0)
C2, C3, C4, C5 = 0.2, 0.3, 0.8, 8.0 / 9.0


@nb.njit(_nrt=False)
def dopri5(m, t, y, f0, h, p, modes, ref0, slope, rtol, atol, ws, lin, ynew, fnew, s0, s1):
    """One Dormand-Prince 5(4) step; same contract as ``rosenbrock23``."""
    n = state_count(m)
    k2 = ws[0]
    k3 = ws[1]
    k4 = ws[2]
    k5 = ws[3]
    k6 = ws[4]
    yt = ws[5]
    err = ws[6]
    for i in range(n):
        yt[i] = y[i] + h * A21 * f0[i]
    m.rhs(m.args, yt, p, modes, ref0 + slope * C2 * h, k2)
    for i in range(n):
        yt[i] = y[i] + h * (A31 * f0[i] + A32 * k2[i])
    m.rhs(m.args, yt, p, modes, ref0 + slope * C3 * h, k3)
    for i in range(n):
        yt[i] = y[i] + h * (A41 * f0[i] + A42 * k2[i] + A43 * k3[i])
    m.rhs(m.args, yt, p, modes, ref0 + slope * C4 * h, k4)
    for i in range(n):
        yt[i] = y[i] + h * (A51 * f0[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i])
    m.rhs(m.args, yt, p, modes, ref0 + slope * C5 * h, k5)
    for i in range(n):
        yt[i] = y[i] + h * (A61 * f0[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i] + A65 * k5[i])
    m.rhs(m.args, yt, p, modes, ref0 + slope * h, k6)
    for i in range(n):
        ynew[i] = y[i] + h * (B1 * f0[i] + B3 * k3[i] + B4 * k4[i] + B5 * k5[i] + B6 * k6[i])
    m.rhs(m.args, ynew, p, modes, ref0 + slope * h, fnew)
    for i in range(n):
        err[i] = h * (E1 * f0[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * fnew[i])
        s0[i] = f0[i]
        s1[i] = fnew[i]
    return error_norm(err, y, ynew, rtol, atol), 6
