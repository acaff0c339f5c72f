"""Paths in SIMD lanes for structures of any size: one loop, compiled once, for every smooth
kick-drift-kick scene of three bodies or more, and of any size in a short run.

``lanes.lane_loop`` is specialised to a scene's sizes and laws: each lane's state sits in
registers, LLVM unrolls the loops over the bodies, and the lane loop around them becomes vector
code.  That is the fastest loop for one floor with one absorber, and a compile (10-30 s) for
each new structure.  Here the sizes (bodies, floors, absorbers, load rows, filter states, noisy
floors, limits, declared signals and history columns) and what the scene holds (white noise,
filters, ground acceleration, shaped springs) are run-time data: a step runs as passes over the batch, one
floor, body or absorber at a time, each pass a loop over the lanes that LLVM turns into vector
code, so that a pass's overhead is shared by the lanes and its trip count costs nothing for
being known at run time only.  A deeper structure is more passes, not a new loop.

Each pass computes, lane by lane, the terms of the scalar step in the scalar step's order
(``physics.structure.structure_forces``, ``physics.absorbers.spring_damper_force`` and
``shaped_force``, ``kdk.kick``, the accounts of ``energy``, ``physics.structure.primary_energy``,
``common.floor_peaks``), the per-lane formulas being the same functions: a lane's numbers are
the scalar loop's on its Philox streams, bitwise (``tests/unit/kernels/test_passes.py``), as the
lanes' are.  Where the scalar step rounds a product once and uses it several times (a ground
acceleration's impulse), the pass rounds it once too, in a pass of its own.  The rare work (the
window's opening, the divergence checks, the history rows, the declared metrics, the first
passages, a lane's end) and the filters (``lanes.filter_rows``: each lane's, on its Philox
filter stream) run the lanes' and the scalar loop's functions lane by lane.

Which scenes run here is ``pass_scene``'s: scenes without impacts or Hertz contact (whose lanes
leave the vector pass for the scalar step, ``lanes.py``), of three bodies or more, and of one or
two in a short run (``paths.general_run``), whose loop is compiled once for every structure: a
longer run of one or two bodies takes the lane loop specialised to it, which is faster there
(``make bench``).
"""

from __future__ import annotations

import numpy as np

from ..jit import njit
from ..jit.flags import INLINE, KERNEL
from ..jit.intrinsics import borrowed, fused, larger, plain, prefer_vectors
from ..outputs import STATUS, STATUS_DIVERGED, declared_slots
from ..physics.absorbers import DAMPING, K_CUBIC, K_LIN, REST, shaped_force, spring_damper_force
from ..physics.structure import host_of, primary_energy
from .common import CHECK_EVERY, diverged, floor_peaks, recording, stored_energy
from .energy import write_accounts
from .grid import GridLoads, end_loads, noise_scales, opening_forces, reset_phasors, start_loads, step_loads
from .lanes import (
    LANES,
    aligned_rows,
    end_metrics,
    filter_rows,
    fold_rows,
    lane_normals,
    lane_rows,
    lane_state,
    pass_rows,
    record_rows,
    spare_rows,
    start_filter_rows,
)
from .loads import filter_scales, has_breaks

W = LANES

#: The rows of a batch's state (``lanes.lane_rows``) the pass loop reads, in this order.
ROW_NAMES = ("x", "v", "work", "d_primary", "d_absorber", "e_sum", "e1_max", "e1", "x_max", "drift_max",
             "acc_max", "x2", "done", "rows")


def pass_scene(scene, general: bool = False) -> bool:
    """Whether ``scene``'s lane realisations run in the pass loop (``pass_loop``): no impact or
    Hertz absorber, and three bodies or more, or any number in a short run (``general``: one whose
    loop is compiled once for every structure, ``paths.general_run``, where the pass loop runs 1-2
    bodies several times faster than the general scalar loop)."""
    return (scene.mass.shape[0] >= 3 or general) and not (scene.has_impact or scene.has_hertz)


