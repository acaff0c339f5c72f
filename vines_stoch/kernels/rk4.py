"""Classical fourth-order Runge-Kutta for scenes without noise, with located events.

The energy integrals of MODEL.md section 4 (work of the loads, viscous dissipation, the
integrals of ``E1`` and ``x1^2``) are integrated as extra states by the same RK4 stages, so
the energy balance closes to the scheme's fourth-order error.

Events (``events.event_ahead``) are located inside a step by Newton iteration on the length
of an RK4 sub-step from the start of the step (converged to round-off):

- an impact absorber reaching its wall: the Newton map is applied at that instant;
- a Hertz absorber touching a contact surface: from there the step is cut into sub-steps
  sized from the contact's stiffness, masses and approach speed (about ``common.CONTACT_STEPS`` per
  contact duration), until the contact ends, which is located the same way.

The outer step ``dt`` never has to be shrunk by the user for contact.
"""

from __future__ import annotations

from functools import cache
from typing import Any, NamedTuple

import numpy as np

from ..jit import njit
from ..jit.flags import INLINE, KERNEL
from ..jit.intrinsics import any_set, fused, int_scratch, pick, plain, put, runtime_value, scratch_within
from ..outputs import CAPPED
from ..physics.absorbers import CLEARANCE, DAMPING, RESTITUTION, WALL_HI, WALL_LO
from ..physics.structure import host_of, primary_energy, structure_power, wall_of
from .carry import restore_absorbers, restore_rows, save_absorbers, save_rows
from .common import (
    HERTZ_BIT,
    IMPACT_BIT,
    MAX_EVENTS,
    MAX_SUBSTEPS,
    PARTNERS_BIT,
    SHAPED_BIT,
    accelerate,
    attachment_forces,
    bit_set,
    contact_force,
    contact_forces,
    contact_step,
    first_passages,
    floor_peaks,
    keep_in_cavities,
    kinds_of,
    log_event,
    pin_to_walls,
    resolve_impact,
    shaped_forces,
    stack_scratch,
    stick_together,
)
from .events import EXIT, IMPACT_EVENT, NONE, ONSET, event_ahead, gap_sign
from .loads import applied, has_breaks, next_break, phasors, rotations, turn
from .protocol import Step, rooms

NEWTON_ITERATIONS = 12
#: Bits of the ``contact`` argument of ``accelerations``: Hertz contact forces (at run time:
#: absorbers in contact), shaped springs (geometric, gap; a compile-time constant of the loop:
#: ``common.shaped_forces``), the contact constraint of stuck impact absorbers (at run
#: time: absorbers stuck), and (``rk4_update``'s) a whole step of the time grid, whose stages
#: read the harmonic rows from the step's phasors.  One argument for all: ``rk4_update`` has
#: numba's 30.
HERTZ_FORCES, SHAPED_FORCES, STICKING, ON_GRID = 1, 2, 4, 8


@njit(**INLINE)
def accelerations(x, v, t, tm, nf, mass, inv_mass, storey_k, storey_c, floor_c, kind, host, wall, rows,
                  forces, series_t, series_v, series_ptr, series_target, pc, stuck, release, acc, load,
                  group_mass, group_sum, contact):
    """Accelerations of all bodies into ``acc`` (``load``: scratch for the floors' loads);
    returns the rates of the energy integrals (load power, structure damping power, absorber
    damping power, ``E1``) and the ground acceleration.

    The scene's arrays come one by one (``forces .. series_target``: the loads of
    kernels/loads.py, piecewise loads on the piece of ``tm``): unpacking a tuple of arrays
    costs reference counting at every call.  ``contact`` (bits ``HERTZ_FORCES``,
    ``SHAPED_FORCES``, ``STICKING``) adds the Hertz contact forces and the shaped
    attachments' and applies the contact constraint of stuck impact absorbers on the bodies
    that hold their walls (``wall``: ``physics.structure.wall_of``) (flags, not branches around
    the calls: see ``jit.flags.INLINE``); with its ``ON_GRID`` bit the harmonic rows are read
    from their cosines at ``t``, ``pc`` (``loads.applied``).
    """
    attachment_forces(x, v, nf, storey_k, storey_c, floor_c, host, rows, acc)
    contact_forces(x, nf, kind, host, rows, acc, (contact & HERTZ_FORCES) != 0)
    shaped_forces(x, nf, host, rows, acc, (contact & SHAPED_FORCES) != 0)
    ag = applied(t, tm, forces, series_t, series_v, series_ptr, series_target, pc, (contact & ON_GRID) != 0,
                 load)
    accelerate(acc, load, ag, inv_mass, acc)
    power = 0.0
    for k in range(nf):
        power += load[k] * v[k]
    if ag != 0.0:
        for b in range(v.shape[0]):
            power -= ag * mass[b] * v[b]
    stick_together(mass, acc, nf, stuck, wall, group_mass, group_sum, release, (contact & STICKING) != 0)
    absorber_power = 0.0
    for a in range(x.shape[0] - nf):
        w = v[nf + a] - v[host_of(host, a, nf)]
        absorber_power += rows[a, DAMPING] * w * w
    return (power, structure_power(v, nf, storey_c, floor_c), absorber_power,
            primary_energy(mass, storey_k, x, v, nf), ag)


