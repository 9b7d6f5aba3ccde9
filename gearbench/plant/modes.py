"""Discrete modes and the guards that switch them, compiled.

The right-hand side is smooth inside a mode; it changes character when

* the teeth touch (contact onset: with Dubowsky's law the damper torque
  appears at once) or separate (the contact torque reaches zero),
* with the ElastoBacklash law, the damping torque meets the spring torque
  (the kink of ``Tc + min(Tc, Td)``; mode ``M_DAMP``),
* the bang-bang controller switches (``|e|`` crosses ``band/2``),
* the set-point shift flips (the motor speed crosses zero; thesis compensator
  only: the set-point-direction compensator switches at the profile's corners,
  in the model's update at each segment's start, ``model.start_segment``),
* a body with stick-slip friction comes to rest or breaks away
  (``friction.py``),
* a continuous law (P, PI, PID) reaches or leaves the amplifier's limit: a
  kink, not a jump, but the Jacobian changes there, and a step straddling it
  with the Jacobian of the other side is a Rosenbrock step with a wrong
  Jacobian (the loop's feedback treated explicitly): its error estimate blows up
  and the step is rejected again and again.

With the unclipped ``linear`` contact law the teeth separate when the
penetration returns to zero (guard ``-cm k p``, torque units), not on the
torque's sign.

Each is a guard that fires when it goes from < 0 to >= 0 (or from exactly 0
where a step starts, which means it was reached already); the generic solver
(``solver/events.py``) locates the root on the step's interpolant, steps
exactly to it, then calls ``apply_event``.  Guards are re-armed from the new
mode after every restart (a guard of the new mode starts at or below zero),
which is what stops the teeth passing through each other when a root lands
just short of a crossing.  The contact sees the mesh's relative angle
through the effects' offset (``rhs.mesh_seen``).
"""
import numba as nb

from ..control.laws import control_error
from ..layout import (COMP_THESIS, CTRL_BANGBANG, CTRL_OPEN, CTRL_P, CTRL_PI, CTRL_PID, CTRL_SAMPLED_PV, P_RIGID,
                      G_BB_A, G_BB_B, G_ENTER_NEG, G_ENTER_POS, G_KINK, G_LEAVE, G_SAT, G_SHIFT, M_BB, M_CONTACT,
                      M_DAMP, M_SAT, M_SHIFT, LAW_ELASTO, LAW_LINEAR, N_GUARDS, P_BAND, P_COMP, P_SPEED_EPS,
                      P_CTRL, P_DMESH, P_H, P_HAS_SHAFT, P_KMESH, P_LAW, P_N, P_SHIFT, P_VMAX, X_WL,
                      X_WM, X_WP, S_IMPACTS, N_SOLVER_STATS, G_STICK_L, G_STICK_M, M_STICK_M, P_STICK_L,
                      P_STICK_M)
from . import friction
from .contact import damping_limited, entry_guard, kink_guard, unclipped
from .rhs import demanded_input, free_torques, linear_region, load_angle, mesh_seen, rhs

INACTIVE = -1.0
REACH_MARGIN = 1.00001
"""``saturation_reach`` ends a step this factor past the predicted crossing of
the amplifier's limit: past it, so the crossing falls inside an accepted step
and is located; by a sliver, because the part past the limit is taken with the
other side's Jacobian (profile 1, P Kp = 50: a step 1 % past it was rejected,
error norm 4e4)."""
REACH_FLOOR = 0.1
"""... and never shortens it below this fraction: a guard that nears the limit
tangentially would be approached in ever-shorter steps."""


