"""The Newton impact of an absorber on a cavity wall and the sticking rule (MODEL.md section 2)."""

from __future__ import annotations

from ..jit import njit
from ..jit.flags import INLINE


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
def sticks(side: int, w_in: float, w_gain: float) -> bool:
    """Sticking rule: an impact slower than the relative velocity the loads add in one step,
    with the loads pressing into the wall, is plastic and starts a sticking phase."""
    return side * w_gain > 0.0 and abs(w_in) <= side * w_gain
