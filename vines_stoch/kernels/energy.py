"""The energy accounts of MODEL.md section 4, one convention for every step loop.

A loop keeps, from the metrics window's opening: the input work (from the energy stored at the
opening, then the work of the loads and of the ground acceleration), the energy the
structure's and the absorbers' dashpots take, the impacts' loss, the integral of ``E1`` and its
peak; in registers through the run, written to the metric vector once at the end
(``write_accounts``) and carried raw from one stretch of a path to the next
(``carry.save_accounts``).  Each scheme adds its own increments: the kick-drift-kick loop the
work of each half kick's impulses at the kick's mean velocity (``impulse_work``, ``momentum``,
``structure_dissipation``, ``absorber_dissipation``: the change of kinetic energy equals the
impulses' work exactly), the SRA3 step its stages' weighted impulses at the step's mean
velocity (``sra3.sra3_update``), the RK4 loop the rates of these (written out in
``rk4.accelerations``: helpers of their own, inlined there with the loop's heap arrays, were
part of a change that cost it 28 % of its speed) integrated as extra states by its stages
(``rk4.rk4_update``).
"""

from __future__ import annotations

from ..jit import njit
from ..jit.flags import INLINE
from ..jit.intrinsics import fused
from ..outputs import (
    ABSORBER_DISS,
    E1_MAX,
    ENERGY_INT,
    IMPACT_LOSS,
    IMPACTS,
    IMPACTS_LEFT,
    IMPACTS_RIGHT,
    INPUT,
    PRIMARY_DISS,
)
from ..physics.absorbers import DAMPING
from ..physics.structure import host_of


@njit(**INLINE)
def momentum(mass, v, vn) -> float:
    """Total momentum at the mean of two velocity vectors (work of the ground acceleration)."""
    p = 0.0
    for b in range(v.shape[0]):
        p += mass[b] * 0.5 * (v[b] + vn[b])
    return p


@njit(**INLINE)
def structure_dissipation(v, vn, nf: int, storey_c, floor_c, s: float, d: float) -> float:
    """``d`` plus the energy the structure's dashpots take in a half kick of length ``s``: their
    forces at the velocities ``v`` times the mean of ``v`` and ``vn`` (the kicks of ``kdk``).
    Each term is fused into the sum (``intrinsics.fused``): left to the compiler, whether the
    last product joined the caller's sum depended on the code around the call, and the loop
    over SIMD lanes (``kernels/lanes.py``) and the scalar loop differed in the last bit."""
    for k in range(nf):
        dv = v[k] - v[k - 1] if k > 0 else v[k]
        dvn = vn[k] - vn[k - 1] if k > 0 else vn[k]
        d = fused(storey_c[k] * dv * 0.5 * s, 0.5 * (dv + dvn), d)
        if nf > 1:
            d = fused(floor_c[k] * v[k] * 0.5 * s, 0.5 * (v[k] + vn[k]), d)
    return d


@njit(**INLINE)
def absorber_dissipation(v, vn, nf: int, host, rows, s: float, d: float) -> float:
    """``d`` plus the energy the absorbers' dashpots take in a half kick of length ``s`` (see
    ``structure_dissipation``)."""
    for a in range(v.shape[0] - nf):
        h = host_of(host, a, nf)
        w = v[nf + a] - v[h]
        d = fused(rows[a, DAMPING] * w * 0.5 * s, 0.5 * (w + vn[nf + a] - vn[h]), d)
    return d


@njit(**INLINE)
def impulse_work(load, s, dws, v, vn) -> float:
    """Work of the floors' load impulses ``load s + dws`` at the mean of ``v`` and ``vn``."""
    w = 0.0
    for k in range(load.shape[0]):
        term = fused(load[k], s, dws[k]) * (0.5 * (v[k] + vn[k]))
        w = term if k == 0 else w + term  # (see ``structure_dissipation``)
    return w


@njit(**INLINE)
def write_accounts(out, work: float, d_primary: float, d_absorber: float, e_integral: float, e1_max: float,
                   loss: float, n_left: float, n_right: float) -> None:
    """The accounts' slots of the raw metric vector (``outputs.SLOTS``)."""
    out[INPUT] = work
    out[PRIMARY_DISS] = d_primary
    out[ABSORBER_DISS] = d_absorber
    out[ENERGY_INT] = e_integral
    out[E1_MAX] = e1_max
    out[IMPACT_LOSS] = loss
    out[IMPACTS] = n_left + n_right
    out[IMPACTS_LEFT] = n_left
    out[IMPACTS_RIGHT] = n_right
