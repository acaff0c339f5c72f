"""Pieces shared by the step loops: forces on all bodies, contact constraints, the impact
resolver, metric slots.

Loops over bodies run to the length of the state arrays (not of the parameter arrays) or to
the floor count ``nf``: the kernels make both compile-time constants (``scratch`` and the
kernel factories' arguments), so the loops unroll.  An absorber's host floor is the constant
0 on a one-storey primary (``host_of``), so its state stays in registers there; on several
floors the host is a run-time index (``pick`` and ``put`` would keep those arrays in
registers too, at several times the compile time of every kernel).
"""

from __future__ import annotations

from functools import cache

import numpy as np

from ..jit import njit
from ..jit.flags import INLINE, KERNEL
from ..jit.intrinsics import larger, pick, plain, put, runtime_value, scratch_within, smaller
from ..outputs import (
    ACC_MAX_K,
    DRIFT_MAX_K,
    EVENT_ABSORBER,
    EVENT_LOSS,
    EVENT_SIDE,
    EVENT_SPEED,
    EVENT_T,
    SLOTS,
    X1_MAX,
    X1_SQ_INT,
    X_MAX_K,
    X_SQ_INT_K,
    passage_slots,
)
from ..physics.absorbers import (
    CLEARANCE,
    DAMPING,
    HERTZ,
    IMPACT,
    K_CUBIC,
    K_LEFT,
    K_LIN,
    K_RIGHT,
    REST,
    WALL_HI,
    WALL_LO,
    coupling_energy,
    shaped_force,
    spring_damper_force,
)
from ..physics.hertz import CONTACT_STEPS, contact_energy, contact_force_law, contact_substep, hertz_force
from ..physics.impact import restitution_impact, sticks
from ..physics.structure import host_of, primary_energy, structure_forces, wall_of
from ..signals import (
    REDUCE_MAX,
    REDUCE_MEAN,
    REDUCE_MIN,
    REDUCE_PEAK,
    REDUCTION_SLOTS,
    SIGNAL_CONTACT,
    SIGNAL_DRIFT,
    SIGNAL_SHARE,
    SIGNAL_STROKE,
    SIGNAL_V,
    SIGNAL_VA,
    SIGNAL_X,
    SIGNAL_XA,
)
from .protocol import KIND_BITS, KINDS

#: Impacts resolved inside one outer step before the rest of the step ignores the walls.
MAX_EVENTS = 64

#: Sub-steps (contact phases, impacts) allowed in one outer step; past it the rest of the
#: step is taken at once and counted in ``capped_steps``.
MAX_SUBSTEPS = 100_000

#: Steps between divergence checks (and between exact re-evaluations of harmonic phases).
CHECK_EVERY = 1024

#: A displacement beyond this counts as divergence.
DIVERGED = 1e100


NOISE_BIT, IMPACT_BIT, HERTZ_BIT, PARTNERS_BIT, FILTERED_BIT, GROUND_BIT, SHAPED_BIT = KIND_BITS.values()


@cache
def stack_scratch(body_room: int, floor_room: int) -> tuple:
    """Zeroed arrays on a loop's stack, one item a body (``body_scratch(n)``) or a floor
    (``floor_scratch(n)``), each holding ``body_room`` or ``floor_room`` items or ``n`` where the
    loop knows it as a constant (``protocol.rooms``: the loop's sizes where it takes them as
    constants; ``jit.intrinsics.scratch_within``)."""

    @njit(**INLINE)
    def body_scratch(n):
        return scratch_within(n, body_room)

    @njit(**INLINE)
    def floor_scratch(n):
        return scratch_within(n, floor_room)

    return body_scratch, floor_scratch


@njit(**INLINE)
def bit_set(bits: int, bit: int) -> bool:
    """Whether ``bit`` is set in ``bits``: a flag of what a scene holds (``protocol.KIND_BITS``)
    that a loop reads at run time from the run's ``Grid.kinds``.  A loop's step functions read
    each flag as ``FLAG if FLAG >= 0 else bit_set(bits, BIT)`` (``FLAG``: the loop's constant
    of ``kinds_of``, or ``protocol.RUN_TIME``), written out where used: numba's branch pruning
    then drops what a constant rules out before typing, as it does for any constant of the loop."""
    return (bits & bit) != 0


