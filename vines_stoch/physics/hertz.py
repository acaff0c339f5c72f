"""Hertz contact (MODEL.md section 2): the contact constant, force and stored energy, and the
sub-step that resolves a contact."""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit
from ..jit.flags import INLINE
from .absorbers import K_LEFT, K_RIGHT, WALL_HI, WALL_LO
from .structure import host_of

#: Sub-steps per Hertz contact duration (MODEL.md section 2 asks for at least about 20).
CONTACT_STEPS = 80

def hertz_constant(young, poisson, radius: float, q: float = 0.318) -> float:
    """Hertz constant ``K = (4/3) q / ((delta_1 + delta_2) sqrt(A + B))`` of a sphere of
    ``radius`` on a flat, ``A = B = 1 / (2 radius)``, ``delta_i = (1 - nu_i^2) / (pi E_i)``
    (MODEL.md section 2, Lizunov et al. eq. 3)."""
    deltas = sum((1.0 - nu * nu) / (np.pi * e) for e, nu in zip(young, poisson))
    return 4.0 / 3.0 * q / (deltas * math.sqrt(1.0 / radius))


@njit(**INLINE)
def hertz_force(z: float, k: float) -> float:
    """Quasi-static Hertz contact force ``K z^1.5`` for an approach ``z > 0``, else 0 (Johnson,
    *Contact Mechanics*, Cambridge 1985, section 4.2; Lizunov, Pogorelova and Postnikova, "Choice
    of the model for vibro-impact nonlinear sink", eq. 3)."""
    return k * z * math.sqrt(z) if z > 0.0 else 0.0


@njit(**INLINE)
def hertz_energy(z: float, k: float) -> float:
    """Energy stored in a Hertz contact: ``0.4 K z^2.5`` for ``z > 0``, else 0."""
    return 0.4 * k * z * z * math.sqrt(z) if z > 0.0 else 0.0


@njit(**INLINE)
def contact_force_law(rows, a: int, u: float) -> float:
    """Hertz contact force on absorber row ``a`` at relative position ``u``: ``+K_L z_L^1.5 -
    K_R z_R^1.5`` (MODEL.md section 2); the opposite acts on its host floor.  (Rows are
    indexed in place: a row view would cost reference counting in the step loops.)"""
    return (hertz_force(rows[a, WALL_LO] - u, rows[a, K_LEFT])
            - hertz_force(u - rows[a, WALL_HI], rows[a, K_RIGHT]))


@njit(**INLINE)
def contact_energy(rows, a: int, u: float) -> float:
    """Energy stored in both Hertz contacts of absorber row ``a`` at relative position ``u``."""
    return (hertz_energy(rows[a, WALL_LO] - u, rows[a, K_LEFT])
            + hertz_energy(u - rows[a, WALL_HI], rows[a, K_RIGHT]))


@njit(**INLINE)
def contact_substep(x, v, nf: int, mass, host, rows, a: int, side: int, steps: int) -> float:
    """Sub-step for Hertz absorber ``a`` in contact on side ``side`` (-1 left, +1 right): about
    ``steps`` per contact duration.

    A Hertz contact with relative energy ``E`` compresses to ``z_max = (E / (0.4 K))^0.4`` and
    lasts about ``4 / omega`` with ``omega = sqrt(1.5 K z_max^0.5 / m_eff)`` (the contact's
    stiffness at ``z_max``; Johnson, *Contact Mechanics*, section 11.4).  ``inf`` for a contact at
    rest with no approach (it asks for no sub-steps)."""
    hf = host_of(host, a, nf)
    j = nf + a
    m_eff = mass[hf] * mass[j] / (mass[hf] + mass[j])
    u = x[j] - x[hf]
    w = v[j] - v[hf]
    k = rows[a, K_LEFT] if side < 0 else rows[a, K_RIGHT]
    z = max(rows[a, WALL_LO] - u if side < 0 else u - rows[a, WALL_HI], 0.0)
    energy = 0.5 * m_eff * w * w + 0.4 * k * z * z * math.sqrt(z)
    z_ref = max(z, (energy / (0.4 * k)) ** 0.4)
    if z_ref <= 0.0:
        return np.inf
    return 4.0 / (steps * math.sqrt(1.5 * k * math.sqrt(z_ref) / m_eff))
