"""The integration loop, compiled and model-agnostic: step-size control,
events, known jump times, output.

The input is a table of segments: on ``[seg_t[k], seg_t[k+1])`` it is
``ref + slope (t - seg_t[k])`` with ``(ref, slope)`` from the model's
``start_segment`` (by default the table's ``seg_v[k]``, ``seg_s[k]``; a
sampled controller computes its held output there).  The corners are known
jump times, as diffrax's ``jump_ts``: a step never straddles one.  Inside a
segment every mode switch is an event (``events.py``): its root is found on
the step's interpolant, the step is re-taken to land on it, the model
switches its mode and the integration restarts.  The model is a
``solver.model.Model``; nothing here knows what it models.
"""
import math
from collections import namedtuple

import numba as nb
import numpy as np

from . import exponential as ex
from .events import first_crossing, hidden_crossing
from .model import state_count
from .steppers import WS_ROWS, dopri5, hermite, jacobian, rodas4, rosenbrock23

METHOD_ROSENBROCK = 0  # ode23s: L-stable Rosenbrock 2(3), Shampine & Reichelt 1997
METHOD_DOPRI = 1       # Dormand-Prince 5(4), explicit
METHOD_RODAS4 = 2      # RODAS: L-stable, stiffly accurate Rosenbrock 4(3), Hairer & Wanner
METHOD_RODAS4_EXP = 3  # RODAS, and an affine model's steps between output samples exact (exponential.py)

# the solver's statistics, first in ``stats``; the model's follow from N_SOLVER_STATS
S_STATUS = 0       # 0 ok, else a STATUS_* code
S_T_FAIL = 1       # time the solver stopped, s
S_STEPS = 2        # accepted steps
S_REJECTED = 3     # rejected steps
S_EVENTS = 4       # located events and re-derived modes
S_FEVALS = 5       # right-hand-side evaluations
N_SOLVER_STATS = 6

STATUS_OK = 0
STATUS_STEP_TOO_SMALL = 1
STATUS_MAX_STEPS = 2
STATUS_NONFINITE = 3
STATUS_CHATTER = 4

CHATTER_EVENTS = 1000
"""Mode switches without an accepted step between them after which a run stops (``STATUS_CHATTER``):
modes switching back and forth at one instant (teeth touching at zero force, a stuck body whose
friction's sign flips) never advance time.  Such a run ran on to its whole step budget: on a
practice record a diagnosis' shaft-compliance fits made 40 such replays, each 1.6-2.5 million
switches in 3.5-5 s, 35 s of the candidate's 45 s.  No finishing replay of the test suite or of the
practice cases' diagnoses reaches it: their answers are unchanged to the last digit (docs/speed.md)."""

FLUSH = 1e-12
"""A state component below this fraction of its absolute tolerance is set to 0 after
each accepted step.  The error control cannot see it, and left alone a decaying mode
(a load ringing on a mesh without clearance against a stuck rotor) decays on into
subnormal numbers: below ~1e-308 their arithmetic loses its precision, the error estimate
with it, and a run that had taken 3 events per millisecond took 900,000 steps in 4 ms.
The perturbation is 1e-12 of what every step already allows."""

Table = namedtuple("Table", "t v s d t_end")
"""The input segments (s, input units, input units/s, disturbance) and the end time (s)."""
Tolerance = namedtuple("Tolerance", "rtol atol scale hmax method max_steps")
"""Error control: relative and absolute tolerances, the states' scales (``atol / rtol``),
the largest step (s), the method (``METHOD_*``) and the budget of steps and events."""
Vectors = namedtuple("Vectors", "f xn fn s0 s1 xi")
"""Per-state scratch: the derivative at the step's start, the step's end state and
derivative, its interpolant's end slopes (``hermite``), an interpolated state."""
Work = namedtuple("Work", "modes before ws g thq widx wtarget mem seg_u ex curved")
"""The modes and a copy, stepper scratch, guard values (4 rows), interpolant extrema,
watched components, the model's memory, the input held on each segment, the exact
steps' table (``Exact``) and the states the model's ``curved`` names."""
Exact = namedtuple("Exact", "keys h fill P b A T dt")
"""The exact steps' table (``exponential.py``): per slot the modes and piece, the step (NaN: unused),
``P1``, ``P2`` at it and at its half, ``df/dref``; the next slot to fill; scratch for ``A`` and
``phi``; the output's sample time (s; 0: no exact steps)."""


