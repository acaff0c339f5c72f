"""What a run records of each realisation, declared in one place: the raw metric vector's slots
(filled by the step loops, turned into columns by ``metrics.finish_table``), the per-floor
blocks, the codes of limits and status, the Poincare samples kept for the regime, the event
log's columns (the signals of its history rows: ``signals.py``).  What a run asks beyond the
metrics its loop reads from these arrays at run time (``kernels.common.recording``)."""

from __future__ import annotations

import numpy as np

from .jit import njit
from .jit.flags import INLINE
from .signals import REDUCTION_SLOTS

#: Slots of the raw metric vector a kernel fills; ``metrics.finish_table`` turns it into columns.
SLOTS = (
    "input_energy", "primary_dissipation", "absorber_dissipation", "impact_loss",
    "energy_integral", "e1_max", "x1_max", "x1_square_integral", "impacts",
    "final_energy", "status", "capped_steps", "impacts_left", "impacts_right", "peak_force",
    "contact_time",
)
(INPUT, PRIMARY_DISS, ABSORBER_DISS, IMPACT_LOSS, ENERGY_INT, E1_MAX, X1_MAX, X1_SQ_INT,
 IMPACTS, FINAL_ENERGY, STATUS, CAPPED, IMPACTS_LEFT, IMPACTS_RIGHT, PEAK_FORCE,
 CONTACT_TIME) = range(len(SLOTS))

#: Per-floor blocks after the slots above, ``n_floors`` entries each (block ``b``, floor ``k``
#: at ``len(SLOTS) + b n_floors + k``): peak
#: displacement, peak drift, peak absolute acceleration, integral of ``x_k^2``.
FLOOR_SLOTS = ("x_max", "drift_max", "acc_max", "x_square_integral")
X_MAX_K, DRIFT_MAX_K, ACC_MAX_K, X_SQ_INT_K = range(len(FLOOR_SLOTS))
#: A limit's code for the peak of the structure's energy ``E1`` (the others use the floor
#: blocks' codes ``X_MAX_K .. ACC_MAX_K``).  After the floor blocks, one slot per limit holds
#: its first-passage time (NaN until it passes: ``first_passages``).
LIMIT_E1 = len(FLOOR_SLOTS)

#: Status codes written into the ``status`` slot.
STATUS_OK, STATUS_DIVERGED = 0, 1



@njit(**INLINE)
def passage_slots(nf: int) -> int:
    """Index of the first limit's first-passage slot (after the per-floor blocks of ``nf`` floors)."""
    return len(SLOTS) + len(FLOOR_SLOTS) * nf


@njit(**INLINE)
def declared_slots(nf: int, n_limits: int) -> int:
    """Index of the first declared metric's slots (``signals.REDUCTION_SLOTS`` each), after the
    first passages of ``n_limits`` limits."""
    return passage_slots(nf) + n_limits


def new_metrics(n_floors: int = 1, n_limits: int = 0, n_declared: int = 0) -> np.ndarray:
    """A raw metric vector of a primary with ``n_floors`` floors: zeros, then NaN in the
    first-passage slots of ``n_limits`` limits, then the slots of ``n_declared`` declared
    metrics (``signals.REDUCTION_SLOTS`` each; zero until the window opens)."""
    base = passage_slots(n_floors)
    out = np.zeros(declared_slots(n_floors, n_limits) + REDUCTION_SLOTS * n_declared)
    out[base:base + n_limits] = np.nan
    return out



#: Columns of a realisation's event log, one row an event (an impact, or the onset of a Hertz
#: contact) in the metrics window, in the order they happen: the time, the absorber (from 0),
#: the wall (-1 left, +1 right), the absorber's velocity relative to its host floor just before
#: the event, and the energy the event took out (the impact's loss; 0 for a Hertz contact's
#: onset, the contact being elastic).  Row ``k`` is the ``k``-th event the ``impacts`` metric
#: counts, so rows past the log's length are counted but not logged.
EVENT_COLUMNS = ("t", "absorber", "side", "speed", "loss")
EVENT_T, EVENT_ABSORBER, EVENT_SIDE, EVENT_SPEED, EVENT_LOSS = range(len(EVENT_COLUMNS))


def new_events(capacity: int) -> np.ndarray:
    """An empty event log of ``capacity`` rows (``EVENT_COLUMNS``; NaN: no event)."""
    return np.full((capacity, len(EVENT_COLUMNS)), np.nan)
