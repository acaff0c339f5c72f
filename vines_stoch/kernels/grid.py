"""What a step on the fixed time grid takes from the scene, shared by the grid steps
(``kdk.kdk_step``, ``sra3.sra3_step``): the loads at the step's start, end and midpoint
(harmonic rows from phasors, filtered loads advanced exactly: ``loads``) and the step's
standard normals on the noisy floors (drawn, or replayed from a given path)."""

from __future__ import annotations

import math
from typing import Any, NamedTuple

from ..jit import njit
from ..jit.flags import INLINE, KERNEL
from ..jit.intrinsics import plain, runtime_value, scratch_within
from ..streams.rng import normal
from .carry import GROUND_NEXT, restore_loads, restore_rows, save_loads, save_rows
from .common import attachment_forces, shaped_forces
from .loads import advance_filters, copy_into, excitation, phasors, rotations, turn


class GridLoads(NamedTuple):
    """The floors' loads at the step's start, end, an event inside it and its midpoint; the
    harmonic rows' phasors (cos, sin) at the step's start and midpoint and their turns over a
    step and half a step (``loads.turn``); the filter state, its next state and the normals'
    scratch; copies of the filter states and a load for ``event_loads`` (on the stack: heap
    arrays passed to the inlined load functions cost reference counting in the step loop)."""

    load: Any
    load_next: Any
    load_end: Any
    load3: Any
    pc: Any
    ps: Any
    mc: Any
    ms: Any
    rc: Any
    rs: Any
    hc: Any
    hs: Any
    z: Any
    zn: Any
    draws: Any
    z_copy: Any
    zn_copy: Any
    load_copy: Any


@njit(**INLINE)
def grid_room(nf: int, nr: int, nz: int, load3: int, mid: int, copies: int, load_copy: int, floor_room: int,
              row_room: int, state_room: int) -> GridLoads:
    """A step's ``GridLoads`` on the loop's stack: ``nf`` floors, ``nr`` load rows, ``nz``
    filter states; ``load3`` (a floor's), ``mid`` (a load row's: the midpoint's and half-step
    phasors), ``copies`` (a filter state's) and ``load_copy`` (a floor's): the sizes of what a step
    keeps of its own.  Each array holds the room of its kind, ``floor_room``, ``row_room`` or
    ``state_room`` (constants of the loop: ``protocol.rooms``; ``jit.intrinsics.scratch_within``)."""
    f = floor_room
    r = row_room
    z = state_room
    return GridLoads(scratch_within(nf, f), scratch_within(nf, f), scratch_within(nf, f),
                     scratch_within(load3, f), scratch_within(nr, r), scratch_within(nr, r),
                     scratch_within(mid, r), scratch_within(mid, r), scratch_within(nr, r),
                     scratch_within(nr, r), scratch_within(mid, r), scratch_within(mid, r),
                     scratch_within(nz, z), scratch_within(nz, z), scratch_within(nz, z),
                     scratch_within(copies, z), scratch_within(copies, z), scratch_within(load_copy, f))


@njit(**INLINE)
def start_loads(gl, ex, fl, dt: float, carry, resume: bool, nf: int, na: int, filtered: bool,
                ground: bool) -> float:
    """The grid loads at a path's start (or restored from the carry where ``resume``): the
    filter state from the filter bundle, the phasors' turns, the loads at the first step's
    start; returns the ground acceleration there."""
    for r in range(gl.z.shape[0]):
        gl.z[r] = fl.z[r]
        gl.zn[r] = fl.zn[r] if resume else fl.z[r]
    rotations(ex.forces, dt, gl.rc, gl.rs)
    rotations(ex.forces, 0.5 * dt, gl.hc, gl.hs)
    if resume:
        restore_loads(carry, gl.load_next)
        restore_rows(carry, nf, na, gl.pc, gl.ps)
        return carry[GROUND_NEXT]
    return excitation(0.0, 0.5 * dt, 0.0, ex.forces, ex.series_t, ex.series_v, ex.series_ptr,
                      ex.series_target,
                      filtered, fl.c_force, fl.c_ground, gl.z, gl.zn, gl.pc, False, ground, gl.load_next)