@njit(**INLINE)
def wall_accelerations(x, v, t, nf, mass, inv_mass, storey_k, storey_c, floor_c, kind, host, wall, rows,
                       forces, series_t, series_v, series_ptr, series_target, stuck, release, acc, load,
                       group_mass, group_sum, contact):
    """``accelerations`` at an instant (an impact, the end of a step with stuck absorbers),
    out of line: rare work that need not grow the step loop.  The floor count and the flags
    reach it as run-time values (``jit.intrinsics.runtime_value``) and the arrays as numba's
    (``jit.intrinsics.plain``), so that it compiles once, not once for each floor count and set
    of flags of the loops that call it."""
    _wall_accelerations(*plain((x, v, t, runtime_value(nf), mass, inv_mass, storey_k, storey_c, floor_c, kind,
                                host, wall, rows, forces, series_t, series_v, series_ptr, series_target,
                                stuck, runtime_value(release), acc, load, group_mass, group_sum,
                                runtime_value(contact))))


@njit(**KERNEL)
def _wall_accelerations(x, v, t, nf, mass, inv_mass, storey_k, storey_c, floor_c, kind, host, wall, rows,
                        forces, series_t, series_v, series_ptr, series_target, stuck, release, acc, load,
                        group_mass, group_sum, contact):
    """``accelerations`` at ``t`` (the out-of-line body of ``wall_accelerations``)."""
    accelerations(x, v, t, t, nf, mass, inv_mass, storey_k, storey_c, floor_c, kind, host, wall, rows, forces,
                  series_t, series_v, series_ptr, series_target, series_t, stuck, release, acc, load,
                  group_mass, group_sum, contact)


@njit(**INLINE)
def rk4_update(x, v, t, h, xo, vo, acc, xs, vs, x2, a0, mass, inv_mass, storey_k, storey_c, floor_c, kind,
               host, wall, rows, forces, series_t, series_v, series_ptr, series_target, cosines, stuck, load,
               groups, contact):
    """One RK4 step of size ``h`` from ``(x, v)`` into ``(xo, vo)``; returns the increments
    of the four energy integrals and writes those of ``x_k^2`` into ``x2`` and the floors'
    absolute accelerations at the start into ``a0``.  ``acc``, ``xs``, ``vs`` are scratch
    (the stage's accelerations and state); ``xo``, ``vo`` gather the weighted stage slopes.
    With the ``ON_GRID`` bit of ``contact`` (a whole step of the grid) the stages read the
    harmonic rows' cosines at the step's start, midpoint and end from ``cosines``
    (``StagePhasors``: turned phasors, not a cosine a stage).  ``groups``: the sticking groups'
    scratch (``common.stick_together``).
    Inlined at one call site of the step loop (a call with this many arrays cost about 40 %
    of a step; Python compiles a call of more than 30 arguments through a tuple, which numba
    cannot inline, so the floor count comes from ``load``'s length and the stack arrays come
    in tuples, ``cosines`` and ``groups``: no reference counting)."""
    nb = x.shape[0]
    nf = load.shape[0]
    group_mass, group_sum = groups
    tm = t + 0.5 * h
    q0 = q1 = q2 = q3 = 0.0
    for stage in range(4):
        if stage == 0:
            for b in range(nb):
                xs[b] = x[b]
                vs[b] = v[b]
        ts = t if stage == 0 else (t + h if stage == 3 else tm)
        pc = cosines[0] if stage == 0 else (cosines[2] if stage == 3 else cosines[1])
        r = accelerations(xs, vs, ts, tm, nf, mass, inv_mass, storey_k, storey_c, floor_c, kind, host, wall,
                          rows, forces, series_t, series_v, series_ptr, series_target, pc, stuck, False, acc,
                          load, group_mass, group_sum, contact)
        weight = 1.0 if stage == 0 or stage == 3 else 2.0
        c = 0.5 * h if stage < 2 else h
        for k in range(nf):
            if stage == 0:
                x2[k] = xs[k] * xs[k]
                a0[k] = acc[k] + r[4]
            else:
                x2[k] += weight * (xs[k] * xs[k])
        for b in range(nb):
            if stage == 0:
                xo[b] = vs[b]
                vo[b] = acc[b]
            else:
                xo[b] = fused(weight, vs[b], xo[b])
                vo[b] = fused(weight, acc[b], vo[b])
            xs[b] = fused(c, vs[b], x[b])
            vs[b] = fused(c, acc[b], v[b])
        if stage == 0:
            q0, q1, q2, q3 = r[0], r[1], r[2], r[3]
        else:
            q0 += weight * r[0]
            q1 += weight * r[1]
            q2 += weight * r[2]
            q3 += weight * r[3]
    for b in range(nb):
        xo[b] = fused(h / 6.0, xo[b], x[b])
        vo[b] = fused(h / 6.0, vo[b], v[b])
    for k in range(nf):
        x2[k] = h / 6.0 * x2[k]
    return h / 6.0 * q0, h / 6.0 * q1, h / 6.0 * q2, h / 6.0 * q3


