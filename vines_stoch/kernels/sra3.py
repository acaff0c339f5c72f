"""The stochastic Runge-Kutta step SRA3 for additive noise (scheme ``"sra"``).

Roessler, A. (2010), "Runge-Kutta methods for the strong approximation of solutions of
stochastic differential equations", SIAM J. Numer. Anal. 48(3), 922-952,
doi:10.1137/09076636X (its method SRA3).  Three stages at ``t``, ``t + h`` and
``t + h/2``; the deterministic part is the third-order strong-stability-preserving Runge-Kutta
method; strong order 1.5 and weak order 2 with additive noise.  Each noisy floor's step draws
``I1 = dW`` and ``I10`` (the time integral of ``W`` over the step, ``sqrt(h) h / 2 (u1 +
u2 / sqrt 3)``); the step loop of ``kdk.py`` draws them and runs this step in place of the
kick-drift-kick one.  It has no impact events and takes white noise only (``schemes.SCHEMES``).
"""

from __future__ import annotations

from numba import njit

from ..jit.flags import INLINE
from ..physics.absorbers import DAMPING
from ..physics.structure import host_of
from .common import accelerate, attachment_forces, geometric_forces
from .energy import momentum


@njit(**INLINE)
def sra3_step(x, v, vn, force, a1, a2, a3, xs, v2, v3, load, load_next, load3, ag, ag_next, ag3, dw, dz, dt,
              mass, inv_mass, storey_k, storey_c, floor_c, host, rows, inside, ground, geometric):
    """One SRA3 step of length ``dt`` from ``(x, v)``, in place.

    ``load``, ``load_next``, ``load3`` (and ``ag``, ``ag_next``, ``ag3``): the floors' loads
    and the ground acceleration at the step's start, end and midpoint; ``dw``, ``dz``: each
    floor's ``sigma I1`` and ``sigma I10 / h``; ``a1 .. v3``, ``xs``, ``vn``, ``force``:
    scratch (``a1`` keeps the accelerations at the step's start).  Returns the step's
    increments of the input work, the structure's and the absorbers' dissipation (zero unless
    ``inside`` the metrics window), with the mean of the step's end velocities, for which the
    kinetic energy change equals the work of the step's impulses exactly.  ``ground``: the
    scene has a ground acceleration, ``geometric``: geometric attachments
    (``common.geometric_forces``; compile-time flags).
    """
    nb = x.shape[0]
    nf = load.shape[0]
    attachment_forces(x, v, nf, storey_k, storey_c, floor_c, host, rows, force)
    geometric_forces(x, nf, host, rows, force, geometric)
    accelerate(force, load, ag, inv_mass, a1)
    for b in range(nb):
        xs[b] = x[b] + dt * v[b]
        v2[b] = v[b] + dt * a1[b]
    attachment_forces(xs, v2, nf, storey_k, storey_c, floor_c, host, rows, force)
    geometric_forces(xs, nf, host, rows, force, geometric)
    accelerate(force, load_next, ag_next, inv_mass, a2)
    for b in range(nb):
        xs[b] = x[b] + 0.25 * dt * (v[b] + v2[b])
        v3[b] = v[b] + 0.25 * dt * (a1[b] + a2[b])
    for k in range(nf):
        v3[k] += 1.5 * dz[k] / mass[k]
    attachment_forces(xs, v3, nf, storey_k, storey_c, floor_c, host, rows, force)
    geometric_forces(xs, nf, host, rows, force, geometric)
    accelerate(force, load3, ag3, inv_mass, a3)
    for b in range(nb):
        vn[b] = v[b] + dt * (a1[b] / 6.0 + a2[b] / 6.0 + 2.0 / 3.0 * a3[b])
    for k in range(nf):
        vn[k] += dw[k] / mass[k]
    work = d_primary = d_absorber = 0.0
    if inside:
        for k in range(nf):
            v_mid = 0.5 * (v[k] + vn[k])
            impulse = dt * (load[k] / 6.0 + load_next[k] / 6.0 + 2.0 / 3.0 * load3[k]) + dw[k]
            work += impulse * v_mid
            dv = v[k] - v[k - 1] if k > 0 else v[k]
            dv2 = v2[k] - v2[k - 1] if k > 0 else v2[k]
            dv3 = v3[k] - v3[k - 1] if k > 0 else v3[k]
            dvn = vn[k] - vn[k - 1] if k > 0 else vn[k]
            d_primary += storey_c[k] * dt * (dv / 6.0 + dv2 / 6.0 + 2.0 / 3.0 * dv3) * (0.5 * (dv + dvn))
            if nf > 1:  # (mass-proportional damping: several floors only)
                d_primary += floor_c[k] * dt * (v[k] / 6.0 + v2[k] / 6.0 + 2.0 / 3.0 * v3[k]) * v_mid
        if ground:
            work -= dt * (ag / 6.0 + ag_next / 6.0 + 2.0 / 3.0 * ag3) * momentum(mass, v, vn)
        for a in range(nb - nf):
            h = host_of(host, a, nf)
            j = nf + a
            w = dt * ((v[j] - v[h]) / 6.0 + (v2[j] - v2[h]) / 6.0 + 2.0 / 3.0 * (v3[j] - v3[h]))
            d_absorber += rows[a, DAMPING] * w * 0.5 * (v[j] - v[h] + vn[j] - vn[h])
    for b in range(nb):
        x[b] += dt * (v[b] / 6.0 + v2[b] / 6.0 + 2.0 / 3.0 * v3[b])
        v[b] = vn[b]
    return work, d_primary, d_absorber
