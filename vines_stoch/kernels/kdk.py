"""Euler-Maruyama for additive noise in kick-drift-kick (velocity Verlet) form, with impacts
located on the Brownian path.

Each step is a half *kick* (half the force impulse of the step plus half the Wiener increment
``sigma dW`` on each noisy floor, additive), a *drift* (positions move linearly with the new
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
root search (``crossing``; which event a sub-step meets: ``events.event_ahead``).  The Newton
map (``common.resolve_impact``) acts at the end of that sub-step, and the rest of the step
continues from the post-impact state.  (Applying the
impact at a grid state of a symmetric map matters: with a kick-drift map the energy balance
drifts by ``O(dt)`` per impact.)  Hertz contact is sub-stepped as in ``rk4.py``: its onset and
its end are located by the same root search, and in between the sub-steps are sized from the
contact's stiffness, masses and approach speed (``common.contact_step``); the contact forces
join the kicks' forces, the closing kick's contact impulse chosen so that the contact's work
over the sub-step balances its potential (``contact_closing``).

Every sub-step takes its Wiener increments from one Brownian path inside the step, the
virtual Brownian tree of ``brownian.py`` pinned to the step's increments (its seed from the
bridge stream; the step increments are the same whatever the sub-steps), so the sub-stepped
path is the same path whatever the sub-steps and root-search iterates query.

The step plugs into the loop driver (``driver.py``: the time grid, the window, the metrics) as
``kdk_step``; the loads on the grid and the step's normals come from ``grid.py``.

Energy bookkeeping uses the midpoint velocity of each kick, for which the change of kinetic
energy equals the work of the impulses exactly; the only residual left in the energy balance
is the scheme's own error in the potential energy (MODEL.md section 4), none of it from Hertz
contact.
"""

from __future__ import annotations

import math
from functools import cache
from typing import Any, NamedTuple

import numpy as np

from ..jit import njit
from ..jit.flags import INLINE
from ..jit.intrinsics import any_set, fused, int_scratch, larger, plain, scratch_within
from ..outputs import CAPPED
from ..physics.absorbers import CLEARANCE, HERTZ, RESTITUTION, WALL_HI, WALL_LO
from ..physics.hertz import contact_energy, contact_force_law
from ..physics.structure import host_of, wall_of
from ..streams.rng import uniform
from .brownian import MEMO, TREE_DEPTH, path_value, tree_seed
from .carry import REPLAYED, SEED_HIGH, SEED_LOW, restore_absorbers, save_absorbers
from .common import (
    FILTERED_BIT,
    GROUND_BIT,
    HERTZ_BIT,
    IMPACT_BIT,
    MAX_EVENTS,
    MAX_SUBSTEPS,
    NOISE_BIT,
    PARTNERS_BIT,
    SHAPED_BIT,
    attachment_forces,
    bit_set,
    contact_force,
    contact_forces,
    contact_step,
    keep_in_cavities,
    kinds_of,
    log_event,
    pin_to_walls,
    resolve_impact,
    shaped_forces,
    stack_scratch,
    stick_together,
)
from .energy import absorber_dissipation, impulse_work, momentum, structure_dissipation
from .events import EXIT, NONE, event_ahead, gap_sign
from .grid import (
    end_loads,
    event_loads,
    finish_loads,
    grid_room,
    noise_scales,
    opening_forces,
    reset_phasors,
    save_grid_loads,
    start_loads,
    step_loads,
    step_normals,
)
from .loads import has_breaks
from .protocol import ROOM, RUN_TIME, Step, rooms

#: Iterations of the bracketed search for the impact instant (Illinois method).
ROOT_ITERATIONS = 100


@njit(**INLINE)
def kick(v, s, dws, load, ag, force, inv_mass, vn, ground):
    """Velocities after a kick of length ``s`` into ``vn``: forces, the loads ``load`` and
    Wiener increments ``dws`` on the floors (one entry each), ground acceleration ``ag`` on
    every body if ``ground`` (a compile-time flag: ``0 * s`` cannot be folded away under IEEE
    rules) (the caller makes stuck absorbers move with their floor).  ``inv_mass``: the
    reciprocal masses.  The load's impulse and the increment are one fused multiply-add
    (``intrinsics.fused``: the same bits in a loop over SIMD lanes, ``lanes.py``).  The
    state-dependent force term comes last, one fused multiply-add after the forces (the step's
    critical path)."""
    base = ag * s if ground else 0.0
    nf = load.shape[0]
    for k in range(nf):
        vn[k] = fused(force[k], s * inv_mass[k], v[k] + (fused(load[k], s, dws[k]) * inv_mass[k] - base))
    for b in range(nf, vn.shape[0]):
        vn[b] = fused(force[b], s * inv_mass[b], v[b] - base)