@nb.njit
def integrate(m, p, seg_t, seg_v, seg_s, seg_d, t_end, x0, t_out, rtol, atol, hmax, method, max_steps):
    """Integrate model ``m`` from ``x0`` at t = 0 to ``t_end`` (s).

    Returns ``(outputs, stats, x_end, seg_u)``: ``outputs[len(t_out), m.n_out]``
    sampled on ``t_out`` (NaN past a failure), ``stats`` (``S_*``, then the
    model's ``m.n_stats``), the final state and the input held on each segment.
    """
    n = m.n_state
    outputs = np.full((t_out.size, m.n_out), np.nan)
    stats = np.zeros(N_SOLVER_STATS + m.n_stats)
    x = x0.copy()
    _flush(x, atol)
    order, na = m.feedback(m.args, p)
    lin = (np.empty((na, n)), np.empty((na, 2 * na)), order, np.empty(n))
    v = np.empty((6, n))
    # exact steps from one output sample to the next, where that is a step the solver may take
    exact = (method == METHOD_RODAS4_EXP and t_out.size > 1 and t_out[1] - t_out[0] <= hmax * (1.0 + 1e-9)
             and m.affine(m.args, p))
    slots, ne = (ex.SLOTS, n) if exact else (0, 0)  # no table for a run without them
    table = Exact(np.zeros((slots, m.n_modes + 1), dtype=np.int64), np.full(slots, np.nan),
                  np.zeros(1, dtype=np.int64), np.empty((slots, 4, ne, ne)), np.empty((slots, ne)),
                  np.empty((ne, ne)), np.empty((4, ne, ne)), t_out[1] - t_out[0] if exact else 0.0)
    work = Work(np.zeros(m.n_modes, dtype=np.int64), np.zeros(m.n_modes, dtype=np.int64),
                np.empty((WS_ROWS, n)), np.empty((4, m.n_guards)), np.empty(2 * m.n_watch),
                np.zeros(m.n_watch, dtype=np.int64), np.empty(m.n_watch), np.zeros(m.n_mem),
                np.zeros(seg_t.size), table, np.zeros(n, dtype=np.int64))
    _run(m, p, Table(seg_t, seg_v, seg_s, seg_d, t_end), x, t_out,
         Tolerance(rtol, atol, atol / rtol, hmax, method, max_steps), outputs, stats,
         stats[N_SOLVER_STATS:], lin, Vectors(v[0], v[1], v[2], v[3], v[4], v[5]), work)
    return outputs, stats, x, work.seg_u


@nb.njit(_nrt=False)
def _run(m, p, tab, x, t_out, tol, outputs, stats, mstats, lin, vec, work):
    """The loop of ``integrate``, on arrays it allocated: compiled without
    numba's reference-counting runtime, whose atomic increments on every array
    view and call were 40 % of a step's time.  ``x`` is advanced in place."""
    u0 = m.start(m.args, x, p, work.modes, tab.t, tab.v, tab.d, work.mem, mstats)
    io = 0
    while io < t_out.size and t_out[io] <= 0.0:
        m.output(m.args, outputs[io], x, p, work.modes, u0, work.mem)
        io += 1
    h = min(tol.hmax, 1e-5)
    t = 0.0
    for k in range(tab.t.size):
        ta = tab.t[k]
        if ta >= tab.t_end:
            break
        tb = min(tab.t[k + 1] if k + 1 < tab.t.size else tab.t_end, tab.t_end)
        if tb <= ta:
            continue
        t, h, io = _segment(m, p, tab, k, ta, tb, h, io, x, t_out, tol, outputs, stats, mstats, lin, vec, work)
        if stats[S_STATUS] != 0:
            break
    stats[S_T_FAIL] = t
    m.finish(m.args, x, mstats)