@njit(**INLINE)
def save_grid_loads(carry, gl, ag_next: float, nf: int, na: int) -> None:
    """Carry the grid loads to the path's next stretch (``start_loads``)."""
    carry[GROUND_NEXT] = ag_next
    save_loads(carry, gl.load_next)
    save_rows(carry, nf, na, gl.pc, gl.ps)


@njit(**INLINE)
def finish_loads(gl, fl) -> None:
    """The filter state back into the filter bundle (the path's next stretch starts there)."""
    for r in range(gl.z.shape[0]):
        fl.z[r] = gl.z[r]
        fl.zn[r] = gl.zn[r]


@njit(**INLINE)
def step_loads(i: int, dt: float, gl, ex, fl, ag_next: float, piecewise: bool, filtered: bool, ground: bool,
               gen_filter) -> float:
    """The loads at the start of step ``i`` into ``load`` (the last step's end, re-evaluated on
    the step's own piece where the loads have breaks), the filters advanced over the step
    first; returns the ground acceleration there.  The step's midpoint (``mid_loads``, the
    Runge-Kutta step's) and end (``end_loads``) follow: separate functions, so that a step
    compiles only the loads it reads."""
    t_step = i * dt
    z, zn = gl.z, gl.zn
    if filtered:
        for r in range(z.shape[0]):
            z[r] = zn[r]
        advance_filters(z, zn, t_step, dt, fl.phi, fl.chol, fl.envelope, gen_filter, gl.draws)
    for k in range(gl.load.shape[0]):
        gl.load[k] = gl.load_next[k]
    if piecewise:  # re-evaluate each step's start on its own piece
        return excitation(t_step, t_step + 0.5 * dt, 0.0, ex.forces, ex.series_t, ex.series_v, ex.series_ptr,
                          ex.series_target, filtered, fl.c_force, fl.c_ground, z, zn, gl.pc, True, ground,
                          gl.load)
    return ag_next


@njit(**INLINE)
def mid_loads(i: int, dt: float, gl, ex, fl, filtered: bool, ground: bool) -> float:
    """The loads at the midpoint of step ``i`` into ``load3`` (after ``step_loads``, before
    ``end_loads``: the phasors are the step's start's); returns the ground acceleration there."""
    t_step = i * dt
    turn(gl.pc, gl.ps, gl.hc, gl.hs, gl.mc, gl.ms)
    return excitation(t_step + 0.5 * dt, t_step + 0.5 * dt, 0.5, ex.forces, ex.series_t, ex.series_v,
                      ex.series_ptr, ex.series_target, filtered, fl.c_force, fl.c_ground, gl.z, gl.zn, gl.mc,
                      True, ground, gl.load3)


@njit(**INLINE)
def end_loads(i: int, dt: float, gl, ex, fl, filtered: bool, ground: bool) -> float:
    """The loads at the end of step ``i`` into ``load_next``, the phasors turned on to it;
    returns the ground acceleration there."""
    t_step = i * dt
    turn(gl.pc, gl.ps, gl.rc, gl.rs, gl.pc, gl.ps)
    return excitation(t_step + dt, t_step + 0.5 * dt, 1.0, ex.forces, ex.series_t, ex.series_v, ex.series_ptr,
                      ex.series_target, filtered, fl.c_force, fl.c_ground, gl.z, gl.zn, gl.pc, True, ground,
                      gl.load_next)