def pass_layout(n_bodies: int, n_floors: int) -> np.ndarray:
    """The first row of each of ``ROW_NAMES`` in a batch's state (``lanes.lane_rows``)."""
    rows = lane_rows(n_bodies, n_floors)
    return np.array([rows[name] for name in ROW_NAMES], np.int64)


@njit(**INLINE)
def forces_pass(s, X, V, f, nl, nf, nb, storey_k, storey_c, floor_c, host, rows, shaped) -> None:
    """Every lane's attachment forces (``common.attachment_forces``, then with ``shaped``
    ``common.shaped_forces``) at its state in rows ``X``, ``V`` of ``s`` into rows of ``f``."""
    for k in range(nf):
        kk, cc = storey_k[k], storey_c[k]
        if k == 0:
            for lane in range(nl):
                d = s[X, lane]
                dv = s[V, lane]
                f[0, lane] = fused(-kk, d, -cc * dv)
        else:
            for lane in range(nl):
                d = s[X + k, lane] - s[X + k - 1, lane]
                dv = s[V + k, lane] - s[V + k - 1, lane]
                f[k, lane] = fused(-kk, d, -cc * dv)
                f[k - 1, lane] += fused(kk, d, cc * dv)
    if nf > 1:
        for k in range(nf):
            fc = floor_c[k]
            for lane in range(nl):
                f[k, lane] = fused(-fc, s[V + k, lane], f[k, lane])
    for a in range(nb - nf):
        h, j = host_of(host, a, nf), nf + a
        rest, k_lin, k_cubic, c = rows[a, REST], rows[a, K_LIN], rows[a, K_CUBIC], rows[a, DAMPING]
        for lane in range(nl):
            force = spring_damper_force(s[X + j, lane] - s[X + h, lane] - rest,
                                        s[V + j, lane] - s[V + h, lane], k_lin, k_cubic, c)
            f[j, lane] = force
            f[h, lane] -= force
    for a in range(nb - nf if shaped else 0):
        h, j = host_of(host, a, nf), nf + a
        rest = rows[a, REST]
        for lane in range(nl):
            force = shaped_force(rows, a, s[X + j, lane] - s[X + h, lane] - rest)
            f[j, lane] += force
            f[h, lane] -= force


@njit(**INLINE)
def kick_pass(s, V, vn, f, dwh, loads, at_load, at_ag, half, inv_mass, nl, nf, nb, ground, base) -> None:
    """Every lane's half kick of length ``half`` (``kdk.kick``) from rows ``V`` of ``s`` into
    ``vn``: forces ``f``, the half increments ``dwh``, the lane's loads in rows ``at_load`` of
    ``loads`` and, where ``ground``, its ground acceleration in row ``at_ag``, its impulse a
    unit mass into the scratch row ``base`` first: one product, rounded once, as the scalar
    step's, which all its bodies share.  Without one, the scalar step's ``- 0.0`` is written
    out as it is."""
    if ground:
        for lane in range(nl):
            base[lane] = loads[at_ag, lane] * half
    for k in range(nf):
        im = inv_mass[k]
        step = half * im
        if ground:
            for lane in range(nl):
                impulse = fused(loads[at_load + k, lane], half, dwh[k, lane])
                vn[k, lane] = fused(f[k, lane], step, s[V + k, lane] + (impulse * im - base[lane]))
        else:
            for lane in range(nl):
                impulse = fused(loads[at_load + k, lane], half, dwh[k, lane])
                vn[k, lane] = fused(f[k, lane], step, s[V + k, lane] + (impulse * im - 0.0))
    for b in range(nf, nb):
        step = half * inv_mass[b]
        if ground:
            for lane in range(nl):
                vn[b, lane] = fused(f[b, lane], step, s[V + b, lane] - base[lane])
        else:
            for lane in range(nl):
                vn[b, lane] = fused(f[b, lane], step, s[V + b, lane] - 0.0)


