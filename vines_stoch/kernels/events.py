"""Which event an absorber meets, for every scheme with events: an impact absorber reaching a
cavity wall, a Hertz absorber starting or ending a contact (MODEL.md section 2).

``event_ahead`` reads an absorber's displacement relative to its host floor at the end of a
trial (sub-)step and says which event lies between: its kind, the side (-1 left, +1 right: the
wall hit, the contact surface touched or left) and the wall's place (the relative displacement
at the event).  The event happens when the gap ``gap_sign(event, side) (u - wall)`` crosses zero
upwards.  Each scheme keeps its own search for the instant: the kick-drift-kick loop the
bracket on the Brownian path, halved at the nodes of the step's Brownian tree and then closed by
the Illinois method (``kdk.crossing``), the RK4 loop Newton iteration on the
length of an RK4 sub-step from a linear first guess (``rk4.next_event``).
"""

from __future__ import annotations

import math

from ..jit import njit
from ..jit.flags import INLINE
from ..physics.absorbers import HERTZ, IMPACT

#: Event kinds: none, an impact on a wall, a contact's onset, a contact's end.
NONE, IMPACT_EVENT, ONSET, EXIT = 0, 1, 2, 3


@njit(**INLINE)
def event_ahead(kind: int, stuck: int, touching: int, clearance: float, wall_lo: float, wall_hi: float,
                u: float, impacts: bool, room: bool, contact: bool):
    """``(event, side, wall)``: the event an absorber (law code ``kind``; its row's clearance
    and contact surfaces ``wall_lo``, ``wall_hi``: ``physics.absorbers``) has passed when its
    displacement relative to its host floor is ``u`` (``NONE``, side 0: none).  An impact
    absorber not stuck (``stuck == 0``) outside its clearance has hit the wall on that side; a
    Hertz absorber touching nothing (``touching == 0``) beyond a contact surface has touched it,
    one in contact on side ``touching`` back inside has left it.  ``impacts``, ``contact``: the
    scene has impact, Hertz absorbers (compile-time flags); ``room``: the step may resolve
    another impact.  (Values, not the loops' arrays: an inlined function given heap arrays
    inside its branches costs reference counting at every call, see ``jit.flags.INLINE``.)"""
    event, side, wall = NONE, 0, 0.0
    if impacts and kind == IMPACT and stuck == 0 and room:
        if abs(u) > clearance:
            side = 1 if u > 0.0 else -1
            event, wall = IMPACT_EVENT, side * clearance
    elif contact and kind == HERTZ:
        if touching == 0 and u < wall_lo:
            event, side, wall = ONSET, -1, wall_lo
        elif touching == 0 and u > wall_hi:
            event, side, wall = ONSET, 1, wall_hi
        elif touching < 0 and u > wall_lo:
            event, side, wall = EXIT, -1, wall_lo
        elif touching > 0 and u < wall_hi:
            event, side, wall = EXIT, 1, wall_hi
    return event, side, wall


@njit(**INLINE)
def quiet_band(kind: int, clearance: float, wall_lo: float, wall_hi: float):
    """``(lo, hi)``: the displacements ``lo <= u <= hi`` at which an absorber neither stuck nor
    touching meets no event (``event_ahead``'s ``NONE``): an impact absorber's cavity, a Hertz
    absorber's room between its contact surfaces, and everywhere for the other laws.  A test
    ``u < lo or u > hi`` has no branch, so a loop over SIMD lanes keeps it (``kernels/lanes.py``)."""
    if kind == IMPACT:
        return -clearance, clearance
    if kind == HERTZ:
        return wall_lo, wall_hi
    return -math.inf, math.inf


@njit(**INLINE)
def pressed(kind: int, u: float, lo: float, hi: float) -> float:
    """1.0 where a Hertz absorber (law code ``kind``) at ``u`` lies beyond its contact surfaces
    ``lo, hi`` (``quiet_band``'s), so that its contact force is not zero; else 0.0.  No branch:
    the SIMD lanes sum it into their event flag (``kernels/lanes.py``)."""
    return 1.0 if ((u < lo) | (u > hi)) & (kind == HERTZ) else 0.0


@njit(**INLINE)
def gap_sign(event: int, side: int) -> int:
    """The sign of an event's gap ``sign (u - wall)``, which crosses zero upwards at the event:
    the side for an impact or an onset (moving out), the other for a contact's end (moving
    back in)."""
    return -side if event == EXIT else side
