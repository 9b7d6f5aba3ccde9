"""The exact step of an affine right-hand side, by the matrix exponential.

Inside one mode and one affine piece a ``piecewise_linear`` model's right-hand side is
``f(x, t) = A x + c + g (t - t0)`` (``g = b slope``, ``b = df/dref``), and a step of ``h``
from ``x0`` (where ``f0 = f(x0, t0)``) is exactly

    x(h) = x0 + P1(h) f0 + P2(h) g,   P1(h) = h phi1(h A),  P2(h) = h^2 phi2(h A),

with ``phi1(z) = (e^z - 1)/z`` and ``phi2(z) = (e^z - 1 - z)/z^2`` (the exponential Euler
method, exact for affine right-hand sides: Hochbruck & Ostermann, Acta Numerica 2010).  A
replay's input is held between samples, so one ``h``, the sample time, serves most of a record:
``P1`` and ``P2`` are made once per mode, piece and step (:func:`phi`) and kept in a small
table (:func:`lookup`), and a step costs two matrix-vector products and one right-hand side.

Nothing here knows what the model is; the integrator (``integrate.py``) decides when such a
step may be taken and checks that no event lies inside it: the step's cubic interpolant, on
which events are located, must follow every guard to its exact midpoint (:func:`guards_followed`).
"""
import numba as nb

from .model import state_count

TAYLOR = 12
"""Terms of the series of ``e^X``, ``phi1``, ``phi2`` at ``||X||_1 <= 1/2`` (the remainder is
below ``0.5^13 / 13!`` = 2e-14 of the sum) before the doublings."""
DIFF_STEP = 1e-4
"""The columns of ``A`` and ``b`` are differences over this fraction of the state's scale (or
of its size): an affine function's differences are exact at any step, and a long one keeps
the rounding of ``f`` (the mesh's large, cancelling terms) out of ``A``."""
SLOTS = 8
"""Modes, pieces and steps whose ``P1``, ``P2`` a run keeps."""
GUARD_SHARE = 0.25
"""An exact step is kept only where its cubic interpolant misses each guard's exact midpoint
by less than this share of the guard's distance from zero (``guards_followed``)."""


@nb.njit(cache=True, _nrt=False)
def _matmul(a, b, out, n):
    for i in range(n):
        for j in range(n):
            s = 0.0
            for k in range(n):
                s += a[i, k] * b[k, j]
            out[i, j] = s


@nb.njit(cache=True, _nrt=False)
def phi(A, h, P, T, n):
    """``P[0], P[1] = P1(h), P2(h)`` and ``P[2], P[3]`` the same at ``h/2``, for the ``n x n``
    matrix ``A`` (``T``: 4 x n x n scratch).

    Scaling and squaring: with ``tau = h / 2^(s+1)`` small enough that ``||A tau||_1 <= 1/2``,
    the three series ``E = e^(A tau)``, ``P1``, ``P2`` at ``tau``; then ``s + 1`` doublings,
    ``P2(2t) = (I + E) P2(t) + t P1(t)``, ``P1(2t) = (I + E) P1(t)``, ``E(2t) = E(t)^2``."""
    norm = 0.0
    for j in range(n):
        c = 0.0
        for i in range(n):
            c += abs(A[i, j])
        norm = max(norm, c)
    s = 0
    tau = 0.5 * h
    while norm * tau > 0.5:
        tau *= 0.5
        s += 1
    X, E, Q, W = T[0], T[1], T[2], T[3]
    P1, P2 = P[0], P[1]
    # E = sum X^k/k!, P1 = tau sum X^k/(k+1)!, P2 = tau^2 sum X^k/(k+2)!, X^k in Q
    for i in range(n):
        for j in range(n):
            X[i, j] = A[i, j] * tau
            d = 1.0 if i == j else 0.0
            Q[i, j] = d
            E[i, j] = d
            P1[i, j] = tau * d
            P2[i, j] = 0.5 * tau * tau * d
    fact = 1.0
    for k in range(1, TAYLOR + 1):
        _matmul(X, Q, W, n)
        fact *= k
        for i in range(n):
            for j in range(n):
                q = W[i, j]
                Q[i, j] = q
                E[i, j] += q / fact
                P1[i, j] += tau * q / (fact * (k + 1))
                P2[i, j] += tau * tau * q / (fact * (k + 1) * (k + 2))
    for d in range(s + 1):
        if d == s:  # the half step: keep it
            for i in range(n):
                for j in range(n):
                    P[2, i, j] = P1[i, j]
                    P[3, i, j] = P2[i, j]
        _matmul(E, P2, W, n)
        for i in range(n):
            for j in range(n):
                P2[i, j] += W[i, j] + tau * P1[i, j]
        _matmul(E, P1, W, n)
        for i in range(n):
            for j in range(n):
                P1[i, j] += W[i, j]
        _matmul(E, E, W, n)
        for i in range(n):
            for j in range(n):
                E[i, j] = W[i, j]
        tau *= 2.0