@njit(**INLINE)
def impulse_term(loads, at_load, dt, dws, s, V, vn, k, lane) -> float:
    """Floor ``k``'s term of a lane's ``energy.impulse_work`` (its loads in rows ``at_load``)."""
    return fused(loads[at_load + k, lane], dt, dws[k, lane]) * (0.5 * (s[V + k, lane] + vn[k, lane]))


@njit(**INLINE)
def work_pass(s, V, WORK, vn, dws, loads, at_load, at_ag, dt, nl, nf, nb, mass, ground, w, p) -> None:
    """Every lane's input work over a half kick (``lanes``' ``half_kick``: ``energy.impulse_work``
    and, with a ground acceleration, ``energy.momentum``) added to its row ``WORK``; ``w``, ``p``:
    scratch rows; the lane's loads in rows ``at_load``, ``at_ag`` of ``loads``.  The first two
    floors' terms are one sum, as in the scalar step."""
    if nf == 1:
        for lane in range(nl):
            w[lane] = impulse_term(loads, at_load, dt, dws, s, V, vn, 0, lane)
    else:
        for lane in range(nl):
            first = impulse_term(loads, at_load, dt, dws, s, V, vn, 0, lane)
            w[lane] = first + impulse_term(loads, at_load, dt, dws, s, V, vn, 1, lane)
    for k in range(2, nf):
        for lane in range(nl):
            w[lane] = w[lane] + impulse_term(loads, at_load, dt, dws, s, V, vn, k, lane)
    if ground:  # (the momentum's work where the lane's ground acceleration is not zero)
        for lane in range(nl):
            p[lane] = 0.0
        for b in range(nb):
            mb = mass[b]
            for lane in range(nl):
                p[lane] += mb * 0.5 * (s[V + b, lane] + vn[b, lane])
        for lane in range(nl):  # (its product rounded apart, as in the scalar step: see ``kick_pass``)
            p[lane] = 0.5 * loads[at_ag, lane] * dt * p[lane]
        for lane in range(nl):
            s[WORK, lane] += 0.5 * w[lane] - (p[lane] if loads[at_ag, lane] != 0.0 else 0.0)
    else:
        for lane in range(nl):
            s[WORK, lane] += 0.5 * w[lane] - 0.0


@njit(**INLINE)
def dissipation_pass(s, V, DP, DA, vn, dt, nl, nf, nb, storey_c, floor_c, host, rows) -> None:
    """Every lane's structure and absorber dissipation over a half kick
    (``energy.structure_dissipation``, ``energy.absorber_dissipation``) added to its rows ``DP``,
    ``DA``."""
    for k in range(nf):
        c, fc = storey_c[k], floor_c[k]
        below = max(k - 1, 0)  # (the floor below, for the storey's relative velocity)
        for lane in range(nl):
            vk, vnk = s[V + k, lane], vn[k, lane]
            dv = vk - s[V + below, lane] if k > 0 else vk
            dvn = vnk - vn[below, lane] if k > 0 else vnk
            d = fused(c * dv * 0.5 * dt, 0.5 * (dv + dvn), s[DP, lane])
            s[DP, lane] = fused(fc * vk * 0.5 * dt, 0.5 * (vk + vnk), d) if nf > 1 else d
    for a in range(nb - nf):
        h, j = host_of(host, a, nf), nf + a
        c = rows[a, DAMPING]
        for lane in range(nl):
            w = s[V + j, lane] - s[V + h, lane]
            s[DA, lane] = fused(c * w * 0.5 * dt, 0.5 * (w + vn[j, lane] - vn[h, lane]), s[DA, lane])