@nb.njit(inline="always", _nrt=False)
def _step(m, method, t, x, f, h, p, modes, ref_t, s, tol, ws, lin, vec):
    """One step of the chosen method (``METHOD_*``): (error norm, rhs evaluations)."""
    if method == METHOD_RODAS4 or method == METHOD_RODAS4_EXP:
        return rodas4(m, t, x, f, h, p, modes, ref_t, s, tol.rtol, tol.atol, ws, lin, vec.xn, vec.fn, vec.s0, vec.s1)
    if method == METHOD_DOPRI:
        return dopri5(m, t, x, f, h, p, modes, ref_t, s, tol.rtol, tol.atol, ws, lin, vec.xn, vec.fn, vec.s0, vec.s1)
    return rosenbrock23(m, t, x, f, h, p, modes, ref_t, s, tol.rtol, tol.atol, ws, lin,
                        vec.xn, vec.fn, vec.s0, vec.s1)


@nb.njit(cache=True, inline="always", _nrt=False)
def _step_factor(err, method):
    """``0.9 err ** -1/(q+1)`` with ``q`` the order of the error estimate; the
    fourth root (RODAS) by square roots, which cost a fraction of ``pow`` in
    the step-size control of every step."""
    if method == METHOD_RODAS4 or method == METHOD_RODAS4_EXP:
        return 0.9 * (1.0 / math.sqrt(math.sqrt(err)))
    return 0.9 * err ** (-1.0 / 3.0 if method == METHOD_ROSENBROCK else -0.2)