@nb.njit(_nrt=False)
def affine_parts(m, x, f0, p, modes, ref, scale, region, order, na, A, b, ytmp, ftmp):
    """``A = df/dx`` (the columns of the states ``order[:na]`` the right-hand side reads; the
    others are zero) and ``b = df/dref`` at ``x``, by differences that stay on ``region``;
    returns the right-hand-side evaluations spent."""
    n = state_count(m)
    for i in range(n):
        for j in range(n):
            A[i, j] = 0.0
    for a in range(na):
        j = order[a]
        for i in range(n):
            ytmp[i] = x[i]
        dy = DIFF_STEP * max(abs(x[j]), scale[j])
        ytmp[j] = x[j] + dy
        if m.region(m.args, ytmp, p, modes, ref) != region:
            ytmp[j] = x[j] - dy
        dy = ytmp[j] - x[j]
        m.rhs(m.args, ytmp, p, modes, ref, ftmp)
        for i in range(n):
            A[i, j] = (ftmp[i] - f0[i]) / dy
    dr = DIFF_STEP * max(abs(ref), 1.0)
    if m.region(m.args, x, p, modes, ref + dr) != region:
        dr = -dr
    m.rhs(m.args, x, p, modes, ref + dr, ftmp)
    for i in range(n):
        b[i] = (ftmp[i] - f0[i]) / dr
    return na + 1


@nb.njit(cache=True, _nrt=False)
def lookup(keys, hs, modes, region, h):
    """The slot of ``keys`` (rows: the modes, then the piece; ``hs``: the step, NaN unused)
    made for these, or -1."""
    nm = modes.shape[0]
    for k in range(hs.shape[0]):
        if hs[k] != h:
            continue
        same = keys[k, nm] == region
        for i in range(nm):
            same = same and keys[k, i] == modes[i]
        if same:
            return k
    return -1


@nb.njit(cache=True, _nrt=False)
def store(keys, hs, fill, modes, region, h):
    """Claim the next slot (round robin, ``fill[0]``) for these modes, piece and step."""
    k = fill[0] % hs.shape[0]
    fill[0] += 1
    nm = modes.shape[0]
    for i in range(nm):
        keys[k, i] = modes[i]
    keys[k, nm] = region
    hs[k] = h
    return k


@nb.njit(_nrt=False)
def exact_step(m, x, f0, h, p, modes, ref0, slope, P, b, xn, fn, s0, s1, xm):
    """The step of ``h`` from ``(x, f0)`` with this slot's ``P`` (:func:`phi`) and ``b``: writes
    ``xn``, ``fn``, the end slopes of the step's cubic interpolant (the derivatives) and the exact
    midpoint ``xm``."""
    n = state_count(m)
    for i in range(n):
        a = x[i]
        c = x[i]
        for j in range(n):
            a += P[0, i, j] * f0[j]
            c += P[2, i, j] * f0[j]
        if slope != 0.0:
            for j in range(n):
                a += P[1, i, j] * b[j] * slope
                c += P[3, i, j] * b[j] * slope
        xn[i] = a
        xm[i] = c
    m.rhs(m.args, xn, p, modes, ref0 + slope * h, fn)
    for i in range(n):
        s0[i] = f0[i]
        s1[i] = fn[i]


@nb.njit(cache=True, _nrt=False)
def guards_followed(g0, g1, gm, gc):
    """Whether the step's cubic follows every guard closely enough to locate its events: the
    guards at the ends ``g0``, ``g1`` and at the exact midpoint ``gm`` on one side of zero, and
    the cubic's midpoint ``gc`` within :data:`GUARD_SHARE` of their least distance from it."""
    for j in range(g0.shape[0]):
        side = gm[j] >= 0.0
        if side != (g0[j] >= 0.0) or side != (g1[j] >= 0.0):
            return False
        margin = min(abs(g0[j]), abs(g1[j]), abs(gm[j]))
        if abs(gm[j] - gc[j]) > GUARD_SHARE * margin:
            return False
    return True
