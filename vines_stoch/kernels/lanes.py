"""Paths in SIMD lanes: a batch of realisations advances together, step-outer and lane-inner,
its state in structure-of-arrays, so that the compiler vectorises the update across paths.

The scalar loop (``driver.step_loop``) runs one path at a time: its step is a chain of
dependent operations a few bodies wide, which leaves most of a vector unit idle.  Here each
step runs, once for the batch, what does not depend on the path (the closed-form loads, their
phasors, the metrics window's opening, the divergence check's schedule), then one loop over the
lanes whose body is the kick-drift-kick step of ``kdk.py`` written for one path (the same inlined
force, kick and energy functions, on a path's state loaded from the batch's arrays into
registers), which LLVM turns into vector code, ``LANES`` paths an instruction group.

The noise comes from counter-based Philox streams (``rng.py``): lane ``l``'s normals of step
``i`` are draws ``i m .. i m + m - 1`` (``m`` noisy floors) of its realisation's stream, a block
of Philox4x32-10 and its two branch-free ``float32`` Box-Muller pairs (``rng.block_normals``)
every four draws, in a loop of their own over the lanes.  A realisation's numbers therefore
depend on (seed, purpose, point, realisation) alone, as the cuda backend's do, and the scalar
loop given the same Philox streams runs the same arithmetic: the two agree bitwise
(``tests/unit/kernels/test_lanes.py``).

Events leave the lanes.  The lane body is the step's first pass without an event, and a test
without a branch (``events.quiet_band``) flags each lane whose drift ends outside its absorbers'
bands free of events, or whose absorber sticks or touches; a flagged lane keeps its state as
before the step, and after the vector loop the flagged lanes take, one at a time, the scalar
step after its loads and increments (``kdk``'s ``advance``: root search on the lane's Brownian
tree, impacts, sticking, contact sub-steps), their absorbers' state kept in rows of the batch.
Then a loop of its own observes every lane's step end (the trapezoid sums, the peaks: the loop
driver's), so that the vector loop holds back no lane's observation with selects.

Filtered loads are the lanes' own: each lane advances its filters on its Philox filter stream
(``loads.filter_row``; the envelopes, the same for every lane, once a step), and its loads are
the batch's closed-form loads plus its filters' read-outs.

Which scenes run here is the scheme registry's (``schemes.in_lanes``): the kick-drift-kick
scheme, recording all the scalar loop records: the built-in metrics, the limits' first passages,
history rows and declared metrics (each lane's written by the scalar loop's
``common.history_row`` and ``common.fold_declared`` from its state at the step's end), and the
event log and the impacts' impulses over a step (the signal ``contact_j``), which the scalar step
writes for the lanes it finishes (a log and a row of impulses a lane).
"""

from __future__ import annotations

from functools import cache

import numpy as np

from ..jit import njit
from ..jit.cache import stable_cache
from ..jit.flags import INLINE, KERNEL
from ..jit.intrinsics import (
    bits_float,
    borrowed,
    float_bits,
    fused,
    int_scratch,
    larger,
    plain,
    prefer_vectors,
    scratch,
)
from ..outputs import (
    ACC_MAX_K,
    CONTACT_TIME,
    DRIFT_MAX_K,
    FINAL_ENERGY,
    PEAK_FORCE,
    STATUS,
    STATUS_DIVERGED,
    X_MAX_K,
    declared_slots,
    passage_slots,
)
from ..physics.absorbers import CLEARANCE, WALL_HI, WALL_LO
from ..physics.absorbers import IMPACT as IMPACT_LAW
from ..physics.structure import primary_energy, wall_of
from ..streams.rng import (
    BLOCK_NORMALS,
    STREAM_WORDS,
    block_normals,
    block_uniforms,
    packed_block,
    packed_normals,
)
from .brownian import forget, tree_seed
from .common import (
    CHECK_EVERY,
    attachment_forces,
    close_window,
    diverged,
    floor_peaks,
    fold_declared,
    history_row,
    into_cavity,
    recording,
    shaped_forces,
    stored_energy,
    write_floor_metrics,
)
from .energy import absorber_dissipation, impulse_work, momentum, structure_dissipation, write_accounts
from .events import pressed, quiet_band
from .grid import GridLoads, end_loads, noise_scales, opening_forces, reset_phasors, start_loads, step_loads
from .kdk import contact_sides, kdk_step, kick
from .loads import filter_row, filter_scales, has_breaks, readout, stationary, stationary_state
from .protocol import Spec

#: Paths a batch advances together: its state (about 17 numbers a path for a one-storey primary
#: with one absorber) stays in the core's first-level cache.
LANES = 128
#: Alignment of the batch's arrays, in bytes (a cache line; numba's own is 32 bytes).
ALIGN = 64


def lane_rows(n_bodies: int, n_floors: int, events: bool = False, n_states: int = 0) -> dict[str, int]:
    """The rows of a batch's state array (one column a lane), by name: positions, velocities,
    the accounts (input work, structure and absorber dissipation, the trapezoid sum of ``E1``,
    its peak and its value at the last step's end), the per-floor
    peaks and ``x_k^2`` sums, and whether the path has ended (diverged: 1).  With ``events``
    (impact or Hertz absorbers) also the impacts' loss and counts, the contact time and peak
    force, per absorber the wall it sticks to, the side it touches and what its contact owes
    (``kdk``'s), whether the step holds an event and each floor's force at the step's end (for
    the peaks: ``observe_lanes``).  With ``n_states`` filter states
    (filtered loads) also the filters' states at the step's start and end and the lane's loads
    on the floors and ground acceleration at the step's start and end."""
    n_absorbers = n_bodies - n_floors if events else 0
    filtered = n_states > 0
    names = [("x", n_bodies), ("v", n_bodies), ("work", 1), ("d_primary", 1), ("d_absorber", 1),
             ("e_sum", 1), ("e1_max", 1), ("e1", 1), ("x_max", n_floors), ("drift_max", n_floors),
             ("acc_max", n_floors), ("x2", n_floors), ("done", 1), ("loss", int(events)),
             ("n_left", int(events)), ("n_right", int(events)), ("contact_time", int(events)),
             ("peak_force", int(events)), ("stuck", n_absorbers), ("touching", n_absorbers),
             ("owed", n_absorbers), ("flag", int(events)), ("acc", n_floors * int(events)), ("z", n_states),
             ("zn", n_states),
             ("load", n_floors * filtered), ("load_next", n_floors * filtered), ("ag", int(filtered)),
             ("ag_next", int(filtered)), ("rows", 0)]
    rows, at = {}, 0
    for name, size in names:
        rows[name] = at
        at += size
    return rows


