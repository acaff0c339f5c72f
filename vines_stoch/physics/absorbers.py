"""Absorber laws (MODEL.md section 2): the kind codes, the columns of an absorber's parameter
row and the attachment formulae.

Bodies are numbered ``0 .. n_floors - 1`` (the primary's floors, lowest first; the last is the
roof) and then one per absorber.  Absorber ``a`` hangs on its host floor ``h``: its relative
motion is ``u = x_a - x_h``, ``w = v_a - v_h``; ``f`` is the force the host exerts on it.

Absorbers reach the kernels as kind-coded rows (``LAWS``, the columns ``K_LIN .. WALL_HI``):
every law has the spring-damper attachment of ``spring_damper_force`` (its coefficients zero
where a law has none); an ``IMPACT`` row adds rigid walls at ``+-CLEARANCE`` (Newton
restitution, ``impact.restitution_impact``), a ``HERTZ`` row finite-duration contact forces
(``hertz.contact_force_law``).
"""

from __future__ import annotations

from numba import njit

from ..jit.flags import INLINE

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
