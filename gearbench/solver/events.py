"""Discrete modes and the guards that switch them, compiled.

The right-hand side is smooth inside a mode; it changes character when

* the teeth touch (contact onset: with Dubowsky's law the damper torque
  appears at once) or separate (the contact torque reaches zero),
* the bang-bang controller switches (``|e|`` crosses ``band/2``),
* the set-point shift flips (the motor speed crosses zero).

Each is a guard that fires when it goes from < 0 to >= 0; the solver locates
the root on the step's interpolant, steps exactly to it, then calls
``apply_event``.  Guards are re-armed from the new mode after every restart
(a guard of the new mode starts at or below zero), which is what stops the
teeth passing through each other when a root lands just short of a crossing.
"""
import numba as nb
import numpy as np

from ..control.laws import control_error
from ..layout import (CTRL_BANGBANG, CTRL_OPEN, G_BB_A, G_BB_B, G_ENTER_NEG,
                      G_ENTER_POS, G_LEAVE, G_SHIFT, M_BB, M_CONTACT, M_SHIFT,
                      N_GUARDS, N_STATE, P_BAND, P_CTRL, P_DMESH, P_H,
                      P_HAS_SHAFT, P_KMESH, P_N, P_SHIFT, X_DELTA, X_WL, X_WM,
                      X_WP)
from ..plant.contact import entry_guard, unclipped
from ..plant.rhs import mesh_rate, rhs

INACTIVE = -1.0


@nb.njit(cache=True)
def guards(x, p, modes, ref, g):
    """Fill ``g`` with the guard values of the current modes."""
    for j in range(N_GUARDS):
        g[j] = INACTIVE
    delta = x[X_DELTA]
    dd = mesh_rate(x, p)
    h, k, d = p[P_H], p[P_KMESH], p[P_DMESH]
    cm = modes[M_CONTACT]
    if cm == 0:
        g[G_ENTER_POS] = entry_guard(delta, dd, h, k, d, 1)
        g[G_ENTER_NEG] = entry_guard(delta, dd, h, k, d, -1)
    else:
        g[G_LEAVE] = -cm * unclipped(delta, dd, h, k, d, cm)
    kind = p[P_CTRL]
    if kind == CTRL_OPEN:
        return
    if kind == CTRL_BANGBANG:
        e = control_error(x, p, modes, ref)
        band = p[P_BAND]
        bb = modes[M_BB]
        if bb == 0:
            g[G_BB_A] = e - band
            g[G_BB_B] = -e - band
        elif bb > 0:
            g[G_BB_A] = band - e
        else:
            g[G_BB_A] = band + e
    if p[P_SHIFT] > 0.0:
        g[G_SHIFT] = -x[X_WM] if modes[M_SHIFT] > 0 else x[X_WM]


@nb.njit(cache=True)
def classify_bangbang(x, p, modes, ref):
    """Set the bang-bang mode from the error (used where the error jumps)."""
    if p[P_CTRL] != CTRL_BANGBANG:
        modes[M_BB] = 0
        return
    e = control_error(x, p, modes, ref)
    band = p[P_BAND]
    if e > band:
        modes[M_BB] = 1
    elif e < -band:
        modes[M_BB] = -1
    else:
        modes[M_BB] = 0


@nb.njit(cache=True)
def classify(x, p, modes, ref):
    """Set every mode from the state alone (at the start of a run)."""
    delta = x[X_DELTA]
    dd = mesh_rate(x, p)
    h, k, d = p[P_H], p[P_KMESH], p[P_DMESH]
    modes[M_CONTACT] = 0
    if delta > h and unclipped(delta, dd, h, k, d, 1) > 0.0:
        modes[M_CONTACT] = 1
    elif delta < -h and unclipped(delta, dd, h, k, d, -1) < 0.0:
        modes[M_CONTACT] = -1
    modes[M_SHIFT] = 1 if x[X_WM] >= 0.0 else -1
    classify_bangbang(x, p, modes, ref)


@nb.njit(cache=True)
def apply_event(which, x, p, modes, ref):
    """Switch the modes for the guard ``which`` that just fired.

    Returns 1 for a contact onset (an impact), 0 otherwise.
    """
    if which == G_ENTER_POS:
        modes[M_CONTACT] = 1
        return 1
    if which == G_ENTER_NEG:
        modes[M_CONTACT] = -1
        return 1
    if which == G_LEAVE:
        cm = modes[M_CONTACT]
        # Refuse a separation whose free-flight torque rate points straight
        # back into contact (a graze at zero torque, not a separation).
        modes[M_CONTACT] = 0
        f = np.empty(N_STATE)
        rhs(x, p, modes, ref, f)
        n = p[P_N]
        wp_dot = f[X_WP] if p[P_HAS_SHAFT] > 0.0 else f[X_WM]
        dd = mesh_rate(x, p)
        rate = p[P_KMESH] * dd + p[P_DMESH] * (wp_dot / n - f[X_WL])
        if cm * rate > 0.0:
            modes[M_CONTACT] = cm
        return 0
    if which == G_BB_A:
        if modes[M_BB] == 0:
            modes[M_BB] = 1
        else:
            modes[M_BB] = 0
        return 0
    if which == G_BB_B:
        modes[M_BB] = -1
        return 0
    if which == G_SHIFT:
        modes[M_SHIFT] = -modes[M_SHIFT]
        # the effective set point jumps by twice the shift
        classify_bangbang(x, p, modes, ref)
        return 0
    return 0