@nb.njit(_nrt=False)
def guards(fx, x, p, modes, ref, g):
    """Fill ``g`` with the guard values of the current modes."""
    for j in range(N_GUARDS):
        g[j] = INACTIVE
    delta, dd = mesh_seen(fx, x, p)
    h, k, d = p[P_H], p[P_KMESH], p[P_DMESH]
    cm = modes[M_CONTACT]
    if p[P_RIGID] > 0.0:
        pass  # no mesh: no contact events
    elif cm == 0:
        g[G_ENTER_POS] = entry_guard(delta, dd, h, k, d, 1)
        g[G_ENTER_NEG] = entry_guard(delta, dd, h, k, d, -1)
    elif p[P_LAW] == LAW_LINEAR:
        g[G_LEAVE] = -cm * k * (delta - cm * h)
    else:
        g[G_LEAVE] = -cm * unclipped(delta, dd, h, k, d, cm)
        if p[P_LAW] == LAW_ELASTO:
            g[G_KINK] = kink_guard(delta, dd, h, k, d, cm, modes[M_DAMP] > 0)
    if p[P_STICK_M] > 0.0 or p[P_STICK_L] > 0.0:
        t0, t1 = free_torques(fx, x, p, modes, ref)[1:3]
        g[G_STICK_M] = friction.guard(fx, x, p, modes, 0, t0)
        g[G_STICK_L] = friction.guard(fx, x, p, modes, 1, t1)
    kind = p[P_CTRL]
    if kind == CTRL_OPEN or kind == CTRL_SAMPLED_PV:
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
    else:
        g[G_SAT] = saturation_guard(fx, x, p, modes, ref)
    if p[P_SHIFT] > 0.0 and p[P_COMP] == COMP_THESIS:
        # Equation 1 flips the shift where the motor speed changes sign.  At
        # rest after an overdamped approach the speed decays to zero and
        # round-off alone would flip it (and start a chatter that the exact
        # solution does not have), so a flip needs the speed past a tiny
        # fixed threshold, P_SPEED_EPS (simulate.SHIFT_SPEED_REL), on the other side.
        eps = p[P_SPEED_EPS]
        g[G_SHIFT] = -x[X_WM] - eps if modes[M_SHIFT] > 0 else x[X_WM] - eps


@nb.njit(cache=True, inline="always", _nrt=False)
def continuous_law(p):
    """True for the P, PI and PID laws, whose output meets the amplifier's
    limit continuously (guard ``G_SAT``)."""
    kind = p[P_CTRL]
    return kind == CTRL_P or kind == CTRL_PI or kind == CTRL_PID


@nb.njit(inline="always", _nrt=False)
def saturation_guard(fx, x, p, modes, ref):
    """Guard ``G_SAT`` of a continuous law, V: ``|u| - Vmax`` inside the
    limits, ``Vmax - side u`` on one (``u`` the demanded input)."""
    u = demanded_input(fx, x, p, modes, ref)
    side = modes[M_SAT]
    return abs(u) - p[P_VMAX] if side == 0 else p[P_VMAX] - side * u


@nb.njit(inline="always", _nrt=False)
def saturation_reach(fx, x, f, p, modes, ref, slope, h, xe):
    """The step to take instead of ``h`` (s): shorter only for a continuous law
    about to cross the amplifier's limit (``_reach``)."""
    if not continuous_law(p):
        return h
    return _reach(fx, x, f, p, modes, ref, slope, h, xe)


@nb.njit(_nrt=False)
def _reach(fx, x, f, p, modes, ref, slope, h, xe):
    """The step to take instead of ``h`` (s) so that a continuous law does
    not cross the amplifier's limit far inside it.

    A step that straddles the limit with the Jacobian of the side it starts on
    treats the loop's feedback (or its absence) explicitly, and its error
    estimate explodes; it would be rejected and shrunk by 5x at a time until
    it no longer reached the limit.  Instead, predict the crossing along the
    tangent (the law is affine in the state and the set point is a ramp, so
    the prediction is the guard's first-order Taylor step) and end the step
    just past it, where the event is located on an accepted step.  ``xe``:
    scratch."""
    g0 = saturation_guard(fx, x, p, modes, ref)
    if g0 >= 0.0:
        return h
    for i in range(x.shape[0]):
        xe[i] = x[i] + h * f[i]
    g1 = saturation_guard(fx, xe, p, modes, ref + slope * h)
    if g1 <= 0.0:
        return h
    return min(h, max(h * g0 / (g0 - g1) * REACH_MARGIN, REACH_FLOOR * h))