@njit(**INLINE)
def increments(path, dw, end, whole, w_at, sigma, normals, slot, memo, out):
    """Each floor's Wiener increment ``sigma W`` from a sub-step's start to the instant ``end`` of
    the step into ``out`` (``w_at``: the path at the start; ``dw``: the step's increments, the
    path at its end, which ``whole`` says the sub-step reaches).  ``path``: the step's tree
    (seed, step, dt, replayed fine normals a step, normals a fine step, replay); ``slot``: each
    floor's place among the noisy floors; ``memo``: the tree's descent memo
    (``brownian.path_value``)."""
    seed, step, dt, refine, stride, replay = path
    for k in range(out.shape[0]):
        if whole:
            out[k] = dw[k] - w_at[k]
        elif sigma[k] == 0.0:
            out[k] = 0.0
        else:
            out[k] = path_value(seed, step, k, dw[k], dt, end, sigma[k], normals, refine, stride,
                                int(slot[k]), replay, memo) - w_at[k]


@njit(**INLINE)
def tree_point(tree_lo: float, tree_hi: float, depth: int, off: float, lo: float, hi: float):
    """The next of a root search's trials on a step's Brownian tree (``crossing``): from the
    tree's interval ``[tree_lo, tree_hi]`` (instants in the step) at level ``depth`` that holds
    the bracket ``(lo, hi)`` (sub-steps from ``off``), down the tree to the first interval whose
    midpoint (a node of the tree) lies inside the bracket; returns that interval, its level and
    its midpoint, or level ``TREE_DEPTH`` where no node does (the bracket lies in one leaf,
    where the path is linear)."""
    while depth < TREE_DEPTH:
        mid = 0.5 * (tree_lo + tree_hi)
        if lo < mid - off < hi:
            return tree_lo, tree_hi, depth, mid
        if mid - off <= lo:
            tree_lo = mid
        else:
            tree_hi = mid
        depth += 1
    return tree_lo, tree_hi, depth, 0.0


@njit(**INLINE)
def crossing(x, v, length, left, path, dw, off, w_at, sigma, normals, slot, memo, load, ag, force, mass,
             inv_mass, stuck, walls, a, side, wall, vt, dws, group_mass, group_sum, ground, sticking, tree):
    """Sub-step length in ``(0, length]`` after which absorber ``a`` is exactly at ``wall``
    (side ``side``: the gap ``side (x_a - x_w) - wall`` crosses zero upwards) of the body ``w``
    that holds its walls (``walls``: ``physics.structure.wall_of``; the bodies that may hold
    walls are as many as the sticking groups, ``group_mass``), on the bracket ``[0, length]``:
    with the tree, first by bisection at the tree's nodes inside the bracket (``tree_point``),
    then, in the one leaf of the tree left, by the Illinois method, as without it; the trial
    kicks take the Wiener increments of the step's Brownian tree (``increments``), and ``vt``
    and ``dws`` are left with the trial kick to the root (the velocities and the half
    increments); ``sticking``: the scene has impact absorbers that may
    stick, ``tree``: the sub-steps' increments come from the Brownian tree (white noise; without
    it they are the step's, zero: compile-time flags, so that a loop without noise prunes the
    tree's code before typing it).  (The floor count is ``load``'s length: a call of 30
    arguments or more is compiled through a tuple, which numba does not inline.)"""
    nf = load.shape[0]
    h = wall_of(walls, a, group_mass.shape[0])
    j = nf + a
    lo, hi = 0.0, length
    g_lo = min(side * (x[j] - x[h]) - wall, 0.0)  # on the wall counts as inside
    g_hi = 0.0
    s = hi
    last = 0
    done = False
    # the tree's interval (in the step) that holds the bracket, and its level: with the tree, the
    # first trials are its own nodes inside the bracket, each below the last, so that together
    # they draw each level's normal once (``tree_point``; an Illinois iterate anywhere in the
    # step drew up to ``TREE_DEPTH``); in the bracket they leave, inside one leaf, the path is linear and the
    # gap a quadratic in ``s``, which the Illinois iterates take to the root in a few trials
    _, _, dt, refine, _, replay = path
    tree_lo, tree_hi, mid = 0.0, dt, 0.0
    depth = 0 if tree and (refine == 1 or not replay) else TREE_DEPTH
    on_tree = False
    cap = ROOT_ITERATIONS + TREE_DEPTH - depth  # (the trials: without the tree's, the Illinois search's)
    # trial 0 kicks over the whole bracket for ``g_hi``, the next are the tree's points and then
    # the Illinois iterates, and a last trial at the root found (where the last iterate was not
    # the root) leaves its kick in ``vt`` and its half increments in ``dws`` for the caller's kick
    # to the event: one inlined trial kick for all (the Brownian tree's code is the bulk of each copy)
    for trial in range(ROOT_ITERATIONS + TREE_DEPTH + 2):
        if trial > 0 and not done:
            if depth < TREE_DEPTH:
                tree_lo, tree_hi, depth, mid = tree_point(tree_lo, tree_hi, depth, off, lo, hi)
                s = mid - off
            on_tree = depth < TREE_DEPTH  # (a trial at a node: the tree's interval halved at it)
            if not on_tree:
                s = hi - g_hi * (hi - lo) / (g_hi - g_lo)
                if not (lo < s < hi):
                    s = 0.5 * (lo + hi)
        if tree:  # (at a node, its instant itself: ``off + s`` may differ from it in the last bit)
            increments(path, dw, mid if on_tree else off + s, s >= left, w_at, sigma, normals, slot, memo,
                       dws)
        else:
            for k in range(nf):
                dws[k] = dw[k]
        for k in range(nf):
            dws[k] *= 0.5
        kick(v, 0.5 * s, dws, load, ag, force, inv_mass, vt, ground)
        stick_together(mass, vt, nf, stuck, walls, group_mass, group_sum, False, sticking)
        if done:
            break
        g = side * (x[j] - x[h] + s * (vt[j] - vt[h])) - wall
        if trial == 0:
            g_hi = g
            continue
        tree_hi = mid if on_tree and g >= 0.0 else tree_hi
        tree_lo = mid if on_tree and g < 0.0 else tree_lo
        depth += 1 if on_tree else 0
        if g >= 0.0:  # (a trial exactly on the wall is the root: the bracket's end returned)
            hi, g_hi = s, g
            if last > 0:
                g_lo *= 0.5
            last = 0 if on_tree else 1
        else:
            lo, g_lo = s, g
            if last < 0:
                g_hi *= 0.5
            last = 0 if on_tree else -1
        if hi - lo <= 1e-15 * length or g == 0.0 or trial == cap:
            if s == hi:
                break
            done = True
            s = hi
            on_tree = False
    return hi


