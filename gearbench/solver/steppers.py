"""One-step methods, compiled.  Each takes one step and reports an error norm;
accepting, rejecting and choosing the next step is the controller's job
(``integrate.py``), as in diffrax.

* ``rosenbrock23``: the modified Rosenbrock triple of Shampine & Reichelt
  (1997), MATLAB/Simulink's ``ode23s``: second order, L-stable, a third-order
  error estimate.  L-stability lets it step straight over the stiff mesh mode
  while the teeth stay in contact.  The Jacobian is taken by finite differences
  over the dynamic states (the quadratures feed nothing back, so the linear
  system is block lower-triangular and only the dynamic block is factored).
* ``dopri5``: Dormand & Prince 5(4), explicit, for cross-checks (it pays for
  the mesh frequency at every step).

Both return the derivative at the step's end, so the step's cubic Hermite
interpolant can locate events and sample the output.
"""
import math

import numba as nb

from ..layout import N_DYN, N_STATE
from ..plant.rhs import rhs

EPS = 2.220446049250313e-16
D_ROS = 1.0 / (2.0 + math.sqrt(2.0))
E32 = 6.0 + math.sqrt(2.0)


@nb.njit(cache=True)
def lu_factor(a, piv):
    """In-place LU with partial pivoting of a small dense matrix."""
    n = a.shape[0]
    for k in range(n):
        m = k
        big = abs(a[k, k])
        for i in range(k + 1, n):
            if abs(a[i, k]) > big:
                big = abs(a[i, k])
                m = i
        piv[k] = m
        if m != k:
            for j in range(n):
                tmp = a[k, j]
                a[k, j] = a[m, j]
                a[m, j] = tmp
        if a[k, k] == 0.0:
            continue
        inv = 1.0 / a[k, k]
        for i in range(k + 1, n):
            a[i, k] *= inv
            f = a[i, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= f * a[k, j]


@nb.njit(cache=True)
def lu_solve(a, piv, b):
    """Solve in place with the factors of ``lu_factor``."""
    n = a.shape[0]
    for k in range(n):
        m = piv[k]
        if m != k:
            tmp = b[k]
            b[k] = b[m]
            b[m] = tmp
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= a[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= a[i, j] * b[j]
        b[i] = s / a[i, i]


@nb.njit(cache=True)
def error_norm(err, y0, y1, rtol, atol):
    """Max over components of ``|err| / (atol + rtol max(|y0|, |y1|))``."""
    e = 0.0
    for i in range(err.shape[0]):
        sc = atol[i] + rtol * max(abs(y0[i]), abs(y1[i]))
        r = abs(err[i]) / sc
        if r > e:
            e = r
    return e


@nb.njit(cache=True)
def hermite(theta, h, y0, f0, y1, f1, out):
    """Cubic Hermite interpolant at ``t0 + theta h``."""
    t2 = theta * theta
    t3 = t2 * theta
    h00 = 2.0 * t3 - 3.0 * t2 + 1.0
    h10 = t3 - 2.0 * t2 + theta
    h01 = -2.0 * t3 + 3.0 * t2
    h11 = t3 - t2
    for i in range(y0.shape[0]):
        out[i] = h00 * y0[i] + h10 * h * f0[i] + h01 * y1[i] + h11 * h * f1[i]


@nb.njit(cache=True)
def rosenbrock23(t, y, f0, h, p, modes, ref0, slope, rtol, atol, scale, ws, piv, ynew, fnew):
    """One ode23s step from ``(t, y)`` with ``f0 = f(t, y)``.

    ``ref(t) = ref0 + slope (t - t_seg)`` enters through ``ref0`` (the value at
    ``t``) and ``slope``.  Writes the new state and its derivative into
    ``ynew``/``fnew`` and returns ``(error norm, rhs evaluations)``.
    ``ws`` is a (8 + 2 N_DYN, N_STATE) scratch array, ``piv`` an int scratch of N_DYN.
    """
    n = N_STATE
    nd = N_DYN
    d = D_ROS
    hd = h * d
    ytmp = ws[0]
    ftmp = ws[1]
    tdot = ws[2]
    k1 = ws[3]
    k2 = ws[4]
    k3 = ws[5]
    f1 = ws[6]
    rhsv = ws[7]
    jac = ws[8:8 + nd]  # jac[j, i] = d f_i / d y_j  (row j: column j of J)
    # Jacobian by forward differences over the dynamic states
    for j in range(nd):
        for i in range(n):
            ytmp[i] = y[i]
        dy = math.sqrt(EPS) * max(abs(y[j]), scale[j])
        ytmp[j] = y[j] + dy
        dy = ytmp[j] - y[j]
        rhs(ytmp, p, modes, ref0, ftmp)
        for i in range(n):
            jac[j, i] = (ftmp[i] - f0[i]) / dy
    # time derivative through the set point
    nfe = nd
    if slope != 0.0:
        dt = math.sqrt(EPS) * max(abs(t), 1.0)
        rhs(y, p, modes, ref0 + slope * dt, ftmp)
        nfe += 1
        for i in range(n):
            tdot[i] = (ftmp[i] - f0[i]) / dt
    else:
        for i in range(n):
            tdot[i] = 0.0
    w = ws[8 + nd:8 + 2 * nd, :nd]
    for i in range(nd):
        for j in range(nd):
            w[i, j] = -hd * jac[j, i]
        w[i, i] += 1.0
    lu_factor(w, piv)
    # k1 = W^-1 (f0 + h d T)
    for i in range(n):
        rhsv[i] = f0[i] + hd * tdot[i]
    _block_solve(w, piv, jac, hd, rhsv, k1)
    for i in range(n):
        ytmp[i] = y[i] + 0.5 * h * k1[i]
    rhs(ytmp, p, modes, ref0 + slope * 0.5 * h, f1)
    # k2 = W^-1 (f1 - k1) + k1
    for i in range(n):
        rhsv[i] = f1[i] - k1[i]
    _block_solve(w, piv, jac, hd, rhsv, k2)
    for i in range(n):
        k2[i] += k1[i]
        ynew[i] = y[i] + h * k2[i]
    rhs(ynew, p, modes, ref0 + slope * h, fnew)
    # k3 = W^-1 (f2 - e32 (k2 - f1) - 2 (k1 - f0) + h d T)
    for i in range(n):
        rhsv[i] = fnew[i] - E32 * (k2[i] - f1[i]) - 2.0 * (k1[i] - f0[i]) + hd * tdot[i]
    _block_solve(w, piv, jac, hd, rhsv, k3)
    for i in range(n):
        ftmp[i] = h / 6.0 * (k1[i] - 2.0 * k2[i] + k3[i])
    return error_norm(ftmp, y, ynew, rtol, atol), nfe + 2


@nb.njit(cache=True)
def _block_solve(w, piv, jac, hd, b, out):
    """Solve ``[[W, 0], [-hd Jq, I]] z = b`` for the dynamic block ``W``."""
    n = N_STATE
    nd = N_DYN
    for i in range(n):
        out[i] = b[i]
    z = out[:nd]
    lu_solve(w, piv, z)
    for i in range(nd, n):
        s = out[i]
        for j in range(nd):
            s += hd * jac[j, i] * z[j]
        out[i] = s


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


@nb.njit(cache=True)
def dopri5(t, y, f0, h, p, modes, ref0, slope, rtol, atol, scale, ws, piv, ynew, fnew):
    """One Dormand-Prince 5(4) step; same contract as ``rosenbrock23``."""
    n = N_STATE
    k2 = ws[0]
    k3 = ws[1]
    k4 = ws[2]
    k5 = ws[3]
    k6 = ws[4]
    yt = ws[5]
    err = ws[6]
    for i in range(n):
        yt[i] = y[i] + h * A21 * f0[i]
    rhs(yt, p, modes, ref0 + slope * C2 * h, k2)
    for i in range(n):
        yt[i] = y[i] + h * (A31 * f0[i] + A32 * k2[i])
    rhs(yt, p, modes, ref0 + slope * C3 * h, k3)
    for i in range(n):
        yt[i] = y[i] + h * (A41 * f0[i] + A42 * k2[i] + A43 * k3[i])
    rhs(yt, p, modes, ref0 + slope * C4 * h, k4)
    for i in range(n):
        yt[i] = y[i] + h * (A51 * f0[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i])
    rhs(yt, p, modes, ref0 + slope * C5 * h, k5)
    for i in range(n):
        yt[i] = y[i] + h * (A61 * f0[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i] + A65 * k5[i])
    rhs(yt, p, modes, ref0 + slope * h, k6)
    for i in range(n):
        ynew[i] = y[i] + h * (B1 * f0[i] + B3 * k3[i] + B4 * k4[i] + B5 * k5[i] + B6 * k6[i])
    rhs(ynew, p, modes, ref0 + slope * h, fnew)
    for i in range(n):
        err[i] = h * (E1 * f0[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * fnew[i])
    return error_norm(err, y, ynew, rtol, atol), 6
