"""Physics formulae of MODEL.md, written as small numba functions that the kernels inline.

Bodies are numbered ``0 .. n_floors - 1`` (the primary's floors, lowest first; the last is the
roof) and then one per absorber.  Absorber ``a`` hangs on its host floor ``h``: its relative
motion is ``u = x_a - x_h``, ``w = v_a - v_h``; ``f`` is the force the host exerts on it.

Absorbers reach the kernels as kind-coded rows (``LAWS``, the columns ``K_LIN .. WALL_HI``):
every law has the spring-damper attachment of ``spring_damper_force`` (its coefficients zero
where a law has none); an ``IMPACT`` row adds rigid walls at ``+-CLEARANCE`` (Newton
restitution, ``restitution_impact``), a ``HERTZ`` row finite-duration contact forces
(``contact_force_law``).  A new law is one formula here, one schema class and one entry in
``LAWS`` and ``scene.absorber_row``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .cache import key_by_sources
from .frontend import install

#: Options of every compiled loop: cached on disk, GIL released, IEEE division (no Python
#: ZeroDivisionError checks in hot loops), and fused multiply-adds (``contract``: one rounding
#: instead of two, half the latency on a step's critical path; no other fast-math licence, so
#: NaN and infinity keep their meaning for the divergence checks).
KERNEL = dict(cache=True, nogil=True, error_model="numpy", fastmath={"contract"})
#: Options of the small formula functions the loops inline.  An inlined function that takes
#: arrays, called inside a branch the compiler cannot remove, costs atomic reference counting
#: of those arrays each time the enclosing loop passes it: the step loops call such functions
#: unconditionally or under compile-time flags, and keep rare work out of the step loop.  Each
#: inlined copy also costs compile time: a large inlined function gets one call site, and rare
#: work calls it through an out-of-line wrapper (``rk4.rk4_step``, ``rk4.wall_accelerations``).
INLINE = dict(KERNEL, inline="always")
install()  # numba's front end in less than half the time, the same code (see ``frontend``)
key_by_sources()  # an edited formula never runs from a stale cache (see ``cache``)

#: Kind codes of absorber rows (MODEL.md section 2), by the ``type`` of a scenario's absorber.
LINEAR, CUBIC, IMPACT, HERTZ = 0, 1, 2, 3
LAWS = {"linear": LINEAR, "cubic": CUBIC, "impact": IMPACT, "hertz": HERTZ}
#: Columns of an absorber row: attachment (linear and cubic stiffness, damping, spring rest
#: offset), impact walls (clearance, restitution), Hertz contact (constants ``K`` and contact
#: surfaces ``z_L = WALL_LO - u``, ``z_R = u - WALL_HI``).
K_LIN, K_CUBIC, DAMPING, REST, CLEARANCE, RESTITUTION, K_LEFT, K_RIGHT, WALL_LO, WALL_HI = range(10)
ROW = 10


@njit(**INLINE)
def spring_damper_force(u: float, w: float, k_lin: float, k_cubic: float, c: float) -> float:
    """Force on an absorber from its attachment (MODEL.md section 2).

    ``linear``: ``f = -k u - c w``; ``cubic`` (Wei et al., Appl. Math. Mech. (Engl. Ed.) 40(5)
    2019, eq. 1): ``f = -k u^3 - k_lin u - c w``.
    """
    return -(k_lin + k_cubic * u * u) * u - c * w


@njit(**INLINE)
def spring_damper_energy(u: float, k_lin: float, k_cubic: float) -> float:
    """Potential energy of an absorber attachment: ``k_lin u^2 / 2 + k_cubic u^4 / 4``."""
    u2 = u * u
    return 0.5 * k_lin * u2 + 0.25 * k_cubic * u2 * u2


@njit(**INLINE)
def restitution_impact(m1: float, ma: float, v1: float, va: float, r: float):
    """Newton impact between primary and absorber (MODEL.md section 2; Wei et al., "Targeted
    energy transfer of a parallel nonlinear energy sink", Appl. Math. Mech. (Engl. Ed.) 40(5)
    2019, eqs. 2-3).

    Momentum is conserved and the relative velocity reversed and scaled by ``r``.  Returns the
    post-impact velocities and the energy lost,
    ``dE = (1 - r^2) m1 ma / (2 (m1 + ma)) (va - v1)^2``.
    """
    w = va - v1
    total = m1 + ma
    v1_new = v1 + ma * (1.0 + r) * w / total
    va_new = va - m1 * (1.0 + r) * w / total
    loss = 0.5 * (1.0 - r * r) * m1 * ma / total * w * w
    return v1_new, va_new, loss


@njit(**INLINE)
def primary_energy(mass, storey_k, x, v, nf: int) -> float:
    """``E1``: kinetic energy of the ``nf`` floors plus the strain energy of their storeys,
    ``sum m_k v_k^2 / 2 + sum k_k d_k^2 / 2``, ``d_k = x_k - x_{k-1}`` (MODEL.md sections 1a, 4;
    one floor: ``m1 v1^2 / 2 + k1 x1^2 / 2``)."""
    e = 0.5 * mass[0] * v[0] * v[0] + 0.5 * storey_k[0] * x[0] * x[0]
    for k in range(1, nf):
        d = x[k] - x[k - 1]
        e += 0.5 * mass[k] * v[k] * v[k] + 0.5 * storey_k[k] * d * d
    return e


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
def hertz_energy(z: float, k: float) -> float:
    """Energy stored in a Hertz contact: ``0.4 K z^2.5`` for ``z > 0``, else 0."""
    return 0.4 * k * z * z * math.sqrt(z) if z > 0.0 else 0.0
