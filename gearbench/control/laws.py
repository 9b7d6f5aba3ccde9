"""Controller laws of the thesis, compiled.

The controllers see only the motor-side angle referred to the output,
``theta_m / N`` (the output angle cannot be measured).  With the set point
``r`` (rad) and the set-point shift ``s`` (rad; thesis Equation 1: ``+s`` while
the motor speed is >= 0, else ``-s``), the error is ``e = r +- s - theta_m/N``.

* bang-bang (thesis Eq. 4): ``u = Vmax sign(e)`` when ``|e| > band/2``, else 0;
* P (Eq. 5):  ``u = Kp e``;
* PI (Eq. 6): ``u = Kp (e + Ki z)``, ``dz/dt = e``;
* PID: ``u = Kp (e + Ki z + Kd (e - f)/Tf)``, ``df/dt = (e - f)/Tf``, a
  derivative filtered with time constant ``Tf``;

plus, for the ``direction_feedforward`` compensator, ``Kff dr/dt``: the
voltage that holds the set point's ramp speed in steady state (``P_FF``, with
``dr/dt`` the current segment's slope); for ``damped_feedforward`` also the
rate damping ``Kr (dr/dt - w_m/N)`` (``P_KRATE``, V per rad/s at the output;
``w_m`` the rate of the measured motor angle; why: ``controllers.COMPENSATORS``);
all saturated at ``+-Vmax``.  Kp in V/rad, Ki in 1/s, Kd in s, Tf in s (the
experiment files give Kp in V/deg, the thesis's unit).
"""
import numba as nb

from ..layout import (CTRL_BANGBANG, CTRL_OPEN, CTRL_PI, CTRL_PID, CTRL_SAMPLED_PV, M_BB, P_FF, P_KRATE, P_REF_SLOPE,
                      M_SHIFT, P_KD, P_KI, P_KP, P_N, P_SHIFT, P_TF, P_VMAX,
                      X_THM, X_WM, X_ZD, X_ZI)


@nb.njit(cache=True, inline="always", _nrt=False)
def control_error(x, p, modes, ref):
    """Motor-side error ``e = r + shift - theta_m/N``, rad."""
    return ref + modes[M_SHIFT] * p[P_SHIFT] - x[X_THM] / p[P_N]


@nb.njit(cache=True, inline="always", _nrt=False)
def command(x, p, modes, ref, kind):
    """Unsaturated controller output, V (for open loop: the input itself)."""
    if kind == CTRL_OPEN or kind == CTRL_SAMPLED_PV:
        return ref
    if kind == CTRL_BANGBANG:
        return modes[M_BB] * p[P_VMAX]
    e = control_error(x, p, modes, ref)
    u = e
    if kind == CTRL_PI or kind == CTRL_PID:
        u += p[P_KI] * x[X_ZI]
    if kind == CTRL_PID:
        u += p[P_KD] * (e - x[X_ZD]) / p[P_TF]
    if p[P_KRATE] == 0.0:
        return p[P_KP] * u + p[P_FF] * p[P_REF_SLOPE]
    # damped_feedforward: the rate damping on the error rate dr/dt - w_m/N
    slope = p[P_REF_SLOPE]
    return p[P_KP] * u + p[P_FF] * slope + p[P_KRATE] * (slope - x[X_WM] / p[P_N])


@nb.njit(cache=True, inline="always", _nrt=False)
def saturate(u, vmax):
    """Clip to the amplifier's range ``[-vmax, vmax]``."""
    if u > vmax:
        return vmax
    if u < -vmax:
        return -vmax
    return u
