"""The stochastic Runge-Kutta step SRA3 for additive noise (scheme ``"sra"``).

Roessler, A. (2010), "Runge-Kutta methods for the strong approximation of solutions of
stochastic differential equations", SIAM J. Numer. Anal. 48(3), 922-952,
doi:10.1137/09076636X (its method SRA3).  Three stages at ``t``, ``t + h`` and
``t + h/2``; the deterministic part is the third-order strong-stability-preserving Runge-Kutta
method; strong order 1.5 and weak order 2 with additive noise.  Each noisy floor's step draws
``I1 = dW`` and ``I10`` (the time integral of ``W`` over the step, ``sqrt(h) h / 2 (u1 +
u2 / sqrt 3)``).  The step plugs into the loop driver (``driver.py``) as ``sra3_step``; it
shares the grid loads and the normals with the kick-drift-kick step (``grid.py``).  It has no
impact events and takes white noise only (``schemes.SCHEMES``).
"""

from __future__ import annotations

import math
from functools import cache
from typing import Any, NamedTuple

from ..jit import njit
from ..jit.flags import INLINE
from ..physics.absorbers import DAMPING
from ..physics.structure import host_of
from .carry import REPLAYED
from .common import (
    FILTERED_BIT,
    GROUND_BIT,
    NOISE_BIT,
    SHAPED_BIT,
    accelerate,
    attachment_forces,
    bit_set,
    kinds_of,
    shaped_forces,
    stack_scratch,
)
from .energy import momentum
from .grid import (
    end_loads,
    finish_loads,
    grid_room,
    mid_loads,
    noise_scales,
    opening_forces,
    reset_phasors,
    save_grid_loads,
    start_loads,
    step_loads,
    step_normals,
)
from .loads import has_breaks
from .protocol import Step, rooms


@njit(**INLINE)
def sra3_update(x, v, vn, force, a1, a2, a3, xs, v2, v3, load, load_next, load3, ag, ag_next, ag3, dw, dz, dt,
              mass, inv_mass, storey_k, storey_c, floor_c, host, rows, inside, ground, shaped):
    """One SRA3 step of length ``dt`` from ``(x, v)``, in place.

    ``load``, ``load_next``, ``load3`` (and ``ag``, ``ag_next``, ``ag3``): the floors' loads
    and the ground acceleration at the step's start, end and midpoint; ``dw``, ``dz``: each
    floor's ``sigma I1`` and ``sigma I10 / h``; ``a1 .. v3``, ``xs``, ``vn``, ``force``:
    scratch (``a1`` keeps the accelerations at the step's start).  Returns the step's
    increments of the input work, the structure's and the absorbers' dissipation (zero unless
    ``inside`` the metrics window), with the mean of the step's end velocities, for which the
    kinetic energy change equals the work of the step's impulses exactly.  ``ground``: the
    scene has a ground acceleration, ``shaped``: shaped springs
    (``common.shaped_forces``; compile-time flags).
    """
    nb = x.shape[0]
    nf = load.shape[0]
    attachment_forces(x, v, nf, storey_k, storey_c, floor_c, host, rows, force)
    shaped_forces(x, nf, host, rows, force, shaped)
    accelerate(force, load, ag, inv_mass, a1)
    for b in range(nb):
        xs[b] = x[b] + dt * v[b]
        v2[b] = v[b] + dt * a1[b]
    attachment_forces(xs, v2, nf, storey_k, storey_c, floor_c, host, rows, force)
    shaped_forces(xs, nf, host, rows, force, shaped)
    accelerate(force, load_next, ag_next, inv_mass, a2)
    for b in range(nb):
        xs[b] = x[b] + 0.25 * dt * (v[b] + v2[b])
        v3[b] = v[b] + 0.25 * dt * (a1[b] + a2[b])
    for k in range(nf):
        v3[k] += 1.5 * dz[k] / mass[k]
    attachment_forces(xs, v3, nf, storey_k, storey_c, floor_c, host, rows, force)
    shaped_forces(xs, nf, host, rows, force, shaped)
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


class SraState(NamedTuple):
    """The SRA3 step's state and scratch on the loop's stack: per body the forces, the end
    velocities and the stages' accelerations, positions and velocities; the grid loads
    (``grid.GridLoads``, the midpoint's included); per floor ``sigma I1`` and ``sigma I10 / h``,
    the step's two normals, ``sigma sqrt(dt)`` and the place among the noisy floors; the noisy
    floors' count; whether the loads have kinks or jumps (``loads.has_breaks``, found once a run)."""

    force: Any
    vn: Any
    a1: Any
    a2: Any
    a3: Any
    xs: Any
    v2: Any
    v3: Any
    gl: Any
    dw: Any
    dz: Any
    u1: Any
    u2: Any
    noise_scale: Any
    slot: Any
    noisy: Any
    piecewise: Any
    kinds: Any


