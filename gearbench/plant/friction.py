"""Event-driven stick-slip friction on the geartrain's bodies, compiled.

A friction effect with a ``friction`` law (``coulomb_friction``,
``stribeck_friction``; ``model: stick_slip``, the default) acts on one of two
bodies, each with its own mode ``s`` (``layout.M_STICK_M`` + ``b``):

* body 0, *the rotor's*: the rotor (speed ``w_m``); on a rigid train without
  a shaft the rotor, pinion and load are one body, and the load's friction
  acts on it too, reflected (``T/N`` at speed ``w_m/N``);
* body 1, *the load's*: the output shaft (``w_l``); on a rigid train with a
  shaft the pinion carries the load, and the friction acts on the pinion
  (``T/N`` at ``w_p/N``).

With ``T`` the torque on the body from everything but this friction (N m,
``free_torques``), ``L(s, w)`` the sliding level and ``B(s)`` the breakaway
level in direction ``s`` (``fx.motor_friction``/``fx.load_friction``: the
effects' sums, N m)::

    slipping (s = +1 or -1):   J dw/dt = T - s L(s, w)
    stuck (s = 0):             w = 0, dw/dt = 0   (the friction is -T, |T| <= B)

The switches are located events (guards ``G_STICK_M`` + ``b``): slipping,
``-s w`` reaching the speed's absolute tolerance (the speed reaches zero: the body sticks if
``|T| <= B(sign T)``, else slips on in the direction of ``T``); stuck,
``|T| - B`` reaching 0 (breakaway, into slip in the direction of ``T``).  At
a stick the speed is set to exactly 0, so a stuck body does not creep.
Friction only takes energy out: its power ``-s L w`` is <= 0 while slipping
(``s w >= 0``, up to the speed's absolute tolerance past 0 where the stop
event fires) and 0 while stuck.
"""
import numba as nb

from ..layout import (M_STICK_M, P_CURVED_L, P_CURVED_M, P_HAS_SHAFT, P_N, P_RIGID, P_STICK_L, P_STICK_M,
                      P_STOP_EPS_M, X_WL, X_WM, X_WP)


@nb.njit(cache=True, inline="always", _nrt=False)
def _on_body(p, b, at_motor, at_load):
    """Whether a law at the motor (``at_motor``) or at the load (``at_load``) acts on body ``b``
    (0 the rotor's, 1 the load's): on one rigid body without a shaft both act on the rotor's."""
    one_body = p[P_RIGID] > 0.0 and p[P_HAS_SHAFT] == 0.0
    if b == 0:
        return at_motor or (one_body and at_load)
    return at_load and not one_body


@nb.njit(cache=True, inline="always", _nrt=False)
def present(p, b):
    """Whether stick-slip friction acts on body ``b`` (0 the rotor's, 1 the load's)."""
    return _on_body(p, b, p[P_STICK_M] > 0.0, p[P_STICK_L] > 0.0)


@nb.njit(cache=True, inline="always", _nrt=False)
def curves(p, modes, b):
    """Whether body ``b`` slips under a sliding level that curves with its speed (Stribeck's,
    ``layout.P_CURVED_M``/``P_CURVED_L``): the right-hand side is then not affine in that speed
    (and in no other state: the level depends on the speed alone).  Stuck, it holds whatever the law."""
    return modes[M_STICK_M + b] != 0 and _on_body(p, b, p[P_CURVED_M] > 0.0, p[P_CURVED_L] > 0.0)


@nb.njit(cache=True, inline="always", _nrt=False)
def speed_index(p, b):
    """The state holding body ``b``'s speed, rad/s."""
    if b == 0:
        return X_WM
    return X_WP if p[P_RIGID] > 0.0 else X_WL


@nb.njit(inline="always", _nrt=False)
def levels(fx, p, b, s, w):
    """``(L, B)``: sliding and breakaway levels (N m, at the body) of body ``b``'s
    friction in direction ``s`` (+1 or -1) at its speed ``w`` (rad/s)."""
    n = p[P_N]
    lv, br = 0.0, 0.0
    if b == 0:
        if p[P_STICK_M] > 0.0:
            lv, br = fx.motor_friction(p, s, w)
        if p[P_RIGID] > 0.0 and p[P_HAS_SHAFT] == 0.0 and p[P_STICK_L] > 0.0:
            a, c = fx.load_friction(p, s, w / n)
            lv += a / n
            br += c / n
        return lv, br
    if p[P_RIGID] > 0.0:
        a, c = fx.load_friction(p, s, w / n)
        return a / n, c / n
    return fx.load_friction(p, s, w)


@nb.njit(inline="always", _nrt=False)
def net_torque(fx, p, modes, b, t, w):
    """The torque on body ``b`` (N m) with its stick-slip friction: ``t`` less
    the sliding level while it slips, 0 while it is stuck (held)."""
    if not present(p, b):
        return t
    s = modes[M_STICK_M + b]
    if s == 0:
        return 0.0
    return t - s * levels(fx, p, b, s, w)[0]


@nb.njit(inline="always", _nrt=False)
def excess(fx, p, b, t):
    """How far the torque ``t`` on stuck body ``b`` is past its breakaway level
    in its own direction, N m (< 0: it holds)."""
    s = 1 if t >= 0.0 else -1
    return abs(t) - levels(fx, p, b, s, 0.0)[1]


@nb.njit(inline="always", _nrt=False)
def guard(fx, x, p, modes, b, t):
    """Guard of body ``b`` (-1 when no stick-slip friction acts on it): ``-s w - e``
    while slipping (rad/s; ``e`` the speed's absolute tolerance: a body that starts
    from rest starts with its guard below 0, not at it, and the interpolant's
    round-off wiggle about 0 is not a stop), the breakaway excess while stuck (N m)."""
    if not present(p, b):
        return -1.0
    s = modes[M_STICK_M + b]
    if s == 0:
        return excess(fx, p, b, t)
    return -s * x[speed_index(p, b)] - p[P_STOP_EPS_M + b]


@nb.njit(inline="always", _nrt=False)
def settle(fx, x, p, modes, b, t):
    """The mode of body ``b`` at rest (speed exactly 0) under torque ``t``: stuck
    while the friction holds it, else slipping in the direction of ``t``."""
    modes[M_STICK_M + b] = 0 if excess(fx, p, b, t) <= 0.0 else (1 if t > 0.0 else -1)


@nb.njit(inline="always", _nrt=False)
def stop(x, p, b):
    """Set body ``b``'s speed to exactly 0 (a body that sticks does not creep);
    the load of a rigid train rides on it."""
    x[speed_index(p, b)] = 0.0
    if p[P_RIGID] > 0.0 and (b == 1 or p[P_HAS_SHAFT] == 0.0):
        x[X_WL] = 0.0


@nb.njit(inline="always", _nrt=False)
def classify(fx, x, p, modes, b, t):
    """Set body ``b``'s mode from the state alone: slipping in the direction it
    turns, or, at rest, ``settle``."""
    if not present(p, b):
        modes[M_STICK_M + b] = 1
        return
    w = x[speed_index(p, b)]
    if w != 0.0:
        modes[M_STICK_M + b] = 1 if w > 0.0 else -1
    else:
        settle(fx, x, p, modes, b, t)
