"""The geartrain as a model of the generic integrator (``solver.model.Model``).

The right-hand side, contact modes and guards live in ``rhs.py`` and
``modes.py``; this module adds what the integrator asks of a model beyond
them: the discrete update at each segment's start (the set point's slope,
the direction compensator's sign, and the sampled EMPS controller's law),
the outputs, and the run's scores (IAE, ISE, largest error, time saturated,
impacts, switchings).  Its names at the end are the contract of
``solver.model``; the module ``effects.codegen`` generates for a set of
effects imports them and adds the effects' terms as the model's ``args``.
"""
import numba as nb

from ..control.laws import saturate
from ..solver.model import NAMES
from ..layout import (COMP_THESIS, CTRL_BANGBANG, CTRL_OPEN, CTRL_SAMPLED_PV, G_BB_A, G_BB_B, G_ENTER_NEG,
                      G_ENTER_POS, G_KINK, G_LEAVE, G_SAT, G_STICK_L, G_STICK_M, M_STICK_L, M_STICK_M,
                      G_SHIFT, M_BB, M_CONTACT, M_SAT, M_SHIFT, N_GUARDS, N_MODEL_STATS, N_MODES, N_OUT,
                      N_SOLVER_STATS, N_STATE, O_CURRENT, O_DELTA, O_LOAD, O_MOTOR, O_SETPOINT, O_TORQUE,
                      O_VOLTAGE, O_WL, O_WM, P_COMP, P_CTRL, P_CTRL_GAIN, P_CURVED_L, P_CURVED_M, P_DELAY, P_KP, P_KV, P_N,
                      P_REF_SLOPE, P_SHIFT, P_VMAX, S_IAE, S_ISE, S_MAX_ERR, S_SWITCHES, S_T_SAT,
                      X_DELTA, X_I, X_IAE, X_ISE, X_THM, X_WL, X_WM)
from . import friction
from .modes import (apply_event, break_away, classify, classify_controller, classify_damping, continuous_law,
                    direction_of_segment, guards, saturation_reach, switch_mode)
from .rhs import (applied_input, curved, feedback_states, linear_region, load_angle, mesh_torque,
                  piecewise_linear, quadrature_rows, rhs)

# the model's memory between calls
MEM_R0 = 0         # the current segment's table value (the sampled controller's set point), rad
MEM_Y_PREV = 1     # sampled controller: the last sample of theta_m / N, rad
MEM_YF_PREV = 2    # ... its last smoothed sample, rad
MEM_C_PREV = 3     # ... its last output, V
MEM_SIGN = 4       # sign of the applied input at the last step (switch counting)
N_MEM = 5

# statistics, counted from the model's share of the stats array
T_IAE, T_ISE = S_IAE - N_SOLVER_STATS, S_ISE - N_SOLVER_STATS
T_MAX_ERR, T_SAT = S_MAX_ERR - N_SOLVER_STATS, S_T_SAT - N_SOLVER_STATS
T_SWITCHES = S_SWITCHES - N_SOLVER_STATS


@nb.njit(cache=True, inline="always", _nrt=False)
def _closed(p):
    return p[P_CTRL] != CTRL_OPEN and p[P_CTRL] != CTRL_SAMPLED_PV


@nb.njit(cache=True, inline="always", _nrt=False)
def _sign(v):
    return 1 if v > 0.0 else (-1 if v < 0.0 else 0)


@nb.njit(inline="always", _nrt=False)
def piece(fx, x, p, modes, ref):
    """A continuous law's side of the amplifier's limit is its mode (on the
    limit itself, after a saturation event, the side it is heading to)."""
    return modes[M_SAT] if continuous_law(p) else linear_region(fx, x, p, modes, ref)


@nb.njit(inline="always", _nrt=False)
def affine(fx, p):
    """Piecewise linear where ``curved`` names no state (with Stribeck friction: while its body is
    stuck), and no error quadrature (|e|, e^2) integrated: open loop, or the sampled controller,
    whose law acts at the segments' starts."""
    return not _closed(p) and (piecewise_linear(fx, p) or p[P_CURVED_M] > 0.0 or p[P_CURVED_L] > 0.0)


@nb.njit(inline="always", _nrt=False)
def watch(fx, p, modes, slope, h, idx, target):
    """The states whose extrema inside a step may hide a crossing: the mesh
    angle in free flight (a graze), the motor speed for the thesis's shift (a
    missed flip), the motor angle against the ramp for bang-bang (an error
    that pokes out of the band)."""
    n = 0
    if modes[M_CONTACT] == 0:
        idx[n], target[n] = X_DELTA, 0.0
        n += 1
    if p[P_SHIFT] > 0.0 and p[P_CTRL] != CTRL_OPEN and p[P_COMP] == COMP_THESIS:
        idx[n], target[n] = X_WM, 0.0
        n += 1
    if p[P_CTRL] == CTRL_BANGBANG:
        idx[n], target[n] = X_THM, slope * h * p[P_N]
        n += 1
    for b in range(2):
        if friction.present(p, b) and modes[M_STICK_M + b] != 0:
            idx[n], target[n] = friction.speed_index(p, b), 0.0
            n += 1
    return n


