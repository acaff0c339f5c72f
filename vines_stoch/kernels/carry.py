"""What a path carries from one stretch of steps to the next: the step loops' accumulators and
hidden state, saved at a stretch's end and restored at the next one's start, so that a path run
in stretches (``kernels.start_path``, ``kernels.advance``) ends in the state and with the
metrics of the path run in one go, bitwise.

The carry is one float vector: the scalar slots of ``CARRIED``, then per floor the blocks of
``FLOOR_CARRIED``, per absorber those of ``ABSORBER_CARRIED`` and per closed-form load row
those of ``ROW_CARRIED`` (``carry_size``).  The accumulators are carried raw, before a
stretch's end turns them into metrics (the trapezoid integrals' last half weight, the peak
forces over the masses).  The rest of a path's state lives in arrays the stretches share: the
bodies' state, the filters' state, the metric vector (first passages; the RK4 loop's sums), the
history rows, the Poincare samples and the generators (a numpy Generator or a Philox stream
carries its position).  The loop's flags (``gpu``: on the stack; on the CPU: heap arrays) are
carried as floats, as are step counts and the Brownian trees' seed halves (exact below 2^53).
"""

from __future__ import annotations

import numpy as np

from ..jit import njit
from ..jit.flags import INLINE

#: Scalar slots: the energy accounts, the impact and contact counts, the last ``E1``, the
#: ground acceleration at the next step's start, the replayed normals used, the limits not
#: passed yet, the next history row's step, the next Poincare sample, the Brownian trees' seed.
CARRIED = ("work", "primary_dissipation", "absorber_dissipation", "e_sum", "e1_max", "impact_loss",
           "impacts_left", "impacts_right", "contact_time", "peak_force", "e1_prev", "ground_next",
           "replayed", "pending", "history_next", "next_sample", "seed_high", "seed_low")
(WORK, PRIMARY, ABSORBER, E_SUM, E1_PEAK, LOSS, LEFT, RIGHT, CONTACT, PEAK, E1_PREV, GROUND_NEXT,
 REPLAYED, PENDING, HISTORY_NEXT, NEXT_SAMPLE, SEED_HIGH, SEED_LOW) = range(len(CARRIED))
#: Per-floor blocks: the peaks, the ``x_k^2`` integral, the loads at the next step's start.
FLOOR_CARRIED = ("x_max", "drift_max", "acc_max", "x2_integral", "load_next")
#: Per-absorber blocks: the wall it sticks to, the side it touches, what its contact owes.
ABSORBER_CARRIED = ("stuck", "touching", "owed")
#: Per load row: the phasor of the harmonic loads at the next step's start (cos, sin).
ROW_CARRIED = ("cos", "sin")


def carry_size(n_floors: int, n_absorbers: int, n_rows: int) -> int:
    """Length of the carry of a scene with these numbers of floors, absorbers and load rows."""
    return (len(CARRIED) + len(FLOOR_CARRIED) * n_floors + len(ABSORBER_CARRIED) * n_absorbers
            + len(ROW_CARRIED) * n_rows)


def new_carry(n_floors: int, n_absorbers: int, n_rows: int) -> np.ndarray:
    """An empty carry (NaN: the first stretch writes every slot)."""
    return np.full(carry_size(n_floors, n_absorbers, n_rows), np.nan)


@njit(**INLINE)
def save_accounts(carry, work, d_primary, d_absorber, e_sum, e1_max, loss, n_left, n_right, contact_time,
                  peak_force) -> None:
    """Carry the energy accounts and the event counts (``energy``), raw."""
    carry[WORK], carry[PRIMARY], carry[ABSORBER] = work, d_primary, d_absorber
    carry[E_SUM], carry[E1_PEAK], carry[LOSS] = e_sum, e1_max, loss
    carry[LEFT], carry[RIGHT], carry[CONTACT], carry[PEAK] = n_left, n_right, contact_time, peak_force