@cache
def sra3_step(spec) -> Step:
    """The SRA3 step for a loop specialised to ``spec`` (``protocol.Spec``), as the driver's
    ``Step``: two normals a step and noisy floor (replayed: all floors' first normals, then
    their second)."""
    NB, NF = spec.n_bodies, spec.n_floors
    NR = spec.n_rows
    NZ = spec.n_states
    BODY_ITEMS, FLOOR_ITEMS, ROW_ITEMS, STATE_ITEMS = rooms(spec)  # (the stack arrays' rooms)
    body_scratch, floor_scratch = stack_scratch(BODY_ITEMS, FLOOR_ITEMS)  # (arrays on the loop's stack)
    HAS_NOISE, HAS_IMPACT, HAS_HERTZ, PARTNERS, FILTERED, GROUND, SHAPED = kinds_of(spec)  # (or ``RUN_TIME``)
    ROOT3 = math.sqrt(3.0)

    @njit(**INLINE)
    def start(bodies, absorbers, ex, fl, noise, grid, carry, resume, x, v, gen_bridge):
        # the bodies, floors, load rows and filter states: run-time sizes on the CPU (``paths.spec_of``)
        nb = NB if NB >= 0 else bodies.mass.shape[0]  # (``RUN_TIME``: the counts read at run time)
        nf = NF if NF >= 0 else bodies.storey_k.shape[0]
        filtered = FILTERED if FILTERED >= 0 else bit_set(grid.kinds, FILTERED_BIT)
        ground = GROUND if GROUND >= 0 else bit_set(grid.kinds, GROUND_BIT)
        nr, nz = NR if NR >= 0 else ex.forces.shape[0], NZ if NZ >= 0 else fl.phi.shape[0]
        gl = grid_room(nf, nr, nz, nf, nr, 0, 0, FLOOR_ITEMS, ROW_ITEMS, STATE_ITEMS)
        noise_scale, slot = floor_scratch(nf), floor_scratch(nf)
        noisy = noise_scales(noise.sigma, grid.dt, noise_scale, slot)
        replayed = int(carry[REPLAYED]) if resume else 0
        ag_next = start_loads(gl, ex, fl, grid.dt, carry, resume, nf, nb - nf, filtered, ground)
        own = SraState(body_scratch(nb), body_scratch(nb), body_scratch(nb), body_scratch(nb),
                       body_scratch(nb), body_scratch(nb), body_scratch(nb), body_scratch(nb), gl,
                       floor_scratch(nf), floor_scratch(nf), floor_scratch(nf), floor_scratch(nf),
                       noise_scale, slot, noisy, has_breaks(ex), grid.kinds)
        return own, (ag_next, replayed)

    @njit(**INLINE)
    def opening(own, x, v, inv_mass, acc, bodies, absorbers):
        nf = NF if NF >= 0 else bodies.storey_k.shape[0]
        opening_forces(own.force, own.gl.load_next, x, v, acc, bodies, absorbers, nf,
                       SHAPED if SHAPED >= 0 else bit_set(own.kinds, SHAPED_BIT))
        for k in range(nf):  # (accelerations)
            acc[k] *= inv_mass[k]

    @njit(**INLINE)
    def check(own, i, dt, ex):
        reset_phasors(own.gl, i, dt, ex)

    @njit(**INLINE)
    def save(carry, own, sc):
        save_grid_loads(carry, own.gl, sc[0], own.dw.shape[0], own.force.shape[0] - own.dw.shape[0])
        carry[REPLAYED] = sc[1]

    @njit(**INLINE)
    def finish(own, sc, fl, out):
        finish_loads(own.gl, fl)

    @njit(**INLINE)
    def step(i, x, v, inv_mass, acc, own, sc, acct, inside, peaks, bodies, absorbers, ex, fl, noise, grid,
             outputs, gen, gen_filter):
        nf = NF if NF >= 0 else bodies.storey_k.shape[0]
        has_noise = HAS_NOISE if HAS_NOISE >= 0 else bit_set(grid.kinds, NOISE_BIT)
        filtered = FILTERED if FILTERED >= 0 else bit_set(grid.kinds, FILTERED_BIT)
        ground = GROUND if GROUND >= 0 else bit_set(grid.kinds, GROUND_BIT)
        shaped = SHAPED if SHAPED >= 0 else bit_set(grid.kinds, SHAPED_BIT)
        dt = grid.dt
        gl = own.gl
        dw, dz, u1, u2, noise_scale = own.dw, own.dz, own.u1, own.u2, own.noise_scale
        ag_next, replayed = sc
        work, d_primary, d_absorber, e_sum, e1_max, loss, n_left, n_right, contact_time, peak_force, \
            pending = acct
        ag = step_loads(i, dt, gl, ex, fl, ag_next, own.piecewise, filtered, ground, gen_filter)
        ag3 = mid_loads(i, dt, gl, ex, fl, filtered, ground)
        ag_next = end_loads(i, dt, gl, ex, fl, filtered, ground)
        # the step's two integrals on the noisy floors
        if has_noise:
            replayed = step_normals(i, 2, noise_scale, own.slot, own.noisy, noise.normals, noise.refine,
                                    replayed, gen, u1, u2)
            for k in range(nf):
                dw[k] = noise_scale[k] * u1[k]
                dz[k] = 0.5 * noise_scale[k] * (u1[k] + u2[k] / ROOT3)  # sigma I10 / h
        mass, storey_k, storey_c, floor_c = bodies.mass, bodies.storey_k, bodies.storey_c, bodies.floor_c
        dwork, dprimary, dabsorber = sra3_update(x, v, own.vn, own.force, own.a1, own.a2, own.a3, own.xs,
                                                 own.v2, own.v3, gl.load, gl.load_next, gl.load3, ag, ag_next,
                                                 ag3, dw, dz, dt, mass, inv_mass, storey_k, storey_c, floor_c,
                                                 absorbers.host, absorbers.rows, inside, ground, shaped)
        work += dwork
        d_primary += dprimary
        d_absorber += dabsorber
        for k in range(nf):
            acc[k] = own.a1[k] + ag  # the step start's absolute acceleration, for the peaks
        return (ag_next, replayed), (work, d_primary, d_absorber, e_sum, e1_max, loss, n_left, n_right,
                                     contact_time, peak_force, pending)

    return Step(start, opening, check, step, save, finish, integrates=False, force_peaks=False, samples=False)