@njit(**KERNEL)
def next_event(x, xn, h, nf, nw, kind, walls, rows, stuck, touching):
    """The first event of a step ``x -> xn`` of length ``h`` (``events.event_ahead``: an impact
    absorber crossing its wall, a Hertz contact starting or ending; ``walls``, ``nw``: the bodies
    that hold the walls, ``physics.structure.wall_of``), by linear interpolation of the gap.
    Returns ``(kind, absorber, side, tau, wall)``; ``kind == NONE`` when nothing happens."""
    event_kind, hit, hit_side, first, hit_wall = NONE, -1, 0, h, 0.0
    for a in range(kind.shape[0]):
        j = nf + a
        hf = wall_of(walls, a, nw)
        u0 = x[j] - x[hf]
        u1 = xn[j] - xn[hf]
        event, side, wall = event_ahead(kind[a], stuck[a], touching[a], rows[a, CLEARANCE], rows[a, WALL_LO],
                                        rows[a, WALL_HI], u1, True, True, True)
        if event != NONE:
            sign = gap_sign(event, side)
            g0 = sign * (u0 - wall)
            g1 = sign * (u1 - wall)
            tau = h * max(-g0, 0.0) / (g1 - g0)
            if tau < first or event_kind == NONE:
                event_kind, hit, hit_side, first, hit_wall = event, a, side, tau, wall
    return event_kind, hit, hit_side, first, hit_wall


class StagePhasors(NamedTuple):
    """Per load row, the harmonic rows' phasors (cos, sin) at a step's start, midpoint and end
    (the next step's start), and their turn over half a step (``loads.phasors``, ``loads.turn``):
    the loads the stages of a step taken whole read (``rk4_update``).  Each step turns the last
    one's end by half a step twice; the end is set exactly every ``common.CHECK_EVERY`` steps
    (``loads.phasors``) and carried between the stretches of a path (``carry.save_rows``), as
    the grid steps' phasors (``grid.reset_phasors``)."""

    pc: Any
    ps: Any
    mc: Any
    ms: Any
    ec: Any
    es: Any
    hc: Any
    hs: Any


def phasor_room(n_rows: int, row_room: int):
    """``new_phasors(forces, dt, carry, resume, nf, na)``: a loop's ``StagePhasors`` on its
    stack, for ``n_rows`` load rows (``protocol.RUN_TIME``: ``forces``' rows, at most
    ``row_room``), with the half step's turns of a grid of step ``dt``, and (``resume``) the next
    step's phasors from the carry of a path of ``nf`` floors and ``na`` absorbers."""

    @njit(**INLINE)
    def new_phasors(forces, dt, carry, resume, nf, na):
        n, r = n_rows if n_rows >= 0 else forces.shape[0], row_room
        p = StagePhasors(scratch_within(n, r), scratch_within(n, r), scratch_within(n, r),
                         scratch_within(n, r), scratch_within(n, r), scratch_within(n, r),
                         scratch_within(n, r), scratch_within(n, r))
        rotations(forces, 0.5 * dt, p.hc, p.hs)
        if resume:
            restore_rows(carry, nf, na, p.ec, p.es)
        return p

    return new_phasors


