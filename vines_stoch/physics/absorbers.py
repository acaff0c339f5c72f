"""Absorber laws (MODEL.md section 2): the kind codes, the columns of an absorber's parameter
row and the attachment formulae.

Bodies are numbered ``0 .. n_floors - 1`` (the primary's floors, lowest first; the last is the
roof) and then one per absorber.  Absorber ``a`` hangs on its host floor ``h``: its relative
motion is ``u = x_a - x_h``, ``w = v_a - v_h``; ``f`` is the force the host exerts on it.

Absorbers reach the kernels as kind-coded rows (``LAWS``, the columns ``K_LIN .. GAP``).
The attachment force of every law is one sum: the polynomial spring-damper of
``spring_damper_force`` (linear, cubic, bistable; its coefficients zero where a law has none)
plus the shaped springs of ``shaped_force``, the terms that are not a polynomial of ``u`` (the
geometric attachment's two inclined springs, the gap spring), each on the rows whose constant
(``SHAPED``) is not zero; the step loops of scenes without such a row leave them out at
compile time (``kernels.common.shaped_forces``); ``coupling_energy`` is the potential.  An
``IMPACT`` row adds rigid walls at ``+-CLEARANCE`` (Newton restitution,
``impact.restitution_impact``), a ``HERTZ`` row finite-duration contact forces
(``hertz.contact_force_law``).

A new law is its code in ``LAWS`` and its schema class in ``scenario/bodies.py``, which gives its
row (``parameters``) and linearised stiffness (``spring``); where it is not a polynomial, also
its columns, its formula and energy here and their terms in ``shaped_force`` and
``shaped_energy`` (the gap spring is the model): the step loops and the energy accounts take it
from there; the estimates without an ensemble need its Gaussian expectations
(``rvt.linearization.law``, ``rvt.energy.coupling_energy``).
"""

from __future__ import annotations

import math

from ..jit import njit
from ..jit.flags import INLINE
from ..jit.intrinsics import fused

#: Kind codes of absorber rows (MODEL.md section 2), by the ``type`` of a scenario's absorber.
LINEAR, CUBIC, IMPACT, HERTZ, BISTABLE, GEOMETRIC, GAP_SPRING = 0, 1, 2, 3, 4, 5, 6
LAWS = {"linear": LINEAR, "cubic": CUBIC, "impact": IMPACT, "hertz": HERTZ, "bistable": BISTABLE,
        "geometric": GEOMETRIC, "gap": GAP_SPRING}
#: Columns of an absorber row: attachment (linear and cubic stiffness, damping, spring rest
#: offset), impact walls (clearance, restitution), Hertz contact (constants ``K`` and contact
#: surfaces ``z_L = WALL_LO - u``, ``z_R = u - WALL_HI``), geometric attachment (each inclined
#: spring's stiffness, its free length and its installed length), gap spring (its stiffness and
#: the gap beyond which it engages).
(K_LIN, K_CUBIC, DAMPING, REST, CLEARANCE, RESTITUTION, K_LEFT, K_RIGHT, WALL_LO, WALL_HI, K_GEO, FREE_LENGTH,
 LENGTH, K_GAP, GAP) = range(15)
ROW = 15
#: The columns by name (the schema classes name the values of their rows: ``parameters``).
COLUMNS = {"k_lin": K_LIN, "k_cubic": K_CUBIC, "damping": DAMPING, "rest": REST, "clearance": CLEARANCE,
           "restitution": RESTITUTION, "k_left": K_LEFT, "k_right": K_RIGHT, "wall_lo": WALL_LO,
           "wall_hi": WALL_HI, "k_geo": K_GEO, "free_length": FREE_LENGTH, "length": LENGTH,
           "k_gap": K_GAP, "gap": GAP}
#: The constants of the shaped springs (``shaped_force``): a row with one of them not zero has
#: that term.
SHAPED = (K_GEO, K_GAP)

@njit(**INLINE)
def spring_damper_force(u: float, w: float, k_lin: float, k_cubic: float, c: float) -> float:
    """Force on an absorber from its attachment (MODEL.md section 2).

    ``linear``: ``f = -k u - c w``; ``cubic`` (Wei et al., Appl. Math. Mech. (Engl. Ed.) 40(5)
    2019, eq. 1): ``f = -k u^3 - k_lin u - c w``; ``bistable``: the cubic law with ``k_lin < 0``
    (Romeo, Sigalov, Bergman and Vakakis, J. Comput. Nonlinear Dyn. 10 (2015) 011007; Habib and
    Romeo, Nonlinear Dyn. 89 (2017)): stable at ``u = +-sqrt(-k_lin / k)``.
    """
    return fused(-(k_lin + k_cubic * u * u), u, -(c * w))