@njit(**INLINE)
def observe_pass(s, at, f, loads, at_load, e1, nl, nf, mass, storey_k) -> None:
    """Every lane's accounts at its step end inside the metrics window (``lanes``' ``observe``):
    ``E1`` (``physics.structure.primary_energy``) into its trapezoid sum and peak, the ``x_k^2``
    sums, the floors' peaks (``common.floor_peaks``; the floor forces ``f`` plus the loads in rows
    ``at_load`` of ``loads``);
    ``at``: ``pass_layout``'s rows; ``e1``: a scratch row."""
    X, V, ESUM, E1MAX, E1 = at[0], at[1], at[5], at[6], at[7]
    XMAX, DRIFT, ACCMAX, X2 = at[8], at[9], at[10], at[11]
    for k in range(nf):
        hk, hm = 0.5 * storey_k[k], 0.5 * mass[k]
        if k == 0:
            for lane in range(nl):
                xk, vk = s[X, lane], s[V, lane]
                e1[lane] = fused(hk * xk, xk, hm * vk * vk)
        else:
            for lane in range(nl):
                xk, vk = s[X + k, lane], s[V + k, lane]
                d = xk - s[X + k - 1, lane]
                e1[lane] += fused(hk * d, d, hm * vk * vk)
                s[DRIFT + k, lane] = larger(s[DRIFT + k, lane], abs(d))
        for lane in range(nl):
            xk = s[X + k, lane]
            s[X2 + k, lane] = s[X2 + k, lane] + xk * xk
            s[XMAX + k, lane] = larger(s[XMAX + k, lane], abs(xk))
            s[ACCMAX + k, lane] = larger(s[ACCMAX + k, lane], abs(f[k, lane] + loads[at_load + k, lane]))
    for lane in range(nl):
        s[ESUM, lane] = s[ESUM, lane] + e1[lane]
        s[E1MAX, lane] = larger(s[E1MAX, lane], e1[lane])
        s[E1, lane] = e1[lane]


@njit(**INLINE)
def step_pass(s, at, scratch_rows, z, nl, inside, dt, loads, at_loads, noise_scale, noise, bodies, absorbers,
              inv_mass, ground, shaped) -> None:
    """One kick-drift-kick step of every lane (``lanes``' ``update`` for a scene without events):
    two half kicks around the drift, each with its accounts inside the metrics window, then the
    accounts at the step's end (``observe_pass``); each lane's loads at the step's start and end
    in ``loads`` (``at_loads``: the rows of the floors' and of the ground acceleration, ``load_rows``)."""
    X, V, WORK, DP, DA = at[0], at[1], at[2], at[3], at[4]
    f, vn, dws, dwh, w, p, base = scratch_rows
    mass, storey_k, storey_c, floor_c = bodies.mass, bodies.storey_k, bodies.storey_c, bodies.floor_c
    host, rows = absorbers.host, absorbers.rows
    nb, nf = mass.shape[0], storey_k.shape[0]
    for k in range(nf):
        scale = noise_scale[k]
        for lane in range(nl):
            dws[k, lane] = scale * z[k, lane] if noise else 0.0
            dwh[k, lane] = 0.5 * dws[k, lane]
    for half in range(2):
        if half == 1:  # the drift
            for b in range(nb):
                for lane in range(nl):
                    s[X + b, lane] = fused(dt, vn[b, lane], s[X + b, lane])
                    s[V + b, lane] = vn[b, lane]
        at_load, at_ag = (at_loads[0], at_loads[2]) if half == 0 else (at_loads[1], at_loads[3])
        forces_pass(s, X, V, f, nl, nf, nb, storey_k, storey_c, floor_c, host, rows, shaped)
        kick_pass(s, V, vn, f, dwh, loads, at_load, at_ag, 0.5 * dt, inv_mass, nl, nf, nb, ground, base)
        if inside:
            work_pass(s, V, WORK, vn, dws, loads, at_load, at_ag, dt, nl, nf, nb, mass, ground, w, p)
            dissipation_pass(s, V, DP, DA, vn, dt, nl, nf, nb, storey_c, floor_c, host, rows)
    for b in range(nb):
        for lane in range(nl):
            s[V + b, lane] = vn[b, lane]
    if inside:
        observe_pass(s, at, f, loads, at_loads[1], w, nl, nf, mass, storey_k)