@njit(**INLINE)
def event_loads(t: float, tm: float, theta: float, gl, ex, fl, filtered: bool, ground: bool) -> float:
    """The loads at ``t`` inside a step (a sub-step's end at an event: ``theta`` of the way
    through the step, its piece chosen at ``tm``) into ``load_end``; returns the ground
    acceleration there.  Out of line (``_event_loads``): events are rare, and the inlined
    loads in the event loop cost the ground-motion contact scene 10 % of its speed; the call
    takes copies of the filter states, so that they stay in registers (see
    ``common.stored_energy``)."""
    copy_into(gl.z_copy, gl.z)
    copy_into(gl.zn_copy, gl.zn)
    ag = _event_loads(*plain((t, tm, theta, ex.forces, ex.series_t, ex.series_v, ex.series_ptr,
                              ex.series_target, runtime_value(filtered), fl.c_force, fl.c_ground, gl.z_copy,
                              gl.zn_copy, runtime_value(ground), gl.load_copy)))
    copy_into(gl.load_end, gl.load_copy)
    return ag


@njit(**KERNEL)
def _event_loads(t, tm, theta, forces, series_t, series_v, series_ptr, series_target, filtered, c_force,
                 c_ground, z, zn, ground, load) -> float:
    """``event_loads``'s body, compiled once for every loop (the harmonic rows from their
    closed form: ``z`` stands in for the phasors, unread)."""
    return excitation(t, tm, theta, forces, series_t, series_v, series_ptr, series_target, filtered, c_force,
                      c_ground, z, zn, z, False, ground, load)


@njit(**INLINE)
def noise_scales(sigma, dt: float, noise_scale, slot) -> int:
    """Each floor's ``sigma sqrt(dt)`` into ``noise_scale`` and its place among the noisy floors
    into ``slot``; returns the number of noisy floors (normals a step; a one-storey primary
    counts as noisy)."""
    nf = noise_scale.shape[0]
    noisy = 0
    for k in range(nf):
        noise_scale[k] = sigma[k] * math.sqrt(dt)
        slot[k] = noisy
        if nf == 1 or noise_scale[k] > 0.0:
            noisy += 1
    return noisy


@njit(**INLINE)
def step_normals(i: int, parts: int, noise_scale, slot, noisy: int, normals, refine: int, replayed: int, gen,
                 u1, u2) -> int:
    """The standard normals of step ``i`` on the noisy floors into ``u1`` (and, with ``parts``
    2, ``u2``: the SRA3 step's second integral), drawn from ``gen`` or replayed from
    ``normals`` (the kick-drift-kick step: the sum of the step's ``refine`` fine normals; with
    two parts, all floors' first normals, then their second, counted by ``replayed``); returns
    the replayed normals used."""
    nf = noise_scale.shape[0]
    replay = normals.shape[0] > 0
    for part in range(parts):
        for k in range(nf):
            if nf == 1 or noise_scale[k] > 0.0:
                if replay and parts == 2:  # (no counter carried through the loop otherwise)
                    u = normals[replayed]
                    replayed += 1
                elif replay:  # the sum of the step's fine normals
                    u = 0.0
                    for f in range(refine):
                        u += normals[(i * refine + f) * noisy + int(slot[k])]
                    u /= math.sqrt(refine)
                else:
                    u = normal(gen)
                if part == 0:
                    u1[k] = u
                else:
                    u2[k] = u
    return replayed


@njit(**INLINE)
def opening_forces(force, load, x, v, acc, bodies, absorbers, nf: int, shaped: bool) -> None:
    """Each floor's force at the metrics window's opening (the structure's, the attachments' and
    the load at the step's start, ``load``) into ``acc``, for the peaks; ``force``: scratch."""
    attachment_forces(x, v, nf, bodies.storey_k, bodies.storey_c, bodies.floor_c, absorbers.host,
                      absorbers.rows, force)
    shaped_forces(x, nf, absorbers.host, absorbers.rows, force, shaped)
    for k in range(nf):
        acc[k] = force[k] + load[k]


@njit(**INLINE)
def reset_phasors(gl, i: int, dt: float, ex) -> None:
    """The harmonic rows' phasors set exactly at step ``i`` (every ``common.CHECK_EVERY`` steps:
    the turned phasors' rounding stays below about 1e-13, ``loads``)."""
    phasors(i * dt, ex.forces, gl.pc, gl.ps)