@nb.njit(inline="always", _nrt=False)
def changed(fx, before, modes):
    """An event changed the contact, the bang-bang output, the shift's sign or a
    body's stick-slip mode."""
    return (before[M_CONTACT] != modes[M_CONTACT] or before[M_BB] != modes[M_BB]
            or before[M_SHIFT] != modes[M_SHIFT] or before[M_STICK_M] != modes[M_STICK_M]
            or before[M_STICK_L] != modes[M_STICK_L])


@nb.njit(inline="always", _nrt=False)
def _stale_contact(fx, x, p, modes, ref, g):
    """Fill ``g`` with the guards at ``x``; return the contact guard that is
    already past zero in the current mode (the mode is stale), else -1."""
    guards(fx, x, p, modes, ref, g)
    if modes[M_CONTACT] != 0:
        return G_LEAVE if g[G_LEAVE] > 0.0 else -1
    if g[G_ENTER_POS] > 0.0:
        return G_ENTER_POS
    if g[G_ENTER_NEG] > 0.0:
        return G_ENTER_NEG
    return -1


@nb.njit(inline="always", _nrt=False)
def _rearm_modes(fx, x, p, modes, ref, g, xi, rtol, atol, stats, f):
    """Switch modes a step left stale; returns how many (each re-evaluates ``f``).

    A guard fires only on a crossing from < 0, so a guard of the current
    contact mode already > 0 here never fires: after a refused separation or
    an event applied a hair before its root, the teeth would stay stuck
    pulling, or pass through each other.  The controller's modes go stale the
    same way (a bang-bang stuck on drives the motor away at full voltage);
    their right mode follows from the state alone.  A saturation side counts
    only past the solver's resolution, rtol Vmax: a step landed on the limit
    is on it within round-off."""
    count = 0
    stale = _stale_contact(fx, x, p, modes, ref, g)
    cm = modes[M_CONTACT]
    if stale >= 0:
        apply_event(fx, stale, x, p, modes, ref, xi, atol, stats)
        if modes[M_CONTACT] != cm:
            count += 1
            rhs(fx, x, p, modes, ref, f)
    elif g[G_KINK] > 0.0:
        classify_damping(fx, x, p, modes)  # ElastoBacklash's damping piece, stale the same way
        count += 1
        rhs(fx, x, p, modes, ref, f)
    for j in range(G_STICK_M, G_STICK_L + 1):
        # a slipping body whose speed passed zero, or a stuck one past breakaway
        if g[j] > 0.0:
            b = j - G_STICK_M
            s = modes[M_STICK_M + b]
            switch_mode(fx, j, x, p, modes, ref, xi)
            if modes[M_STICK_M + b] != s or s != 0:
                count += 1
                rhs(fx, x, p, modes, ref, f)
    if g[G_BB_A] > 0.0 or g[G_BB_B] > 0.0 or g[G_SHIFT] > 0.0 or g[G_SAT] > rtol * p[P_VMAX]:
        if g[G_SHIFT] > 0.0:
            switch_mode(fx, G_SHIFT, x, p, modes, ref, xi)  # flips, re-derives the bang-bang
        else:
            classify_controller(fx, x, p, modes, ref)
        count += 1
        rhs(fx, x, p, modes, ref, f)
    return count


@nb.njit(inline="always", _nrt=False)
def rearm(fx, x, p, modes, ref, g, xi, rtol, atol, mem, stats, f, moved):
    """After each step: stale modes (only once time moved: an event applied
    where it stands is judged after the next step, else the two could undo
    each other forever), then count a change of sign of the applied input.
    A continuous law at rest hovers at a voltage of round-off size whose sign
    means nothing: its change counts once past rtol * Vmax."""
    count = _rearm_modes(fx, x, p, modes, ref, g, xi, rtol, atol, stats, f) if moved else 0
    u = applied_input(fx, x, p, modes, ref)
    last = int(mem[MEM_SIGN])
    if _closed(p) and p[P_CTRL] != CTRL_BANGBANG:
        u_res = rtol * p[P_VMAX]
        sg = 1 if u > u_res else (-1 if u < -u_res else last)
    else:
        sg = _sign(u)
    if sg != last:
        stats[T_SWITCHES] += 1
        mem[MEM_SIGN] = sg
    return count


@nb.njit(_nrt=False)
def start(fx, x, p, modes, seg_t, seg_v, seg_d, mem, stats):
    """The modes at t = 0 from the state, and the input there.  The sampled
    controller is taken to have run before t = 0 at the initial speed, so a
    record that starts moving starts smoothly."""
    ts0 = seg_t[1] - seg_t[0] if seg_t.size > 1 else 1.0
    w0 = x[X_WM] / p[P_N]
    mem[MEM_Y_PREV] = x[X_THM] / p[P_N] - w0 * ts0
    mem[MEM_YF_PREV] = mem[MEM_Y_PREV] - 0.5 * w0 * ts0
    mem[MEM_C_PREV] = 0.0
    mem[MEM_R0] = seg_v[0]
    u0 = p[P_CTRL_GAIN] * seg_d[0] if p[P_CTRL] == CTRL_SAMPLED_PV else seg_v[0]
    classify(fx, x, p, modes, u0)
    mem[MEM_SIGN] = _sign(applied_input(fx, x, p, modes, u0))
    return u0