@njit(**INLINE)
def laws(bodies, absorbers) -> tuple:
    """What the per-lane functions read of a scene: masses, storey stiffnesses, the absorbers'
    laws, hosts and rows."""
    return bodies.mass, bodies.storey_k, absorbers.kind, absorbers.host, absorbers.rows


@njit(**INLINE)
def open_pass(s, at, nl, t, loads, at_load, bodies, absorbers, inv_mass, limits, passages, shaped,
              lane) -> None:
    """The metrics window's opening (``lanes``' ``open_lanes``), lane by lane: the stored energy
    as the input work's start, the accounts' and peaks' first values (each lane's loads at the
    step's start in rows ``at_load`` of ``loads``); ``lane``: a lane's scratch (``x, v``, the
    bodies' forces, the floors' forces and loads)."""
    X, V, WORK, E1MAX, XMAX, DRIFT, ACCMAX, X2 = at[0], at[1], at[2], at[6], at[8], at[9], at[10], at[11]
    x, v, force, acc, load = lane
    mass, storey_k, kind, host, rows = laws(bodies, absorbers)
    nf = storey_k.shape[0]
    for j in range(nl):
        for b in range(x.shape[0]):
            x[b], v[b] = s[(X + b) * W + j], s[(V + b) * W + j]
        e1 = primary_energy(mass, storey_k, x, v, nf)
        s[WORK * W + j] = stored_energy(*plain((x, v, mass, nf, storey_k, kind, host, rows)))
        s[E1MAX * W + j], s[at[5] * W + j], s[at[7] * W + j] = e1, 0.5 * e1, e1
        for k in range(nf):
            load[k] = loads[at_load + k, j]
        opening_forces(force, load, x, v, acc, bodies, absorbers, nf, shaped)
        x_max, drift_max, acc_max = np.zeros(nf), np.zeros(nf), np.zeros(nf)
        floor_peaks(x, nf, acc, x_max, drift_max, acc_max)
        for k in range(nf):
            s[(X2 + k) * W + j] = 0.5 * x[k] * x[k]
            s[(XMAX + k) * W + j], s[(DRIFT + k) * W + j] = x_max[k], drift_max[k]
            s[(ACCMAX + k) * W + j] = acc_max[k]
    pass_rows(s, nl, t, limits, inv_mass, passages, (E1MAX, XMAX, DRIFT, ACCMAX))


@njit(**INLINE)
def finish_pass(s, at, lane, out, inside, i0, n_steps, dt, bodies, absorbers, inv_mass, passages, limits,
                x, v) -> None:
    """Lane ``lane``'s metric vector into ``out``, as the scalar loop's end writes it (``lanes``'
    ``finish_lane``); ``x, v``: scratch."""
    X, V, ESUM, E1, XMAX, DRIFT, ACCMAX, X2 = at[0], at[1], at[5], at[7], at[8], at[9], at[10], at[11]
    mass, storey_k, kind, host, rows = laws(bodies, absorbers)
    nf = storey_k.shape[0]
    for b in range(x.shape[0]):
        x[b], v[b] = s[(X + b) * W + lane], s[(V + b) * W + lane]
    if diverged(x):
        out[STATUS] = STATUS_DIVERGED
    x_max, drift_max, acc_max, x2 = np.empty(nf), np.empty(nf), np.empty(nf), np.empty(nf)
    for k in range(nf):
        x_max[k], drift_max[k] = s[(XMAX + k) * W + lane], s[(DRIFT + k) * W + lane]
        acc_max[k], x2[k] = s[(ACCMAX + k) * W + lane], s[(X2 + k) * W + lane]
    e_integral = 0.0
    if inside and i0 < n_steps:  # (the window's last state at half weight)
        e_integral = (s[ESUM * W + lane] - 0.5 * s[E1 * W + lane]) * dt
        for k in range(nf):
            x2[k] = (x2[k] - 0.5 * x[k] * x[k]) * dt
            acc_max[k] *= inv_mass[k]
    work, d_primary, d_absorber = s[at[2] * W + lane], s[at[3] * W + lane], s[at[4] * W + lane]
    write_accounts(out, work, d_primary, d_absorber, e_integral, s[at[6] * W + lane], 0.0, 0.0, 0.0)
    floors = (x_max, drift_max, acc_max, x2)
    end_metrics(out, lane, x, v, mass, nf, storey_k, kind, host, rows, floors, passages, limits.shape[0])