@njit(**INLINE)
def contact_start(x, v, vn, s, nf, host, rows, touching, held):
    """``held[a]``: the contact potential of Hertz absorber ``a`` in contact (``touching[a]``) at
    the sub-step's start less the work of its contact impulse in the first half kick (of length
    ``s / 2``, from ``v`` to ``vn``) at the kick's mean relative velocity: what the closing kick's
    contact impulse must balance (``contact_closing``)."""
    for a in range(x.shape[0] - nf):
        held[a] = 0.0
        if touching[a] != 0:
            h = host_of(host, a, nf)
            j = nf + a
            u = x[j] - x[h]
            w_mean = 0.5 * ((v[j] - v[h]) + (vn[j] - vn[h]))
            held[a] = contact_energy(rows, a, u) - 0.5 * s * contact_force_law(rows, a, u) * w_mean


@njit(**INLINE)
def contact_closing(x, v, vn, s, nf, inv_mass, host, rows, touching, held, owed):
    """The closing half kick's contact impulses made energy-consistent (``vn``: the velocities
    after the kick, ``v``: before it): for each Hertz absorber in contact in the sub-step, the
    impulse whose work at the kick's mean relative velocity makes the contact's work over the
    sub-step equal the fall of its potential (``held``: ``contact_start``), plus what earlier
    sub-steps ``owed``; a quadratic in the relative velocity after the kick, whose root nearer
    the plain kick's is taken.

    The plain kick takes the force at the new positions: the trapezoid rule of the force along
    the drift.  The Hertz force ``K z^1.5`` has an unbounded second derivative at ``z = 0``, so a
    contact loses about ``0.1 K (w s)^2.5`` in its first sub-step (``w``: the approach speed)
    that its last, a part sub-step, does not give back, and sub-steps of changing length (at
    the outer step's end; the noise changing the contact's energy and so the sub-step) break
    the cancellation of the rest: a relative ``O(s^2.5)`` loss a contact, whatever ``dt``.  The
    change of the impulse is of the order of the scheme's own error (``O(s^3)`` a sub-step,
    relative ``O(1)`` only in the first sub-step's tiny impulse), so the scheme keeps its
    order.  Where no impulse balances (at a turning point, more energy to take out than the
    relative motion has) the kick takes the impulse that comes nearest, and the rest is owed
    to the next sub-step.  Leaves each absorber's contact impulse in ``held`` and its target in ``owed``
    for ``contact_owed``."""
    for a in range(x.shape[0] - nf):
        if touching[a] != 0:
            h = host_of(host, a, nf)
            j = nf + a
            u = x[j] - x[h]
            inv_eff = inv_mass[h] + inv_mass[j]
            impulse = 0.5 * s * contact_force_law(rows, a, u)
            target = held[a] - contact_energy(rows, a, u) + owed[a]
            w_mid = v[j] - v[h]
            w_plain = vn[j] - vn[h]
            rest = w_plain - impulse * inv_eff  # after the kick without the contact impulse
            disc = (w_mid + rest) * (w_mid + rest) + 8.0 * target * inv_eff
            w_end = 0.5 * ((rest - w_mid) + math.copysign(math.sqrt(max(disc, 0.0)),
                                                          2.0 * w_plain - rest + w_mid))
            dp = (w_end - w_plain) / inv_eff
            vn[j] += dp * inv_mass[j]
            vn[h] -= dp * inv_mass[h]
            held[a] = impulse + dp
            owed[a] = target


