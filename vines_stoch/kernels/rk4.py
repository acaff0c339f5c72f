"""Classical fourth-order Runge-Kutta for scenes without noise, with located events.

The energy integrals of MODEL.md section 4 (work of the loads, viscous dissipation, the
integrals of ``E1`` and ``x1^2``) are integrated as extra states by the same RK4 stages, so
the energy balance closes to the scheme's fourth-order error.

Events are located inside a step by Newton iteration on the length of an RK4 sub-step from
the start of the step (converged to round-off):

- an impact absorber reaching its wall: the Newton map is applied at that instant;
- a Hertz absorber touching a contact surface: from there the step is cut into sub-steps
  sized from the contact's stiffness, masses and approach speed (about ``CONTACT_STEPS`` per
  contact duration), until the contact ends, which is located the same way.

The outer step ``dt`` never has to be shrunk by the user for contact.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import njit

from ..physics import KERNEL, primary_energy, restitution_impact
from .common import (ABSORBER_DISS, CAPPED, CHECK_EVERY, CONTACT_TIME, E1_MAX, ENERGY_INT,
                     FINAL_ENERGY, IMPACT_LOSS, IMPACTS, IMPACTS_LEFT, IMPACTS_RIGHT, INLINE,
                     INPUT, MAX_EVENTS, PEAK_FORCE, PRIMARY_DISS, STATUS, STATUS_DIVERGED, X1_MAX,
                     X1_SQ_INT, accelerate, attachment_forces, block_end, contact_force, contact_forces,
                     diverged, pick, pin_to_walls, record_history, record_sample, scratch, start_history,
                     stick_together, sticks, stored_energy)
from .loads import applied, next_break

NEWTON_ITERATIONS = 12
#: Sub-steps per Hertz contact duration.
CONTACT_STEPS = 80
#: Sub-steps (contact phases, impacts) allowed in one outer step; past it the rest of the
#: step is taken at once and counted in ``capped_steps``.
MAX_SUBSTEPS = 100_000
#: Event kinds.
NONE, IMPACT, ONSET, EXIT = 0, 1, 2, 3


@njit(**INLINE)
def accelerations(x, v, t, tm, mass, inv_mass, k1, c1, k_lin, k_cubic, c_abs, rest, forces, series_t, series_v,
                  series_ptr, series_ground, impact_body, hertz_body, hertz_k, hertz_walls, stuck, release,
                  acc, sticking, contact):
    """Accelerations of all bodies into ``acc``; returns the rates of the energy integrals
    (load power, primary damping power, absorber damping power, ``E1``, ``x1^2``).

    The scene's arrays come one by one (``forces .. series_ground``: the loads of
    kernels/loads.py, piecewise loads on the piece of ``tm``): unpacking a tuple of arrays
    costs reference counting at every call.  ``sticking`` applies the contact constraint of
    stuck impact absorbers, ``contact`` the Hertz contact forces (flags, not branches around
    the calls: see ``physics.INLINE``).
    """
    attachment_forces(x, v, k1, c1, k_lin, k_cubic, c_abs, rest, acc)
    contact_forces(x, hertz_body, hertz_k, hertz_walls, acc, contact)
    load, ag = applied(t, tm, forces, series_t, series_v, series_ptr, series_ground, series_t, False)
    accelerate(acc, load, ag, inv_mass, acc)
    power = load * v[0]
    if ag != 0.0:
        for b in range(v.shape[0]):
            power -= ag * mass[b] * v[b]
    stick_together(mass, acc, stuck, impact_body, release, sticking)
    absorber_power = 0.0
    for a in range(x.shape[0] - 1):
        w = v[a + 1] - v[0]
        absorber_power += c_abs[a] * w * w
    return (power, c1 * v[0] * v[0], absorber_power,
            primary_energy(mass[0], k1, x[0], v[0]), x[0] * x[0])


@njit(**KERNEL)
def wall_accelerations(x, v, t, mass, inv_mass, k1, c1, k_lin, k_cubic, c_abs, rest, forces, series_t, series_v,
                       series_ptr, series_ground, impact_body, hertz_body, hertz_k, hertz_walls, stuck,
                       release, acc, sticking, contact):
    """``accelerations`` at an instant (an impact, the end of a step with stuck absorbers),
    out of line: rare work that need not grow the step loop."""
    accelerations(x, v, t, t, mass, inv_mass, k1, c1, k_lin, k_cubic, c_abs, rest, forces, series_t, series_v, series_ptr,
                  series_ground, impact_body, hertz_body, hertz_k, hertz_walls, stuck, release, acc, sticking,
                  contact)


@njit(**INLINE)
def rk4_step(x, v, t, h, xo, vo, acc, xs, vs, mass, inv_mass, k1, c1, k_lin, k_cubic, c_abs, rest, forces, series_t,
             series_v, series_ptr, series_ground, impact_body, hertz_body, hertz_k, hertz_walls, stuck,
             sticking, contact):
    """One RK4 step of size ``h`` from ``(x, v)`` into ``(xo, vo)``; returns the increments
    of the five energy integrals.  ``acc``, ``xs``, ``vs`` are scratch (the stage's
    accelerations and state); ``xo``, ``vo`` gather the weighted stage slopes.  Inlined at one
    call site of the step loop (a call with this many arrays cost about 40 % of a step)."""
    nb = x.shape[0]
    tm = t + 0.5 * h
    q0 = q1 = q2 = q3 = q4 = 0.0
    for stage in range(4):
        if stage == 0:
            for b in range(nb):
                xs[b] = x[b]
                vs[b] = v[b]
        ts = t if stage == 0 else (t + h if stage == 3 else tm)
        r = accelerations(xs, vs, ts, tm, mass, inv_mass, k1, c1, k_lin, k_cubic, c_abs, rest, forces, series_t,
                          series_v, series_ptr, series_ground, impact_body, hertz_body, hertz_k, hertz_walls,
                          stuck, False, acc, sticking, contact)
        weight = 1.0 if stage == 0 or stage == 3 else 2.0
        c = 0.5 * h if stage < 2 else h
        for b in range(nb):
            if stage == 0:
                xo[b] = vs[b]
                vo[b] = acc[b]
            else:
                xo[b] += weight * vs[b]
                vo[b] += weight * acc[b]
            xs[b] = x[b] + c * vs[b]
            vs[b] = v[b] + c * acc[b]
        if stage == 0:
            q0, q1, q2, q3, q4 = r
        else:
            q0 += weight * r[0]
            q1 += weight * r[1]
            q2 += weight * r[2]
            q3 += weight * r[3]
            q4 += weight * r[4]
    for b in range(nb):
        xo[b] = x[b] + h / 6.0 * xo[b]
        vo[b] = v[b] + h / 6.0 * vo[b]
    return h / 6.0 * q0, h / 6.0 * q1, h / 6.0 * q2, h / 6.0 * q3, h / 6.0 * q4


@njit(**KERNEL)
def event_geometry(kind, q, side, impact_body, clearance, hertz_body, hertz_walls):
    """Body ``j``, sign and wall of an event's gap ``g = sign * (x_j - x_1 - wall)``, which
    crosses zero upwards when the event happens."""
    if kind == IMPACT:
        return impact_body[q] + 1, side, side * clearance[q]
    wall = hertz_walls[q, 0] if side < 0 else hertz_walls[q, 1]
    return hertz_body[q] + 1, (side if kind == ONSET else -side), wall


@njit(**KERNEL)
def next_event(x, xn, h, impact_body, clearance, stuck, hertz_body, hertz_walls, touching):
    """The first event of a step ``x -> xn`` of length ``h``: an impact absorber crossing its
    wall, a Hertz contact starting or ending (by linear interpolation of the gap).
    Returns ``(kind, q, side, tau)``; ``kind == NONE`` when nothing happens."""
    kind, hit, hit_side, first = NONE, -1, 0, h
    for q in range(impact_body.shape[0]):
        if stuck[q] == 0:
            j = impact_body[q] + 1
            u1 = xn[j] - xn[0]
            if abs(u1) > clearance[q]:
                s = 1 if u1 > 0.0 else -1
                g0 = s * (x[j] - x[0]) - clearance[q]
                g1 = s * u1 - clearance[q]
                tau = h * max(-g0, 0.0) / (g1 - g0)
                if tau < first or kind == NONE:
                    kind, hit, hit_side, first = IMPACT, q, s, tau
    for q in range(hertz_body.shape[0]):
        j = hertz_body[q] + 1
        u0 = x[j] - x[0]
        u1 = xn[j] - xn[0]
        for s in (-1, 1):
            if touching[q] == 0 or touching[q] == s:
                event = ONSET if touching[q] == 0 else EXIT
                sign = s if event == ONSET else -s
                wall = hertz_walls[q, 0] if s < 0 else hertz_walls[q, 1]
                g1 = sign * (u1 - wall)
                if g1 > 0.0:
                    g0 = sign * (u0 - wall)
                    tau = h * max(-g0, 0.0) / (g1 - g0)
                    if tau < first or kind == NONE:
                        kind, hit, hit_side, first = event, q, s, tau
    return kind, hit, hit_side, first


@njit(**KERNEL)
def contact_step(x, v, mass, hertz_body, hertz_k, hertz_walls, touching) -> float:
    """Sub-step for the Hertz contacts in progress: about ``CONTACT_STEPS`` per contact.

    A Hertz contact with relative energy ``E`` compresses to ``z_max = (E / (0.4 K))^0.4`` and
    lasts about ``4 / omega`` with ``omega = sqrt(1.5 K z_max^0.5 / m_eff)``.
    """
    h = np.inf
    for q in range(hertz_body.shape[0]):
        side = touching[q]
        if side != 0:
            j = hertz_body[q] + 1
            m_eff = mass[0] * mass[j] / (mass[0] + mass[j])
            u = x[j] - x[0]
            w = v[j] - v[0]
            k = hertz_k[q, 0] if side < 0 else hertz_k[q, 1]
            z = max(hertz_walls[q, 0] - u if side < 0 else u - hertz_walls[q, 1], 0.0)
            energy = 0.5 * m_eff * w * w + 0.4 * k * z * z * np.sqrt(z)
            z_ref = max(z, (energy / (0.4 * k)) ** 0.4)
            if z_ref > 0.0:
                omega = np.sqrt(1.5 * k * np.sqrt(z_ref) / m_eff)
                h = min(h, 4.0 / (CONTACT_STEPS * omega))
    return h


@lru_cache(maxsize=None)
def rk4_kernel(n_bodies: int, has_impact: bool, has_hertz: bool, sampling: bool, piecewise: bool):
    """The RK4 loop specialised to a scene's structure (number of bodies, impact absorbers,
    Hertz absorbers, Poincare sampling for the regime, loads with kinks or jumps:
    ``Scene.kernel_flags``)."""
    NB = n_bodies

    @njit(**KERNEL)
    def kernel(mass, k1, c1, k_lin, k_cubic, c_abs, rest, impact_body, clearance, restitution,
               hertz_body, hertz_k, hertz_walls, ex, fl, sigma, state_x, state_v, dt, n_steps, i0,
               period, sample_from, gen, normals, out, samples, history, stride):
        nb = NB
        forces, series_t, series_v, series_ptr, series_ground = ex
        # the state and the stages' scratch on the stack (see ``common.scratch``)
        x, v, xn, vn, xp, vp = scratch(NB), scratch(NB), scratch(NB), scratch(NB), scratch(NB), scratch(NB)
        acc, xs, vs, inv_mass = scratch(NB), scratch(NB), scratch(NB), scratch(NB)
        # the out-of-line calls' own arrays, so that the stages' stay in registers
        acc_wall, x_event = scratch(NB), scratch(NB)
        for b in range(nb):
            x[b] = state_x[b]
            v[b] = state_v[b]
            inv_mass[b] = 1.0 / mass[b]
        stuck = np.zeros(impact_body.shape[0], np.int64)
        touching = np.zeros(hertz_body.shape[0], np.int64)
        m0 = mass[0]
        next_sample = 0
        h_next = start_history(history, stride, x[0], primary_energy(m0, k1, x[0], v[0]))
        i = 0
        inside = i0 == 0
        while i < n_steps:
            # rare work between blocks of steps (see ``block_end``)
            if i == i0:
                inside = True
                out[INPUT] = stored_energy(x, v, mass, k1, k_lin, k_cubic, rest, hertz_body, hertz_k, hertz_walls)
                out[E1_MAX] = primary_energy(m0, k1, x[0], v[0])
                out[X1_MAX] = abs(x[0])
            if i % CHECK_EVERY == 0 and diverged(x):
                out[STATUS] = STATUS_DIVERGED
                break
            end = block_end(i, n_steps, i0, h_next)
            for i in range(i, end):
                if sampling:
                    xp[:] = x
                    vp[:] = v
                t = i * dt
                left = dt
                n_impacts = 0
                sub = 0
                # phase 0: a new sub-step; 1 .. NEWTON_ITERATIONS: Newton iterations on the
                # length of the sub-step that ends at an event; -1: the sub-step at the final
                # length.  One call site of the (inlined) step for all of them.
                phase = 0
                while True:
                    if phase == 0:
                        sticking = has_impact and stuck.any()
                        contact = has_hertz and touching.any()
                        h = left
                        if contact:
                            h = min(left, contact_step(x, v, mass, hertz_body, hertz_k, hertz_walls, touching))
                        if piecewise:  # sub-steps end at the loads' kinks and jumps
                            tb = next_break(t + 1e-9 * dt, ex)
                            if tb < t + h - 1e-9 * dt:
                                h = tb - t
                        capped = sub == MAX_SUBSTEPS - 1 or n_impacts >= MAX_EVENTS
                        if capped:  # take the rest of the step at once, keep absorbers in their cavity
                            h = left
                            out[CAPPED] += 1
                        tau = h
                    inc = rk4_step(x, v, t, tau, xn, vn, acc, xs, vs, mass, inv_mass, k1, c1, k_lin, k_cubic, c_abs, rest, forces, series_t, series_v, series_ptr, series_ground, impact_body, hertz_body, hertz_k, hertz_walls, stuck, sticking, contact)
                    if phase == 0:
                        kind, q, side, j, sign, wall = NONE, -1, 0, 0, 0, 0.0
                        if (has_impact or has_hertz) and not capped:
                            for b in range(nb):
                                x_event[b] = xn[b]
                            kind, q, side, tau = next_event(x, x_event, h, impact_body, clearance, stuck,
                                                            hertz_body, hertz_walls, touching)
                        if kind != NONE:
                            j, sign, wall = event_geometry(kind, q, side, impact_body, clearance, hertz_body, hertz_walls)
                            phase = 1
                            continue
                    elif phase > 0:
                        approach = sign * (pick(vn, j) - vn[0])
                        if approach > 0.0:
                            correction = sign * (pick(xn, j) - xn[0] - wall) / approach
                            tau = min(max(tau - correction, 0.0), h)
                            phase = phase + 1 if abs(correction) > 1e-15 * dt and phase < NEWTON_ITERATIONS else -1
                            continue
                    phase = 0
                    h = tau
                    done = kind == NONE and h == left
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
                        if contact:
                            for c in range(touching.shape[0]):
                                if touching[c] != 0:
                                    out[CONTACT_TIME] += h
                                    out[PEAK_FORCE] = max(out[PEAK_FORCE], contact_force(x, c, hertz_body, hertz_k, hertz_walls))
                    t += h
                    left -= h
                    if done:
                        if capped:
                            for s in range(impact_body.shape[0]):
                                js = impact_body[s] + 1
                                x[js] = x[0] + min(max(x[js] - x[0], -clearance[s]), clearance[s])
                        break
                    if kind == IMPACT:
                        n_impacts += 1
                        x[j] = x[0] + side * clearance[q]
                        wall_accelerations(x, v, t, mass, inv_mass, k1, c1, k_lin, k_cubic, c_abs, rest, forces, series_t, series_v, series_ptr, series_ground, impact_body, hertz_body, hertz_k, hertz_walls, stuck, False, acc_wall, True, contact)
                        # the last impact a step may resolve ends a chatter sequence: inelastic collapse
                        plastic = sticks(side, v[j] - v[0], (acc_wall[j] - acc_wall[0]) * dt) or n_impacts >= MAX_EVENTS
                        r = 0.0 if plastic else restitution[q]
                        v[0], v[j], loss = restitution_impact(m0, mass[j], v[0], v[j], r)
                        for s in range(stuck.shape[0]):
                            stuck[s] = 0
                        if plastic:
                            v[j] = v[0]
                            stuck[q] = side
                        if inside:
                            out[IMPACT_LOSS] += loss
                            out[E1_MAX] = max(out[E1_MAX], primary_energy(m0, k1, x[0], v[0]))
                    elif kind == ONSET:
                        touching[q] = side
                    elif kind == EXIT:
                        touching[q] = 0
                    if inside and (kind == IMPACT or kind == ONSET):
                        out[IMPACTS] += 1
                        out[IMPACTS_LEFT if side < 0 else IMPACTS_RIGHT] += 1
                    sub += 1
                if has_impact and stuck.any():
                    pin_to_walls(x, stuck, impact_body, clearance)
                    # release contacts the wall would have to pull (checked at step ends)
                    wall_accelerations(x, v, t, mass, inv_mass, k1, c1, k_lin, k_cubic, c_abs, rest, forces, series_t, series_v, series_ptr, series_ground, impact_body, hertz_body, hertz_k, hertz_walls, stuck, True, acc_wall, True, False)
                if sampling:
                    next_sample = record_sample(samples, next_sample, sample_from, period, i * dt, dt,
                                                xp, vp, x, v, out[IMPACTS_LEFT], out[IMPACTS_RIGHT])
            i = end
            if i == h_next:
                h_next = record_history(history, stride, h_next, x[0], primary_energy(m0, k1, x[0], v[0]))
        if diverged(x):
            out[STATUS] = STATUS_DIVERGED
        for b in range(nb):
            state_x[b] = x[b]
            state_v[b] = v[b]
        out[FINAL_ENERGY] = stored_energy(x, v, mass, k1, k_lin, k_cubic, rest, hertz_body, hertz_k, hertz_walls)

    return kernel