@njit(**INLINE)
def grid_loads(nf: int, nr: int) -> GridLoads:
    """The loads on the grid (``grid.GridLoads``) of ``nf`` floors and ``nr`` closed-form rows,
    without filters."""
    none = np.zeros(0)
    return GridLoads(np.zeros(nf), np.zeros(nf), np.zeros(nf), none, np.zeros(nr), np.zeros(nr), none, none,
                     np.zeros(nr), np.zeros(nr), none, none, none, none, none, none, none, np.zeros(nf))


@njit(**INLINE)
def start_batch(s, at, nl, bodies, limits, passages) -> None:
    """A batch's lanes at their paths' start: the scene's state, the accounts zero, no passage."""
    X, V, WORK, ROWS = at[0], at[1], at[2], at[13]
    for lane in range(nl):
        for b in range(bodies.x.shape[0]):
            s[(X + b) * W + lane], s[(V + b) * W + lane] = bodies.x[b], bodies.v[b]
        for r in range(WORK, ROWS):
            s[r * W + lane] = 0.0
        for j in range(limits.shape[0]):
            passages[j * W + lane] = np.nan


@njit(**INLINE)
def end_diverged(s, at, nl, raw, first, inside, grid, bodies, absorbers, inv_mass, passages, limits, x, v):
    """Each lane whose path diverged ends here, as the scalar loop's: its metrics written
    (``finish_pass``), its state set to rest."""
    X, V, DONE = at[0], at[1], at[12]
    for lane in range(nl):
        if lane_state(s, lane, (DONE, X, V), x, v) and diverged(x):
            s[DONE * W + lane] = 1.0
            finish_pass(s, at, lane, raw[first + lane], inside, grid.i0, grid.n_steps, grid.dt, bodies,
                        absorbers, inv_mass, passages, limits, x, v)
            for b in range(x.shape[0]):
                s[(X + b) * W + lane] = s[(V + b) * W + lane] = 0.0


@njit(**INLINE)
def shared_loads(loads, at_loads, nl, load, load_next, ag, ag_next) -> None:
    """Every lane's loads at the step's start and end, the batch's (a scene without filters)."""
    for k in range(load.shape[0]):
        for lane in range(nl):
            loads[at_loads[0] + k, lane] = load[k]
            loads[at_loads[1] + k, lane] = load_next[k]
    for lane in range(nl):
        loads[at_loads[2], lane] = ag
        loads[at_loads[3], lane] = ag_next


@njit(**INLINE)
def load_rows(nf: int, nz: int) -> tuple:
    """The rows of a batch's filters and loads (``lanes.filter_rows``'): the filter states at the
    step's start and end, each lane's floor loads at the step's start and end and its ground
    acceleration there, and the rows in all."""
    rows = (0, nz, 2 * nz, 2 * nz + nf, 2 * nz + 2 * nf, 2 * nz + 2 * nf + 1)
    return rows, 2 * nz + 2 * nf + 2