@njit(**INLINE)
def contact_owed(v, vn, nf, host, touching, held, owed):
    """What each Hertz absorber in contact still owes after the closing kick
    (``contact_closing``: its contact impulse in ``held``, its target in ``owed``): the target
    less the impulse's work at the kick's final mean relative velocity (several absorbers on
    one host, or sticking, move the host after an absorber's impulse was chosen)."""
    for a in range(v.shape[0] - nf):
        if touching[a] != 0:
            h = host_of(host, a, nf)
            j = nf + a
            owed[a] -= held[a] * 0.5 * ((v[j] - v[h]) + (vn[j] - vn[h]))


@njit(**INLINE)
def contact_sides(x, nf, kind, host, rows, touching):
    """``touching[a]``: the side (-1 left, +1 right) on which Hertz absorber ``a`` touches or
    presses into a contact surface, 0 when it touches none (the start of a run; events keep it
    from there on)."""
    for a in range(x.shape[0] - nf):
        u = x[nf + a] - x[host_of(host, a, nf)]
        touching[a] = 0
        if kind[a] == HERTZ and u <= rows[a, WALL_LO]:
            touching[a] = -1
        elif kind[a] == HERTZ and u >= rows[a, WALL_HI]:
            touching[a] = 1


class KdkState(NamedTuple):
    """The kick-drift-kick step's state and scratch on the loop's stack: per body the forces,
    the kicked velocities, a root search's trial kick and the kick to a sub-step's first event
    (``vt``, ``vh``); the grid loads (``grid.GridLoads``); per floor the step's Wiener
    increments (the step's, a sub-step's, half of them, the root search's), each floor's
    ``sigma sqrt(dt)``, its place among the noisy floors, the path at a sub-step's start, the
    step's normals, the sticking groups; the Brownian trees' descent memo; per absorber the
    wall it sticks to, the side it touches, a contact's balance over a sub-step and what it
    owes (``contact_closing``); the noisy floors' count, the Brownian trees' seed (with its
    halves, for the carry) and whether the loads have kinks or jumps (``loads.has_breaks``,
    found once a run)."""

    force: Any
    vn: Any
    vt: Any
    vh: Any
    gl: Any
    dw: Any
    dws: Any
    dwh: Any
    dwc: Any
    noise_scale: Any
    slot: Any
    w_at: Any
    u1: Any
    group_mass: Any
    group_sum: Any
    memo: Any
    stuck: Any
    touching: Any
    held: Any
    owed: Any
    noisy: Any
    seed: Any
    high: Any
    low: Any
    piecewise: Any
    kinds: Any


