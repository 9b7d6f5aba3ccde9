"""Right-hand side of the geartrain, compiled (SPEC section 2).

States (``gearbench.layout``): current ``i``, rotor angle ``theta_m`` and speed
``w_m``, shaft twist ``phi`` and pinion speed ``w_p`` (only with a shaft), mesh
relative angle ``delta = theta_p/N - theta_l``, load speed ``w_l``, controller
states, and two error quadratures.  Equations (SI units)::

    L di/dt      = u - R i - v_e(i) - ke w_m
    Jm dw_m/dt   = kt i - bm w_m - T/N                (rigid shaft)
    Jr dw_m/dt   = kt i - bm w_m - Ts,  Ts = ks phi + ds (w_m - w_p)
    Jp dw_p/dt   = Ts - T/N,            dphi/dt = w_m - w_p   (with a shaft)
    d delta/dt   = w_p/N - w_l
    Jl dw_l/dt   = T - bl w_l

``T`` is the mesh contact torque of ``plant.contact``.  With a torque input the
electrical part drops out and the rotor torque is ``g u`` (``g`` = 1 for a
torque in N m, ``lead/(2 pi N)`` for a force in N).  With a rigid gear there is
no mesh: ``delta = 0`` and the load rides on the pinion,

    (Jp + Jl/N^2) dw_p/dt = (torques on the pinion) + (Te - bl w_l)/N,  w_l = w_p/N

The effects (``plant/effects``) add ``Tm_e(theta_m, w_m)`` on the rotor,
``Te(theta_l, w_l)`` on the load, map the command to the motor voltage, and
offset the mesh's relative angle as the contact sees it by ``e(theta_l)``, and
lose ``v_e(i)`` in the winding; an effect with a state of its own (after the
plant's, ``x[N_STATE:]``) evolves by its rate.  Their compiled terms reach these
functions as ``fx`` (``effects.codegen``: ``fx.motor``, ``fx.load``,
``fx.voltage``, ``fx.mesh``, ``fx.winding``, ``fx.rates``), the model's ``args``.
"""
import numba as nb
import numpy as np

from ..control.laws import command, control_error, saturate
from ..layout import (CTRL_OPEN, CTRL_PI, CTRL_PID, CTRL_SAMPLED_PV, M_CONTACT, M_DAMP, P_BL, P_BM, P_CTRL,
                      P_DMESH, P_DRIVE_GAIN, P_DS, P_H, P_HAS_SHAFT, P_JL, P_JM, P_JP, P_KE,
                      P_KMESH, P_KS, P_KT, P_L, P_LAW, P_N, P_R, P_RIGID, P_TF, P_TORQUE_IN,
                      P_VMAX, X_DELTA, X_I, X_IAE, X_ISE, X_PHI, X_THM, X_WL, X_WM, X_WP,
                      X_ZD, X_ZI, N_DYN, P_CURVED_L, P_CURVED_M, P_FRIC_EPS_M, P_FRIC_EPS_L, P_PWL)
from . import friction
from .contact import engaged_torque
from .friction import net_torque


@nb.njit(cache=True, inline="always", _nrt=False)
def pinion_speed(x, p):
    """Pinion speed, rad/s: the rotor's unless a shaft separates them."""
    return x[X_WP] if p[P_HAS_SHAFT] > 0.0 else x[X_WM]


@nb.njit(cache=True, inline="always", _nrt=False)
def load_angle(x, p):
    """Output angle ``theta_l = (theta_m - phi)/N - delta``, rad."""
    return (x[X_THM] - x[X_PHI]) / p[P_N] - x[X_DELTA]


@nb.njit(cache=True, inline="always", _nrt=False)
def mesh_rate(x, p):
    """``d delta/dt = w_p/N - w_l``, rad/s."""
    return pinion_speed(x, p) / p[P_N] - x[X_WL]


@nb.njit(inline="always", _nrt=False)
def mesh_seen(fx, x, p):
    """The mesh's relative angle and its rate as the contact sees them, rad and
    rad/s: ``delta + e(theta_l)`` and ``d delta/dt + e'(theta_l) w_l``, with
    ``e`` the effects' offset (a transmission error; 0 without one)."""
    e, de = fx.mesh(p, load_angle(x, p))
    return x[X_DELTA] + e, mesh_rate(x, p) + de * x[X_WL]


@nb.njit(inline="always", _nrt=False)
def mesh_torque(fx, x, p, modes):
    """Contact torque on the load in the current contact mode, N m."""
    m = modes[M_CONTACT]
    if m == 0 or p[P_RIGID] > 0.0:
        return 0.0
    delta, rate = mesh_seen(fx, x, p)
    return engaged_torque(delta, rate, p[P_H], p[P_KMESH], p[P_DMESH], p[P_LAW], m, modes[M_DAMP] > 0)