@njit(**INLINE)
def batch(s_, rows_, scratch_, z_, spare_, passages_, lane_, filters_, first, nl, bodies_, absorbers_, ex_,
          fl_, noise_, grid_, limits_, key, filter_key, p0_, places_, raw_, history_, stride, signals_,
          reductions_, at_, kinds):
    """Realisations ``first .. first + nl - 1`` in the lanes of a batch: ``s_`` its state
    (``rows_``: the same, a row a line), ``scratch_`` the step's rows, ``z_`` the normals,
    ``lane_`` a lane's scratch (``x, v``, forces, loads), ``filters_`` the filters' rows, normals
    and scratch; the rest ``pass_loop``'s."""
    # every array as a borrowed view (``jit.intrinsics.borrowed``): no reference counting in the
    # passes, which calls in branches would cost at every step
    s, rows2, scratch_rows, z, spare, passages = borrowed((s_, rows_, scratch_, z_, spare_, passages_))
    bodies, absorbers, ex, fl, noise, grid = borrowed((bodies_, absorbers_, ex_, fl_, noise_, grid_))
    limits, places, raw, history, signals, reductions, at = borrowed((limits_, places_, raw_, history_,
                                                                        signals_, reductions_, at_))
    x, v, force, acc, own_load = borrowed(lane_)
    fs, loads, fz, fspare, scales, fzs, fzn, draws = borrowed(filters_)
    p0 = borrowed(p0_)
    noisy_scene, ground, shaped = kinds
    nf, nz = bodies.storey_k.shape[0], fl.phi.shape[0]
    frows = load_rows(nf, nz)[0]
    at_loads = frows[2:]
    state, e1_row, peaks = (at[12], at[0], at[1]), at[7], (at[6], at[8], at[9], at[10])  # (``lanes``' rows)
    dt, n_steps, i0 = grid.dt, grid.n_steps, grid.i0
    mass, storey_k, kind, host, rows = laws(bodies, absorbers)
    inv_mass = 1.0 / mass
    impulses = np.zeros((W, 0))  # (no impacts: ``lanes.record_rows`` reads a row a lane)
    declared, _ = recording(history.shape[1], signals, reductions, False)  # (``common.recording``)
    at_declared = declared_slots(nf, limits.shape[0])
    noise_scale, slot, floor_of = np.zeros(nf), np.zeros(nf), np.zeros(nf, np.int64)
    noisy = noise_scales(noise.sigma, dt, noise_scale, slot) if noisy_scene else 0
    for k in range(nf):
        if nf == 1 or noise_scale[k] > 0.0:
            floor_of[int(slot[k])] = k
    piecewise = has_breaks(ex)
    gl = grid_loads(nf, ex.forces.shape[0])
    ag_next = start_loads(gl, ex, fl, dt, gl.z, False, nf, 0, False, ground)
    drawn = 0  # (the filter streams' draws at the paths' start)
    if nz > 0:
        drawn = start_filter_rows(fs, fz, fspare, nl, fl, p0, filter_key, places, first, gl.load_next,
                                  ag_next, frows, ground, fzs, draws)
    else:
        shared_loads(loads, at_loads, nl, gl.load_next, gl.load_next, ag_next, ag_next)
    start_batch(s, at, nl, bodies, limits, passages)
    inside = i0 == 0
    h_next = -1  # (the step after which the next history row is due; -1: none)
    if history.shape[1] > 0:
        h_next = record_rows(s, nl, 0, stride, history, first, signals, x, v, state, nf, mass, storey_k, kind,
                             host, rows, impulses, dt)
    for i in range(n_steps):
        if i == i0:
            inside = True
            open_pass(s, at, nl, i * dt, loads, at_loads[1], bodies, absorbers, inv_mass, limits, passages,
                      shaped, (x, v, force, acc, own_load))
            if reductions.shape[0] > 0:
                fold_rows(s, nl, raw, first, reductions, at_declared, x, v, state, e1_row, nf, mass, kind,
                          host, rows, impulses, dt, True)
        if i % CHECK_EVERY == 0:
            end_diverged(s, at, nl, raw, first, inside, grid, bodies, absorbers, inv_mass, passages, limits,
                         x, v)
            reset_phasors(gl, i, dt, ex)
        ag = step_loads(i, dt, gl, ex, fl, ag_next, piecewise, False, ground, fl.z)
        ag_next = end_loads(i, dt, gl, ex, fl, False, ground)
        if nz > 0:  # (the loads above without the filters: each lane adds its own)
            filter_scales(i * dt, dt, fl.envelope, scales)
            for c in range(nz):
                draw = drawn + i * nz + c
                lane_normals(*plain((fz[c * W:(c + 1) * W], fspare, nl, draw, filter_key, places, first)))
            filter_rows(fs, fz, nl, gl.load, gl.load_next, ag, ag_next, piecewise, fl, scales, frows, ground,
                        fzs, fzn, draws)
        else:
            shared_loads(loads, at_loads, nl, gl.load, gl.load_next, ag, ag_next)
        for q in range(noisy):
            k = floor_of[q]
            lane_normals(*plain((z[k], spare, nl, i * noisy + q, key, places, first)))
        step_pass(rows2, at, scratch_rows, z, nl, inside, dt, loads, at_loads, noise_scale, noisy_scene,
                  bodies, absorbers, inv_mass, ground, shaped)
        if declared and inside:
            fold_rows(s, nl, raw, first, reductions, at_declared, x, v, state, e1_row, nf, mass, kind, host,
                      rows, impulses, dt, False)
        if limits.shape[0] > 0 and inside:
            pass_rows(s, nl, i * dt + dt, limits, inv_mass, passages, peaks)
        if i + 1 == h_next:  # (``common.record_history``'s schedule)
            h_next = record_rows(s, nl, h_next // stride, stride, history, first, signals, x, v, state, nf,
                                 mass, storey_k, kind, host, rows, impulses, dt)
    for lane in range(nl):
        if s[at[12] * W + lane] == 0.0:
            finish_pass(s, at, lane, raw[first + lane], inside, i0, n_steps, dt, bodies, absorbers, inv_mass,
                        passages, limits, x, v)