@nb.njit(_nrt=False)
def classify_controller(fx, x, p, modes, ref):
    """Set the controller's modes from the state: the bang-bang output, or a
    continuous law's side of the amplifier's limit (used where the error jumps,
    or where a step left a mode stale)."""
    modes[M_SAT] = linear_region(fx, x, p, modes, ref) if continuous_law(p) else 0
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


@nb.njit(_nrt=False)
def classify_damping(fx, x, p, modes):
    """Set ElastoBacklash's damping piece (``M_DAMP``) from the state; 0 out
    of contact and for the other laws."""
    cm = modes[M_CONTACT]
    limited = False
    if cm != 0 and p[P_LAW] == LAW_ELASTO:
        delta, dd = mesh_seen(fx, x, p)
        limited = damping_limited(delta, dd, p[P_H], p[P_KMESH], p[P_DMESH], cm)
    modes[M_DAMP] = 1 if limited else 0


@nb.njit(_nrt=False)
def classify(fx, x, p, modes, ref):
    """Set every mode from the state alone (at the start of a run)."""
    delta, dd = mesh_seen(fx, x, p)
    h, k, d = p[P_H], p[P_KMESH], p[P_DMESH]
    modes[M_CONTACT] = 0
    linear = p[P_LAW] == LAW_LINEAR
    if p[P_RIGID] > 0.0:
        pass
    elif delta > h and (linear or unclipped(delta, dd, h, k, d, 1) > 0.0):
        modes[M_CONTACT] = 1
    elif delta < -h and (linear or unclipped(delta, dd, h, k, d, -1) < 0.0):
        modes[M_CONTACT] = -1
    classify_damping(fx, x, p, modes)
    if p[P_COMP] == COMP_THESIS:
        modes[M_SHIFT] = 1 if x[X_WM] >= 0.0 else -1
    else:
        modes[M_SHIFT] = 0  # no direction until the set point first moves
    classify_controller(fx, x, p, modes, ref)
    classify_friction(fx, x, p, modes, ref)


@nb.njit(_nrt=False)
def classify_friction(fx, x, p, modes, ref):
    """Set the stick-slip modes from the state (``friction.classify``): a body
    at rest sticks unless the torque on it is past its breakaway level."""
    for b in range(2):
        t = free_torques(fx, x, p, modes, ref)[1 + b]
        friction.classify(fx, x, p, modes, b, t)


@nb.njit(_nrt=False)
def break_away(fx, x, p, modes, ref):
    """Where the input jumps (a segment's start), a stuck body whose torque is
    now past its breakaway level slips: a guard already past zero never fires.
    Returns how many broke away."""
    count = 0
    for b in range(2):
        if friction.present(p, b) and modes[M_STICK_M + b] == 0:
            t = free_torques(fx, x, p, modes, ref)[1 + b]
            friction.settle(fx, x, p, modes, b, t)
            count += modes[M_STICK_M + b] != 0
    return count


@nb.njit(_nrt=False)
def apply_event(fx, which, x, p, modes, ref, f, atol, stats):
    """Switch the modes for the guard ``which`` that just fired; count a
    contact onset the solver resolves as an impact (``impact``).  A switch can
    make a torque jump (Dubowsky's damper at a contact onset): a stuck body it
    pushes past breakaway slips from here, not a step later."""
    if switch_mode(fx, which, x, p, modes, ref, f):
        stats[S_IMPACTS - N_SOLVER_STATS] += impact(fx, x, p, modes, atol)
    if p[P_STICK_M] > 0.0 or p[P_STICK_L] > 0.0:
        break_away(fx, x, p, modes, ref)