@njit(**INLINE)
def stage_cosines(p):
    """The harmonic rows' cosines at the start, midpoint and end of a step (``StagePhasors``
    ``p``): the last step's end, turned by half a step twice."""
    for r in range(p.pc.shape[0]):
        p.pc[r], p.ps[r] = p.ec[r], p.es[r]
    turn(p.pc, p.ps, p.hc, p.hs, p.mc, p.ms)
    turn(p.mc, p.ms, p.hc, p.hs, p.ec, p.es)
    return p.pc, p.mc, p.ec


class Rk4State(NamedTuple):
    """The RK4 step's state and scratch on the loop's stack: per body the sub-step's end state,
    the stages' accelerations, state and the copies for the out-of-line calls (so that the
    stages' arrays stay in registers); per floor the loads, the sticking groups, the sub-step's
    ``x_k^2`` integrals and start accelerations, and the out-of-line calls' own; per absorber
    the wall it sticks to, the side it touches and a contact's debt (none here: the carry's
    block stays zero); whether the loads have kinks or jumps (``loads.has_breaks``, found once a
    run); the harmonic rows' phasors of a step (``StagePhasors``)."""

    xn: Any
    vn: Any
    acc: Any
    xs: Any
    vs: Any
    x_event: Any
    acc_wall: Any
    load: Any
    group_mass: Any
    group_sum: Any
    x2: Any
    a0: Any
    load_wall: Any
    gm_wall: Any
    gs_wall: Any
    stuck: Any
    touching: Any
    owed: Any
    piecewise: Any
    phasors: Any


