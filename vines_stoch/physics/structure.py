"""The primary structure (MODEL.md sections 1, 1a): storey forces, damping power and ``E1``,
which floor hosts an absorber and which body holds an impact absorber's walls."""

from __future__ import annotations

from ..jit import njit
from ..jit.flags import INLINE
from ..jit.intrinsics import fused


@njit(**INLINE)
def host_of(host, a: int, nf: int) -> int:
    """Host floor of absorber ``a`` (the constant 0 on a one-storey primary, so the compiler
    keeps every index into the state constant there)."""
    return host[a] if nf > 1 else 0


@njit(**INLINE)
def wall_of(wall, a: int, nw: int) -> int:
    """The body whose walls absorber ``a`` meets (``wall``: body indices, ``scene.Scene.wall``):
    its host floor, or for an impact absorber in another absorber's cavity that absorber.
    ``nw``: the bodies that may hold walls (the floors, or every body in a scene with impacts
    between absorbers; a compile-time constant), so that on a one-storey primary without them
    the index is the constant 0 (as ``host_of``)."""
    return wall[a] if nw > 1 else 0


@njit(**INLINE)
def structure_forces(x, v, nf: int, storey_k, storey_c, floor_c, force):
    """``force[k]``, ``k < nf``: the forces of the storey springs and dashpots and of the
    mass-proportional (Rayleigh) damping on each floor, ``-(K x + C v)`` of MODEL.md 1a;
    storey ``k`` joins floor ``k - 1`` (the ground for ``k = 0``) to floor ``k``.  (Rayleigh
    damping needs two modes, so a one-storey primary has no mass-proportional term: it is
    left out there, about 5 % of a smooth scene's step.)"""
    for k in range(nf):
        d = x[k] - x[k - 1] if k > 0 else x[k]
        dv = v[k] - v[k - 1] if k > 0 else v[k]
        # written as the one-storey -k1 x1 - c1 v1: the negated coefficients are loop
        # invariants, so the force is one multiply and one fused multiply-add on the step's
        # critical path (negating a sum would add an operation there)
        force[k] = fused(-storey_k[k], d, -storey_c[k] * dv)
        if k > 0:
            force[k - 1] += fused(storey_k[k], d, storey_c[k] * dv)
    if nf > 1:
        for k in range(nf):
            force[k] = fused(-floor_c[k], v[k], force[k])


@njit(**INLINE)
def structure_power(v, nf: int, storey_c, floor_c) -> float:
    """Power dissipated by the structure's dashpots, ``v^T C v``."""
    p = 0.0
    for k in range(nf):
        dv = v[k] - v[k - 1] if k > 0 else v[k]
        term = storey_c[k] * dv * dv + (floor_c[k] * v[k] * v[k] if nf > 1 else 0.0)
        p = term if k == 0 else p + term  # (no ``0.0 +`` to fold: see ``structure_dissipation``)
    return p


@njit(**INLINE)
def primary_energy(mass, storey_k, x, v, nf: int) -> float:
    """``E1``: kinetic energy of the ``nf`` floors plus the strain energy of their storeys,
    ``sum m_k v_k^2 / 2 + sum k_k d_k^2 / 2``, ``d_k = x_k - x_{k-1}`` (MODEL.md sections 1a, 4;
    one floor: ``m1 v1^2 / 2 + k1 x1^2 / 2``).  Each floor's strain term is fused into its
    kinetic term (``intrinsics.fused``): left to the compiler, which of the two it fused
    depended on the code around the call, and a loop over SIMD lanes (``kernels/lanes.py``)
    and the scalar loop differed in the last bit."""
    e = fused(0.5 * storey_k[0] * x[0], x[0], 0.5 * mass[0] * v[0] * v[0])
    for k in range(1, nf):
        d = x[k] - x[k - 1]
        e += fused(0.5 * storey_k[k] * d, d, 0.5 * mass[k] * v[k] * v[k])
    return e