@nb.njit(_nrt=False)
def impact(fx, x, p, modes, atol):
    """1 if the contact that just began closed at an approach speed the error
    control resolves (above the load speed's absolute tolerance), else 0.

    While the train settles on a flank at zero force the teeth re-touch at
    approach speeds of ~1e-12 rad/s, rounding noise; those are not impacts.
    """
    return 1 if modes[M_CONTACT] * mesh_seen(fx, x, p)[1] > atol[X_WL] else 0


@nb.njit(_nrt=False)
def switch_mode(fx, which, x, p, modes, ref, f):
    """Switch the modes for the guard ``which``; 1 for a contact onset, else 0.
    ``f``: scratch."""
    if which == G_ENTER_POS or which == G_ENTER_NEG:
        modes[M_CONTACT] = 1 if which == G_ENTER_POS else -1
        classify_damping(fx, x, p, modes)
        return 1
    if which == G_LEAVE:
        cm = modes[M_CONTACT]
        # Refuse a separation whose free-flight torque rate points straight
        # back into contact (a graze at zero torque, not a separation), or is 0:
        # teeth at rest touching at zero force would leave and touch again at one
        # instant, forever (docs/solver-notes.md, "States at exact rest").
        modes[M_CONTACT] = 0
        rhs(fx, x, p, modes, ref, f)  # f: scratch for the free-flight derivative
        n = p[P_N]
        wp_dot = f[X_WP] if p[P_HAS_SHAFT] > 0.0 else f[X_WM]
        dd = mesh_seen(fx, x, p)[1]
        if p[P_LAW] == LAW_LINEAR:
            rate = p[P_KMESH] * dd  # the guard is the spring torque alone
        else:
            # (an offset e(theta_l) adds e' dw_l/dt; its curvature term e'' w_l^2 is left out)
            de = fx.mesh(p, load_angle(x, p))[1]
            rate = p[P_KMESH] * dd + p[P_DMESH] * (wp_dot / n - f[X_WL] + de * f[X_WL])
        if cm * rate >= 0.0:
            modes[M_CONTACT] = cm
        classify_damping(fx, x, p, modes)
        return 0
    if which == G_KINK:
        modes[M_DAMP] = 1 - modes[M_DAMP]
        return 0
    if which == G_STICK_M or which == G_STICK_L:
        # a slipping body came to rest: held exactly at 0 (then it sticks, or slips back
        # if the torque on it is past breakaway); a stuck one breaks away, in the direction
        # of the torque (the guard says it reached breakaway: the root may land a hair short)
        b = which - G_STICK_M
        t = free_torques(fx, x, p, modes, ref)[1 + b]
        if modes[M_STICK_M + b] == 0:
            modes[M_STICK_M + b] = 1 if t >= 0.0 else -1
        else:
            friction.stop(x, p, b)
            friction.settle(fx, x, p, modes, b, free_torques(fx, x, p, modes, ref)[1 + b])
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
        classify_controller(fx, x, p, modes, ref)
        return 0
    if which == G_SAT:
        if modes[M_SAT] == 0:
            modes[M_SAT] = 1 if demanded_input(fx, x, p, modes, ref) > 0.0 else -1
        else:
            modes[M_SAT] = 0
        return 0
    return 0


@nb.njit(cache=True, _nrt=False)
def direction_of_segment(k, seg_t, seg_v, seg_s, held):
    """Set-point direction for the set-point-direction compensator on segment ``k``.

    The sign of the segment's slope; on a dwell (zero slope) the sign of the
    step that opens it, if any; else ``held`` (the direction so far).  So the
    direction changes only where the set point itself turns, and it is held
    through dwells (the hysteresis: an overshoot never flips it).
    """
    s = seg_s[k]
    if s > 0.0:
        return 1
    if s < 0.0:
        return -1
    if k > 0:
        prev_end = seg_v[k - 1] + seg_s[k - 1] * (seg_t[k] - seg_t[k - 1])
        jump = seg_v[k] - prev_end
        if jump > 0.0:
            return 1
        if jump < 0.0:
            return -1
    return held