@njit(**INLINE)
def restore_accounts(carry):
    """The accounts back from the carry (``save_accounts``), in its order."""
    return (carry[WORK], carry[PRIMARY], carry[ABSORBER], carry[E_SUM], carry[E1_PEAK], carry[LOSS],
            carry[LEFT], carry[RIGHT], carry[CONTACT], carry[PEAK])


@njit(**INLINE)
def save_floors(carry, x_max, drift_max, acc_max, x2_integral) -> None:
    """Carry the per-floor peaks and ``x_k^2`` integrals (the driver's blocks of
    ``FLOOR_CARRIED``)."""
    nf = x_max.shape[0]
    base = len(CARRIED)
    for k in range(nf):
        carry[base + k] = x_max[k]
        carry[base + nf + k] = drift_max[k]
        carry[base + 2 * nf + k] = acc_max[k]
        carry[base + 3 * nf + k] = x2_integral[k]


@njit(**INLINE)
def restore_floors(carry, x_max, drift_max, acc_max, x2_integral) -> None:
    """The per-floor peaks and integrals back from the carry (``save_floors``)."""
    nf = x_max.shape[0]
    base = len(CARRIED)
    for k in range(nf):
        x_max[k] = carry[base + k]
        drift_max[k] = carry[base + nf + k]
        acc_max[k] = carry[base + 2 * nf + k]
        x2_integral[k] = carry[base + 3 * nf + k]


@njit(**INLINE)
def save_loads(carry, load_next) -> None:
    """Carry the floors' loads at the next step's start (the grid steps' block of
    ``FLOOR_CARRIED``)."""
    nf = load_next.shape[0]
    base = len(CARRIED) + 4 * nf
    for k in range(nf):
        carry[base + k] = load_next[k]


@njit(**INLINE)
def restore_loads(carry, load_next) -> None:
    """The floors' loads at the next step's start back from the carry (``save_loads``)."""
    nf = load_next.shape[0]
    base = len(CARRIED) + 4 * nf
    for k in range(nf):
        load_next[k] = carry[base + k]


@njit(**INLINE)
def save_absorbers(carry, nf: int, stuck, touching, owed) -> None:
    """Carry the per-absorber blocks (``ABSORBER_CARRIED``)."""
    na = stuck.shape[0]
    base = len(CARRIED) + len(FLOOR_CARRIED) * nf
    for a in range(na):
        carry[base + a] = stuck[a]
        carry[base + na + a] = touching[a]
        carry[base + 2 * na + a] = owed[a]


@njit(**INLINE)
def restore_absorbers(carry, nf: int, stuck, touching, owed) -> None:
    """The per-absorber blocks back from the carry (``save_absorbers``)."""
    na = stuck.shape[0]
    base = len(CARRIED) + len(FLOOR_CARRIED) * nf
    for a in range(na):
        stuck[a] = int(carry[base + a])
        touching[a] = int(carry[base + na + a])
        owed[a] = carry[base + 2 * na + a]


@njit(**INLINE)
def save_rows(carry, nf: int, na: int, pc, ps) -> None:
    """Carry the harmonic loads' phasors (``ROW_CARRIED``)."""
    nr = pc.shape[0]
    base = len(CARRIED) + len(FLOOR_CARRIED) * nf + len(ABSORBER_CARRIED) * na
    for r in range(nr):
        carry[base + r] = pc[r]
        carry[base + nr + r] = ps[r]


@njit(**INLINE)
def restore_rows(carry, nf: int, na: int, pc, ps) -> None:
    """The harmonic loads' phasors back from the carry (``save_rows``)."""
    nr = pc.shape[0]
    base = len(CARRIED) + len(FLOOR_CARRIED) * nf + len(ABSORBER_CARRIED) * na
    for r in range(nr):
        pc[r] = carry[base + r]
        ps[r] = carry[base + nr + r]