@njit(**KERNEL)
def pass_loop(bodies, absorbers, ex, fl, noise, grid, limits, key, bridge_key, filter_key, p0, places, raw,
              history, stride, signals, reductions, events, at, kinds):
    """The pass loop: realisation ``j``'s metric vector into ``raw[j]`` (preset to the vector's
    start), its history rows into ``history[j]`` (preset to NaN) and its declared metrics; the
    arguments are ``chunk.lane_call``'s, then ``pass_layout``'s rows and what the scene holds
    (``kinds``: white noise, ground acceleration, shaped springs)."""
    prefer_vectors()
    nb, nf = bodies.mass.shape[0], bodies.storey_k.shape[0]
    s = aligned_rows(at[13])
    rows = s.reshape((at[13], W))
    scratch_rows = (aligned_rows(nb).reshape((nb, W)), aligned_rows(nb).reshape((nb, W)),
                    aligned_rows(nf).reshape((nf, W)), aligned_rows(nf).reshape((nf, W)), aligned_rows(1),
                    aligned_rows(1), aligned_rows(1))
    z, spare = aligned_rows(nf).reshape((nf, W)), spare_rows()
    passages = aligned_rows(limits.shape[0])
    lane = (np.zeros(nb), np.zeros(nb), np.zeros(nb), np.zeros(nf), np.zeros(nf))
    nz = fl.phi.shape[0]
    n_rows = load_rows(nf, nz)[1]
    fs = aligned_rows(n_rows)
    fspare = spare_rows()
    filters = (fs, fs.reshape((n_rows, W)), aligned_rows(nz), fspare, np.zeros(nz), np.zeros(nz),
               np.zeros(nz), np.zeros(nz))
    for first in range(0, raw.shape[0], W):
        nl = min(W, raw.shape[0] - first)
        batch(s, rows, scratch_rows, z, spare, passages, lane, filters, first, nl, bodies, absorbers, ex, fl,
              noise, grid, limits, key, filter_key, p0, places, raw, history, stride, signals, reductions, at,
              kinds)
