"""Pieces shared by the step loops: forces on all bodies, contact constraints, metric slots.

Loops over bodies run to the length of the state arrays (not of the parameter arrays): the
kernels make those lengths compile-time constants (``scratch``), so the loops unroll.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic
from numba.np.arrayobj import make_array, populate_array

from ..physics import INLINE, hertz_energy, hertz_force, spring_damper_energy, spring_damper_force

#: Slots of the raw metric vector a kernel fills; ``metrics.finish`` turns it into columns.
SLOTS = (
    "input_energy", "primary_dissipation", "absorber_dissipation", "impact_loss",
    "energy_integral", "e1_max", "x1_max", "x1_square_integral", "impacts",
    "final_energy", "status", "capped_steps", "impacts_left", "impacts_right", "peak_force",
    "contact_time",
)
(INPUT, PRIMARY_DISS, ABSORBER_DISS, IMPACT_LOSS, ENERGY_INT, E1_MAX, X1_MAX, X1_SQ_INT,
 IMPACTS, FINAL_ENERGY, STATUS, CAPPED, IMPACTS_LEFT, IMPACTS_RIGHT, PEAK_FORCE,
 CONTACT_TIME) = range(len(SLOTS))

#: Status codes written into the ``status`` slot.
STATUS_OK, STATUS_DIVERGED = 0, 1

#: Impacts resolved inside one outer step before the rest of the step ignores the walls.
MAX_EVENTS = 64

#: Steps between divergence checks (and between exact re-evaluations of harmonic phases).
CHECK_EVERY = 1024

#: A displacement beyond this counts as divergence.
DIVERGED = 1e100

#: Poincare samples (one per forcing period) kept at the end of the window for the regime.
POINCARE_SAMPLES = 32


@intrinsic
def scratch(typingctx, size):
    """``np.zeros(size)`` on the kernel's stack, for a compile-time constant ``size`` (a kernel
    factory's body count): the compiler then knows these arrays alias nothing else and, with
    the loops over bodies unrolled, keeps the state in registers across steps.  (The same loop
    on heap arrays ran at 0.65-0.7x.)  The array must not outlive the kernel that makes it."""
    if not isinstance(size, types.IntegerLiteral):
        return None
    n = size.literal_value
    array_type = types.Array(types.float64, 1, "C")

    def codegen(context, builder, signature, args):
        data = cgutils.alloca_once(builder, ir.DoubleType(), size=max(n, 1))
        cgutils.memset(builder, data, ir.Constant(cgutils.intp_t, 8 * max(n, 1)), 0)
        array = make_array(array_type)(context, builder)
        populate_array(array, data=data, shape=[cgutils.intp_t(n)], strides=[cgutils.intp_t(8)],
                       itemsize=8, meminfo=None)
        return array._getvalue()

    return array_type(size), codegen


@njit(**INLINE)
def pick(a, j: int) -> float:
    """``a[j]`` for a run-time ``j``, as a scan over constant indices: an array on the stack
    (``scratch``) indexed only at constant positions stays in registers, one indexed at a
    run-time position is kept in memory, where every access waits on a store."""
    value = a[0]
    for b in range(1, a.shape[0]):
        if b == j:
            value = a[b]
    return value


@njit(**INLINE)
def put(a, j: int, value: float) -> None:
    """``a[j] = value`` for a run-time ``j`` (see ``pick``)."""
    for b in range(a.shape[0]):
        if b == j:
            a[b] = value


@njit(**INLINE)
def attachment_forces(x, v, k1, c1, k_lin, k_cubic, c_abs, rest, force):
    """``force[b]``: force on body ``b`` from the primary's spring and damper and every
    absorber attachment (MODEL.md section 1); external loads are added by the caller."""
    force[0] = -k1 * x[0] - c1 * v[0]
    for a in range(x.shape[0] - 1):
        f = spring_damper_force(x[a + 1] - x[0] - rest[a], v[a + 1] - v[0], k_lin[a], k_cubic[a], c_abs[a])
        force[a + 1] = f
        force[0] -= f


@njit(**INLINE)
def accelerate(force, load, ag, inv_mass, acc):
    """Accelerations ``acc`` from the attachment forces, the load on the primary and the ground
    acceleration (``acc`` may be ``force``; ``inv_mass``: the reciprocal masses)."""
    acc[0] = (force[0] + load) * inv_mass[0] - ag
    for b in range(1, acc.shape[0]):
        acc[b] = force[b] * inv_mass[b] - ag


@njit(**INLINE)
def contact_forces(x, hertz_body, hertz_k, hertz_walls, force, active=True):
    """Add the Hertz contact forces (MODEL.md section 2): ``+K_L z_L^1.5 - K_R z_R^1.5`` on
    each Hertz absorber, the opposite on the primary; nothing unless ``active``."""
    for q in range(hertz_body.shape[0] if active else 0):
        j = hertz_body[q] + 1
        u = pick(x, j) - x[0]
        f = (hertz_force(hertz_walls[q, 0] - u, hertz_k[q, 0])
             - hertz_force(u - hertz_walls[q, 1], hertz_k[q, 1]))
        put(force, j, pick(force, j) + f)
        force[0] -= f


@njit(**INLINE)
def contact_force(x, q, hertz_body, hertz_k, hertz_walls) -> float:
    """Magnitude of the contact force on Hertz absorber ``q`` (either side)."""
    u = x[hertz_body[q] + 1] - x[0]
    return (hertz_force(hertz_walls[q, 0] - u, hertz_k[q, 0])
            + hertz_force(u - hertz_walls[q, 1], hertz_k[q, 1]))


@njit(**INLINE)
def stored_energy(x, v, mass, k1, k_lin, k_cubic, rest, hertz_body, hertz_k, hertz_walls) -> float:
    """Mechanical energy stored in all bodies, springs and Hertz contacts."""
    e = 0.5 * k1 * x[0] * x[0]
    for i in range(v.shape[0]):
        e += 0.5 * mass[i] * v[i] * v[i]
    for a in range(x.shape[0] - 1):
        e += spring_damper_energy(x[a + 1] - x[0] - rest[a], k_lin[a], k_cubic[a])
    for q in range(hertz_body.shape[0]):
        u = x[hertz_body[q] + 1] - x[0]
        e += hertz_energy(hertz_walls[q, 0] - u, hertz_k[q, 0]) + hertz_energy(u - hertz_walls[q, 1], hertz_k[q, 1])
    return e


@njit(**INLINE)
def stick_together(mass, values, stuck, impact_body, release, active=True):
    """Primary and absorbers stuck to a cavity wall move as one body (MODEL.md section 2).

    ``values`` holds velocities (after a kick) or accelerations; stuck bodies get the
    mass-weighted common value.  With ``release``, an absorber the wall would have to pull
    (constraint of the wrong sign) is released first.  Nothing happens unless ``active``
    (a flag rather than a branch around the call: see ``physics.INLINE``).
    """
    passes = (2 if release else 1) if active else 0
    common = values[0]
    for attempt in range(passes):
        # mass-weighted mean over the primary and the stuck absorbers
        total_mass = mass[0]
        total = mass[0] * values[0]
        for q in range(stuck.shape[0]):
            if stuck[q] != 0:
                j = impact_body[q] + 1
                total_mass += mass[j]
                total += mass[j] * pick(values, j)
        common = total / total_mass
        if attempt + 1 < passes:
            for q in range(stuck.shape[0]):
                # wall force on the absorber ~ mass * (common - free value); a wall only pushes
                if stuck[q] * (common - pick(values, impact_body[q] + 1)) > 0.0:
                    stuck[q] = 0
    if passes > 0:
        values[0] = common
        for q in range(stuck.shape[0]):
            if stuck[q] != 0:
                put(values, impact_body[q] + 1, common)


@njit(**INLINE)
def pin_to_walls(x, stuck, impact_body, clearance):
    """Place stuck absorbers exactly at their wall (removes round-off drift)."""
    for q in range(stuck.shape[0]):
        if stuck[q] != 0:
            x[impact_body[q] + 1] = x[0] + stuck[q] * clearance[q]


@njit(**INLINE)
def diverged(x) -> bool:
    """True if any coordinate is not finite or beyond ``DIVERGED``."""
    for b in range(x.shape[0]):
        if not (abs(x[b]) < DIVERGED):
            return True
    return False


@njit(**INLINE)
def sticks(side: int, w_in: float, w_gain: float) -> bool:
    """Sticking rule: an impact slower than the relative velocity the loads add in one step,
    with the loads pressing into the wall, is plastic and starts a sticking phase."""
    return side * w_gain > 0.0 and abs(w_in) <= side * w_gain


def new_metrics() -> np.ndarray:
    """A zeroed raw metric vector."""
    return np.zeros(len(SLOTS))


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
    loop (see ``physics.INLINE``)."""
    end = min(n_steps, (i // CHECK_EVERY + 1) * CHECK_EVERY)
    if i < i0:
        end = min(end, i0)
    if h_next > 0:
        end = min(end, h_next)
    return end


@njit(**INLINE)
def start_history(history, stride, x1, e1) -> int:
    """Write the first history row (``t = 0``) when a history is kept; returns the step after
    which the next row is due (``-1``: never)."""
    if history.shape[0] == 0:
        return -1
    history[0, 0] = x1
    history[0, 1] = e1
    return stride if history.shape[0] > 1 else -1


@njit(**INLINE)
def record_history(history, stride, step, x1, e1) -> int:
    """Write the history row of ``t = step dt`` (``x1``, ``E1``); returns the next due step."""
    j = step // stride
    history[j, 0] = x1
    history[j, 1] = e1
    return step + stride if j + 1 < history.shape[0] else -1