@njit(**KERNEL)
def aligned_rows(rows: int):
    """A zeroed array of ``rows`` rows of ``LANES`` lanes, one after the other, starting on an
    ``ALIGN``-byte boundary (so that every row does)."""
    buffer = np.zeros(rows * LANES + ALIGN // 8)
    skip = (ALIGN - buffer.ctypes.data % ALIGN) % ALIGN // 8
    return buffer[skip:skip + rows * LANES]


#: Rows of the normals a lane keeps from a block for its next draws (``lane_normals``).
SPARE_ROWS = BLOCK_NORMALS - 1


@njit(**INLINE)
def spare_rows():
    """The rows a batch's lanes keep their block's next normals in (``lane_normals``)."""
    return aligned_rows(SPARE_ROWS).reshape((SPARE_ROWS, LANES))


@njit(**KERNEL)
def lane_normals(z, spare, nl: int, draw: int, key, places, first: int) -> None:
    """Draw ``draw`` of the Philox streams ``(key, places[first + lane])`` into ``z[lane]``, lane by
    lane: at a draw ``4m`` the normals of block ``m`` (``rng.block_normals``), the last three kept
    in the rows of ``spare`` (``(SPARE_ROWS, lanes)``) for the next three draws, which take them.
    (Out of line, as the lane step: a small function that the compiler vectorises on its own.)

    A block's draw runs two loops over the lanes: the Philox rounds, the block parked in ``z``
    and ``spare``'s first row as the bits of its two 64-bit words (``rng.packed_block``), then
    its two ``float32`` Box-Muller pairs (``rng.packed_normals``), each loop vectorised apart
    (their integer and floating-point work each keep their registers).  A tail pair (one in
    65,536) sends the batch to ``tail_lanes``."""
    prefer_vectors()
    q = draw & 3
    if q == 0:
        block = np.uint64(draw >> 2)
        for lane in range(nl):
            a, b = packed_block(key, places[first + lane], block)
            z[lane], spare[0, lane] = bits_float(a), bits_float(b)
        tails = 0
        for lane in range(nl):
            z0, z1, z2, z3, tail = packed_normals(float_bits(z[lane]), float_bits(spare[0, lane]))
            z[lane], spare[0, lane], spare[1, lane], spare[2, lane] = z0, z1, z2, z3
            tails += tail
        if tails > 0:
            tail_lanes(z, spare, nl, block, key, places, first)
    else:
        for lane in range(nl):
            z[lane] = spare[q - 1, lane]


@njit(**KERNEL)
def tail_lanes(z, spare, nl: int, block, key, places, first: int) -> None:
    """A batch's block of normals again, lane by lane, where a lane's holds a tail pair
    (``lane_normals``; ``rng.block_normals``: the same bits for the other pairs)."""
    for lane in range(nl):
        place = places[first + lane]
        z[lane], spare[0, lane], spare[1, lane], spare[2, lane] = block_normals(key, place, block)


@njit(**INLINE)
def pass_rows(s, nl, t, limits, inv_mass, passages, peaks) -> None:
    """``t`` as the first passage of each limit whose peak exceeds its value for the first time
    (``common.first_passages``, lane by lane: a select, no branch); ``peaks``: the batch's rows
    of ``E1``'s peak and of the floors' ``x``, drift and force peaks (``lane_rows``)."""
    e1max, xmax, drift, accmax = peaks
    for j in range(limits.shape[0]):
        code, k, value = limits[j, 0], int(limits[j, 1]), limits[j, 2]
        row, scale = e1max, 1.0
        if code == X_MAX_K or (code == DRIFT_MAX_K and k == 0):
            row = xmax + k
        elif code == DRIFT_MAX_K:
            row = drift + k
        elif code == ACC_MAX_K:
            row, scale = accmax + k, inv_mass[k]
        for lane in range(nl):
            peak = s[row * LANES + lane] * scale if code == ACC_MAX_K else s[row * LANES + lane]
            before = passages[j * LANES + lane]
            passages[j * LANES + lane] = t if (before != before and peak > value) else before


@njit(**INLINE)
def end_metrics(out, lane, x, v, mass, nf, storey_k, kind, host, rows, floors, passages, n_limits) -> None:
    """The end of lane ``lane``'s metric vector ``out`` (``driver.step_loop``'s): the energy stored
    in its state ``x, v``, the floors' metrics (``floors``: the peaks and ``x_k^2`` integrals) and
    the first passages of its ``n_limits`` limits (``passages``: the batch's rows)."""
    out[FINAL_ENERGY] = stored_energy(*plain((x, v, mass, nf, storey_k, kind, host, rows)))
    x_max, drift_max, acc_max, x2 = floors
    write_floor_metrics(out, nf, x_max, drift_max, acc_max, x2)
    base = passage_slots(nf)
    for j in range(n_limits):
        out[base + j] = passages[j * LANES + lane]


@njit(**INLINE)
def lane_state(s, lane, state, x, v) -> bool:
    """Whether lane ``lane``'s path goes on (it has not ended), its state then in ``x, v``
    (``state``: the batch's rows of the ended flag, ``x`` and ``v``)."""
    done, xs, vs = state
    if s[done * LANES + lane] != 0.0:
        return False
    for b in range(x.shape[0]):
        x[b] = s[(xs + b) * LANES + lane]
        v[b] = s[(vs + b) * LANES + lane]
    return True


@njit(**INLINE)
def record_rows(s, nl, j, stride, history, first, signals, x, v, state, nf, mass, storey_k, kind, host, rows,
                impulses, dt) -> int:
    """History row ``j`` (``t = j stride dt``) of every lane of a batch whose path has not ended,
    by the scalar loop's ``common.history_row`` from the lane's state and primary energy
    (``state``: ``lane_state``'s rows; ``x, v``: scratch; ``impulses``: a row a lane); returns
    the step after which the next row is due, -1 for none (``common.record_history``'s)."""
    for lane in range(nl):
        if lane_state(s, lane, state, x, v):
            history_row(history[first + lane], j, signals, x, v, nf, primary_energy(mass, storey_k, x, v, nf),
                        mass, kind, host, rows, impulses[lane], dt)
    return (j + 1) * stride if j + 1 < history.shape[1] else -1


@njit(**INLINE)
def fold_rows(s, nl, raw, first, reductions, at, x, v, state, e1_row, nf, mass, kind, host, rows, impulses,
              dt, opening) -> None:
    """The declared metrics (``common.fold_declared``, the scalar loop's, slots from ``at``) of
    every lane of a batch whose path has not ended folded into its metric vector ``raw[first +
    lane]``, from the lane's state and ``E1`` at the step's end (row ``e1_row``), at the metrics
    window's ``opening`` or after a step."""
    for lane in range(nl):
        if lane_state(s, lane, state, x, v):
            fold_declared(reductions, raw[first + lane], at, x, v, nf, s[e1_row * LANES + lane], mass, host,
                          kind, rows, impulses[lane], dt, opening)


@njit(**INLINE)
def filter_rows(s, fz, nl, load, load_next, ag, ag_next, piecewise, fl, scales, rows, ground, z, zn,
                draws) -> None:
    """Every lane's filters advanced over the step (``loads.advance_filters``: the lane's
    normals in rows ``fz``, the envelopes in ``scales``), then its loads at the step's start
    and end, as ``grid.step_loads`` and ``grid.end_loads`` give them: the loads the lanes
    share (``load``, ``load_next``, the ground acceleration ``ag``, ``ag_next``: without the
    filters) plus the filters' read-outs (``loads.excitation``'s).  Without a break in the
    loads (``piecewise``) a step starts with the last step's end loads.  ``rows``: the batch's
    rows of the filter states at the step's start and end, the lane's floor loads at the step's
    start and end and its ground acceleration there (``lane_rows``); ``ground``: the scene has
    a ground acceleration; ``z, zn, draws``: scratch of the filter states' size."""
    Z, ZN, LOAD, LOAD_NEXT, AG, AG_NEXT = rows
    for lane in range(nl):
        for r in range(z.shape[0]):
            z[r] = s[(ZN + r) * LANES + lane]
            draws[r] = fz[r * LANES + lane]
        for r in range(z.shape[0]):
            zn[r] = filter_row(z, r, fl.phi, fl.chol, draws, scales[r])
            s[(Z + r) * LANES + lane] = z[r]
            s[(ZN + r) * LANES + lane] = zn[r]
        for k in range(load.shape[0]):
            at_start = load[k] + readout(fl.c_force, k, z, zn, 0.0)
            carried = s[(LOAD_NEXT + k) * LANES + lane]
            s[(LOAD + k) * LANES + lane] = at_start if piecewise else carried
            s[(LOAD_NEXT + k) * LANES + lane] = load_next[k] + readout(fl.c_force, k, z, zn, 1.0)
        if ground:
            at_start = ag + readout(fl.c_ground, 0, z, zn, 0.0)
            carried = s[AG_NEXT * LANES + lane]
            s[AG * LANES + lane] = at_start if piecewise else carried
            s[AG_NEXT * LANES + lane] = ag_next + readout(fl.c_ground, 0, z, zn, 1.0)


@njit(**INLINE)
def start_filter_rows(s, fz, fspare, nl, fl, p0, filter_key, places, first, load_next, ag_next, rows, ground,
                      z, draws) -> int:
    """Every lane's filters at the path's start (``loads.stationary_start``: from their
    stationary law, the first normals of the lane's filter stream, or from rest) and its loads
    at the first step's start (``grid.start_loads``'s, the lanes' shared ``load_next`` and
    ``ag_next`` plus the read-outs); returns the draws the start took (``filter_rows``' ``rows``,
    ``ground``; ``z, draws``: scratch)."""
    Z, ZN, LOAD, LOAD_NEXT, AG, AG_NEXT = rows
    nz = z.shape[0]
    drawn = nz if stationary(p0) else 0
    for c in range(drawn):
        lane_normals(*plain((fz[c * LANES:(c + 1) * LANES], fspare, nl, c, filter_key, places, first)))
    for lane in range(nl):
        for r in range(nz):
            draws[r] = fz[r * LANES + lane]
        stationary_state(p0, draws, z, drawn > 0)
        for r in range(nz):
            s[(ZN + r) * LANES + lane] = z[r]
        for k in range(load_next.shape[0]):
            s[(LOAD_NEXT + k) * LANES + lane] = load_next[k] + readout(fl.c_force, k, z, z, 0.0)
        if ground:
            s[AG_NEXT * LANES + lane] = ag_next + readout(fl.c_ground, 0, z, z, 0.0)
    return drawn


@cache
def lane_loop(spec: Spec):
    """The lane loop of kick-drift-kick scenes specialised to ``spec`` (``protocol.Spec``).  It
    takes the bundles of ``kernels/bundles.py`` (the state's start in ``bodies``), the keys of
    the increments', the bridges' and the filters' Philox streams, the root of the filters'
    stationary covariance (``p0``: zero for a start from rest) and each realisation's stream
    place (``rng.stream_place``), and writes realisation ``j``'s metric vector into ``raw[j]``
    (preset to the vector's start), its history rows into ``history[j]`` and its event log into
    ``events[j]`` (both preset to NaN; ``spec`` says which it keeps)."""
    NB = spec.n_bodies
    NF = spec.n_floors
    NA = NB - NF
    NA2 = 2 * NA
    NR = spec.n_rows
    NW = NB if spec.partners else NF  # (the bodies that may hold an impact absorber's walls)
    GROUND = spec.ground
    SHAPED = spec.shaped
    NOISE = spec.has_noise
    IMPACT, CONTACT = spec.has_impact, spec.has_hertz
    EVENTS = IMPACT or CONTACT
    TREE = NOISE and EVENTS  # (the lanes' Brownian trees: a seed each)
    FILTERED = spec.filtered
    NZ = spec.n_states if FILTERED else 0
    start, advance = kdk_step(spec).start, kdk_step(spec).advance
    W = LANES  # (a row's length, a compile-time constant: the rows' distances are known)
    R = lane_rows(NB, NF, EVENTS, NZ)
    X, V, WORK, DP, DA, ESUM, E1MAX, E1 = (R["x"], R["v"], R["work"], R["d_primary"], R["d_absorber"],
                                           R["e_sum"], R["e1_max"], R["e1"])
    XMAX, DRIFT, ACCMAX, X2, DONE, ROWS = (R["x_max"], R["drift_max"], R["acc_max"], R["x2"], R["done"],
                                           R["rows"])
    LOSS, LEFT, RIGHT, CTIME, PEAK = R["loss"], R["n_left"], R["n_right"], R["contact_time"], R["peak_force"]
    STUCK, TOUCHING, OWED, FLAG, ACC = R["stuck"], R["touching"], R["owed"], R["flag"], R["acc"]
    Z, ZN, LOAD, LOAD_NEXT, AG, AG_NEXT = R["z"], R["zn"], R["load"], R["load_next"], R["ag"], R["ag_next"]
    PEAKS, STATE = (E1MAX, XMAX, DRIFT, ACCMAX), (DONE, X, V)  # (rows of ``pass_rows``, ``record_rows``)
    FILTER_ROWS = (Z, ZN, LOAD, LOAD_NEXT, AG, AG_NEXT)  # (``filter_rows``')

    @njit(**INLINE)
    def load_lane(s, lane, x, v):
        """A lane's state into ``x, v``."""
        for b in range(NB):
            x[b] = s[(X + b) * W + lane]
            v[b] = s[(V + b) * W + lane]

    @njit(**INLINE)
    def load_peaks(s, lane, x_max, drift_max, acc_max):
        """A lane's per-floor peaks into ``x_max, drift_max, acc_max``."""
        for k in range(NF):
            x_max[k] = s[(XMAX + k) * W + lane]
            drift_max[k] = s[(DRIFT + k) * W + lane]
            acc_max[k] = s[(ACCMAX + k) * W + lane]

    @njit(**INLINE)
    def store_peaks(s, lane, x_max, drift_max, acc_max):
        """``load_peaks``'s inverse."""
        for k in range(NF):
            s[(XMAX + k) * W + lane] = x_max[k]
            s[(DRIFT + k) * W + lane] = drift_max[k]
            s[(ACCMAX + k) * W + lane] = acc_max[k]

    @njit(**INLINE)
    def finish_lane(s, lane, out, inside, i0, n_steps, dt, mass, storey_k, nf, kind, host, rows, inv_mass,
                    passages, limits):
        """Lane ``lane``'s metric vector into ``out``, as the scalar loop's end writes it."""
        x, v = scratch(NB), scratch(NB)
        load_lane(s, lane, x, v)
        x_max, drift_max, acc_max, x2 = scratch(NF), scratch(NF), scratch(NF), scratch(NF)
        if diverged(x):
            out[STATUS] = STATUS_DIVERGED
        load_peaks(s, lane, x_max, drift_max, acc_max)
        for k in range(NF):
            x2[k] = s[(X2 + k) * W + lane]
        e_integral = close_window(inside and i0 < n_steps, dt, s[ESUM * W + lane], s[E1 * W + lane], x, NF,
                                  x2, acc_max, inv_mass, True)
        loss, n_left, n_right = ((s[LOSS * W + lane], s[LEFT * W + lane], s[RIGHT * W + lane]) if EVENTS
                                 else (0.0, 0.0, 0.0))
        write_accounts(out, s[WORK * W + lane], s[DP * W + lane], s[DA * W + lane], e_integral,
                       s[E1MAX * W + lane], loss, n_left, n_right)
        if CONTACT:
            out[CONTACT_TIME], out[PEAK_FORCE] = s[CTIME * W + lane], s[PEAK * W + lane]
        end_metrics(out, lane, x, v, mass, NF, storey_k, kind, host, rows, (x_max, drift_max, acc_max, x2),
                    passages, limits.shape[0])

    @njit(**INLINE)
    def open_lanes(s, nl, t, gl, bodies, absorbers, inv_mass, limits, passages):
        """The metrics window's opening (``driver.step_loop``'s): the stored energy as the input
        work's start, the accounts' and peaks' first values."""
        mass, storey_k, kind, host, rows = (bodies.mass, bodies.storey_k, absorbers.kind, absorbers.host,
                                            absorbers.rows)
        x, v, force, acc, own_load = scratch(NB), scratch(NB), scratch(NB), scratch(NF), scratch(NF)
        x_max, drift_max, acc_max = scratch(NF), scratch(NF), scratch(NF)
        for lane in range(nl):
            load_lane(s, lane, x, v)
            for k in range(NF if FILTERED else 0):
                own_load[k] = s[(LOAD_NEXT + k) * W + lane]
            e1 = primary_energy(mass, storey_k, x, v, NF)
            s[WORK * W + lane] = stored_energy(*plain((x, v, mass, NF, storey_k, kind, host, rows)))
            s[E1MAX * W + lane] = e1
            s[ESUM * W + lane] = 0.5 * e1
            s[E1 * W + lane] = e1
            opening_forces(force, own_load if FILTERED else gl.load_next, x, v, acc, bodies, absorbers, NF,
                           SHAPED)
            for k in range(NF):
                s[(X2 + k) * W + lane] = 0.5 * x[k] * x[k]
                x_max[k], drift_max[k], acc_max[k] = 0.0, 0.0, 0.0
            floor_peaks(x, NF, acc, x_max, drift_max, acc_max)
            store_peaks(s, lane, x_max, drift_max, acc_max)
        pass_rows(s, nl, t, limits, inv_mass, passages, PEAKS)

    @njit(**INLINE)
    def half_kick(x, v, vn, force, dwh, dws, load, ag, dt, inside, accounts, mass, inv_mass, storey_k,
                  storey_c, floor_c, host, rows):
        """A half kick of the step (``kdk.kdk_step``'s without an event: the forces at ``x``, the
        kick from ``v`` into ``vn``; no absorber stuck, none touching: the Hertz contact forces
        are zero, ``update`` flags a lane where one is not) and, inside the metrics window, its
        input work and dissipation added to the ``accounts``."""
        attachment_forces(x, v, NF, storey_k, storey_c, floor_c, host, rows, force)
        shaped_forces(x, NF, host, rows, force, SHAPED)
        kick(v, 0.5 * dt, dwh, load, ag, force, inv_mass, vn, GROUND)
        work, d_primary, d_absorber = accounts
        if inside:
            work += 0.5 * impulse_work(load, dt, dws, v, vn) - (
                0.5 * ag * dt * momentum(mass, v, vn) if GROUND and ag != 0.0 else 0.0)
            d_primary = structure_dissipation(v, vn, NF, storey_c, floor_c, dt, d_primary)
            d_absorber = absorber_dissipation(v, vn, NF, host, rows, dt, d_absorber)
        return work, d_primary, d_absorber

    @njit(**INLINE)
    def observe(s, lane, x, v, acc, mass, storey_k, x_max, drift_max, acc_max):
        """The loop driver's accounts at a lane's step end, inside the metrics window (its state
        ``x, v``, each floor's force ``acc``): the trapezoid sums, the peaks."""
        e1 = primary_energy(mass, storey_k, x, v, NF)
        load_peaks(s, lane, x_max, drift_max, acc_max)
        for k in range(NF):
            s[(X2 + k) * W + lane] += x[k] * x[k]
        floor_peaks(x, NF, acc, x_max, drift_max, acc_max)
        store_peaks(s, lane, x_max, drift_max, acc_max)
        s[ESUM * W + lane] += e1
        s[E1MAX * W + lane] = larger(s[E1MAX * W + lane], e1)
        s[E1 * W + lane] = e1

    @njit(**INLINE)
    def observe_lanes(s, nl, mass, storey_k):
        """``observe`` of every lane from its rows: a scene with events' pass after ``fix_lanes``."""
        x, v, acc = scratch(NB), scratch(NB), scratch(NF)
        x_max, drift_max, acc_max = scratch(NF), scratch(NF), scratch(NF)
        for lane in range(nl):
            load_lane(s, lane, x, v)
            for k in range(NF):
                acc[k] = s[(ACC + k) * W + lane]
            observe(s, lane, x, v, acc, mass, storey_k, x_max, drift_max, acc_max)

    @njit(**INLINE)
    def update(s, z, nl, inside, dt, ag, ag_next, load, load_next, noise_scale, mass, inv_mass, storey_k,
               storey_c, floor_c, kind, host, rows, walls, band):
        """Every lane's step, ``kdk.kdk_step``'s first pass without an event; with ``EVENTS`` each
        lane whose step holds an event or whose absorber sticks or touches flagged, as before the
        step (``fix_lanes`` finishes it; returns how many), and each lane's floor forces kept for
        ``observe_lanes``; without, inside the metrics window, each lane's step end observed."""
        x, v, vn, force, x0, v0 = scratch(NB), scratch(NB), scratch(NB), scratch(NB), scratch(NB), scratch(NB)
        dws, dwh, acc, own_load, own_next = scratch(NF), scratch(NF), scratch(NF), scratch(NF), scratch(NF)
        x_max, drift_max, acc_max = scratch(NF), scratch(NF), scratch(NF)
        flagged = 0  # (an integer sum: LLVM vectorises it, not a sum of floats, whose order it keeps)
        for lane in range(nl):
            load_lane(s, lane, x, v)
            # the loads: the batch's, or with filtered loads the lane's (``filter_lanes``)
            for k in range(NF if FILTERED else 0):
                own_load[k] = s[(LOAD + k) * W + lane]
                own_next[k] = s[(LOAD_NEXT + k) * W + lane]
            f_start = own_load if FILTERED else load
            f_end = own_next if FILTERED else load_next
            g_start = s[AG * W + lane] if FILTERED and GROUND else ag
            g_end = s[AG_NEXT * W + lane] if FILTERED and GROUND else ag_next
            for b in range(NB):
                x0[b], v0[b] = x[b], v[b]
            for k in range(NF):
                dws[k] = noise_scale[k] * z[k * W + lane] if NOISE else 0.0
                dwh[k] = 0.5 * dws[k]
            before = (s[WORK * W + lane], s[DP * W + lane], s[DA * W + lane])
            accounts = half_kick(x, v, vn, force, dwh, dws, f_start, g_start, dt, inside, before, mass,
                                 inv_mass, storey_k, storey_c, floor_c, host, rows)
            held = 0.0  # (events ahead, absorbers stuck or touching: a sum, no branch)
            for a in range(NA if EVENTS else 0):
                h = wall_of(walls, a, NW)
                j = NF + a
                u_end = x[j] - x[h] + dt * (vn[j] - vn[h])  # (``kdk``'s event test at the drift's end)
                ahead = (u_end < band[2 * a]) | (u_end > band[2 * a + 1])
                held += ((1.0 if ahead else 0.0) + (abs(s[(STUCK + a) * W + lane]) if IMPACT else 0.0)
                         + (abs(s[(TOUCHING + a) * W + lane]) if CONTACT else 0.0))
                if CONTACT:  # (a Hertz absorber beyond its surfaces at the start: a contact force)
                    held += pressed(kind[a], x[j] - x[h], band[2 * a], band[2 * a + 1])
            for b in range(NB):
                x[b] = fused(dt, vn[b], x[b])
                v[b] = vn[b]
            for a in range(NA if CONTACT else 0):  # (and at the drift's end, as it lies: the same)
                held += pressed(kind[a], x[NF + a] - x[wall_of(walls, a, NW)], band[2 * a], band[2 * a + 1])
            work, d_primary, d_absorber = half_kick(x, v, vn, force, dwh, dws, f_end, g_end, dt, inside,
                                                    accounts, mass, inv_mass, storey_k, storey_c, floor_c,
                                                    host, rows)
            for b in range(NB):
                v[b] = vn[b]
            for k in range(NF):
                acc[k] = force[k] + f_end[k]
            keep = False
            if EVENTS:  # (a lane kept has no contact force: its peak force stays)
                for a in range(NA if IMPACT else 0):  # (``common.keep_in_cavities`` on the band)
                    clipped = into_cavity(x, wall_of(walls, a, NW), NF + a, band[2 * a], band[2 * a + 1])
                    x[NF + a] = clipped if kind[a] == IMPACT_LAW else x[NF + a]
                keep = (held > 0.0) & (s[DONE * W + lane] == 0.0)  # (no branch: ``&``, not ``and``)
                for b in range(NB):  # (selects: the stores are unconditional)
                    s[(X + b) * W + lane] = x0[b] if keep else x[b]
                    s[(V + b) * W + lane] = v0[b] if keep else v[b]
                s[WORK * W + lane] = before[0] if keep else work
                s[DP * W + lane] = before[1] if keep else d_primary
                s[DA * W + lane] = before[2] if keep else d_absorber
                s[FLAG * W + lane] = 1.0 if keep else 0.0
                flagged += 1 if keep else 0
                for k in range(NF):  # (``observe_lanes`` reads them; ``fix_lanes`` writes its lanes')
                    s[(ACC + k) * W + lane] = acc[k]
            else:
                for b in range(NB):
                    s[(X + b) * W + lane] = x[b]
                    s[(V + b) * W + lane] = v[b]
                s[WORK * W + lane], s[DP * W + lane], s[DA * W + lane] = work, d_primary, d_absorber
                if inside:
                    observe(s, lane, x, v, acc, mass, storey_k, x_max, drift_max, acc_max)
        return flagged

    @njit(**INLINE)
    def fix_lanes(s, z, nl, i, inside, dt, ag, ag_next, gl, own, noise_scale, inv_mass, bodies, absorbers,
                  ex, fl, noise, seeds, raw, first, events, impulses):
        """The flagged lanes' steps (``update``), one at a time, by the scalar loop's step after
        its loads and increments (``kdk``'s ``advance``: the root search on the lane's Brownian
        tree, the impacts, sticking, the contact's sub-steps), each one's state and floor forces
        into its rows (for ``observe_lanes``); ``own``: its state and scratch, set for each lane."""
        x, v, acc = scratch(NB), scratch(NB), scratch(NF)
        for lane in range(nl):
            if s[FLAG * W + lane] == 0.0:
                continue
            load_lane(s, lane, x, v)
            for a in range(NA):
                own.stuck[a] = int(s[(STUCK + a) * W + lane])
                own.touching[a] = int(s[(TOUCHING + a) * W + lane])
                own.owed[a] = s[(OWED + a) * W + lane]
            for k in range(NF):
                if NOISE:
                    own.dw[k] = noise_scale[k] * z[k * W + lane]
                own.gl.load[k] = s[(LOAD + k) * W + lane] if FILTERED else gl.load[k]
                own.gl.load_next[k] = s[(LOAD_NEXT + k) * W + lane] if FILTERED else gl.load_next[k]
            for r in range(NZ):  # (the filters' states: the loads inside the step, ``grid.event_loads``)
                own.gl.z[r], own.gl.zn[r] = s[(Z + r) * W + lane], s[(ZN + r) * W + lane]
            if TREE:
                forget(own.memo)
            acct = (s[WORK * W + lane], s[DP * W + lane], s[DA * W + lane], 0.0, 0.0, s[LOSS * W + lane],
                    s[LEFT * W + lane], s[RIGHT * W + lane], s[CTIME * W + lane], s[PEAK * W + lane], 0)
            g_start = s[AG * W + lane] if FILTERED and GROUND else ag
            g_end = s[AG_NEXT * W + lane] if FILTERED and GROUND else ag_next
            work, d_primary, d_absorber, _, _, loss, n_left, n_right, contact_time, peak, _ = advance(
                i, x, v, inv_mass, acc, own, seeds[lane], g_start, g_end, acct, inside, bodies, absorbers, ex,
                fl, noise, dt, raw[first + lane], events[first + lane], impulses[lane])
            for b in range(NB):
                s[(X + b) * W + lane] = x[b]
                s[(V + b) * W + lane] = v[b]
            for a in range(NA):
                s[(STUCK + a) * W + lane] = own.stuck[a]
                s[(TOUCHING + a) * W + lane] = own.touching[a]
                s[(OWED + a) * W + lane] = own.owed[a]
            s[WORK * W + lane], s[DP * W + lane], s[DA * W + lane] = work, d_primary, d_absorber
            s[LOSS * W + lane], s[LEFT * W + lane], s[RIGHT * W + lane] = loss, n_left, n_right
            s[CTIME * W + lane], s[PEAK * W + lane] = contact_time, peak
            for k in range(NF):
                s[(ACC + k) * W + lane] = acc[k]

    @njit(**INLINE)
    def batch(s_, z_, spare_, nl, bodies_, absorbers_, ex_, fl_, noise_, grid_, limits_, key, places_,
              passages_, raw_, first, own_, seeds_, bridge_key, events_, impulses_, fz_, fspare_, filter_key,
              p0_, history_, stride, signals_, reductions_):
        # every array as a borrowed view (``jit.intrinsics.borrowed``): no reference counting in
        # the lane loops, whose calls would keep the compiler from vectorising them
        bodies, absorbers, ex, fl, noise, grid = borrowed((bodies_, absorbers_, ex_, fl_, noise_, grid_))
        s, z, spare, limits, places, passages, raw = borrowed((s_, z_, spare_, limits_, places_, passages_,
                                                               raw_))
        own, seeds, events, impulses = borrowed((own_, seeds_, events_, impulses_))
        fz, fspare, p0, history, signals, reductions = borrowed((fz_, fspare_, p0_, history_, signals_,
                                                                 reductions_))
        mass, storey_k, kind, host, rows, walls = (bodies.mass, bodies.storey_k, absorbers.kind,
                                                   absorbers.host, absorbers.rows, absorbers.wall)
        dt, n_steps, i0 = grid.dt, grid.n_steps, grid.i0
        # what every lane shares, on the stack: the parameters (so that the lane loop's stores
        # alias none of them), the loads on the grid, the noise scales
        m, inv_mass, sk, sc, fc = scratch(NB), scratch(NB), scratch(NF), scratch(NF), scratch(NF)
        for b in range(NB):
            m[b] = mass[b]
            inv_mass[b] = 1.0 / mass[b]
        for k in range(NF):
            sk[k], sc[k], fc[k] = storey_k[k], bodies.storey_c[k], bodies.floor_c[k]
        # the absorbers' law codes and walls, and the band of each outside which its step holds an
        # event (``events.quiet_band``): on the stack, so that the lane loop's stores alias none
        laws, wall_at, band = int_scratch(NA), int_scratch(NA), scratch(NA2)
        for a in range(NA):
            laws[a], wall_at[a] = kind[a], walls[a]
            band[2 * a], band[2 * a + 1] = quiet_band(kind[a], rows[a, CLEARANCE], rows[a, WALL_LO],
                                                      rows[a, WALL_HI])
        gl = GridLoads(scratch(NF), scratch(NF), scratch(NF), scratch(0), scratch(NR), scratch(NR),
                       scratch(0), scratch(0), scratch(NR), scratch(NR), scratch(0), scratch(0), scratch(0),
                       scratch(0), scratch(0), scratch(0), scratch(0), scratch(NF))
        noise_scale, slot, floor_of = scratch(NF), scratch(NF), int_scratch(NF)
        noisy = noise_scales(noise.sigma, dt, noise_scale, slot) if NOISE else 0
        for k in range(NF):
            if NF == 1 or noise_scale[k] > 0.0:
                floor_of[int(slot[k])] = k
        ag_next = start_loads(gl, ex, fl, dt, gl.z, False, NF, 0, False, GROUND)
        piecewise = has_breaks(ex)
        # the sides the Hertz absorbers touch at the start (``kdk.contact_sides``), the same in
        # every lane
        if CONTACT:
            contact_sides(bodies.x, NF, kind, host, rows, own.touching)
        for lane in range(nl):
            for b in range(NB):
                s[(X + b) * W + lane], s[(V + b) * W + lane] = bodies.x[b], bodies.v[b]
            for r in range(WORK, ROWS):
                s[r * W + lane] = 0.0
            for j in range(limits.shape[0]):
                passages[j * W + lane] = np.nan
            for a in range(NA if CONTACT else 0):
                s[(TOUCHING + a) * W + lane] = own.touching[a]
            if TREE:  # the seed of the lane's Brownian trees: its bridge stream's first two uniforms
                high, low = block_uniforms(bridge_key, places[first + lane], np.uint64(0))
                seeds[lane] = tree_seed(high, low)
        # the filters' start, and the draw of their first step's normals
        scales, z_, zn_, draws_ = scratch(NZ), scratch(NZ), scratch(NZ), scratch(NZ)
        drawn = start_filter_rows(s, fz, fspare, nl, fl, p0, filter_key, places, first, gl.load_next, ag_next,
                                  FILTER_ROWS, GROUND, z_, draws_) if FILTERED else 0
        inside = i0 == 0
        x, v = scratch(NB), scratch(NB)
        declared_at = declared_slots(NF, limits.shape[0])
        # what the run records (``common.recording``; a signal reading the impacts' impulses over a
        # step: a row a lane)
        declared, contact = recording(history.shape[1], signals, reductions, IMPACT)
        for lane in range(nl if contact else 0):  # (the impacts' impulses over a step: none yet)
            for a in range(NA):
                impulses[lane, a] = 0.0
        h_next = -1  # (the step after which the next history row is due; -1: none)
        if history.shape[1] > 0:
            h_next = record_rows(s, nl, 0, stride, history, first, signals, x, v, STATE, NF, m, sk, kind,
                                 host, rows, impulses, dt)
        for i in range(n_steps):
            if i == i0:
                inside = True
                open_lanes(s, nl, i * dt, gl, bodies, absorbers, inv_mass, limits, passages)
                if declared:
                    fold_rows(s, nl, raw, first, reductions, declared_at, x, v, STATE, E1, NF, m, kind, host,
                              rows, impulses, dt, True)
            if i % CHECK_EVERY == 0:
                for lane in range(nl):  # a path that diverged ends here, as the scalar loop's
                    load_lane(s, lane, x, v)
                    if s[DONE * W + lane] == 0.0 and diverged(x):
                        s[DONE * W + lane] = 1.0
                        finish_lane(s, lane, raw[first + lane], inside, i0, n_steps, dt, m, sk, NF, kind,
                                    host, rows, inv_mass, passages, limits)
                        for b in range(NB):
                            s[(X + b) * W + lane] = s[(V + b) * W + lane] = 0.0
                reset_phasors(gl, i, dt, ex)
            ag = step_loads(i, dt, gl, ex, fl, ag_next, piecewise, False, GROUND, fl.z)
            ag_next = end_loads(i, dt, gl, ex, fl, False, GROUND)
            if FILTERED:  # (the loads above without the filters: each lane adds its own)
                filter_scales(i * dt, dt, fl.envelope, scales)
                for c in range(NZ):
                    lane_normals(*plain((fz[c * W:(c + 1) * W], fspare, nl, drawn + i * NZ + c, filter_key,
                                         places, first)))
                filter_rows(s, fz, nl, gl.load, gl.load_next, ag, ag_next, piecewise, fl, scales, FILTER_ROWS,
                            GROUND, z_, zn_, draws_)
            if NOISE:
                for q in range(noisy):
                    k = floor_of[q] * W
                    lane_normals(*plain((z[k:k + W], spare, nl, i * noisy + q, key, places, first)))
            # (``inside`` a constant in each copy: LLVM vectorises each copy on its own)
            if inside:
                flagged = update(s, z, nl, True, dt, ag, ag_next, gl.load, gl.load_next, noise_scale, m,
                                 inv_mass, sk, sc, fc, laws, host, rows, wall_at, band)
            else:
                flagged = update(s, z, nl, False, dt, ag, ag_next, gl.load, gl.load_next, noise_scale, m,
                                 inv_mass, sk, sc, fc, laws, host, rows, wall_at, band)
            for lane in range(nl if contact else 0):  # (this step's impacts' impulses, from none)
                for a in range(NA):
                    impulses[lane, a] = 0.0
            if EVENTS:  # (a compile-time flag alone: a scene without events compiles none of it)
                if flagged > 0:
                    fix_lanes(s, z, nl, i, inside, dt, ag, ag_next, gl, own, noise_scale, inv_mass, bodies,
                              absorbers, ex, fl, noise, seeds, raw, first, events, impulses)
                if inside:
                    observe_lanes(s, nl, m, sk)
            if declared and inside:
                fold_rows(s, nl, raw, first, reductions, declared_at, x, v, STATE, E1, NF, m, kind, host,
                          rows, impulses, dt, False)
            if inside:
                pass_rows(s, nl, i * dt + dt, limits, inv_mass, passages, PEAKS)
            if i + 1 == h_next:  # (``common.record_history``'s schedule)
                h_next = record_rows(s, nl, h_next // stride, stride, history, first, signals, x, v, STATE,
                                     NF, m, sk, kind, host, rows, impulses, dt)
        for lane in range(nl):
            if s[DONE * W + lane] == 0.0:
                finish_lane(s, lane, raw[first + lane], inside, i0, n_steps, dt, m, sk, NF, kind, host, rows,
                            inv_mass, passages, limits)

    @njit(**KERNEL)
    def run(bodies, absorbers, ex, fl, noise, grid, limits, key, bridge_key, filter_key, p0, places, raw,
            history, stride, signals, reductions, events):
        prefer_vectors()
        n = raw.shape[0]
        s, z, spare = aligned_rows(ROWS), aligned_rows(NF), spare_rows()
        fz, fspare = aligned_rows(NZ), spare_rows()  # (the filters' normals)
        passages = aligned_rows(limits.shape[0])
        # the scalar step's state and scratch for the lanes whose step holds an event (its own
        # start: the lanes set what is theirs into it), the lanes' tree seeds
        x = bodies.x.copy()
        own, _ = start(bodies, absorbers, ex, fl, noise, grid, np.zeros(0), False, x, bodies.v.copy(),
                       np.zeros(STREAM_WORDS, np.uint64))
        seeds = np.zeros(W, np.uint64)
        impulses = np.zeros((W, NA))  # (a lane's impacts' impulses over a step)
        for first in range(0, n, W):
            nl = min(W, n - first)
            batch(s, z, spare, nl, bodies, absorbers, ex, fl, noise, grid, limits, key, places,
                  passages, raw, first, own, seeds, bridge_key, events, impulses, fz, fspare, filter_key, p0,
                  history, stride, signals, reductions)

    stable_cache(run)  # (its closure holds the lane step's functions: see ``jit.cache.stable_cache``)
    return run