@nb.njit(inline="always", _nrt=False)
def _segment(m, p, tab, k, ta, tb, h, io, x, t_out, tol, outputs, stats, mstats, lin, vec, work):
    """Integrate segment ``k`` over ``[ta, tb]``; returns ``(t, h, io)``: where
    it stopped, the next step to try and the next output row."""
    v0, s = m.start_segment(m.args, k, tab.t, tab.v, tab.s, tab.d, x, p, work.modes, work.mem, mstats)
    work.seg_u[k] = v0
    f = vec.f
    m.rhs(m.args, x, p, work.modes, v0, f)
    stats[S_FEVALS] += 1
    # The Jacobian is taken again only when it may have changed: never for a
    # step re-taken from the same point (after a rejection, or to land on an
    # event), and for a piecewise-linear right-hand side only when the mode,
    # the segment or the region changes (it is constant in between); where it
    # curves along a few states only (``m.curved``), their columns after each step.
    linear = m.piecewise_linear(m.args, p)
    jac_ok = False
    jac_region = 0
    stale = 0  # the curved columns to take again before the next step
    skip = -1  # a guard refused where it stands, ignored until time moves on
    t = ta
    tried = -math.inf  # where an exact step was last tried
    steps_seen, events_then = stats[S_STEPS], stats[S_EVENTS]
    while t < tb:
        if stats[S_STEPS] + stats[S_REJECTED] + stats[S_EVENTS] > tol.max_steps:  # events too: no endless loop
            stats[S_STATUS] = STATUS_MAX_STEPS
            break
        if stats[S_STEPS] != steps_seen:
            steps_seen, events_then = stats[S_STEPS], stats[S_EVENTS]
        elif stats[S_EVENTS] - events_then > CHATTER_EVENTS:
            stats[S_STATUS] = STATUS_CHATTER
            break
        ref_t = v0 + s * (t - ta)
        if work.ex.dt > 0.0 and t > tried and (linear or m.curved(m.args, p, work.modes, work.curved) == 0):
            tried = t
            t1 = _exact(m, p, t, tb, io, x, f, ref_t, s, skip, t_out, tol, stats, lin, vec, work)
            if t1 > t:
                io = _sample(m, p, t, t1, t1 - t, ta, v0, s, io, x, t_out, outputs, vec, work)
                if not _advance(m, p, x, f, t1 - t, ref_t + s * (t1 - t), tol.atol, vec, work, stats, mstats):
                    t = t1
                    break
                moved = m.rearm(m.args, x, p, work.modes, v0 + s * (t1 - ta), work.g[3], vec.xi, tol.rtol, tol.atol,
                                work.mem, mstats, f, True)
                t = t1
                skip = -1
                if moved > 0:
                    stats[S_EVENTS] += moved
                    stats[S_FEVALS] += moved
                    jac_ok = False
                continue
        hh = m.limit_step(m.args, x, f, p, work.modes, ref_t, s, min(h, tol.hmax), vec.xi)
        last = hh >= (tb - t) * (1.0 - 1e-12)
        # With exact steps the others end on the output's samples too, where the next exact step
        # starts; a sample a round-off short of the segment's end is its end (a step from one sample
        # to the next, of the largest step, would leave a sliver of 3e-14 s to step).
        ts = -1.0
        if work.ex.dt > 0.0:
            ts = _next_sample(t_out, io, t)
            last = last or t + hh >= tb - _round_off(tb)
        proposed = hh
        if last:
            hh = tb - t
        on_sample = not last and t < ts <= t + hh and ts < tb - _round_off(tb)
        if on_sample:
            hh = ts - t
        if tol.method != METHOD_DOPRI:
            jac_ok, jac_region = _refresh_jacobian(m, p, t, x, f, ref_t, s, jac_ok, jac_region, stale, tol,
                                                   stats, lin, work)
            stale = 0
        err, ne = _step(m, tol.method, t, x, f, hh, p, work.modes, ref_t, s, tol, work.ws, lin, vec)
        stats[S_FEVALS] += ne
        if not (err <= 1.0):
            stats[S_REJECTED] += 1
            h = hh * (0.2 if not math.isfinite(err) else max(0.2, _step_factor(err, tol.method)))
            if h < 1e-14 * max(1.0, abs(t)):
                stats[S_STATUS] = STATUS_STEP_TOO_SMALL if math.isfinite(err) else STATUS_NONFINITE
                break
            continue
        h_next = hh * min(5.0, max(0.2, _step_factor(max(err, 1e-10), tol.method)))
        # A step cut short to land on the segment's end has a small error that says little of the
        # next segment: grown from it, the next step often exceeded the proposed one and was
        # rejected (90 % of a replay's rejections before, docs/speed.md "The step after a corner").
        if (last or on_sample) and h_next > proposed:
            h_next = proposed
        which, hh, last, h_next, retry = _find_event(m, p, t, hh, last, h, h_next, x, ref_t, s, skip,
                                                     tol, stats, lin, vec, work)
        if retry:
            h = hh
            continue
        if hh > 0.0:
            t1 = tb if last else (ts if on_sample and which < 0 else t + hh)
            io = _sample(m, p, t, t1, hh, ta, v0, s, io, x, t_out, outputs, vec, work)
            if not _advance(m, p, x, f, hh, ref_t + s * hh, tol.atol, vec, work, stats, mstats):
                t = t1
                break
            t = t1
            if not linear:
                stale = m.curved(m.args, p, work.modes, work.curved)
                jac_ok = jac_ok and stale >= 0
            skip = -1
        ref_now = v0 + s * (t - ta)
        if which >= 0:
            skip = _switch(m, p, which, hh, x, f, ref_now, tol, stats, mstats, vec, work, skip)
            jac_ok = False
        moved = m.rearm(m.args, x, p, work.modes, ref_now, work.g[3], vec.xi, tol.rtol, tol.atol, work.mem, mstats,
                        f, hh > 0.0)
        if moved > 0:
            stats[S_EVENTS] += moved
            stats[S_FEVALS] += moved
            jac_ok = False
        h = h_next
    return t, h, io