@njit(**INLINE)
def spring_damper_energy(u: float, k_lin: float, k_cubic: float) -> float:
    """Potential energy of a polynomial attachment: ``k_lin u^2 / 2 + k_cubic u^4 / 4`` (zero at
    ``u = 0``, the bistable law's barrier top included)."""
    u2 = u * u
    return 0.5 * k_lin * u2 + 0.25 * k_cubic * u2 * u2


@njit(**INLINE)
def geometric_stretch(u: float, free: float, length: float) -> tuple[float, float]:
    """``(s, d)``: each inclined spring's length ``s = sqrt(u^2 + l^2)`` and its stretch
    ``d = s - l0``, written ``(l - l0) + u^2 / (s + l)`` so that a spring installed at its free
    length keeps the relative accuracy of its small stretch ``u^2 / (2 l)``."""
    s = math.sqrt(u * u + length * length)
    return s, (length - free) + u * u / (s + length)


@njit(**INLINE)
def geometric_force(u: float, k: float, free: float, length: float) -> float:
    """Force of two transverse linear springs (stiffness ``k`` each, free length ``l0``, installed
    length ``l``) on a mass moved ``u`` across them: ``-2 k u (1 - l0 / sqrt(u^2 + l^2))``
    (MODEL.md section 2; McFarland, Bergman and Vakakis, Int. J. Non-Linear Mech. 40 (2005) 891).
    For ``l = l0`` and small ``u`` it is the cubic law ``-k u^3 / l0^2``."""
    s, d = geometric_stretch(u, free, length)
    return -2.0 * k * u * (d / s)


@njit(**INLINE)
def geometric_energy(u: float, k: float, free: float, length: float) -> float:
    """Potential energy of the geometric attachment counted from ``u = 0``:
    ``k (sqrt(u^2 + l^2) - l0)^2 - k (l - l0)^2``, written ``k (d - d0) (d + d0)`` with
    ``d - d0 = u^2 / (s + l)`` (``geometric_stretch``)."""
    s, d = geometric_stretch(u, free, length)
    return k * (u * u / (s + length)) * (d + (length - free))


@njit(**INLINE)
def gap_force(u: float, k: float, gap: float) -> float:
    """Force of a linear spring of stiffness ``k`` engaged beyond a gap ``g`` on either side:
    ``-k (u - g)`` for ``u > g``, ``-k (u + g)`` for ``u < -g``, zero between (MODEL.md section 2;
    the piecewise-linear non-smooth NES of Lamarque, Gendelman, Ture Savadkoohi and Etcheverria,
    Acta Mech. 221 (2011) 175; a linear spring with a clearance, Shaw and Holmes, J. Sound Vib.
    90 (1983) 129).  With ``k_lin = 0`` beside it the absorber has no linear stiffness at rest:
    a nonlinear energy sink."""
    if u > gap:
        return -k * (u - gap)
    if u < -gap:
        return -k * (u + gap)
    return 0.0


@njit(**INLINE)
def gap_energy(u: float, k: float, gap: float) -> float:
    """Potential energy of the gap spring: ``k (|u| - g)^2 / 2`` beyond the gap, zero within."""
    d = abs(u) - gap
    return 0.5 * k * d * d if d > 0.0 else 0.0


@njit(**INLINE)
def shaped_force(rows, a: int, u: float) -> float:
    """The force of absorber row ``a``'s shaped springs at ``u`` (spring rest offset taken off):
    the terms that are not a polynomial of ``u``, each where the row has it (``SHAPED``)."""
    f = 0.0
    if rows[a, K_GEO] != 0.0:
        f += geometric_force(u, rows[a, K_GEO], rows[a, FREE_LENGTH], rows[a, LENGTH])
    if rows[a, K_GAP] != 0.0:
        f += gap_force(u, rows[a, K_GAP], rows[a, GAP])
    return f


@njit(**INLINE)
def shaped_energy(rows, a: int, u: float) -> float:
    """Potential energy of absorber row ``a``'s shaped springs at ``u`` (``shaped_force``'s)."""
    e = 0.0
    if rows[a, K_GEO] != 0.0:
        e += geometric_energy(u, rows[a, K_GEO], rows[a, FREE_LENGTH], rows[a, LENGTH])
    if rows[a, K_GAP] != 0.0:
        e += gap_energy(u, rows[a, K_GAP], rows[a, GAP])
    return e


@njit(**INLINE)
def coupling_energy(rows, a: int, u: float) -> float:
    """Potential energy of absorber row ``a``'s attachment at ``u`` (spring rest offset taken off):
    the polynomial spring's and its shaped springs' (``shaped_energy``)."""
    return spring_damper_energy(u, rows[a, K_LIN], rows[a, K_CUBIC]) + shaped_energy(rows, a, u)
