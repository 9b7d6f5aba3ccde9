"""What the generic integrator needs from a model: a module of compiled functions.

The integrator (``integrate.py``) solves a hybrid system: a state ``x`` that
flows by a right-hand side inside discrete modes, guards whose zero crossings
are events that switch the modes, and an input table of segments whose
corners are known jump times (diffrax's ``jump_ts``), at each of which the
model may update its discrete part (a sampled controller).  It imports
nothing about the physics; a model gives it a module with the names below
(numba functions and integers), passed to ``integrate.integrate`` as an
argument: numba compiles the loop for that module and resolves each name
at compile time, so calls cost nothing and the compiled entry point can be
cached on disk (a tuple of functions would be passed as pointers, which
numba cannot cache).  Every function takes the module's ``args`` first
(gearbench's gear model passes the module holding its effects' terms), as
diffrax's vector fields take ``args``.

Sizes
    ``n_state``, ``n_modes``, ``n_guards``, ``n_out`` (output columns),
    ``n_mem`` (the model's memory between calls), ``n_stats`` (its statistics),
    ``n_watch`` (most state components ``watch`` names).

Flow
    ``rhs(args, x, p, modes, ref, out)``: write ``dx/dt``.
    ``feedback(args, p) -> (order, count)``: the states ``rhs`` reads, first;
    the others feed nothing back (their Jacobian columns are zero).
    ``piecewise_linear(args, p) -> bool``: ``rhs`` is affine in ``x`` inside
    each mode and each ``region``, so a Jacobian can be reused there.
    ``curved(args, p, modes, idx) -> count``: where it is not, the states along
    which the Jacobian changes inside these modes and one ``region``, written to
    ``idx``: 0 where ``rhs`` is affine in ``x`` there after all (a Jacobian can
    be reused), a few where it curves along those states alone (only their
    columns are taken again), -1 where it may curve along any (the whole
    Jacobian is taken at every step).
    ``affine(args, p) -> bool``: more than ``curved`` 0: ``rhs`` is affine in the
    whole state and in ``ref`` inside each mode and ``region`` where ``curved`` is 0
    (no row left to ``jacobian_rows``), so a step there may be taken exactly
    (``exponential.py``).
    ``region(args, x, p, modes, ref) -> int``: which affine piece ``x`` lies in.
    ``piece(args, x, p, modes, ref) -> int``: the piece a step from ``x`` is
    on (a located kink leaves ``x`` on the boundary: there the mode says).
    ``jacobian_rows(args, x, p, ref, slope, order, count, jac, tdot)``:
    overwrite the Jacobian entries the model knows exactly (rows of terms that
    are not affine, taken fresh at every step).
    ``limit_step(args, x, f, p, modes, ref, slope, h, scratch) -> h``: a
    shorter step where the model sees a kink coming.

Events
    ``guards(args, x, p, modes, ref, g)``: an event fires where ``g[j]`` goes
    from < 0 to >= 0.
    ``watch(args, p, modes, slope, h, idx, target) -> count``: state
    components whose interpolant's slope reaching ``target`` (per unit step
    fraction) may hide a guard's brief crossing inside a step: the guards are
    also tested there.
    ``apply_event(args, which, x, p, modes, ref, scratch, atol, stats)``.
    ``changed(args, before, modes) -> bool``: whether an event changed the
    modes that matter (an event that changed none where it stands is
    skipped until time moves on).
    ``rearm(args, x, p, modes, ref, g, scratch, rtol, atol, mem, stats, f,
    moved) -> count``: after each step (``moved``: it advanced time) switch the modes
    a step left stale and update the statistics; returns how many times it
    re-evaluated ``rhs`` into ``f``.

Input and output
    ``start(args, x, p, modes, seg_t, seg_v, seg_d, mem, stats) -> ref``:
    the modes at t = 0 and the input there.
    ``start_segment(args, k, seg_t, seg_v, seg_s, seg_d, x, p, modes, mem,
    stats) -> (ref, slope)``: the discrete update at segment ``k``'s start;
    the input is ``ref + slope (t - seg_t[k])`` on it.
    ``after_step(args, x, p, modes, ref, h, stats)``: statistics after an
    accepted step of ``h`` s ending at input ``ref``.
    ``output(args, row, x, p, modes, ref, mem)``: one row of outputs.
    ``finish(args, x, stats)``: the last statistics from the final state.
"""
from numba.extending import overload


def state_count(m) -> int:
    """``m.n_state``; compiled, a constant of the compiled code (numba reads a
    module argument's integers as run-time values, and the one-step methods'
    loops over the states unroll only over a constant count)."""
    return m.n_state


@overload(state_count, inline="always")
def _state_count(m):
    n = int(m.pymod.n_state)
    return lambda m: n


def guard_count(m) -> int:
    """``m.n_guards``, a compile-time constant likewise (the event scan's loops)."""
    return m.n_guards


@overload(guard_count, inline="always")
def _guard_count(m):
    n = int(m.pymod.n_guards)
    return lambda m: n


NAMES = ("args", "n_state", "n_modes", "n_guards", "n_out", "n_mem", "n_stats", "n_watch",
         "rhs", "feedback", "piecewise_linear", "curved", "affine", "region", "piece", "jacobian_rows", "limit_step",
         "guards", "watch", "apply_event", "changed", "rearm",
         "start", "start_segment", "after_step", "output", "finish")


def missing(model) -> list[str]:
    """The names of the contract ``model`` lacks (empty when it is complete)."""
    return [name for name in NAMES if not hasattr(model, name)]
