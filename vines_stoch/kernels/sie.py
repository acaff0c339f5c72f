"""Semi-implicit (symplectic) Euler-Maruyama with exact impact location.

Each step is a *kick* then a *drift*: velocities take the force impulses of the step
(plus the Wiener increment ``sigma dW`` on the primary, Ito, additive), then positions move
linearly with the new velocities.  During the drift every relative coordinate is linear in
time, so the instant an impact absorber reaches its wall is found exactly, the Newton map is
applied there and the drift continues from the post-impact state.

Energy bookkeeping uses the midpoint velocity of each kick, for which the change of kinetic
energy equals the work of the impulses exactly; the only residual left in the energy balance
is the scheme's own error in the potential energy (MODEL.md section 4).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import njit

from ..physics import primary_energy, restitution_impact, total_energy, wall_hit_time
from ..physics import KERNEL
from .common import (ABSORBER_DISS, CAPPED, CHECK_EVERY, E1_MAX, ENERGY_INT, FINAL_ENERGY, IMPACT_LOSS,
                     IMPACTS, INLINE, INPUT, MAX_EVENTS, PRIMARY_DISS, STATUS, STATUS_DIVERGED, X1_MAX,
                     X1_SQ_INT, attachment_forces, diverged, pin_to_walls, stick_together, sticks)


@njit(**INLINE)
def drift_with_impacts(x, v, dt, mass, impact_body, clearance, restitution, stuck, w_gain, result):
    """Move all bodies for ``dt`` at constant velocity, resolving wall impacts in time order.

    Adds impact losses to ``result[0]`` and counts impacts in ``result[1]``; returns False
    if more than ``MAX_EVENTS`` impacts had to be resolved in this step.
    """
    left = dt
    for _ in range(MAX_EVENTS):
        first = left
        hit = -1
        side = 0
        for q in range(impact_body.shape[0]):
            if stuck[q] == 0:
                j = impact_body[q] + 1
                tau, s = wall_hit_time(x[j] - x[0], v[j] - v[0], clearance[q])
                if tau < first:
                    first, hit, side = tau, q, s
        for b in range(x.shape[0]):
            x[b] += first * v[b]
        left -= first
        if hit < 0:
            return True
        j = impact_body[hit] + 1
        x[j] = x[0] + side * clearance[hit]
        w_in = v[j] - v[0]
        plastic = sticks(side, w_in, w_gain[hit])
        r = 0.0 if plastic else restitution[hit]
        v[0], v[j], loss = restitution_impact(mass[0], mass[j], v[0], v[j], r)
        for q in range(stuck.shape[0]):  # the primary's velocity jumped: re-examine every contact
            stuck[q] = 0
        if plastic:
            v[j] = v[0]
            stuck[hit] = side
        result[0] += loss
        result[1] += 1.0
    for b in range(x.shape[0]):
        x[b] += left * v[b]
    for q in range(impact_body.shape[0]):
        j = impact_body[q] + 1
        x[j] = x[0] + min(max(x[j] - x[0], -clearance[q]), clearance[q])
    return False


@lru_cache(maxsize=None)
def sie_kernel(has_noise: bool, has_impact: bool):
    """The semi-implicit Euler-Maruyama loop specialised to a scene's structure."""

    @njit(**KERNEL)
    def kernel(mass, k1, c1, k_lin, k_cubic, c_abs, impact_body, clearance, restitution,
               harmonic, sigma, x0, v0, dt, n_steps, i0, gen, out):
        nb = mass.shape[0]
        ni = impact_body.shape[0]
        nh = harmonic.shape[0]
        x = x0.copy()
        v = v0.copy()
        force = np.zeros(nb)
        vn = np.zeros(nb)
        stuck = np.zeros(ni, np.int64)
        w_gain = np.zeros(ni)
        impact = np.zeros(2)
        # harmonic loads by rotation, re-evaluated exactly every CHECK_EVERY steps
        hc = np.zeros(nh)
        hs = np.zeros(nh)
        rc = np.cos(harmonic[:, 1] * dt)
        rs = np.sin(harmonic[:, 1] * dt)
        noise_scale = sigma * np.sqrt(dt)
        m0 = mass[0]
        e1_prev = primary_energy(m0, k1, x[0], v[0])
        x2_prev = x[0] * x[0]
        # accumulators in registers; written to ``out`` once at the end
        work = d_primary = d_absorber = e_integral = x2_integral = e1_max = x1_max = 0.0
        for i in range(n_steps):
            if i == i0:
                work = total_energy(x, v, mass, k1, k_lin, k_cubic)
                e1_max = e1_prev
                x1_max = abs(x[0])
            if i % CHECK_EVERY == 0:
                if diverged(x):
                    out[STATUS] = STATUS_DIVERGED
                    break
                for h in range(nh):
                    phase = harmonic[h, 1] * (i * dt) + harmonic[h, 2]
                    hc[h] = np.cos(phase)
                    hs[h] = np.sin(phase)
            load = 0.0
            for h in range(nh):
                load += harmonic[h, 0] * hc[h]
                hc[h], hs[h] = hc[h] * rc[h] - hs[h] * rs[h], hs[h] * rc[h] + hc[h] * rs[h]
            # kick
            attachment_forces(x, v, k1, c1, k_lin, k_cubic, c_abs, force)
            dw = 0.0
            if has_noise:
                dw = noise_scale * gen.standard_normal()
            vn[0] = v[0] + ((force[0] + load) * dt + dw) / m0
            for b in range(1, nb):
                vn[b] = v[b] + force[b] * dt / mass[b]
            if has_impact:
                for q in range(ni):
                    j = impact_body[q] + 1
                    w_gain[q] = (vn[j] - vn[0]) - (v[j] - v[0])
                stick_together(mass, vn, stuck, impact_body, True)
            inside = i >= i0
            if inside:
                v_mid = 0.5 * (v[0] + vn[0])
                work += (load * dt + dw) * v_mid
                d_primary += c1 * v[0] * dt * v_mid
                for a in range(nb - 1):
                    w = v[a + 1] - v[0]
                    d_absorber += c_abs[a] * w * dt * 0.5 * (w + vn[a + 1] - vn[0])
            for b in range(nb):
                v[b] = vn[b]
            # drift
            if has_impact:
                impact[0] = 0.0
                impact[1] = 0.0
                if not drift_with_impacts(x, v, dt, mass, impact_body, clearance, restitution,
                                          stuck, w_gain, impact):
                    out[CAPPED] += 1
                pin_to_walls(x, stuck, impact_body, clearance)
                if inside:
                    out[IMPACT_LOSS] += impact[0]
                    out[IMPACTS] += impact[1]
            else:
                for b in range(nb):
                    x[b] += dt * v[b]
            e1 = primary_energy(m0, k1, x[0], v[0])
            x2 = x[0] * x[0]
            if inside:
                e_integral += 0.5 * (e1 + e1_prev) * dt
                x2_integral += 0.5 * (x2 + x2_prev) * dt
                e1_max = max(e1_max, e1)
                x1_max = max(x1_max, abs(x[0]))
            e1_prev = e1
            x2_prev = x2
        if diverged(x):
            out[STATUS] = STATUS_DIVERGED
        out[INPUT] = work
        out[PRIMARY_DISS] = d_primary
        out[ABSORBER_DISS] = d_absorber
        out[ENERGY_INT] = e_integral
        out[X1_SQ_INT] = x2_integral
        out[E1_MAX] = e1_max
        out[X1_MAX] = x1_max
        out[FINAL_ENERGY] = total_energy(x, v, mass, k1, k_lin, k_cubic)

    return kernel