@cache
def kdk_step(spec) -> Step:
    """The kick-drift-kick Euler-Maruyama step for a loop specialised to ``spec``
    (``protocol.Spec``), as the driver's ``Step``.  Ground acceleration is a compile-time flag
    (``Scene.has_ground``: as a run-time value it cost the smooth scene 7 % of its speed, the
    ground term joining every kick); loads with kinks or jumps (``loads.has_breaks``) are a
    run-time value, costing nothing measurable.  Harmonic loads on the step grid come from
    phasors (``loads.turn``), set exactly every ``CHECK_EVERY`` steps (``check``).

    Given replayed normals (the noise bundle's ``normals``: ``refine`` fine normals a step and
    noisy floor, for convergence studies), the step increments are sums of them instead of
    draws.  Replaying is a run-time choice, not a specialisation: a path drawn from the stream
    and the same path replayed run the same machine code, so they agree bitwise.

    On the GPU (``spec.gpu``: the loop the cuda backend compiles, ``kernels/launch.py``) the
    per-absorber flags live on the stack (a GPU thread has no heap); on the CPU they are heap
    arrays (on the stack the impact-rich scene ran 8 % slower).
    """
    HAS_NOISE, HAS_IMPACT, HAS_HERTZ, PARTNERS, FILTERED, GROUND, SHAPED = kinds_of(spec)  # (or ``RUN_TIME``)
    NB, NF, GPU = spec.n_bodies, spec.n_floors, spec.gpu
    NA = spec.n_bodies - spec.n_floors
    # sub-steps take increments from the Brownian trees (white noise, impact or Hertz absorbers):
    # a constant, or ``RUN_TIME``; room for the trees' descent memo where they may
    EVENT_BITS = IMPACT_BIT | HERTZ_BIT
    TREE = (RUN_TIME if RUN_TIME in (HAS_NOISE, HAS_IMPACT, HAS_HERTZ)
            else HAS_NOISE and (HAS_IMPACT or HAS_HERTZ))
    MEMO_ROOM = MEMO * (NF if NF >= 0 else ROOM) if TREE else 1
    NR, NZ = spec.n_rows, spec.n_states
    BODY_ITEMS, FLOOR_ITEMS, ROW_ITEMS, STATE_ITEMS = rooms(spec)  # (the stack arrays' rooms)
    body_scratch, floor_scratch = stack_scratch(BODY_ITEMS, FLOOR_ITEMS)  # (arrays on the loop's stack)

    @njit(**INLINE)
    def start(bodies, absorbers, ex, fl, noise, grid, carry, resume, x, v, gen_bridge):
        # the bodies, floors, load rows and filter states: run-time sizes on the CPU (``paths.spec_of``)
        nb = NB if NB >= 0 else bodies.mass.shape[0]  # (``RUN_TIME``: the counts read at run time)
        nf = NF if NF >= 0 else bodies.storey_k.shape[0]
        has_hertz = HAS_HERTZ if HAS_HERTZ >= 0 else bit_set(grid.kinds, HERTZ_BIT)
        partners = PARTNERS if PARTNERS >= 0 else bit_set(grid.kinds, PARTNERS_BIT)
        filtered = FILTERED if FILTERED >= 0 else bit_set(grid.kinds, FILTERED_BIT)
        ground = GROUND if GROUND >= 0 else bit_set(grid.kinds, GROUND_BIT)
        tree = TREE if TREE >= 0 else bit_set(grid.kinds, NOISE_BIT) and bit_set(grid.kinds, EVENT_BITS)
        nr, nz = NR if NR >= 0 else ex.forces.shape[0], NZ if NZ >= 0 else fl.phi.shape[0]
        na, nw = nb - nf, nb if partners else nf
        gl = grid_room(nf, nr, nz, 0, 0, nz, nf, FLOOR_ITEMS, ROW_ITEMS, STATE_ITEMS)
        noise_scale, slot = floor_scratch(nf), floor_scratch(nf)
        noisy = noise_scales(noise.sigma, grid.dt, noise_scale, slot)
        # the seed of the Brownian trees inside the steps (``brownian``)
        seed = np.uint64(0)
        high = low = 0.0
        if tree:
            if resume:
                high, low = carry[SEED_HIGH], carry[SEED_LOW]
            else:
                high, low = uniform(gen_bridge), uniform(gen_bridge)
            seed = tree_seed(high, low)
        if GPU:
            stuck, touching = int_scratch(NA), int_scratch(NA)
        else:
            stuck, touching = np.zeros(na, np.int64), np.zeros(na, np.int64)
        if has_hertz and not resume:
            contact_sides(x, nf, absorbers.kind, absorbers.host, absorbers.rows, touching)
        held, owed = body_scratch(na), body_scratch(na)
        replayed = 0
        if resume:
            replayed = int(carry[REPLAYED])
            restore_absorbers(carry, nf, stuck, touching, owed)
        ag_next = start_loads(gl, ex, fl, grid.dt, carry, resume, nf, na, filtered, ground)
        own = KdkState(body_scratch(nb), body_scratch(nb), body_scratch(nb), body_scratch(nb), gl,
                       floor_scratch(nf), floor_scratch(nf), floor_scratch(nf), floor_scratch(nf),
                       noise_scale, slot, floor_scratch(nf), floor_scratch(nf), body_scratch(nw),
                       body_scratch(nw), scratch_within(nf * MEMO if tree else 0, MEMO_ROOM), stuck, touching,
                       held, owed, noisy, seed, high, low, has_breaks(ex), grid.kinds)
        return own, (ag_next, replayed)

    @njit(**INLINE)
    def opening(own, x, v, inv_mass, acc, bodies, absorbers):
        # (the floors' forces: the driver's ``force_peaks``)
        nf = NF if NF >= 0 else bodies.storey_k.shape[0]
        shaped = SHAPED if SHAPED >= 0 else bit_set(own.kinds, SHAPED_BIT)
        opening_forces(own.force, own.gl.load_next, x, v, acc, bodies, absorbers, nf, shaped)

    @njit(**INLINE)
    def check(own, i, dt, ex):
        reset_phasors(own.gl, i, dt, ex)

    @njit(**INLINE)
    def save(carry, own, sc):
        save_grid_loads(carry, own.gl, sc[0], own.gl.load.shape[0], own.stuck.shape[0])
        carry[REPLAYED], carry[SEED_HIGH], carry[SEED_LOW] = sc[1], own.high, own.low
        save_absorbers(carry, own.gl.load.shape[0], own.stuck, own.touching, own.owed)

    @njit(**INLINE)
    def finish(own, sc, fl, out):
        finish_loads(own.gl, fl)

    @njit(**INLINE)
    def step(i, x, v, inv_mass, acc, own, sc, acct, inside, peaks, bodies, absorbers, ex, fl, noise, grid,
             outputs, gen, gen_filter):
        dt = grid.dt
        has_noise = HAS_NOISE if HAS_NOISE >= 0 else bit_set(grid.kinds, NOISE_BIT)
        filtered = FILTERED if FILTERED >= 0 else bit_set(grid.kinds, FILTERED_BIT)
        ground = GROUND if GROUND >= 0 else bit_set(grid.kinds, GROUND_BIT)
        ag_next, replayed = sc
        ag = step_loads(i, dt, own.gl, ex, fl, ag_next, own.piecewise, filtered, ground, gen_filter)
        ag_next = end_loads(i, dt, own.gl, ex, fl, filtered, ground)
        # the step's Wiener increments on the noisy floors: one normal per noisy floor
        if has_noise:
            replayed = step_normals(i, 1, own.noise_scale, own.slot, own.noisy, noise.normals, noise.refine,
                                    replayed, gen, own.u1, own.u1)
            for k in range(own.dw.shape[0]):
                own.dw[k] = own.noise_scale[k] * own.u1[k]
        acct = advance(i, x, v, inv_mass, acc, own, own.seed, ag, ag_next, acct, inside, bodies, absorbers,
                       ex, fl, noise, dt, outputs.out, outputs.events, outputs.impulses)
        return (ag_next, replayed), acct

    @njit(**INLINE)
    def advance(i, x, v, inv_mass, acc, own, seed, ag, ag_next, acct, inside, bodies, absorbers, ex, fl,
                noise, dt, out, events, impulses):
        """Step ``i`` of the path ``x, v`` (in place), its loads on the grid in ``own.gl`` (ground
        acceleration ``ag`` at its start, ``ag_next`` at its end) and its increments in
        ``own.dw``: the sub-steps between its events, each event resolved (``seed``: the step's
        Brownian tree's); returns the accounts.  (``step``'s, and the SIMD lanes' for the lanes
        whose step holds an event, ``lanes.py``.)"""
        nb = NB if NB >= 0 else bodies.mass.shape[0]  # (``RUN_TIME``: the counts read at run time)
        nf = NF if NF >= 0 else bodies.storey_k.shape[0]
        has_impact = HAS_IMPACT if HAS_IMPACT >= 0 else bit_set(own.kinds, IMPACT_BIT)
        has_hertz = HAS_HERTZ if HAS_HERTZ >= 0 else bit_set(own.kinds, HERTZ_BIT)
        partners = PARTNERS if PARTNERS >= 0 else bit_set(own.kinds, PARTNERS_BIT)
        filtered = FILTERED if FILTERED >= 0 else bit_set(own.kinds, FILTERED_BIT)
        ground = GROUND if GROUND >= 0 else bit_set(own.kinds, GROUND_BIT)
        shaped = SHAPED if SHAPED >= 0 else bit_set(own.kinds, SHAPED_BIT)
        tree = TREE if TREE >= 0 else bit_set(own.kinds, NOISE_BIT) and bit_set(own.kinds, EVENT_BITS)
        # passes of a step's event loop: one without impact or Hertz absorbers (nothing to split at)
        passes = MAX_SUBSTEPS if has_hertz else (MAX_EVENTS + 1 if has_impact else 1)
        na, nw = nb - nf, nb if partners else nf
        mass, storey_k, storey_c, floor_c = bodies.mass, bodies.storey_k, bodies.storey_c, bodies.floor_c
        kind, host, rows, walls = absorbers.kind, absorbers.host, absorbers.rows, absorbers.wall
        sigma, normals, refine = noise.sigma, noise.normals, noise.refine
        force, vn, vt, vh, gl = own.force, own.vn, own.vt, own.vh, own.gl
        load, load_next, load_end = gl.load, gl.load_next, gl.load_end
        dw, dws, dwh, dwc, w_at = own.dw, own.dws, own.dwh, own.dwc, own.w_at
        slot, memo, stuck, touching = own.slot, own.memo, own.stuck, own.touching
        held, owed = own.held, own.owed
        group_mass, group_sum = own.group_mass, own.group_sum
        work, d_primary, d_absorber, e_sum, e1_max, loss_sum, n_left, n_right, contact_time, peak_force, \
            pending = acct
        t_step = i * dt
        tm = t_step + 0.5 * dt
        left = dt
        t = t_step
        off = 0.0  # the sub-step's start in the step
        path = (seed, i, dt, refine, own.noisy, normals.shape[0] > 0)
        if tree:
            for k in range(nf):
                w_at[k] = 0.0
        n_impacts = 0
        capped = False
        for event in range(passes):
            if event > 0 and left <= 0.0:
                break
            attachment_forces(x, v, nf, storey_k, storey_c, floor_c, host, rows, force)
            contact_forces(x, nf, kind, host, rows, force, has_hertz)
            shaped_forces(x, nf, host, rows, force, shaped)
            # the sub-step: the rest of the step, or a Hertz contact's share of it; the
            # last pass a step allows takes the rest at once, with no events
            search = event < passes - 1
            s = left
            if has_hertz and not search:
                capped = True
            elif has_hertz and any_set(touching):
                s = min(left, contact_step(*plain((x, v, nf, mass, host, rows, touching))))
            if tree:
                increments(path, dw, off + s, s >= left, w_at, sigma, normals, slot, memo, dws)
            else:
                for k in range(nf):
                    dws[k] = dw[k]
            for k in range(nf):
                dwh[k] = 0.5 * dws[k]
            kick(v, 0.5 * s, dwh, load, ag, force, inv_mass, vn, ground)
            if has_impact:
                stick_together(mass, vn, nf, stuck, walls, group_mass, group_sum, True)
            # the first impact, contact onset or contact end in the sub-step
            hit, side, s_hit, hit_event, hit_wall = -1, 0, s, NONE, 0.0
            if search and ((has_impact and n_impacts < MAX_EVENTS) or has_hertz):
                for a in range(na):
                    h = wall_of(walls, a, nw)
                    j = nf + a
                    u_end = x[j] - x[h] + s * (vn[j] - vn[h])
                    event, sa, wall = event_ahead(kind[a], stuck[a], touching[a], rows[a, CLEARANCE],
                                                  rows[a, WALL_LO], rows[a, WALL_HI], u_end,
                                                  has_impact, n_impacts < MAX_EVENTS, has_hertz)
                    if event != NONE:
                        sq = gap_sign(event, sa)
                        sc_ = crossing(x, v, s, left, path, dw, off, w_at, sigma, normals, slot, memo,
                                       load, ag, force, mass, inv_mass, stuck, walls, a, sq, sq * wall,
                                       vt, dwc, group_mass, group_sum, ground, has_impact, tree)
                        if hit < 0 or sc_ < s_hit:
                            hit, side, s_hit, hit_event, hit_wall = a, sa, sc_, event, wall
                            for b in range(nb):  # the root search's kick to its root
                                vh[b] = vt[b]
                            for k in range(nf):
                                dwh[k] = dwc[k]
                if hit >= 0:  # the first half kick to the event: the search's last trial
                    s = s_hit
                    for k in range(nf):
                        dws[k] = 2.0 * dwh[k]
                    for b in range(nb):
                        vn[b] = vh[b]
            if inside:
                work += 0.5 * impulse_work(load, s, dws, v, vn) - (
                    0.5 * ag * s * momentum(mass, v, vn) if ag != 0.0 else 0.0)
                d_primary = structure_dissipation(v, vn, nf, storey_c, floor_c, s, d_primary)
                d_absorber = absorber_dissipation(v, vn, nf, host, rows, s, d_absorber)
                if has_hertz:  # contact time: the sub-steps that start in contact
                    for a in range(na):
                        if touching[a] != 0:
                            contact_time += s
            if has_hertz:
                contact_start(x, v, vn, s, nf, host, rows, touching, held)
            for b in range(nb):
                x[b] = fused(s, vn[b], x[b])
                v[b] = vn[b]
            # closing half kick with the forces at the new positions (its bookkeeping is
            # written out like the first kick's: an inlined helper for both measured 40 %
            # slower)
            ag_end = ag_next
            if (has_impact or has_hertz) and s < left:
                ag_end = event_loads(t + s, tm, (t + s - t_step) / dt, gl, ex, fl, filtered, ground)
            else:
                for k in range(nf):
                    load_end[k] = load_next[k]
            attachment_forces(x, v, nf, storey_k, storey_c, floor_c, host, rows, force)
            contact_forces(x, nf, kind, host, rows, force, has_hertz)
            shaped_forces(x, nf, host, rows, force, shaped)
            kick(v, 0.5 * s, dwh, load_end, ag_end, force, inv_mass, vn, ground)
            if has_hertz:
                contact_closing(x, v, vn, s, nf, inv_mass, host, rows, touching, held, owed)
            if has_impact:
                stick_together(mass, vn, nf, stuck, walls, group_mass, group_sum, False)
            if has_hertz:
                contact_owed(v, vn, nf, host, touching, held, owed)
            if inside:
                work += 0.5 * impulse_work(load_end, s, dws, v, vn) - (
                    0.5 * ag_end * s * momentum(mass, v, vn) if ag_end != 0.0 else 0.0)
                d_primary = structure_dissipation(v, vn, nf, storey_c, floor_c, s, d_primary)
                d_absorber = absorber_dissipation(v, vn, nf, host, rows, s, d_absorber)
            for b in range(nb):
                v[b] = vn[b]
            if has_hertz and inside:
                for a in range(na):
                    if kind[a] == HERTZ:
                        peak_force = larger(peak_force, contact_force(x, nf, a, host, rows))
            if not (has_impact or has_hertz) or (hit < 0 and s >= left):
                break
            # the sub-step's end: an impact, a contact onset or a contact sub-step's end
            t += s
            left -= s
            off += s
            ag = ag_end
            for k in range(nf):
                w_at[k] += dws[k]
                load[k] = load_end[k]
            if hit >= 0 and hit_event != EXIT:
                h = wall_of(walls, hit, nw)
                j = nf + hit
                if inside:
                    if side < 0:
                        n_left += 1.0
                    else:
                        n_right += 1.0
            if has_hertz and hit >= 0 and kind[hit] == HERTZ:  # onto or off the contact surface
                h = host_of(host, hit, nf)
                j = nf + hit
                if inside and hit_event != EXIT:  # (the event log: as many rows as it has)
                    log_event(events, n_left + n_right - 1.0, t, hit, side, v[j] - v[h], 0.0)
                x[j] = x[h] + hit_wall
                touching[hit] = 0 if hit_event == EXIT else side
            elif has_impact and hit >= 0:  # the impact, at t + s
                x[j] = x[h] + hit_wall
                gain = (force[j] / mass[j] - (force[h] + (load_end[h] if h < nf else 0.0)) / mass[h]) * dt
                # the last impact a step may resolve ends a chatter sequence: inelastic collapse
                last = n_impacts == MAX_EVENTS - 1
                speed = v[j] - v[h]
                loss = resolve_impact(mass, v, nf, nw, hit, side, gain, rows[hit, RESTITUTION], last,
                                      stuck, walls, impulses)
                n_impacts += 1
                if inside:
                    loss_sum += loss
                    log_event(events, n_left + n_right - 1.0, t, hit, side, speed, loss)
                capped = capped or last
        if (has_impact or has_hertz) and capped:
            out[CAPPED] += 1
        if has_hertz and capped:  # the last pass took no events: the contacts as they are
            contact_sides(x, nf, kind, host, rows, touching)
        if has_impact:
            keep_in_cavities(x, nf, nw, kind, walls, rows)
            pin_to_walls(x, nf, nw, stuck, walls, rows)
        for k in range(nf):  # the forces on the floor at the step's end, for the peaks
            acc[k] = force[k] + load_end[k]
        return (work, d_primary, d_absorber, e_sum, e1_max, loss_sum, n_left, n_right, contact_time,
                peak_force, pending)

    return Step(start, opening, check, step, save, finish, integrates=False, force_peaks=True, samples=False,
                advance=advance)
