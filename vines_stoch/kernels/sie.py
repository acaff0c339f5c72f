"""Euler-Maruyama for additive noise in kick-drift-kick (velocity Verlet) form, with impacts
located on the Brownian path.

Each step is a half *kick* (half the force impulse of the step plus half the Wiener increment
``sigma dW`` on the primary, additive), a *drift* (positions move linearly with the new
velocities) and a closing half kick with the forces at the new positions and the other half of
``sigma dW``.  Without noise this is the second-order velocity Verlet map; with additive noise
it has strong order 1.  The even split moves the positions by ``dt sigma dW / 2``, the mean
of the exact ``sigma int W dt`` given ``dW``; it gives the linear oscillator's stationary
position variance almost exactly (4e-6 relative at ``omega dt = 0.4``), and the noise's part
of a step's energy residual is ``(F' - F) dt sigma dW / (8 m)``.  (With the whole increment in
the first kick that part is ``F dt sigma dW / (4 m)``, whose mean is not zero where the moving
mass depends on ``dW``: an absorber stuck to its wall and released by the noise.)

When the drift would carry an impact absorber through its wall, the step is split at the
impact: the sub-step of length ``s`` that lands exactly on the wall is found by a bracketed
root search, with its Wiener increment drawn from the Brownian bridge pinned to the step's
increment (``dW_s = dW s / h + sqrt(s (h - s) / h) Z``), so the sub-stepped path is the same
Brownian path.  The Newton map acts at the end of that sub-step, and the rest of the step
continues from the post-impact state with the rest of the increment.  (Applying the impact
at a grid state of a symmetric map matters: with a kick-drift map the energy balance drifts
by ``O(dt)`` per impact.)

Energy bookkeeping uses the midpoint velocity of each kick, for which the change of kinetic
energy equals the work of the impulses exactly; the only residual left in the energy balance
is the scheme's own error in the potential energy (MODEL.md section 4).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import njit

from ..physics import KERNEL, primary_energy, restitution_impact
from .common import (ABSORBER_DISS, CAPPED, CHECK_EVERY, E1_MAX, ENERGY_INT, FINAL_ENERGY,
                     IMPACT_LOSS, IMPACTS, IMPACTS_LEFT, IMPACTS_RIGHT, INLINE, INPUT, MAX_EVENTS,
                     PRIMARY_DISS, STATUS, STATUS_DIVERGED, X1_MAX, X1_SQ_INT, accelerate,
                     attachment_forces, block_end, diverged, pin_to_walls, record_history,
                     scratch, start_history, stick_together, sticks, stored_energy)
from .loads import advance_filters, excitation, phasors, rotations, turn

#: Iterations of the bracketed search for the impact instant (Illinois method).
ROOT_ITERATIONS = 100


@njit(**INLINE)
def kick(v, s, dws, load, ag, force, inv_mass, vn, ground):
    """Velocities after a kick of length ``s`` into ``vn``: forces, the load ``load`` and
    Wiener increment ``dws`` on the primary, ground acceleration ``ag`` on every body if
    ``ground`` (a compile-time flag: ``0 * s`` cannot be folded away under IEEE rules) (the
    caller makes stuck absorbers move with the primary).  ``inv_mass``: the reciprocal masses.
    The state-dependent force term comes last, one fused multiply-add after the forces (the
    step's critical path)."""
    base = ag * s if ground else 0.0
    vn[0] = (v[0] + ((load * s + dws) * inv_mass[0] - base)) + force[0] * (s * inv_mass[0])
    for b in range(1, vn.shape[0]):
        vn[b] = (v[b] - base) + force[b] * (s * inv_mass[b])


@njit(**INLINE)
def momentum(mass, v, vn) -> float:
    """Total momentum at the mean of two velocity vectors (work of the ground acceleration)."""
    p = 0.0
    for b in range(v.shape[0]):
        p += mass[b] * 0.5 * (v[b] + vn[b])
    return p


@njit(**INLINE)
def bridge(total, length, s, z):
    """Increment over ``[0, s]`` of ``sigma W`` given its increment ``total`` over ``[0, length]``
    (Brownian bridge; ``z`` is ``sigma`` times a standard normal)."""
    if length <= 0.0:
        return total
    return total * (s / length) + np.sqrt(max(s * (length - s) / length, 0.0)) * z


@njit(**INLINE)
def crossing(x, v, length, total, z, load, ag, force, mass, inv_mass, stuck, impact_body, j, side, wall, vt, ground):
    """Sub-step length in ``(0, length]`` after which absorber body ``j`` is exactly at
    ``wall`` (side ``side``), by the Illinois method on the bracket ``[0, length]``."""
    lo, hi = 0.0, length
    g_lo = min(side * (x[j] - x[0]) - wall, 0.0)  # on the wall counts as inside
    kick(v, 0.5 * length, 0.5 * total, load, ag, force, inv_mass, vt, ground)
    stick_together(mass, vt, stuck, impact_body, False)
    g_hi = side * (x[j] - x[0] + length * (vt[j] - vt[0])) - wall
    s = hi
    last = 0
    for _ in range(ROOT_ITERATIONS):
        s = hi - g_hi * (hi - lo) / (g_hi - g_lo)
        if not (lo < s < hi):
            s = 0.5 * (lo + hi)
        kick(v, 0.5 * s, 0.5 * bridge(total, length, s, z), load, ag, force, inv_mass, vt, ground)
        stick_together(mass, vt, stuck, impact_body, False)
        g = side * (x[j] - x[0] + s * (vt[j] - vt[0])) - wall
        if g > 0.0:
            hi, g_hi = s, g
            if last > 0:
                g_lo *= 0.5
            last = 1
        else:
            lo, g_lo = s, g
            if last < 0:
                g_hi *= 0.5
            last = -1
        if hi - lo <= 1e-15 * length or g == 0.0:
            break
    return hi


@lru_cache(maxsize=None)
def sie_kernel(n_bodies: int, n_rows: int, has_noise: bool, has_impact: bool, filtered: bool, piecewise: bool,
               ground: bool, replay: bool = False, sra: bool = False):
    """The semi-implicit Euler-Maruyama loop specialised to a scene's structure (number of
    bodies and of closed-form force rows, white noise, impact absorbers, filtered loads, loads
    with kinks or jumps, ground acceleration: ``Scene.kernel_flags``).
    Harmonic loads on the step grid come from phasors (``loads.turn``), set exactly every
    ``CHECK_EVERY`` steps.

    With ``replay``, the step increments are ``sigma sqrt(dt) normals[i]`` (a given Brownian
    path, for convergence studies) instead of draws from ``gen``.

    With ``sra`` (scenes without impact absorbers and filtered loads), each step is the
    stochastic Runge-Kutta method SRA3 of Roessler (2010) for additive noise instead: three
    stages at ``t``, ``t + h`` and ``t + h/2`` (the deterministic part is the third-order
    strong-stability-preserving Runge-Kutta method), strong order 1.5 and weak order 2 with
    additive noise.  The step draws ``I1 = dW`` and ``I10`` (the time integral of ``W`` over
    the step, ``sqrt(h) h / 2 (u1 + u2 / sqrt 3)``); replayed paths give two normals a step.
    Its energy bookkeeping uses the mean of the step's end velocities, as the kicks do, so the
    kinetic energy change equals the work of the step's impulses exactly.
    """

    # passes of a step's event loop: one without impact absorbers (nothing to split at), none
    # with the Runge-Kutta step
    EVENTS = 0 if sra else (MAX_EVENTS + 1 if has_impact else 1)
    NB = n_bodies
    NR = n_rows
    NS = n_bodies if sra else 0
    GROUND = ground
    ROOT3 = np.sqrt(3.0)

    @njit(**KERNEL)
    def kernel(mass, k1, c1, k_lin, k_cubic, c_abs, rest, impact_body, clearance, restitution,
               hertz_body, hertz_k, hertz_walls, ex, fl, sigma, state_x, state_v, dt, n_steps, i0,
               period, sample_from, gen, normals, out, samples, history, stride):
        nb = NB
        ni = impact_body.shape[0]
        phi, chol, envelopes, c_force, c_ground, z = fl
        forces, series_t, series_v, series_ptr, series_ground = ex
        nz = z.shape[0]
        # the state (copied back at the end) and the scratch, on the stack (see ``common.scratch``)
        x, v, force, vn, vt, inv_mass = scratch(NB), scratch(NB), scratch(NB), scratch(NB), scratch(NB), scratch(NB)
        for b in range(nb):
            x[b] = state_x[b]
            v[b] = state_v[b]
            inv_mass[b] = 1.0 / mass[b]
        # the Runge-Kutta stages' scratch, only where they run
        a1, a2, a3, xs, v2, v3 = scratch(NS), scratch(NS), scratch(NS), scratch(NS), scratch(NS), scratch(NS)
        zn = z.copy()
        draws = np.zeros(nz)
        # phasors (cos, sin) of the harmonic loads at the step's start and at its midpoint, and
        # their turns in a step and in half a step; on the stack (heap arrays passed to the
        # inlined load functions cost reference counting in the step loop)
        pc, ps, mc, ms = scratch(NR), scratch(NR), scratch(NR), scratch(NR)
        rc, rs, hc, hs = scratch(NR), scratch(NR), scratch(NR), scratch(NR)
        rotations(forces, dt, rc, rs)
        rotations(forces, 0.5 * dt, hc, hs)
        stuck = np.zeros(ni, np.int64)
        noise_scale = sigma * np.sqrt(dt)
        m0 = mass[0]
        e1_prev = primary_energy(m0, k1, x[0], v[0])
        x2_prev = x[0] * x[0]
        h_next = start_history(history, stride, x[0], e1_prev)
        load_next, ag_next = excitation(0.0, 0.5 * dt, 0.0, forces, series_t, series_v, series_ptr, series_ground,
                                        filtered, c_force, c_ground, z, zn, pc, False, GROUND)
        # accumulators in registers; written to ``out`` once at the end
        work = d_primary = d_absorber = e_integral = x2_integral = e1_max = x1_max = 0.0
        loss_sum = n_left = n_right = 0.0
        i = 0
        inside = i0 == 0
        while i < n_steps:
            # rare work between blocks of steps, out of the step loop: the window opening,
            # the divergence check, history rows
            if i == i0:
                inside = True
                work = stored_energy(x, v, mass, k1, k_lin, k_cubic, rest, hertz_body, hertz_k, hertz_walls)
                e1_max = e1_prev
                x1_max = abs(x[0])
            if i % CHECK_EVERY == 0:
                if diverged(x):
                    out[STATUS] = STATUS_DIVERGED
                    break
                phasors(i * dt, forces, pc, ps)
            end = block_end(i, n_steps, i0, h_next)
            for i in range(i, end):
                t_step = i * dt
                tm = t_step + 0.5 * dt
                if filtered:
                    for r in range(nz):
                        z[r] = zn[r]
                    advance_filters(z, zn, t_step, dt, phi, chol, envelopes, gen, draws)
                load, ag = load_next, ag_next
                if piecewise:  # re-evaluate each step's start on its own piece
                    load, ag = excitation(t_step, tm, 0.0, forces, series_t, series_v, series_ptr, series_ground,
                                          filtered, c_force, c_ground, z, zn, pc, True, GROUND)
                load3, ag3 = 0.0, 0.0  # the Runge-Kutta step's mid-step loads
                if sra:
                    turn(pc, ps, hc, hs, mc, ms)
                    load3, ag3 = excitation(t_step + 0.5 * dt, tm, 0.5, forces, series_t, series_v, series_ptr,
                                            series_ground, filtered, c_force, c_ground, z, zn, mc, True, GROUND)
                turn(pc, ps, rc, rs, pc, ps)
                load_next, ag_next = excitation(t_step + dt, tm, 1.0, forces, series_t, series_v, series_ptr, series_ground,
                                                filtered, c_force, c_ground, z, zn, pc, True, GROUND)
                dw = 0.0
                if has_noise and not sra:
                    dw = noise_scale * (normals[i] if replay else gen.standard_normal())
                if sra:
                    dz = 0.0  # sigma I10 / h
                    if has_noise:
                        u1 = normals[2 * i] if replay else gen.standard_normal()
                        u2 = normals[2 * i + 1] if replay else gen.standard_normal()
                        dw = noise_scale * u1
                        dz = 0.5 * noise_scale * (u1 + u2 / ROOT3)
                    attachment_forces(x, v, k1, c1, k_lin, k_cubic, c_abs, rest, force)
                    accelerate(force, load, ag, inv_mass, a1)
                    for b in range(nb):
                        xs[b] = x[b] + dt * v[b]
                        v2[b] = v[b] + dt * a1[b]
                    attachment_forces(xs, v2, k1, c1, k_lin, k_cubic, c_abs, rest, force)
                    accelerate(force, load_next, ag_next, inv_mass, a2)
                    for b in range(nb):
                        xs[b] = x[b] + 0.25 * dt * (v[b] + v2[b])
                        v3[b] = v[b] + 0.25 * dt * (a1[b] + a2[b])
                    v3[0] += 1.5 * dz / m0
                    attachment_forces(xs, v3, k1, c1, k_lin, k_cubic, c_abs, rest, force)
                    accelerate(force, load3, ag3, inv_mass, a3)
                    for b in range(nb):
                        vn[b] = v[b] + dt * (a1[b] / 6.0 + a2[b] / 6.0 + 2.0 / 3.0 * a3[b])
                    vn[0] += dw / m0
                    if inside:
                        v_mid = 0.5 * (v[0] + vn[0])
                        impulse = dt * (load / 6.0 + load_next / 6.0 + 2.0 / 3.0 * load3) + dw
                        ground = dt * (ag / 6.0 + ag_next / 6.0 + 2.0 / 3.0 * ag3)
                        work += impulse * v_mid - (ground * momentum(mass, v, vn) if ground != 0.0 else 0.0)
                        d_primary += c1 * dt * (v[0] / 6.0 + v2[0] / 6.0 + 2.0 / 3.0 * v3[0]) * v_mid
                        for a in range(nb - 1):
                            w = dt * ((v[a + 1] - v[0]) / 6.0 + (v2[a + 1] - v2[0]) / 6.0
                                      + 2.0 / 3.0 * (v3[a + 1] - v3[0]))
                            d_absorber += c_abs[a] * w * 0.5 * (v[a + 1] - v[0] + vn[a + 1] - vn[0])
                    for b in range(nb):
                        x[b] += dt * (v[b] / 6.0 + v2[b] / 6.0 + 2.0 / 3.0 * v3[b])
                        v[b] = vn[b]
                left = dt
                t = t_step
                for event in range(EVENTS):
                    if event > 0 and left <= 0.0:
                        break
                    attachment_forces(x, v, k1, c1, k_lin, k_cubic, c_abs, rest, force)
                    kick(v, 0.5 * left, 0.5 * dw, load, ag, force, inv_mass, vn, GROUND)
                    if has_impact:
                        stick_together(mass, vn, stuck, impact_body, True)
                    s = left
                    hit, side = -1, 0
                    zb = 0.0
                    if has_impact and event < MAX_EVENTS:
                        for q in range(ni):
                            j = impact_body[q] + 1
                            u_end = x[j] - x[0] + left * (vn[j] - vn[0])
                            if stuck[q] == 0 and abs(u_end) > clearance[q]:
                                if has_noise and hit < 0:  # one bridge draw per split step
                                    zb = sigma * gen.standard_normal()
                                sq = 1 if u_end > 0.0 else -1
                                sc = crossing(x, v, left, dw, zb, load, ag, force, mass, inv_mass, stuck, impact_body,
                                              j, sq, clearance[q], vt, GROUND)
                                if hit < 0 or sc < s:
                                    hit, side, s = q, sq, sc
                        if hit >= 0:
                            kick(v, 0.5 * s, 0.5 * bridge(dw, left, s, zb), load, ag, force, inv_mass, vn, GROUND)
                            stick_together(mass, vn, stuck, impact_body, False)
                    dws = dw
                    if has_impact:  # the increment of the sub-step before an impact
                        dws = bridge(dw, left, s, zb)
                    if inside:
                        v_mid = 0.5 * (v[0] + vn[0])
                        work += 0.5 * (load * s + dws) * v_mid - (0.5 * ag * s * momentum(mass, v, vn) if ag != 0.0 else 0.0)
                        d_primary += c1 * v[0] * 0.5 * s * v_mid
                        for a in range(nb - 1):
                            w = v[a + 1] - v[0]
                            d_absorber += c_abs[a] * w * 0.5 * s * 0.5 * (w + vn[a + 1] - vn[0])
                    for b in range(nb):
                        x[b] += s * vn[b]
                        v[b] = vn[b]
                    # closing half kick with the forces at the new positions (its bookkeeping is
                    # written out like the first kick's: an inlined helper for both measured 40 %
                    # slower)
                    load_end, ag_end = load_next, ag_next
                    if hit >= 0:
                        load_end, ag_end = excitation(t + s, tm, (t + s - t_step) / dt, forces, series_t, series_v, series_ptr, series_ground,
                                                      filtered, c_force, c_ground, z, zn, pc, False, GROUND)
                    attachment_forces(x, v, k1, c1, k_lin, k_cubic, c_abs, rest, force)
                    kick(v, 0.5 * s, 0.5 * dws, load_end, ag_end, force, inv_mass, vn, GROUND)
                    if has_impact:
                        stick_together(mass, vn, stuck, impact_body, False)
                    if inside:
                        v_mid = 0.5 * (v[0] + vn[0])
                        work += 0.5 * (load_end * s + dws) * v_mid - (0.5 * ag_end * s * momentum(mass, v, vn) if ag_end != 0.0 else 0.0)
                        d_primary += c1 * v[0] * 0.5 * s * v_mid
                        for a in range(nb - 1):
                            w = v[a + 1] - v[0]
                            d_absorber += c_abs[a] * w * 0.5 * s * 0.5 * (w + vn[a + 1] - vn[0])
                    for b in range(nb):
                        v[b] = vn[b]
                    if hit < 0:
                        break
                    # the impact, at t + s; the rest of the step keeps the rest of the increment
                    j = impact_body[hit] + 1
                    x[j] = x[0] + side * clearance[hit]
                    t += s
                    left -= s
                    dw -= dws
                    load, ag = load_end, ag_end
                    gain = (force[j] / mass[j] - (force[0] + load) / m0) * dt
                    # the last impact a step may resolve ends a chatter sequence: inelastic collapse
                    plastic = sticks(side, v[j] - v[0], gain) or event == MAX_EVENTS - 1
                    r = 0.0 if plastic else restitution[hit]
                    v[0], v[j], loss = restitution_impact(m0, mass[j], v[0], v[j], r)
                    for q in range(ni):  # the primary's velocity jumped: re-examine every contact
                        stuck[q] = 0
                    if plastic:
                        v[j] = v[0]
                        stuck[hit] = side
                    if inside:
                        loss_sum += loss
                        if side < 0:
                            n_left += 1.0
                        else:
                            n_right += 1.0
                    if event == MAX_EVENTS - 1:
                        out[CAPPED] += 1
                if has_impact:
                    for q in range(ni):
                        j = impact_body[q] + 1
                        x[j] = x[0] + min(max(x[j] - x[0], -clearance[q]), clearance[q])
                    pin_to_walls(x, stuck, impact_body, clearance)
                e1 = primary_energy(m0, k1, x[0], v[0])
                x2 = x[0] * x[0]
                if inside:
                    e_integral += 0.5 * (e1 + e1_prev) * dt
                    x2_integral += 0.5 * (x2 + x2_prev) * dt
                    e1_max = max(e1_max, e1)
                    x1_max = max(x1_max, abs(x[0]))
                e1_prev = e1
                x2_prev = x2
            i = end
            if i == h_next:
                h_next = record_history(history, stride, h_next, x[0], e1_prev)
        if diverged(x):
            out[STATUS] = STATUS_DIVERGED
        for b in range(nb):
            state_x[b] = x[b]
            state_v[b] = v[b]
        out[INPUT] = work
        out[PRIMARY_DISS] = d_primary
        out[ABSORBER_DISS] = d_absorber
        out[ENERGY_INT] = e_integral
        out[X1_SQ_INT] = x2_integral
        out[E1_MAX] = e1_max
        out[X1_MAX] = x1_max
        out[IMPACT_LOSS] = loss_sum
        out[IMPACTS] = n_left + n_right
        out[IMPACTS_LEFT] = n_left
        out[IMPACTS_RIGHT] = n_right
        out[FINAL_ENERGY] = stored_energy(x, v, mass, k1, k_lin, k_cubic, rest, hertz_body, hertz_k, hertz_walls)

    return kernel
