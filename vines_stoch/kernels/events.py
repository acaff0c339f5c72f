"""Which event an absorber meets, for every scheme with events: an impact absorber reaching a
cavity wall, a Hertz absorber starting or ending a contact (MODEL.md section 2).

``event_ahead`` reads an absorber's displacement relative to its host floor at the end of a
trial (sub-)step and says which event lies between: its kind, the side (-1 left, +1 right: the
wall hit, the contact surface touched or left) and the wall's place (the relative displacement
at the event).  The event happens when the gap ``gap_sign(event, side) (u - wall)`` crosses zero
upwards.  Each scheme keeps its own search for the instant: the kick-drift-kick loop the
Illinois bracket on the Brownian path (``kdk.crossing``), the RK4 loop Newton iteration on the
length of an RK4 sub-step from a linear first guess (``rk4.next_event``).
"""

from __future__ import annotations

from numba import njit

from ..jit.flags import INLINE
from ..physics.absorbers import CLEARANCE, HERTZ, IMPACT, WALL_HI, WALL_LO

#: Event kinds: none, an impact on a wall, a contact's onset, a contact's end.
NONE, IMPACT_EVENT, ONSET, EXIT = 0, 1, 2, 3


@njit(**INLINE)
def event_ahead(kind, stuck, touching, rows, a: int, u: float, impacts: bool, room: bool, contact: bool):
    """``(event, side, wall)``: the event absorber ``a`` has passed when its displacement
    relative to its host floor is ``u`` (``NONE``, side 0: none).  An impact absorber not stuck
    (``stuck[a] == 0``) outside its clearance has hit the wall on that side; a Hertz absorber
    touching nothing (``touching[a] == 0``) beyond a contact surface has touched it, one in
    contact on side ``touching[a]`` back inside has left it.  ``impacts``, ``contact``: the scene
    has impact, Hertz absorbers (compile-time flags); ``room``: the step may resolve another
    impact."""
    event, side, wall = NONE, 0, 0.0
    if impacts and kind[a] == IMPACT and stuck[a] == 0 and room:
        if abs(u) > rows[a, CLEARANCE]:
            side = 1 if u > 0.0 else -1
            event, wall = IMPACT_EVENT, side * rows[a, CLEARANCE]
    elif contact and kind[a] == HERTZ:
        if touching[a] == 0 and u < rows[a, WALL_LO]:
            event, side, wall = ONSET, -1, rows[a, WALL_LO]
        elif touching[a] == 0 and u > rows[a, WALL_HI]:
            event, side, wall = ONSET, 1, rows[a, WALL_HI]
        elif touching[a] < 0 and u > rows[a, WALL_LO]:
            event, side, wall = EXIT, -1, rows[a, WALL_LO]
        elif touching[a] > 0 and u < rows[a, WALL_HI]:
            event, side, wall = EXIT, 1, rows[a, WALL_HI]
    return event, side, wall


@njit(**INLINE)
def gap_sign(event: int, side: int) -> int:
    """The sign of an event's gap ``sign (u - wall)``, which crosses zero upwards at the event:
    the side for an impact or an onset (moving out), the other for a contact's end (moving
    back in)."""
    return -side if event == EXIT else side