@nb.njit(inline="always", _nrt=False)
def _exact(m, p, t, tb, io, x, f, ref_t, s, skip, t_out, tol, stats, lin, vec, work):
    """Try the exact step of an affine model from ``t`` to the next output sample (``exponential.py``);
    returns where it ends, or ``t`` where it is not taken: the step is not a whole sample time
    inside the segment, the model would shorten it, it ends on another piece, an event lies inside
    it, or its cubic does not follow the guards (``exponential.guards_followed``): the Rosenbrock
    steps then take it, and locate the event as they always do."""
    tab = work.ex
    dt = tab.dt
    t1 = _next_sample(t_out, io, t)
    if abs(t1 - tb) <= _round_off(tb):
        t1 = tb
    hx = t1 - t
    if t1 < 0.0 or t1 > tb or abs(hx - dt) > 1e-9 * dt:
        return t
    if m.limit_step(m.args, x, f, p, work.modes, ref_t, s, hx, vec.xi) < hx:
        return t
    region = m.piece(m.args, x, p, work.modes, ref_t)
    k = ex.lookup(tab.keys, tab.h, work.modes, region, dt)
    if k < 0:
        stats[S_FEVALS] += ex.affine_parts(m, x, f, p, work.modes, ref_t, tol.scale, region, lin[2],
                                           lin[1].shape[0], tab.A, vec.xi, work.ws[0], work.ws[1])
        k = ex.store(tab.keys, tab.h, tab.fill, work.modes, region, dt)
        for i in range(state_count(m)):
            tab.b[k, i] = vec.xi[i]
        ex.phi(tab.A, dt, tab.P[k], tab.T, state_count(m))
    xm = work.ws[0]
    ex.exact_step(m, x, f, hx, p, work.modes, ref_t, s, tab.P[k], tab.b[k], vec.xn, vec.fn, vec.s0, vec.s1, xm)
    stats[S_FEVALS] += 1
    if m.region(m.args, vec.xn, p, work.modes, ref_t + s * hx) != region:
        return t
    if _crossing(m, p, t, hx, x, ref_t, s, skip, vec, work)[0] >= 0:
        return t
    g = work.g
    ref_m = ref_t + 0.5 * s * hx
    m.guards(m.args, xm, p, work.modes, ref_m, g[2])
    hermite(0.5, hx, x, vec.s0, vec.xn, vec.s1, vec.xi)
    m.guards(m.args, vec.xi, p, work.modes, ref_m, g[3])
    return t1 if ex.guards_followed(g[0], g[1], g[2], g[3]) else t


@nb.njit(inline="always", _nrt=False)
def _refresh_jacobian(m, p, t, x, f, ref_t, s, jac_ok, jac_region, stale, tol, stats, lin, work):
    """Take the Jacobian again unless it still holds (``jac_ok``: same mode and
    segment, piecewise-linear, on the same piece), or only its ``stale`` columns
    along ``work.curved`` (the state moved since they were taken); then the rows
    the model knows exactly.  Returns the new ``(jac_ok, jac_region)``."""
    region = m.piece(m.args, x, p, work.modes, ref_t)
    whole = not jac_ok or region != jac_region
    if whole or stale > 0:
        stats[S_FEVALS] += jacobian(m, t, x, f, p, work.modes, ref_t, s, tol.scale, region, lin,
                                    work.ws[0], work.ws[1], work.ws[2], work.curved, -1 if whole else stale)
        jac_ok = True
        jac_region = region
    m.jacobian_rows(m.args, x, p, ref_t, s, lin[2], lin[1].shape[0], lin[0], lin[3])
    return jac_ok, jac_region


@nb.njit(cache=True, inline="always", _nrt=False)
def _round_off(t):
    """How far apart two times (s) near ``t`` may be and still be one: the output grid and a
    segment's end, computed apart, differ in their last bits."""
    return 1e-12 * max(1.0, abs(t))


@nb.njit(cache=True, inline="always", _nrt=False)
def _next_sample(t_out, io, t):
    """The first output time from row ``io`` on that lies ahead of ``t`` by more than its round-off
    (-1 for none): a step that ended a hair short of a sample does not take a step of that hair."""
    for j in range(io, t_out.size):
        if t_out[j] > t + _round_off(t):
            return t_out[j]
    return -1.0


@nb.njit(inline="always", _nrt=False)
def _crossing(m, p, t, hh, x, ref_t, s, skip, vec, work):
    """The first guard that fires inside the step on its interpolant, and where: ``(which, theta)``
    (-1 for none); the guards at its ends are left in ``work.g[0]``, ``work.g[1]``."""
    g = work.g
    which, theta = first_crossing(m, t, hh, x, vec.s0, vec.xn, vec.s1, p, work.modes, ref_t, s, skip,
                                  g[0], g[1], vec.xi, g[2])
    return hidden_crossing(m, t, hh, x, vec.s0, vec.xn, vec.s1, p, work.modes, ref_t, s, skip,
                           which, theta, g[0], g[1], g[3], vec.xi, g[2], work.thq, work.widx, work.wtarget)


