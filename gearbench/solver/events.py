"""Finding events inside an accepted step, compiled and model-agnostic.

A guard fires where it goes from < 0 to >= 0 (or from exactly 0 where a step
starts, which means it was reached already).  Its root is found on the
step's cubic Hermite interpolant (``steppers.hermite``) by the Illinois
method; the integration loop then re-takes the step to land on it.  A guard
can also cross and cross back inside one step (a graze: teeth that would
pass through each other); each guard is monotone in one state between that
state's extrema, so the guards are also tested at the interior extrema of the
components the model ``watch``-es.
"""
import math

import numba as nb

from .model import guard_count
from .steppers import hermite


@nb.njit(_nrt=False)
def locate(m, j, g0j, t, hh, x, f, xn, fn, p, modes, ref_t, slope, xi, gt, hi0, lo0=0.0):
    """Root of guard ``j`` on the step's interpolant in ``(lo0, hi0]`` (Illinois),
    where the guard is ``g0j`` < 0 at ``lo0`` and >= 0 at ``hi0``; returns theta."""
    lo, hi = lo0, hi0
    glo = g0j
    if hi0 >= 1.0:
        m.guards(m.args, xn, p, modes, ref_t + slope * hh, gt)
    else:
        hermite(hi0, hh, x, f, xn, fn, xi)
        m.guards(m.args, xi, p, modes, ref_t + slope * hi0 * hh, gt)
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
        m.guards(m.args, xi, p, modes, ref_t + slope * th * hh, gt)
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
def extrema(hh, x, f, xn, fn, idx, target, out, n):
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


@nb.njit(_nrt=False)
def _crossing_after(m, j, t, hh, x, f, xn, fn, p, modes, ref_t, slope, xi, gt, hi, none):
    """Guard ``j`` is at exactly 0 where the step starts and >= 0 at ``hi``: where it
    crosses.  If it first goes below zero (it leaves the surface, and comes back later in
    the step: a pinion that springs off its flank on the shaft and strikes it again), the
    crossing after that (the probes halve from ``hi / 2``); else ``none`` (0: it was reached
    already, where the step starts; -1: it never crosses, for a guard refused there)."""
    lo = 0.5 * hi
    for _ in range(40):
        hermite(lo, hh, x, f, xn, fn, xi)
        m.guards(m.args, xi, p, modes, ref_t + slope * lo * hh, gt)
        if gt[j] < 0.0:
            return locate(m, j, gt[j], t, hh, x, f, xn, fn, p, modes, ref_t, slope, xi, gt, hi, lo)
        lo *= 0.5
    return none


@nb.njit(inline="always", _nrt=False)
def first_crossing(m, t, hh, x, f, xn, fn, p, modes, ref_t, slope, skip, g0, g1, xi, gt):
    """The earliest guard that fires between the step's ends: ``(which, theta)``
    (``which`` = -1 when none).  Fills ``g0``/``g1`` with the guards at its ends.

    A guard at exactly 0 where the step starts and > 0 after has been reached
    already: a step re-taken to land on a root can end a round-off short of it
    (-4e-19), and the input recomputed for the next step puts the guard at
    exactly 0, which "< 0 to >= 0" would never see (profile 3, bang-bang,
    rtol 3e-7: the first switch went unseen for 22 ms).  Unless it goes below zero first
    (``_crossing_after``): a state at rest on a switching surface, a mode just switched there,
    would switch straight back and forth at one instant."""
    m.guards(m.args, x, p, modes, ref_t, g0)
    m.guards(m.args, xn, p, modes, ref_t + slope * hh, g1)
    which = -1
    theta = 1.0
    for j in range(guard_count(m)):
        th = -1.0
        if j != skip and g0[j] < 0.0 and g1[j] >= 0.0:
            th = locate(m, j, g0[j], t, hh, x, f, xn, fn, p, modes, ref_t, slope, xi, gt, 1.0)
        elif j != skip and g0[j] == 0.0 and g1[j] > 0.0:
            th = _crossing_after(m, j, t, hh, x, f, xn, fn, p, modes, ref_t, slope, xi, gt, 1.0, 0.0)
        elif j == skip and g1[j] >= 0.0:
            th = _crossing_after(m, j, t, hh, x, f, xn, fn, p, modes, ref_t, slope, xi, gt, 1.0, -1.0)
        if th >= 0.0 and (which < 0 or th < theta):
            theta = th
            which = j
    return which, theta


@nb.njit(inline="always", _nrt=False)
def hidden_crossing(m, t, hh, x, f, xn, fn, p, modes, ref_t, slope, skip, which, theta,
                    g0, g1, g2, xi, gt, thq, widx, wtarget):
    """Guards that cross and cross back inside the step: tested at the interior
    extrema of the components the model watches; returns the updated
    ``(which, theta)`` of ``first_crossing``."""
    nw = m.watch(m.args, p, modes, slope, hh, widx, wtarget)
    nq = 0
    for i in range(nw):
        nq = extrema(hh, x, f, xn, fn, widx[i], wtarget[i], thq, nq)
    for q in range(nq):
        tq = thq[q]
        if which >= 0 and tq >= theta:
            continue
        hermite(tq, hh, x, f, xn, fn, xi)
        m.guards(m.args, xi, p, modes, ref_t + slope * tq * hh, g2)
        for j in range(guard_count(m)):
            if j != skip and g0[j] < 0.0 and g1[j] < 0.0 and g2[j] >= 0.0:
                th = locate(m, j, g0[j], t, hh, x, f, xn, fn, p, modes, ref_t, slope, xi, gt, tq)
                if which < 0 or th < theta:
                    theta = th
                    which = j
            elif j != skip and g0[j] == 0.0 and g2[j] > 0.0:
                th = _crossing_after(m, j, t, hh, x, f, xn, fn, p, modes, ref_t, slope, xi, gt, tq, 0.0)
                if which < 0 or th < theta:
                    theta = th
                    which = j
    return which, theta