@nb.njit(inline="always", _nrt=False)
def applied_input(fx, x, p, modes, ref):
    """The input as applied: motor voltage (V, after any dead zone and the
    saturation) or drive torque / force (N m or N, saturated at the drive's limit).

    A sampled controller's output comes saturated from the integration loop.
    """
    u = demanded_input(fx, x, p, modes, ref)
    if p[P_CTRL] == CTRL_SAMPLED_PV:
        return u
    return saturate(u, p[P_VMAX])


@nb.njit(inline="always", _nrt=False)
def demanded_input(fx, x, p, modes, ref):
    """``applied_input`` before the saturation: the command, through any
    amplifier dead zone when it is a voltage."""
    kind = p[P_CTRL]
    u = command(x, p, modes, ref, kind)
    if kind != CTRL_SAMPLED_PV and p[P_TORQUE_IN] == 0.0:
        u = fx.voltage(p, u)
    return u


@nb.njit(inline="always", _nrt=False)
def free_torques(fx, x, p, modes, ref):
    """``(u, t0, t1, tp)``: the applied input, and the torques (N m) on the
    rotor's body and on the load's (``plant/friction.py``) from everything but
    their stick-slip friction, and on the pinion between a shaft and the mesh.

    The rotor's body is the rotor (with the pinion on a rigid shaft, and the
    load too on a rigid gear: its torques then reflected, ``/N``); the load's
    is the output shaft, or on a rigid gear with a shaft the pinion carrying it."""
    n = p[P_N]
    u = applied_input(fx, x, p, modes, ref)
    wm = x[X_WM]
    if p[P_TORQUE_IN] > 0.0:
        tm = p[P_DRIVE_GAIN] * u
    else:
        tm = p[P_KT] * x[X_I]
    tm += fx.motor(p, x, x[X_THM], wm, p[P_FRIC_EPS_M]) - p[P_BM] * wm
    shaft = p[P_HAS_SHAFT] > 0.0
    ts = p[P_KS] * x[X_PHI] + p[P_DS] * (wm - x[X_WP]) if shaft else tm
    if p[P_RIGID] > 0.0:
        # the load rides on the pinion: one body, reflected to the pinion
        wl = pinion_speed(x, p) / n
        t_load = fx.load(p, x, load_angle(x, p), wl, p[P_FRIC_EPS_L]) - p[P_BL] * wl
        if shaft:
            return u, tm - ts, ts + t_load / n, 0.0
        return u, ts + t_load / n, 0.0, 0.0
    t_mesh = mesh_torque(fx, x, p, modes)
    wl = x[X_WL]
    t1 = t_mesh - p[P_BL] * wl + fx.load(p, x, load_angle(x, p), wl, p[P_FRIC_EPS_L])
    if shaft:
        return u, tm - ts, t1, ts - t_mesh / n
    return u, tm - t_mesh / n, t1, 0.0


@nb.njit(_nrt=False)
def rhs(fx, x, p, modes, ref, out):
    """Write dx/dt into ``out`` for state ``x`` and set point (or input) ``ref``."""
    n = p[P_N]
    u, t0, t1, tp = free_torques(fx, x, p, modes, ref)
    wm = x[X_WM]
    if p[P_TORQUE_IN] > 0.0:
        out[X_I] = 0.0
    else:
        out[X_I] = (u - p[P_R] * x[X_I] - fx.winding(p, x, x[X_I]) - p[P_KE] * wm) / p[P_L]
    out[X_THM] = wm
    shaft = p[P_HAS_SHAFT] > 0.0
    wp = pinion_speed(x, p)
    out[X_PHI] = wm - wp if shaft else 0.0
    if p[P_RIGID] > 0.0:
        jl = p[P_JL] / (n * n)
        if shaft:
            out[X_WM] = net_torque(fx, p, modes, 0, t0, wm) / p[P_JM]
            acc = net_torque(fx, p, modes, 1, t1, wp) / (p[P_JP] + jl)
            out[X_WP] = acc
        else:
            acc = net_torque(fx, p, modes, 0, t0, wm) / (p[P_JM] + jl)
            out[X_WM] = acc
            out[X_WP] = 0.0
        out[X_DELTA] = 0.0
        out[X_WL] = acc / n
    else:
        out[X_WM] = net_torque(fx, p, modes, 0, t0, wm) / p[P_JM]
        out[X_WP] = tp / p[P_JP] if shaft else 0.0
        out[X_DELTA] = wp / n - x[X_WL]
        out[X_WL] = net_torque(fx, p, modes, 1, t1, x[X_WL]) / p[P_JL]
    wl = pinion_speed(x, p) / n if p[P_RIGID] > 0.0 else x[X_WL]
    fx.rates(p, x, x[X_THM], wm, load_angle(x, p), wl, out)
    kind = p[P_CTRL]
    if kind == CTRL_OPEN or kind == CTRL_SAMPLED_PV:
        # `ref` is the input itself (or the held sampled command): no error to score here
        out[X_ZI] = 0.0
        out[X_ZD] = 0.0
        out[X_IAE] = 0.0
        out[X_ISE] = 0.0
        return
    e = control_error(x, p, modes, ref)
    out[X_ZI] = e
    out[X_ZD] = (e - x[X_ZD]) / p[P_TF] if kind == CTRL_PID else 0.0
    err = ref - load_angle(x, p)
    out[X_IAE] = abs(err)
    out[X_ISE] = err * err