@cache
def rk4_step(spec) -> Step:
    """The RK4 step with located events for a loop specialised to ``spec`` (``protocol.Spec``:
    the bodies and floors, impact and Hertz absorbers, shaped springs; no noise), as the
    driver's ``Step``.  It integrates the energy accounts with its stages and observes the peaks
    and first passages at each sub-step's end (``integrates``); loads with kinks or jumps
    (``loads.has_breaks``) end its sub-steps (a run-time value).  ``spec.gpu``: per-absorber flags
    on the stack (as ``kdk.kdk_step``)."""
    NB, NF = spec.n_bodies, spec.n_floors  # (``RUN_TIME``: the counts read at run time)
    body_room, floor_room, row_room, _ = rooms(spec)
    body_scratch, floor_scratch = stack_scratch(body_room, floor_room)  # (arrays on the loop's stack)
    new_phasors = phasor_room(spec.n_rows, row_room)
    NA, GPU = NB - NF, spec.gpu

    HAS_NOISE, HAS_IMPACT, HAS_HERTZ, PARTNERS, FILTERED, GROUND, SHAPED = kinds_of(spec)  # (or ``RUN_TIME``)

    @njit(**INLINE)
    def start(bodies, absorbers, ex, fl, noise, grid, carry, resume, x, v, gen_bridge):
        nb = NB if NB >= 0 else bodies.mass.shape[0]  # (``RUN_TIME``: the counts read at run time)
        nf = NF if NF >= 0 else bodies.storey_k.shape[0]
        partners = PARTNERS if PARTNERS >= 0 else bit_set(grid.kinds, PARTNERS_BIT)
        na, nw = nb - nf, nb if partners else nf
        if GPU:
            stuck, touching = int_scratch(NA), int_scratch(NA)
        else:
            stuck, touching = np.zeros(na, np.int64), np.zeros(na, np.int64)
        owed = body_scratch(na)
        if resume:
            restore_absorbers(carry, nf, stuck, touching, owed)
        own = Rk4State(body_scratch(nb), body_scratch(nb), body_scratch(nb), body_scratch(nb),
                       body_scratch(nb), body_scratch(nb), body_scratch(nb), floor_scratch(nf),
                       body_scratch(nw), body_scratch(nw), floor_scratch(nf), floor_scratch(nf),
                       floor_scratch(nf), body_scratch(nw), body_scratch(nw), stuck, touching, owed,
                       has_breaks(ex), new_phasors(ex.forces, grid.dt, carry, resume, nf, na))
        return own, 0

    @njit(**INLINE)
    def opening(own, x, v, inv_mass, acc, bodies, absorbers):
        pass  # (the accelerations count from the window's first sub-step on)

    @njit(**INLINE)
    def check(own, i, dt, ex):
        phasors(i * dt, ex.forces, own.phasors.ec, own.phasors.es)  # (the next step's start, exact)

    @njit(**INLINE)
    def save(carry, own, sc):
        save_absorbers(carry, own.load.shape[0], own.stuck, own.touching, own.owed)
        save_rows(carry, own.load.shape[0], own.stuck.shape[0], own.phasors.ec, own.phasors.es)

    @njit(**INLINE)
    def finish(own, sc, fl, out):
        pass

    @njit(**INLINE)
    def step(i, x, v, inv_mass, floor_acc, own, sc, acct, inside, peaks, bodies, absorbers, ex, fl, noise,
             grid, outputs, gen, gen_filter):
        nb = NB if NB >= 0 else bodies.mass.shape[0]  # (``RUN_TIME``: the counts read at run time)
        nf = NF if NF >= 0 else bodies.storey_k.shape[0]
        has_impact = HAS_IMPACT if HAS_IMPACT >= 0 else bit_set(grid.kinds, IMPACT_BIT)
        has_hertz = HAS_HERTZ if HAS_HERTZ >= 0 else bit_set(grid.kinds, HERTZ_BIT)
        partners = PARTNERS if PARTNERS >= 0 else bit_set(grid.kinds, PARTNERS_BIT)
        shaped = SHAPED if SHAPED >= 0 else bit_set(grid.kinds, SHAPED_BIT)
        na, nw = nb - nf, nb if partners else nf
        geo = SHAPED_FORCES if shaped else 0
        mass, storey_k, storey_c, floor_c = bodies.mass, bodies.storey_k, bodies.storey_c, bodies.floor_c
        kind, host, rows, walls = absorbers.kind, absorbers.host, absorbers.rows, absorbers.wall
        forces, series_t, series_v, series_ptr, series_target = (ex.forces, ex.series_t, ex.series_v,
                                                                 ex.series_ptr, ex.series_target)
        dt, out, limits = grid.dt, outputs.out, outputs.limits
        x_max, drift_max, acc_max, x2_integral = peaks
        xn, vn, acc, xs, vs = own.xn, own.vn, own.acc, own.xs, own.vs
        x_event, acc_wall, stuck, touching = own.x_event, own.acc_wall, own.stuck, own.touching
        load, groups, x2, a0 = own.load, (own.group_mass, own.group_sum), own.x2, own.a0
        load_wall, gm_wall, gs_wall = own.load_wall, own.gm_wall, own.gs_wall
        work, d_primary, d_absorber, e_integral, e1_max, loss_sum, n_left, n_right, contact_time, \
            peak_force, pending = acct
        piecewise = own.piecewise  # sub-steps end at the loads' kinks and jumps
        cosines = stage_cosines(own.phasors)  # (the stages' harmonic loads, a step taken whole)
        t, left, n_impacts, sub = i * dt, dt, 0, 0
        # phase 0: a new sub-step; 1 .. NEWTON_ITERATIONS: Newton iterations on the length of the
        # sub-step that ends at an event; -1: the sub-step at the final length.  One call site of
        # the (inlined) step for all of them.
        phase = 0
        while True:
            if phase == 0:
                sticking = has_impact and any_set(stuck)
                contact = has_hertz and any_set(touching)
                h = left
                if contact:
                    h = min(left, contact_step(*plain((x, v, nf, mass, host, rows, touching))))
                if piecewise:  # sub-steps end at the loads' kinks and jumps
                    tb = next_break(t + 1e-9 * dt, ex)
                    if tb < t + h - 1e-9 * dt:
                        h = tb - t
                capped = sub == MAX_SUBSTEPS - 1 or n_impacts >= MAX_EVENTS
                if capped:  # take the rest of the step at once, keep absorbers in their cavity
                    h = left
                    out[CAPPED] += 1
                tau = h
            whole = ON_GRID if sub == 0 and tau == dt else 0  # (a step of the grid: its phasors)
            inc = rk4_update(x, v, t, tau, xn, vn, acc, xs, vs, x2, a0, mass, inv_mass, storey_k, storey_c,
                             floor_c, kind, host, walls, rows, forces, series_t, series_v, series_ptr,
                             series_target, cosines, stuck, load, groups,
                             (STICKING if sticking else 0) | (HERTZ_FORCES if contact else 0) | geo | whole)
            if phase == 0:
                event_kind, q, side, j, hf, sign, wall = NONE, -1, 0, 0, 0, 0, 0.0
                if (has_impact or has_hertz) and not capped:
                    for b in range(nb):
                        x_event[b] = xn[b]
                    event_kind, q, side, tau, wall = next_event(*plain((x, x_event, h, nf, nw, kind, walls,
                                                                        rows, stuck, touching)))
                if event_kind != NONE:
                    j, hf, sign = nf + q, wall_of(walls, q, nw), gap_sign(event_kind, side)
                    phase = 1
                    continue
            elif (has_impact or has_hertz) and phase > 0:
                approach = sign * (pick(vn, j) - vn[hf])
                if approach > 0.0:
                    correction = sign * (pick(xn, j) - xn[hf] - wall) / approach
                    tau = min(max(tau - correction, 0.0), h)
                    phase = phase + 1 if abs(correction) > 1e-15 * dt and phase < NEWTON_ITERATIONS else -1
                    continue
            phase = 0
            h = tau
            done = event_kind == NONE and h == left
            if inside:
                work += inc[0]
                d_primary += inc[1]
                d_absorber += inc[2]
                e_integral += inc[3]
                for k in range(nf):
                    x2_integral[k] += x2[k]
                # peaks: the state at the sub-step's end, the accelerations at its start
                floor_peaks(xn, nf, a0, x_max, drift_max, acc_max)
                e1_max = max(e1_max, primary_energy(mass, storey_k, xn, vn, nf))
                if pending > 0:
                    pending = first_passages(limits, t + h, nf, x_max, drift_max, acc_max, inv_mass, False,
                                             e1_max, out)
            for b in range(nb):
                x[b] = xn[b]
                v[b] = vn[b]
            if has_hertz and inside and contact:
                for c in range(na):
                    if touching[c] != 0:
                        contact_time += h
                        peak_force = max(peak_force, contact_force(x, nf, c, host, rows))
            t += h
            left -= h
            if done:
                if capped:
                    keep_in_cavities(x, nf, nw, kind, walls, rows)
                break
            if has_impact and event_kind == IMPACT_EVENT:
                n_impacts += 1
                put(x, j, x[hf] + wall)
                wall_accelerations(x, v, t, nf, mass, inv_mass, storey_k, storey_c, floor_c, kind, host,
                                   walls, rows, forces, series_t, series_v, series_ptr, series_target, stuck,
                                   False, acc_wall, load_wall, gm_wall, gs_wall,
                                   STICKING | (HERTZ_FORCES if contact else 0) | geo)
                # the last impact a step may resolve ends a chatter sequence: inelastic collapse
                gain = (pick(acc_wall, j) - acc_wall[hf]) * dt
                speed = pick(v, j) - v[hf]
                loss = resolve_impact(mass, v, nf, nw, q, side, gain, rows[q, RESTITUTION],
                                      n_impacts >= MAX_EVENTS, stuck, walls, outputs.impulses)
                if inside:
                    loss_sum += loss
                    e1_max = max(e1_max, primary_energy(mass, storey_k, x, v, nf))
                    log_event(outputs.events, n_left + n_right, t, q, side, speed, loss)  # (as it has rows)
            elif has_hertz and event_kind == ONSET:
                touching[q] = side
                if inside:
                    log_event(outputs.events, n_left + n_right, t, q, side, pick(v, j) - v[hf], 0.0)
            elif has_hertz and event_kind == EXIT:
                touching[q] = 0
            if inside and (event_kind == IMPACT_EVENT or event_kind == ONSET):
                if side < 0:
                    n_left += 1.0
                else:
                    n_right += 1.0
            sub += 1
        if has_impact and any_set(stuck):
            pin_to_walls(x, nf, nw, stuck, walls, rows)
            # release contacts the wall would have to pull (checked at step ends)
            wall_accelerations(x, v, t, nf, mass, inv_mass, storey_k, storey_c, floor_c, kind, host, walls,
                               rows, forces, series_t, series_v, series_ptr, series_target, stuck, True,
                               acc_wall, load_wall, gm_wall, gs_wall, STICKING | geo)
        return sc, (work, d_primary, d_absorber, e_integral, e1_max, loss_sum, n_left, n_right, contact_time,
                    peak_force, pending)

    return Step(start, opening, check, step, save, finish, integrates=True, force_peaks=False, samples=True)