def kinds_of(spec) -> tuple:
    """The flags of ``protocol.KINDS`` of a loop specialised to ``spec``, in that order: bools,
    or ``protocol.RUN_TIME`` (``bit_set``)."""
    return tuple(getattr(spec, name) for name in KINDS)


@njit(**INLINE)
def attachment_forces(x, v, nf: int, storey_k, storey_c, floor_c, host, rows, force):
    """``force[b]``: force on body ``b`` from the structure and every absorber attachment
    (MODEL.md sections 1, 1a, 2; ``physics.absorbers.spring_damper_force``); loads, contact
    forces and shaped springs (``shaped_forces``) are added by the caller."""
    structure_forces(x, v, nf, storey_k, storey_c, floor_c, force)
    for a in range(x.shape[0] - nf):
        h = host_of(host, a, nf)
        j = nf + a
        f = spring_damper_force(x[j] - x[h] - rows[a, REST], v[j] - v[h], rows[a, K_LIN],
                                rows[a, K_CUBIC], rows[a, DAMPING])
        force[j] = f
        force[h] -= f


@njit(**INLINE)
def accelerate(force, load, ag, inv_mass, acc):
    """Accelerations ``acc`` from the attachment forces, the loads on the floors (``load``, one
    per floor) and the ground acceleration (``acc`` may be ``force``; ``inv_mass``: the
    reciprocal masses)."""
    nf = load.shape[0]
    for k in range(nf):
        acc[k] = (force[k] + load[k]) * inv_mass[k] - ag
    for b in range(nf, acc.shape[0]):
        acc[b] = force[b] * inv_mass[b] - ag


@njit(**INLINE)
def contact_forces(x, nf: int, kind, host, rows, force, active=True):
    """Add the Hertz contact forces (MODEL.md section 2, ``physics.hertz.contact_force_law``) on each
    Hertz absorber, the opposite on its host floor; nothing unless ``active``."""
    for a in range(x.shape[0] - nf if active else 0):
        if kind[a] == HERTZ:
            h = host_of(host, a, nf)
            j = nf + a
            f = contact_force_law(rows, a, x[j] - x[h])
            force[j] += f
            force[h] -= f


@njit(**INLINE)
def shaped_forces(x, nf: int, host, rows, force, active=True):
    """Add the force of each absorber's shaped springs (``physics.absorbers.shaped_force``: the
    geometric attachment, the gap spring) on the absorber, the opposite on its host floor;
    nothing unless ``active`` (a compile-time flag: the scene holds a row with such a spring,
    ``Scene.has_shaped``.  Tested at run time on every row, it halved the smooth scene's speed)."""
    for a in range(x.shape[0] - nf if active else 0):
        h = host_of(host, a, nf)
        j = nf + a
        f = shaped_force(rows, a, x[j] - x[h] - rows[a, REST])
        force[j] += f
        force[h] -= f


@njit(**INLINE)
def contact_force(x, nf: int, a: int, host, rows) -> float:
    """Magnitude of the contact force on Hertz absorber ``a`` (either side)."""
    u = x[nf + a] - x[host_of(host, a, nf)]
    return (hertz_force(rows[a, WALL_LO] - u, rows[a, K_LEFT])
            + hertz_force(u - rows[a, WALL_HI], rows[a, K_RIGHT]))


@njit(**KERNEL)
def contact_step(x, v, nf: int, mass, host, rows, touching) -> float:
    """The sub-step the Hertz contacts in progress ask for (``touching[a]``: the side absorber
    ``a`` touches, 0 for none; ``contact_substep``); ``inf`` when none does."""
    h = np.inf
    for a in range(touching.shape[0]):
        if touching[a] != 0:
            h = min(h, contact_substep(x, v, nf, mass, host, rows, a, touching[a], CONTACT_STEPS))
    return h