@nb.njit(inline="always", _nrt=False)
def _find_event(m, p, t, hh, last, h, h_next, x, ref_t, s, skip, tol, stats, lin, vec, work):
    """Look for an event inside the accepted step and land on it.

    Returns ``(which, hh, last, h_next, retry)``: the guard that fired (-1:
    none), the step to keep (shortened to the root; 0 for an event where the
    step starts), whether it still ends the segment, the next step to try,
    and whether to retry instead (``h`` = ``hh``): the step re-taken to the
    root ended short of it."""
    g = work.g
    which, theta = _crossing(m, p, t, hh, x, ref_t, s, skip, vec, work)
    if which < 0:
        return which, hh, last, h_next, False
    hs = theta * hh
    if hs < 1e-13 * max(1.0, abs(t)):
        hs = 0.0
    elif theta < 1.0:
        err, ne = _step(m, tol.method, t, x, vec.f, hs, p, work.modes, ref_t, s, tol, work.ws, lin, vec)
        stats[S_FEVALS] += ne
        # The root was found on the long step's interpolant, whose error is
        # not controlled; the re-taken step can end short of the crossing
        # (teeth still apart by up to ~1e-8 rad).  Switching the mode there
        # would act across the gap.  Retry with the shorter step as a plain
        # one: the next step finds the crossing again, from much closer.
        m.guards(m.args, vec.xn, p, work.modes, ref_t + s * hs, g[2])
        if g[2][which] < 0.0:
            stats[S_REJECTED] += 1
            return which, hs, last, h_next, True
    return which, hs, last and theta >= 1.0, max(h, 1e-12 * max(1.0, abs(t))), False


@nb.njit(inline="always", _nrt=False)
def _sample(m, p, t, t1, hh, ta, v0, s, io, x, t_out, outputs, vec, work):
    """Write the output rows on ``(t, t1]`` from the step's interpolant; returns the next row."""
    while io < t_out.size and t_out[io] <= t1:
        hermite((t_out[io] - t) / hh, hh, x, vec.s0, vec.xn, vec.s1, vec.xi)
        m.output(m.args, outputs[io], vec.xi, p, work.modes, v0 + s * (t_out[io] - ta), work.mem)
        io += 1
    return io


@nb.njit(inline="always", _nrt=False)
def _advance(m, p, x, f, hh, ref_end, atol, vec, work, stats, mstats):
    """Accept the step: the state and derivative move to its end.  False if
    the state became non-finite (the run stops)."""
    for i in range(state_count(m)):
        x[i] = vec.xn[i]
        f[i] = vec.fn[i]
    _flush(x, atol)
    stats[S_STEPS] += 1
    for i in range(state_count(m)):
        if not math.isfinite(x[i]):
            stats[S_STATUS] = STATUS_NONFINITE
            return False
    m.after_step(m.args, x, p, work.modes, ref_end, hh, mstats)
    return True


@nb.njit(cache=True, inline="always", _nrt=False)
def _flush(x, atol):
    """Set the components below ``FLUSH`` times their absolute tolerance to exactly 0."""
    for i in range(x.shape[0]):
        if abs(x[i]) < FLUSH * atol[i]:
            x[i] = 0.0


@nb.njit(inline="always", _nrt=False)
def _switch(m, p, which, hh, x, f, ref, tol, stats, mstats, vec, work, skip):
    """Apply the event of guard ``which`` and restart; returns the guard to
    skip: an event refused where it stands (a separation whose torque rate
    points back into contact) with no time gained would be found again
    forever, so the next step goes without it and the model's ``rearm``
    judges it again once time has moved."""
    stats[S_EVENTS] += 1
    modes = work.modes
    for i in range(modes.shape[0]):
        work.before[i] = modes[i]
    m.apply_event(m.args, which, x, p, modes, ref, vec.xi, tol.atol, mstats)
    m.rhs(m.args, x, p, modes, ref, f)
    stats[S_FEVALS] += 1
    if hh == 0.0 and not m.changed(m.args, work.before, modes):
        return which
    return skip