@nb.njit
def feedback_states(fx, p):
    """The states whose value ``rhs`` reads for this plant and controller, first,
    then the rest; returns ``(order, count)``.

    The rest feed nothing back, so their Jacobian columns are exactly zero and
    an implicit step handles them by substitution, like quadratures: the error
    integrals, a shaft's twist and pinion speed without a shaft, the mesh and
    load states of a rigid gear (the load rides on the pinion), the integrator
    unless the controller is PI or PID, the derivative filter unless PID, an effect's
    state unless the effect is present.
    """
    used = np.zeros(fx.n_state, dtype=np.bool_)
    used[:N_DYN] = True
    fx.effect_states(p, used)
    used[X_PHI] = used[X_WP] = p[P_HAS_SHAFT] > 0.0
    used[X_DELTA] = used[X_WL] = p[P_RIGID] == 0.0
    used[X_I] = p[P_TORQUE_IN] == 0.0
    used[X_ZI] = p[P_CTRL] == CTRL_PI or p[P_CTRL] == CTRL_PID
    used[X_ZD] = p[P_CTRL] == CTRL_PID
    return np.concatenate((np.flatnonzero(used), np.flatnonzero(~used))), int(used.sum())


@nb.njit(inline="always", _nrt=False)
def piecewise_linear(fx, p):
    """True when ``rhs`` is affine in the state inside each mode and each
    ``linear_region`` (every contact law: ElastoBacklash's kink is a mode), and
    every effect keeps it so (each declares it: ``Effect.piecewise_linear``;
    the packer writes ``P_PWL``).  Its Jacobian is then constant there, and a
    Jacobian taken once serves every step until the region changes.
    """
    return p[P_PWL] > 0.0


@nb.njit(inline="always", _nrt=False)
def curved(fx, p, modes, idx):
    """The states along which ``rhs``'s Jacobian changes inside ``modes`` and one
    ``linear_region``, written to ``idx``, and how many: none for a piecewise-linear
    right-hand side; the speed of each body slipping under a curved sliding level
    (``friction.curves``) where that is all that keeps it from being one; -1 otherwise."""
    if p[P_PWL] > 0.0:
        return 0
    if p[P_CURVED_M] == 0.0 and p[P_CURVED_L] == 0.0:
        return -1
    n = 0
    for b in range(2):
        if friction.curves(p, modes, b):
            idx[n] = friction.speed_index(p, b)
            n += 1
    return n


@nb.njit(_nrt=False)
def linear_region(fx, x, p, modes, ref):
    """Which side of the amplifier's limits the command is on (-1, 0, +1): the
    only kink of a ``piecewise_linear`` right-hand side inside a mode, apart
    from the error quadratures (see ``quadrature_rows``)."""
    kind = p[P_CTRL]
    if kind == CTRL_OPEN or kind == CTRL_SAMPLED_PV:
        return 0
    u = demanded_input(fx, x, p, modes, ref)
    vmax = p[P_VMAX]
    return 1 if u >= vmax else (-1 if u <= -vmax else 0)


@nb.njit(_nrt=False)
def quadrature_rows(fx, x, p, ref, slope, order, na, jac, tdot):
    """Write the error quadratures' rows of the Jacobian exactly: with
    ``e = r - theta_l``, ``theta_l = (theta_m - phi)/N - delta``,
    d|e|/dx = -sign(e) d theta_l/dx and d e^2/dx = -2 e d theta_l/dx, and
    through the set point's slope d|e|/dt = sign(e) slope, d e^2/dt = 2 e slope.
    They are not affine in the state, so a reused Jacobian takes them fresh."""
    kind = p[P_CTRL]
    if kind == CTRL_OPEN or kind == CTRL_SAMPLED_PV:
        return
    e = ref - load_angle(x, p)
    sg = 1.0 if e > 0.0 else (-1.0 if e < 0.0 else 0.0)
    for a in range(na):
        j = order[a]
        if j == X_THM:
            dl = 1.0 / p[P_N]
        elif j == X_PHI:
            dl = -1.0 / p[P_N]
        elif j == X_DELTA:
            dl = -1.0
        else:
            dl = 0.0
        jac[a, X_IAE] = -sg * dl
        jac[a, X_ISE] = -2.0 * e * dl
    tdot[X_IAE] = sg * slope
    tdot[X_ISE] = 2.0 * e * slope