@nb.njit(cache=True, _nrt=False)
def _sampled_pv(k, seg_t, v0, d, x, p, mem):
    """The EMPS controller's output held from sample ``k``, in input units.

    With the set point ``r_k = v0`` (rad) and ``y = theta_m/N`` (rad)::

        yf_k = (y_k + y_{k-1})/2,   v_k = (yf_k - yf_{k-1})/Ts,
        c_k = Kv (Kp (r_k - y_k) - v_k)

    it holds ``G (sat(c_{k-1}) + d_k)`` until the next sample (``P_DELAY`` = 1;
    ``c_k`` without the delay; saturation at ``P_VMAX`` V, ``G = P_CTRL_GAIN``
    input units per V, ``d_k`` a disturbance in V)."""
    y = x[X_THM] / p[P_N]
    yf = 0.5 * (y + mem[MEM_Y_PREV])
    ts = seg_t[k] - seg_t[k - 1] if k > 0 else (seg_t[1] - seg_t[0] if seg_t.size > 1 else 1.0)
    c = p[P_KV] * (p[P_KP] * (v0 - y) - (yf - mem[MEM_YF_PREV]) / ts)
    held = mem[MEM_C_PREV] if p[P_DELAY] > 0.0 else c
    mem[MEM_Y_PREV], mem[MEM_YF_PREV], mem[MEM_C_PREV] = y, yf, c
    return p[P_CTRL_GAIN] * (saturate(held, p[P_VMAX]) + d)


@nb.njit(inline="always", _nrt=False)
def start_segment(fx, k, seg_t, seg_v, seg_s, seg_d, x, p, modes, mem, stats):
    """The discrete update where segment ``k`` starts; returns its ``(ref, slope)``.

    The sampled controller computes its held output; the set-point-direction
    compensator's sign follows the profile, known ahead segment by segment
    (it switches only here); the feedforward reads the segment's slope from
    ``P_REF_SLOPE``, the one slot of ``p`` written while running."""
    v0 = seg_v[k]
    s = seg_s[k]
    mem[MEM_R0] = v0
    if p[P_CTRL] == CTRL_SAMPLED_PV:
        v0 = _sampled_pv(k, seg_t, v0, seg_d[k], x, p, mem)
        s = 0.0
    break_away(fx, x, p, modes, v0)
    closed = _closed(p)
    if closed and p[P_SHIFT] > 0.0 and p[P_COMP] != COMP_THESIS:
        modes[M_SHIFT] = direction_of_segment(k, seg_t, seg_v, seg_s, modes[M_SHIFT])
    p[P_REF_SLOPE] = s
    if closed:
        classify_controller(fx, x, p, modes, v0)
        stats[T_MAX_ERR] = max(stats[T_MAX_ERR], abs(v0 - load_angle(x, p)))
    return v0, s


@nb.njit(inline="always", _nrt=False)
def after_step(fx, x, p, modes, ref, h, stats):
    """Scores after an accepted step of ``h`` s: the time at the voltage limit
    (its crossings are events, so a step is on one side) and the largest error."""
    if _closed(p):
        if modes[M_SAT] != 0 or modes[M_BB] != 0:
            stats[T_SAT] += h
        stats[T_MAX_ERR] = max(stats[T_MAX_ERR], abs(ref - load_angle(x, p)))


@nb.njit(inline="always", _nrt=False)
def output(fx, row, x, p, modes, ref, mem):
    """One row of the sampled outputs (``layout.O_*``)."""
    row[O_SETPOINT] = mem[MEM_R0] if p[P_CTRL] == CTRL_SAMPLED_PV else ref
    row[O_LOAD] = load_angle(x, p)
    row[O_MOTOR] = x[X_THM]
    row[O_VOLTAGE] = applied_input(fx, x, p, modes, ref)
    row[O_CURRENT] = x[X_I]
    row[O_WM] = x[X_WM]
    row[O_WL] = x[X_WL]
    row[O_TORQUE] = mesh_torque(fx, x, p, modes)
    row[O_DELTA] = x[X_DELTA]


@nb.njit(_nrt=False)
def finish(fx, x, stats):
    stats[T_IAE] = x[X_IAE]
    stats[T_ISE] = x[X_ISE]


# ---- the model's contract (solver.model.NAMES), less ``args``: the generated module's
n_state, n_modes, n_guards, n_out = N_STATE, N_MODES, N_GUARDS, N_OUT
n_mem, n_stats, n_watch = N_MEM, N_MODEL_STATS, 5
feedback = feedback_states
region = linear_region
jacobian_rows = quadrature_rows
limit_step = saturation_reach
__all__ = [name for name in NAMES if name != "args"]
