"""Contact laws of the gear mesh with backlash (an impact pair after Dubowsky).

All quantities are at the output gear: ``delta`` = theta_pinion/N - theta_load
(rad), ``ddelta`` its rate (rad/s), ``h`` half the total clearance (rad),
``k`` mesh stiffness (N m/rad), ``d`` mesh damping (N m s/rad).  The returned
torque acts on the load (positive drives it forward) and, divided by N, in
reverse on the pinion.

Penetration ``p = delta - h`` (delta > h), ``delta + h`` (delta < -h), else 0.

* Dubowsky (SPEC default): ``T = k p + d ddelta`` while in contact, clipped so
  the teeth never pull.  The damper torque ``d ddelta`` appears at once at
  contact onset, so onset is a discontinuity the solver locates as an event.
* Modelica ``ElastoBacklash``: with ``Tc = k p`` and ``Td = d ddelta``,
  ``T = Tc + min(Tc, Td)`` on the positive flank (``max`` on the negative one),
  and 0 once ``Tc + Td`` would pull: the damping torque is limited to the
  spring torque, so T is continuous at onset.
* ``linear`` (for validation): the unclipped spring-damper ``T = k p + d ddelta``
  for as long as the teeth overlap (``p != 0``); it may pull.  A single impact
  then has the textbook restitution ``exp(-zeta pi / sqrt(1 - zeta^2))`` and
  lasts exactly ``pi / omega_d``.

The solver keeps a contact mode (-1, 0, +1).  ``engaged_torque`` is the torque
while engaged on flank ``mode``; ``unclipped`` is ``Tc + Td``, whose sign
decides when the teeth separate (docs/solver-notes.md: leave contact on the sign of the
torque, not on the penetration).  ElastoBacklash's ``min(Tc, Td)`` is a kink
inside the contact: the solver keeps which piece is active as a mode too
(``limited``: ``2 Tc`` where the damping is limited, else ``Tc + Td``) and
locates the switch as an event (``kink_guard``), so the right-hand side it
integrates is linear inside every mode.
"""
import numba as nb

from ..layout import LAW_ELASTO, LAW_LINEAR


@nb.njit(cache=True, inline="always", _nrt=False)
def penetration(delta, h):
    """Overlap of the teeth beyond the clearance, rad (0 inside the dead zone)."""
    if delta > h:
        return delta - h
    if delta < -h:
        return delta + h
    return 0.0


@nb.njit(cache=True, inline="always", _nrt=False)
def unclipped(delta, ddelta, h, k, d, mode):
    """Spring plus damper torque ``k (delta - mode h) + d ddelta`` on flank ``mode``, N m."""
    return k * (delta - mode * h) + d * ddelta


@nb.njit(cache=True, inline="always", _nrt=False)
def damping_limited(delta, ddelta, h, k, d, mode):
    """ElastoBacklash on flank ``mode``: True where the damper torque ``Td`` is
    at or past the spring torque ``Tc`` (``mode (Td - Tc) >= 0``), so that
    ``min(Tc, Td)`` (``max`` on the negative flank) is ``Tc``."""
    return kink_guard(delta, ddelta, h, k, d, mode, False) >= 0.0


@nb.njit(cache=True, inline="always", _nrt=False)
def kink_guard(delta, ddelta, h, k, d, mode, limited):
    """Guard that turns >= 0 where ElastoBacklash's damping torque crosses its
    spring torque on flank ``mode``, leaving the piece ``limited`` says:
    ``mode (Td - Tc)``, negated while limited, N m."""
    g = mode * (d * ddelta - k * (delta - mode * h))
    return -g if limited else g


@nb.njit(cache=True, inline="always", _nrt=False)
def engaged_torque(delta, ddelta, h, k, d, law, mode, limited):
    """Contact torque on the load while engaged on flank ``mode`` (+1 or -1), N m:
    ``Tc + Td``, and for ElastoBacklash ``Tc + min(Tc, Td)`` (``max`` on the
    negative flank), that is ``2 Tc`` when ``limited`` (``damping_limited``)."""
    tc = k * (delta - mode * h)
    if law == LAW_ELASTO and limited:
        return 2.0 * tc
    return tc + d * ddelta


@nb.njit(cache=True, inline="always", _nrt=False)
def clipped_torque(delta, ddelta, h, k, d, law):
    """The memoryless law: contact torque from the configuration alone, N m.

    Used for checks and post-processing; the solver uses the mode-based form,
    which is identical except exactly at the switching instants.
    """
    p = penetration(delta, h)
    if law == LAW_LINEAR:
        if p > 0.0:
            return unclipped(delta, ddelta, h, k, d, 1)
        if p < 0.0:
            return unclipped(delta, ddelta, h, k, d, -1)
        return 0.0
    if p > 0.0:
        t = unclipped(delta, ddelta, h, k, d, 1)
        lim = damping_limited(delta, ddelta, h, k, d, 1)
        return engaged_torque(delta, ddelta, h, k, d, law, 1, lim) if t > 0.0 else 0.0
    if p < 0.0:
        t = unclipped(delta, ddelta, h, k, d, -1)
        lim = damping_limited(delta, ddelta, h, k, d, -1)
        return engaged_torque(delta, ddelta, h, k, d, law, -1, lim) if t < 0.0 else 0.0
    return 0.0


@nb.njit(cache=True, inline="always", _nrt=False)
def entry_guard(delta, ddelta, h, k, d, side):
    """Guard that turns >= 0 when free teeth touch flank ``side``, in N m.

    Outside the penetrated region it is the spring torque the contact would have,
    ``k (side*delta - h)`` (< 0); inside it (the teeth overlap but the torque
    would pull) it is the unclipped torque, so re-engagement without a gap is
    caught too.
    """
    if side * delta <= h:
        return k * (side * delta - h)
    return side * unclipped(delta, ddelta, h, k, d, side)