@njit(**INLINE)
def absorber_energy(x, v, mass, nf: int, kind, host, rows, e: float = 0.0) -> float:
    """``E_abs``: the absorbers' kinetic energy and the energy stored in their attachment springs
    and Hertz contacts, added to ``e``."""
    for b in range(nf, v.shape[0]):
        e += 0.5 * mass[b] * v[b] * v[b]
    for a in range(x.shape[0] - nf):
        u = x[nf + a] - x[host_of(host, a, nf)]
        e += coupling_energy(rows, a, u - rows[a, REST])
        if kind[a] == HERTZ:
            e += contact_energy(rows, a, u)
    return e


@njit(**INLINE)
def energy_share(e1: float, e_abs: float) -> float:
    """The absorbers' share of the energy, ``E_abs / (E1 + E_abs)`` (MODEL.md section 4; Wei et
    al. eq. 21); 0 where there is none."""
    total = e1 + e_abs
    return e_abs / total if total > 0.0 else 0.0


@njit(**KERNEL)
def stored_energy(x, v, mass, nf: int, storey_k, kind, host, rows) -> float:
    """Mechanical energy stored in all bodies, storeys, attachment springs and Hertz contacts.

    Out of line: it runs twice a path (the window's opening, the end), and every inlined copy
    costs compile time.  Callers pass copies of a state kept in registers (an array whose
    address reaches an out-of-line call is kept in memory across the generator's calls)."""
    return absorber_energy(x, v, mass, nf, kind, host, rows, primary_energy(mass, storey_k, x, v, nf))


@njit(**INLINE)
def stick_together(mass, values, nf: int, stuck, wall, group_mass, group_sum, release, active=True):
    """Bodies and the absorbers stuck to their walls move as one body (MODEL.md section 2).

    ``values`` holds velocities (after a kick) or accelerations; each body that holds walls
    (``wall``: ``physics.structure.wall_of``) and the absorbers stuck on it get their
    mass-weighted common value, and a body with none stuck keeps its own (exactly, not
    ``(m v) / m``).  With ``release``, an absorber the wall would have to pull (constraint of
    the wrong sign) is released first.  ``group_mass`` and ``group_sum`` are
    scratch, one entry per body that may hold walls (the floors, or every body where absorbers
    impact absorbers): their length is that count.  Nothing happens unless ``active`` (a flag
    rather than a branch around the call: see ``jit.flags.INLINE``).
    """
    nw = group_mass.shape[0]
    passes = (2 if release else 1) if active else 0
    for attempt in range(passes):
        # mass-weighted mean over each body and its stuck absorbers
        for k in range(nw):
            group_mass[k] = mass[k]
            group_sum[k] = mass[k] * values[k]
        for a in range(values.shape[0] - nf):
            if stuck[a] != 0:
                h = wall_of(wall, a, nw)
                j = nf + a
                group_mass[h] += mass[j]
                group_sum[h] += mass[j] * values[j]
        for k in range(nw):
            group_sum[k] = group_sum[k] / group_mass[k]
        if attempt + 1 < passes:
            for a in range(values.shape[0] - nf):
                # wall force on the absorber ~ mass * (common - free value); a wall only pushes
                if stuck[a] * (group_sum[wall_of(wall, a, nw)] - values[nf + a]) > 0.0:
                    stuck[a] = 0
    if passes > 0:
        for a in range(values.shape[0] - nf):
            if stuck[a] != 0:
                h = wall_of(wall, a, nw)
                values[nf + a] = group_sum[h]
                values[h] = group_sum[h]


@njit(**INLINE)
def pin_to_walls(x, nf: int, nw: int, stuck, wall, rows):
    """Place stuck absorbers exactly at their wall (removes round-off drift); ``nw``: the
    bodies that may hold walls (``physics.structure.wall_of``)."""
    for a in range(x.shape[0] - nf):
        if stuck[a] != 0:
            x[nf + a] = x[wall_of(wall, a, nw)] + stuck[a] * rows[a, CLEARANCE]


@njit(**INLINE)
def into_cavity(x, h: int, j: int, lo: float, hi: float) -> float:
    """Body ``j``'s position with its displacement relative to body ``h`` clipped into
    ``[lo, hi]`` (``keep_in_cavities``)."""
    return x[h] + smaller(larger(x[j] - x[h], lo), hi)


