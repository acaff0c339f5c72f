"""Classical fourth-order Runge-Kutta for scenes without noise, with located impacts.

The energy integrals of MODEL.md section 4 (work of the loads, viscous dissipation, the
integrals of ``E1`` and ``x1^2``) are integrated as extra states by the same RK4 stages, so
the energy balance closes to the scheme's fourth-order error.  When an impact absorber
crosses its wall inside a step, the impact instant is found by Newton iteration on the
length of an RK4 sub-step from the start of the step (converged to round-off), the Newton
map is applied at that instant and the step continues from the post-impact state.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import njit

from ..physics import harmonic_force, primary_energy, restitution_impact, total_energy
from ..physics import KERNEL
from .common import (ABSORBER_DISS, CAPPED, CHECK_EVERY, E1_MAX, ENERGY_INT, FINAL_ENERGY,
                     IMPACT_LOSS, IMPACTS, INLINE, INPUT, MAX_EVENTS, PRIMARY_DISS, STATUS,
                     STATUS_DIVERGED, X1_MAX, X1_SQ_INT, attachment_forces, diverged,
                     pin_to_walls, stick_together, sticks)

NEWTON_ITERATIONS = 12


@njit(**INLINE)
def accelerations(x, v, t, mass, k1, c1, k_lin, k_cubic, c_abs, harmonic, impact_body, stuck,
                  release, acc, sticking=True):
    """Accelerations of all bodies into ``acc``; returns the rates of the energy integrals
    (load power, primary damping power, absorber damping power, ``E1``, ``x1^2``)."""
    attachment_forces(x, v, k1, c1, k_lin, k_cubic, c_abs, acc)
    load = harmonic_force(t, harmonic)
    acc[0] += load
    for b in range(mass.shape[0]):
        acc[b] /= mass[b]
    if sticking:
        stick_together(mass, acc, stuck, impact_body, release)
    absorber_power = 0.0
    for a in range(c_abs.shape[0]):
        w = v[a + 1] - v[0]
        absorber_power += c_abs[a] * w * w
    return (load * v[0], c1 * v[0] * v[0], absorber_power,
            primary_energy(mass[0], k1, x[0], v[0]), x[0] * x[0])


@njit(**INLINE)
def rk4_step(x, v, t, h, xo, vo, a1, a2, a3, a4, xs, v2, v3, v4, mass, k1, c1, k_lin, k_cubic, c_abs, harmonic,
             impact_body, stuck, sticking):
    """One RK4 step of size ``h`` from ``(x, v)`` into ``(xo, vo)``; returns the increments
    of the five energy integrals."""
    nb = mass.shape[0]
    r1 = accelerations(x, v, t, mass, k1, c1, k_lin, k_cubic, c_abs, harmonic, impact_body,
                       stuck, False, a1, sticking)
    for b in range(nb):
        xs[b] = x[b] + 0.5 * h * v[b]
        v2[b] = v[b] + 0.5 * h * a1[b]
    r2 = accelerations(xs, v2, t + 0.5 * h, mass, k1, c1, k_lin, k_cubic, c_abs, harmonic,
                       impact_body, stuck, False, a2, sticking)
    for b in range(nb):
        xs[b] = x[b] + 0.5 * h * v2[b]
        v3[b] = v[b] + 0.5 * h * a2[b]
    r3 = accelerations(xs, v3, t + 0.5 * h, mass, k1, c1, k_lin, k_cubic, c_abs, harmonic,
                       impact_body, stuck, False, a3, sticking)
    for b in range(nb):
        xs[b] = x[b] + h * v3[b]
        v4[b] = v[b] + h * a3[b]
    r4 = accelerations(xs, v4, t + h, mass, k1, c1, k_lin, k_cubic, c_abs, harmonic,
                       impact_body, stuck, False, a4, sticking)
    for b in range(nb):
        xo[b] = x[b] + h / 6.0 * (v[b] + 2.0 * v2[b] + 2.0 * v3[b] + v4[b])
        vo[b] = v[b] + h / 6.0 * (a1[b] + 2.0 * a2[b] + 2.0 * a3[b] + a4[b])
    return (h / 6.0 * (r1[0] + 2.0 * r2[0] + 2.0 * r3[0] + r4[0]),
            h / 6.0 * (r1[1] + 2.0 * r2[1] + 2.0 * r3[1] + r4[1]),
            h / 6.0 * (r1[2] + 2.0 * r2[2] + 2.0 * r3[2] + r4[2]),
            h / 6.0 * (r1[3] + 2.0 * r2[3] + 2.0 * r3[3] + r4[3]),
            h / 6.0 * (r1[4] + 2.0 * r2[4] + 2.0 * r3[4] + r4[4]))


@njit(**INLINE)
def first_crossing(x, v, xn, clearance, impact_body, stuck, h):
    """The free impact absorber whose wall crossing during a step ``x -> xn`` comes first
    (by linear interpolation); returns ``(q, side, tau)`` or ``(-1, 0, h)``."""
    hit, side, first = -1, 0, h
    for q in range(impact_body.shape[0]):
        if stuck[q] == 0:
            j = impact_body[q] + 1
            u_end = xn[j] - xn[0]
            if abs(u_end) > clearance[q]:
                s = 1 if u_end > 0.0 else -1
                g0 = s * (x[j] - x[0]) - clearance[q]
                g1 = s * u_end - clearance[q]
                tau = h * max(-g0, 0.0) / (g1 - g0)
                if tau < first or hit < 0:
                    hit, side, first = q, s, tau
    return hit, side, first


@lru_cache(maxsize=None)
def rk4_kernel(has_impact: bool):
    """The RK4 loop specialised to a scene's structure."""

    @njit(**KERNEL)
    def kernel(mass, k1, c1, k_lin, k_cubic, c_abs, impact_body, clearance, restitution,
               harmonic, sigma, x0, v0, dt, n_steps, i0, gen, out):
        nb = mass.shape[0]
        x = x0.copy()
        v = v0.copy()
        xn = np.zeros(nb)
        vn = np.zeros(nb)
        acc = np.zeros(nb)
        a1, a2, a3, a4 = np.zeros(nb), np.zeros(nb), np.zeros(nb), np.zeros(nb)
        xs, v2, v3, v4 = np.zeros(nb), np.zeros(nb), np.zeros(nb), np.zeros(nb)
        stuck = np.zeros(impact_body.shape[0], np.int64)
        m0 = mass[0]
        for i in range(n_steps):
            inside = i >= i0
            if i == i0:
                out[INPUT] = total_energy(x, v, mass, k1, k_lin, k_cubic)
                out[E1_MAX] = primary_energy(m0, k1, x[0], v[0])
                out[X1_MAX] = abs(x[0])
            if i % CHECK_EVERY == 0 and diverged(x):
                out[STATUS] = STATUS_DIVERGED
                break
            t = i * dt
            left = dt
            for event in range(MAX_EVENTS + 1):
                if has_impact and stuck.any():
                    inc = rk4_step(x, v, t, left, xn, vn, a1, a2, a3, a4, xs, v2, v3, v4, mass, k1, c1,
                                   k_lin, k_cubic, c_abs, harmonic, impact_body, stuck, True)
                else:  # the common case, compiled without the contact constraint
                    inc = rk4_step(x, v, t, left, xn, vn, a1, a2, a3, a4, xs, v2, v3, v4, mass, k1, c1,
                                   k_lin, k_cubic, c_abs, harmonic, impact_body, stuck, False)
                hit, side, tau, j = -1, 0, left, 0
                if has_impact and event < MAX_EVENTS:
                    hit, side, tau = first_crossing(x, v, xn, clearance, impact_body, stuck, left)
                if hit >= 0:
                    j = impact_body[hit] + 1
                    for _ in range(NEWTON_ITERATIONS):
                        inc = rk4_step(x, v, t, tau, xn, vn, a1, a2, a3, a4, xs, v2, v3, v4, mass, k1, c1, k_lin, k_cubic,
                                       c_abs, harmonic, impact_body, stuck, True)
                        gap = side * (xn[j] - xn[0]) - clearance[hit]
                        approach = side * (vn[j] - vn[0])
                        if approach <= 0.0:
                            break
                        correction = gap / approach
                        tau = min(max(tau - correction, 0.0), left)
                        if abs(correction) <= 1e-15 * dt:
                            break
                    inc = rk4_step(x, v, t, tau, xn, vn, a1, a2, a3, a4, xs, v2, v3, v4, mass, k1, c1, k_lin, k_cubic, c_abs,
                                   harmonic, impact_body, stuck, True)
                for b in range(nb):
                    x[b] = xn[b]
                    v[b] = vn[b]
                if inside:
                    out[INPUT] += inc[0]
                    out[PRIMARY_DISS] += inc[1]
                    out[ABSORBER_DISS] += inc[2]
                    out[ENERGY_INT] += inc[3]
                    out[X1_SQ_INT] += inc[4]
                    out[E1_MAX] = max(out[E1_MAX], primary_energy(m0, k1, x[0], v[0]))
                    out[X1_MAX] = max(out[X1_MAX], abs(x[0]))
                if hit < 0:
                    if has_impact and event == MAX_EVENTS:
                        out[CAPPED] += 1
                        for q in range(impact_body.shape[0]):
                            jq = impact_body[q] + 1
                            x[jq] = x[0] + min(max(x[jq] - x[0], -clearance[q]), clearance[q])
                    break
                # the impact, at t + tau
                t += tau
                left -= tau
                x[j] = x[0] + side * clearance[hit]
                accelerations(x, v, t, mass, k1, c1, k_lin, k_cubic, c_abs, harmonic,
                              impact_body, stuck, False, acc)
                plastic = sticks(side, v[j] - v[0], (acc[j] - acc[0]) * dt)
                r = 0.0 if plastic else restitution[hit]
                v[0], v[j], loss = restitution_impact(m0, mass[j], v[0], v[j], r)
                for q in range(stuck.shape[0]):
                    stuck[q] = 0
                if plastic:
                    v[j] = v[0]
                    stuck[hit] = side
                if inside:
                    out[IMPACT_LOSS] += loss
                    out[IMPACTS] += 1
                    out[E1_MAX] = max(out[E1_MAX], primary_energy(m0, k1, x[0], v[0]))
            if has_impact and stuck.any():
                pin_to_walls(x, stuck, impact_body, clearance)
                # release contacts the wall would have to pull (checked at step ends)
                accelerations(x, v, t + left, mass, k1, c1, k_lin, k_cubic, c_abs, harmonic,
                              impact_body, stuck, True, acc)
        if diverged(x):
            out[STATUS] = STATUS_DIVERGED
        out[FINAL_ENERGY] = total_energy(x, v, mass, k1, k_lin, k_cubic)

    return kernel
