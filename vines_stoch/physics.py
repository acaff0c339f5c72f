"""Physics formulae of MODEL.md, written as small numba functions that the kernels inline.

Bodies are numbered 0 (primary) and 1..n (absorbers).  Relative motion of absorber ``a`` is
``u = x_a - x_1``, ``w = v_a - v_1``; ``f`` is the force the primary exerts on the absorber.
"""

from __future__ import annotations

import numpy as np
from numba import njit

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


@njit(**INLINE)
def spring_damper_force(u: float, w: float, k_lin: float, k_cubic: float, c: float) -> float:
    """Force on an absorber from its attachment (MODEL.md section 2).

    ``linear``: ``f = -k u - c w``; ``cubic`` (Wei et al. eq. 1): ``f = -k u^3 - k_lin u - c w``.
    """
    return -(k_lin + k_cubic * u * u) * u - c * w


@njit(**INLINE)
def spring_damper_energy(u: float, k_lin: float, k_cubic: float) -> float:
    """Potential energy of an absorber attachment: ``k_lin u^2 / 2 + k_cubic u^4 / 4``."""
    u2 = u * u
    return 0.5 * k_lin * u2 + 0.25 * k_cubic * u2 * u2


@njit(**INLINE)
def restitution_impact(m1: float, ma: float, v1: float, va: float, r: float):
    """Newton impact between primary and absorber (MODEL.md section 2, Wei et al. eqs. 2-3).

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
def primary_energy(m1: float, k1: float, x1: float, v1: float) -> float:
    """``E1 = m1 v1^2 / 2 + k1 x1^2 / 2`` (MODEL.md section 4)."""
    return 0.5 * m1 * v1 * v1 + 0.5 * k1 * x1 * x1


def hertz_constant(young, poisson, radius: float, q: float = 0.318) -> float:
    """Hertz constant ``K = (4/3) q / ((delta_1 + delta_2) sqrt(A + B))`` of a sphere of
    ``radius`` on a flat, ``A = B = 1 / (2 radius)``, ``delta_i = (1 - nu_i^2) / (pi E_i)``
    (MODEL.md section 2, Lizunov et al. eq. 3)."""
    deltas = sum((1.0 - nu * nu) / (np.pi * e) for e, nu in zip(young, poisson))
    return 4.0 / 3.0 * q / (deltas * np.sqrt(1.0 / radius))


@njit(**INLINE)
def hertz_force(z: float, k: float) -> float:
    """Quasi-static Hertz contact force ``K z^1.5`` for an approach ``z > 0``, else 0."""
    return k * z * np.sqrt(z) if z > 0.0 else 0.0


@njit(**INLINE)
def hertz_energy(z: float, k: float) -> float:
    """Energy stored in a Hertz contact: ``0.4 K z^2.5`` for ``z > 0``, else 0."""
    return 0.4 * k * z * z * np.sqrt(z) if z > 0.0 else 0.0