@njit(**INLINE)
def keep_in_cavities(x, nf: int, nw: int, kind, wall, rows):
    """Clip impact absorbers into their cavities ``|u| <= clearance`` (round-off of a located
    impact, or the rest of a step taken at once after the event cap)."""
    for a in range(x.shape[0] - nf):
        if kind[a] == IMPACT:
            c = rows[a, CLEARANCE]
            x[nf + a] = into_cavity(x, wall_of(wall, a, nw), nf + a, -c, c)


@njit(**INLINE)
def resolve_impact(mass, v, nf: int, nw: int, a: int, side: int, gain: float, restitution: float, last: bool,
                   stuck, wall, impulses) -> float:
    """The Newton impact of absorber ``a`` on the ``side`` wall of its cavity, in its host floor
    or in the absorber that holds it (``physics.structure.wall_of``; MODEL.md section 2, Wei et
    al. eqs. 2-3), the one impact resolver of every scheme.

    An impact slower than ``gain`` (the relative velocity the loads add in one step, pressing
    into the wall) or the ``last`` one a step may resolve is plastic and starts sticking.  The
    wall body's velocity jumps, so the absorbers stuck on it are re-examined; the impulse on
    the wall body is added to ``impulses[a]`` where the run keeps them (the signal
    ``contact_j``).  Returns the energy lost."""
    h = wall_of(wall, a, nw)
    j = nf + a
    vh, vj = v[h], pick(v, j)
    plastic = sticks(side, vj - vh, gain) or last
    vh, vj, loss = restitution_impact(mass[h], mass[j], vh, vj, 0.0 if plastic else restitution)
    for q in range(stuck.shape[0]):
        if wall_of(wall, q, nw) == h:
            stuck[q] = 0
    if plastic:
        vj = vh
        stuck[a] = side
    if impulses.shape[0] > 0:
        impulses[a] += mass[h] * (vh - v[h])
    v[h] = vh
    put(v, j, vj)
    return loss


@njit(**INLINE)
def log_event(events, counted: float, t: float, a: int, side: int, speed: float, loss: float) -> None:
    """Row ``counted`` of the event log (``outputs.EVENT_COLUMNS``: the events counted so far
    in the window, before this one): absorber ``a`` meets its ``side`` wall at ``t`` with
    relative velocity ``speed``, losing ``loss``; past the log's length nothing is written."""
    k = int(counted)
    if k < events.shape[0]:
        events[k, EVENT_T] = t
        events[k, EVENT_ABSORBER] = a
        events[k, EVENT_SIDE] = side
        events[k, EVENT_SPEED] = speed
        events[k, EVENT_LOSS] = loss


@njit(**INLINE)
def floor_peaks(x, nf: int, acc, x_max, drift_max, acc_max):
    """Fold a state into the per-floor peaks of ``|x_k|``, of the drift ``|x_k - x_{k-1}|``
    and of the absolute acceleration ``|acc[k]|`` (MODEL.md section 4)."""
    for k in range(nf):
        x_max[k] = larger(x_max[k], abs(x[k]))
        if k > 0:  # (the first storey's drift is the first floor's displacement: write_floor_metrics)
            drift_max[k] = larger(drift_max[k], abs(x[k] - x[k - 1]))
        acc_max[k] = larger(acc_max[k], abs(acc[k]))


@njit(**INLINE)
def close_window(closes: bool, dt: float, e_sum: float, e1_last: float, x, nf: int, x2, acc_max, inv_mass,
                 force_peaks: bool) -> float:
    """The trapezoid rule's integral of ``E1`` over the metrics window from its sum of the step
    ends' values ``e_sum`` (the window's ends at half weight: its last state's ``e1_last``), and
    each floor's ``x_k^2`` integral into ``x2`` (from its sums), where the window ``closes``
    (it opened before the path's end; else 0 and ``x2`` as it is); ``force_peaks``: ``acc_max``
    holds the peak floor forces, made accelerations (over the masses ``1 / inv_mass``)."""
    if not closes:
        return 0.0
    for k in range(nf):
        x2[k] = (x2[k] - 0.5 * x[k] * x[k]) * dt
        if force_peaks:  # peak absolute acceleration: the peak floor force over the mass
            acc_max[k] *= inv_mass[k]
    return (e_sum - 0.5 * e1_last) * dt


