"""Pieces shared by the step loops: forces on all bodies, contact constraints, metric slots."""

from __future__ import annotations

import numpy as np
from numba import njit

from ..physics import INLINE, KERNEL, spring_damper_force

#: Slots of the raw metric vector a kernel fills; ``metrics.finish`` turns it into columns.
SLOTS = (
    "input_energy", "primary_dissipation", "absorber_dissipation", "impact_loss",
    "energy_integral", "e1_max", "x1_max", "x1_square_integral", "impacts",
    "final_energy", "status", "capped_steps",
)
(INPUT, PRIMARY_DISS, ABSORBER_DISS, IMPACT_LOSS, ENERGY_INT, E1_MAX, X1_MAX, X1_SQ_INT,
 IMPACTS, FINAL_ENERGY, STATUS, CAPPED) = range(len(SLOTS))

#: Status codes written into the ``status`` slot.
STATUS_OK, STATUS_DIVERGED = 0, 1

#: Impacts resolved inside one outer step before the rest of the step ignores the walls.
MAX_EVENTS = 64

#: Steps between divergence checks (and between exact re-evaluations of harmonic phases).
CHECK_EVERY = 1024

#: A displacement beyond this counts as divergence.
DIVERGED = 1e100


@njit(**INLINE)
def attachment_forces(x, v, k1, c1, k_lin, k_cubic, c_abs, force):
    """``force[b]``: force on body ``b`` from the primary's spring and damper and every
    absorber attachment (MODEL.md section 1); external loads are added by the caller."""
    force[0] = -k1 * x[0] - c1 * v[0]
    for a in range(k_lin.shape[0]):
        f = spring_damper_force(x[a + 1] - x[0], v[a + 1] - v[0], k_lin[a], k_cubic[a], c_abs[a])
        force[a + 1] = f
        force[0] -= f


@njit(**INLINE)
def common_value(mass, values, stuck, impact_body):
    """Mass-weighted mean of ``values`` over the primary and the stuck absorbers."""
    total_mass = mass[0]
    total = mass[0] * values[0]
    for q in range(stuck.shape[0]):
        if stuck[q] != 0:
            j = impact_body[q] + 1
            total_mass += mass[j]
            total += mass[j] * values[j]
    return total / total_mass


@njit(**INLINE)
def stick_together(mass, values, stuck, impact_body, release):
    """Primary and absorbers stuck to a cavity wall move as one body (MODEL.md section 2).

    ``values`` holds velocities (after a kick) or accelerations; stuck bodies get the
    mass-weighted common value.  With ``release``, an absorber the wall would have to pull
    (constraint of the wrong sign) is released first.
    """
    common = common_value(mass, values, stuck, impact_body)
    if release:
        for q in range(stuck.shape[0]):
            # wall force on the absorber ~ mass * (common - free value); a wall only pushes
            if stuck[q] * (common - values[impact_body[q] + 1]) > 0.0:
                stuck[q] = 0
        common = common_value(mass, values, stuck, impact_body)
    values[0] = common
    for q in range(stuck.shape[0]):
        if stuck[q] != 0:
            values[impact_body[q] + 1] = common


@njit(**INLINE)
def pin_to_walls(x, stuck, impact_body, clearance):
    """Place stuck absorbers exactly at their wall (removes round-off drift)."""
    for q in range(stuck.shape[0]):
        if stuck[q] != 0:
            x[impact_body[q] + 1] = x[0] + stuck[q] * clearance[q]


@njit(**INLINE)
def diverged(x) -> bool:
    """True if any coordinate is not finite or beyond ``DIVERGED``."""
    for b in range(x.shape[0]):
        if not (abs(x[b]) < DIVERGED):
            return True
    return False


@njit(**INLINE)
def sticks(side: int, w_in: float, w_gain: float) -> bool:
    """Sticking rule: an impact slower than the relative velocity the loads add in one step,
    with the loads pressing into the wall, is plastic and starts a sticking phase."""
    return side * w_gain > 0.0 and abs(w_in) <= side * w_gain


def new_metrics() -> np.ndarray:
    """A zeroed raw metric vector."""
    return np.zeros(len(SLOTS))