@njit(**INLINE)
def write_floor_metrics(out, nf: int, x_max, drift_max, acc_max, x2_integral):
    """Per-floor slots of the raw metric vector (``FLOOR_SLOTS``) and the roof's ``x1`` slots."""
    base = len(SLOTS)
    for k in range(nf):
        out[base + X_MAX_K * nf + k] = x_max[k]
        out[base + DRIFT_MAX_K * nf + k] = drift_max[k] if k > 0 else x_max[0]
        out[base + ACC_MAX_K * nf + k] = acc_max[k]
        out[base + X_SQ_INT_K * nf + k] = x2_integral[k]
    out[X1_MAX] = x_max[nf - 1]
    out[X1_SQ_INT] = x2_integral[nf - 1]


@njit(**INLINE)
def diverged(x) -> bool:
    """True if any coordinate is not finite or beyond ``DIVERGED``."""
    for b in range(x.shape[0]):
        if not (abs(x[b]) < DIVERGED):
            return True
    return False




@njit(**INLINE)
def first_passages(limits, t, nf: int, x_max, drift_max, acc_max, inv_mass, acc_force: bool, e1_max,
                   out) -> int:
    """Record ``t`` as the first passage of each limit (rows of ``scene.limit_row``: code,
    floor, value) whose running peak exceeds its value for the first time, in the slots after
    the floor blocks; returns how many limits have not passed yet (the loops stop calling at
    zero).  The peaks are those the metrics report (``write_floor_metrics``: the first storey's
    drift is the first floor's displacement; ``acc_force``: ``acc_max`` holds peak floor forces,
    the acceleration being the force times ``inv_mass``), so a limit has a first passage exactly
    when its metric exceeds the value."""
    base = passage_slots(nf)
    left = 0
    for limit in range(limits.shape[0]):
        if out[base + limit] != out[base + limit]:  # NaN: not passed yet
            code = limits[limit, 0]
            k = int(limits[limit, 1])
            if code == X_MAX_K or (code == DRIFT_MAX_K and k == 0):
                peak = x_max[k]
            elif code == DRIFT_MAX_K:
                peak = drift_max[k]
            elif code == ACC_MAX_K:
                peak = acc_max[k] * inv_mass[k] if acc_force else acc_max[k]
            else:
                peak = e1_max
            if peak > limits[limit, 2]:
                out[base + limit] = t
            else:
                left += 1
    return left


@njit(**INLINE)
def record_sample(samples, k, sample_from, period, t0, dt, xp, vp, x, v, left, right) -> int:
    """Write the Poincare samples at times ``sample_from + k period`` that fall in the step
    ``[t0, t0 + dt]`` from ``(xp, vp)`` to ``(x, v)``: positions by cubic Hermite, velocities
    by linear interpolation, then the impact counts per side.  Returns the next ``k``."""
    nb = x.shape[0]
    while k < samples.shape[0]:
        ts = sample_from + k * period
        if ts > t0 + dt * (1.0 + 1e-9):
            break
        s = min(max((ts - t0) / dt, 0.0), 1.0)
        h00 = (1.0 + 2.0 * s) * (1.0 - s) ** 2
        h10 = s * (1.0 - s) ** 2
        h01 = s * s * (3.0 - 2.0 * s)
        h11 = s * s * (s - 1.0)
        for b in range(nb):
            samples[k, b] = h00 * xp[b] + h10 * dt * vp[b] + h01 * x[b] + h11 * dt * v[b]
            samples[k, nb + b] = (1.0 - s) * vp[b] + s * v[b]
        samples[k, 2 * nb] = left
        samples[k, 2 * nb + 1] = right
        k += 1
    return k


@njit(**INLINE)
def block_end(i: int, n_steps: int, i0: int, h_next: int) -> int:
    """End of the block of steps from ``i`` that the step loops run without interruption: up
    to the next divergence check, the opening of the metrics window (``i0``) or the next
    history row (``h_next``, ``-1``: none).  The rare work in between stays out of the step
    loop (see ``jit.flags.INLINE``)."""
    end = min(n_steps, (i // CHECK_EVERY + 1) * CHECK_EVERY)
    if i < i0:
        end = min(end, i0)
    if h_next > 0:
        end = min(end, h_next)
    return end


@njit(**INLINE)
def contact_on_host(x, nf: int, a: int, kind, host, rows, impulses, dt: float) -> float:
    """The contact or impact force of absorber ``a`` on its host floor at a step's end (the
    signal ``contact_j``): a Hertz absorber's contact force there (the opposite of
    ``contact_force_law``'s on the absorber); an impact absorber's impulses on the body that holds
    its walls (its host, or the absorber of ``impacts_with``) over the step that ended, over
    ``dt`` (``impulses``: summed by ``resolve_impact``); 0 for the other laws, and for an
    absorber stuck to its wall (the constraint's force is not resolved)."""
    if kind[a] == HERTZ:
        return -contact_force_law(rows, a, pick(x, nf + a) - pick(x, host_of(host, a, nf)))
    if kind[a] == IMPACT and impulses.shape[0] > 0:
        return impulses[a] / dt
    return 0.0


@njit(**INLINE)
def signal_value(code: int, index: int, x, v, nf: int, e1: float, e_abs: float, host, kind, rows, impulses,
                 dt: float) -> float:
    """A declared signal's value (``signals.declare``: ``code``, ``index``) in the state
    ``x, v`` (``E1``: ``e1``; the absorbers' energy: ``e_abs``; ``host``, ``kind``, ``rows``: the
    absorbers' host floors, laws and parameters; ``impulses``, ``dt``: ``contact_on_host``).  The
    state is read at run-time indices by ``pick``, so that it stays in registers
    (``jit.intrinsics.pick``)."""
    if code == SIGNAL_X or code == SIGNAL_XA:
        return pick(x, index)
    if code == SIGNAL_V or code == SIGNAL_VA:
        return pick(v, index)
    if code == SIGNAL_DRIFT:
        return pick(x, index) - pick(x, index - 1) if index > 0 else pick(x, 0)
    if code == SIGNAL_STROKE:
        return pick(x, nf + index) - pick(x, host_of(host, index, nf))
    if code == SIGNAL_SHARE:
        return energy_share(e1, e_abs)
    if code == SIGNAL_CONTACT:
        return contact_on_host(x, nf, index, kind, host, rows, impulses, dt)
    return e1


@njit(**INLINE)
def history_row(history, j: int, signals, x, v, nf: int, e1: float, mass, kind, host, rows, impulses,
                dt: float) -> None:
    """History row ``j``: the declared ``signals`` (rows ``(code, index)``, ``signals.declare``),
    one column each.  Out of line (``_history_row``: rare work, a row every ``stride`` steps,
    whose inlined copies of ``signal_value`` cost every loop compile time), so callers pass
    copies of a state kept in registers (see ``stored_energy``)."""
    _history_row(*plain((history, j, signals, x, v, runtime_value(nf), e1, mass, kind, host, rows, impulses,
                         dt)))


@njit(**KERNEL)
def _history_row(history, j: int, signals, x, v, nf: int, e1: float, mass, kind, host, rows, impulses,
                 dt: float) -> None:
    """``history_row``'s body, compiled once for every loop (the absorbers' energy computed
    where a signal is their share)."""
    e_abs = 0.0
    for c in range(signals.shape[0]):
        if signals[c, 0] == SIGNAL_SHARE:
            e_abs = absorber_energy(x, v, mass, nf, kind, host, rows)
    for c in range(signals.shape[0]):
        history[j, c] = signal_value(signals[c, 0], signals[c, 1], x, v, nf, e1, e_abs, host, kind, rows,
                                     impulses, dt)


@njit(**INLINE)
def start_history(history, stride, signals, x, v, nf, e1, mass, kind, host, rows, impulses, dt) -> int:
    """Write the first history row (``t = 0``) when a history is kept; returns the step after
    which the next row is due (``-1``: never)."""
    if history.shape[0] == 0:
        return -1
    history_row(history, 0, signals, x, v, nf, e1, mass, kind, host, rows, impulses, dt)
    return stride if history.shape[0] > 1 else -1


@njit(**INLINE)
def record_history(history, stride, step, signals, x, v, nf, e1, mass, kind, host, rows, impulses, dt) -> int:
    """Write the history row of ``t = step dt`` (``history_row``); returns the next due step."""
    j = step // stride
    history_row(history, j, signals, x, v, nf, e1, mass, kind, host, rows, impulses, dt)
    return step + stride if j + 1 < history.shape[0] else -1


@njit(**INLINE)
def reads_signal(codes, code: int) -> bool:
    """Whether a row of ``codes`` (rows ``(code, ...)``: declared metrics, history columns) reads
    the signal ``code`` (``signals.SIGNAL_*``)."""
    found = False
    for r in range(codes.shape[0]):
        found = found or codes[r, 0] == code
    return found


@njit(**INLINE)
def recording(history_rows: int, signals, reductions, impacts: bool) -> tuple:
    """What a run records beyond the built-in metrics and the first passages (its limits') and
    event log (its rows), read from its output arrays once (a branch the same for every step,
    not a loop of its own): whether it folds declared metrics, and whether a signal reads the
    impacts' impulses over a step (``contact_j``, of a history column where ``history_rows``
    are kept; ``impacts``: the scene has impacts)."""
    contact = impacts and (reads_signal(reductions, SIGNAL_CONTACT) or
                           (history_rows > 0 and reads_signal(signals, SIGNAL_CONTACT)))
    return reductions.shape[0] > 0, contact


@njit(**INLINE)
def fold_declared(reductions, out, at: int, x, v, nf: int, e1: float, mass, host, kind, rows, impulses,
                  dt: float, opening: bool) -> None:
    """Fold a step end's state into the declared metrics (rows ``(code, index, reduction)``,
    ``signals.declare_metrics``; slots from ``at``, ``signals.REDUCTION_SLOTS`` each): peaks,
    extremes, sums of the signal or its square; at the metrics window's ``opening``, each
    signal's first value (a sum's at half weight: the trapezoid rule).  The last slot keeps the
    signal, whose half weight ``metrics.finish_table`` takes off the sums at the window's end.
    Out of line (``_fold_declared``, compiled once for every loop: inlined, its copies of
    ``signal_value`` and of the absorbers' energy cost each loop compile time), so callers pass
    copies of a state kept in registers (see ``stored_energy``)."""
    _fold_declared(*plain((reductions, out, runtime_value(at), x, v, runtime_value(nf), e1, mass, host, kind,
                           rows, impulses, dt, runtime_value(opening))))


@njit(**KERNEL)
def _fold_declared(reductions, out, at: int, x, v, nf: int, e1: float, mass, host, kind, rows, impulses,
                   dt: float, opening: bool) -> None:
    """``fold_declared``'s body (the absorbers' energy computed where a metric folds their
    share)."""
    share = reads_signal(reductions, SIGNAL_SHARE)
    e_abs = absorber_energy(x, v, mass, nf, kind, host, rows) if share else 0.0
    for r in range(reductions.shape[0]):
        q = signal_value(reductions[r, 0], reductions[r, 1], x, v, nf, e1, e_abs, host, kind, rows, impulses,
                         dt)
        op = reductions[r, 2]
        j = at + REDUCTION_SLOTS * r
        if op == REDUCE_PEAK:
            out[j] = abs(q) if opening else max(out[j], abs(q))
        elif op == REDUCE_MAX:
            out[j] = q if opening else max(out[j], q)
        elif op == REDUCE_MIN:
            out[j] = q if opening else min(out[j], q)
        else:
            w = q if op == REDUCE_MEAN else q * q
            out[j] = 0.5 * w if opening else out[j] + w
        out[j + 1] = q
