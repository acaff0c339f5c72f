"""The signals a run records at its history points (SCENARIOS.md, "Signals"), declared by name:
``declare`` turns names into the columns the loop driver evaluates at each history point
(``kernels.common.signal_value``), so a history holds just the signals asked for; and the
metrics a scene declares as a signal's reduction over the metrics window (``[output] metrics``,
``<signal>_<reduction>``: ``declare_metrics``), which the driver folds in at every step's end;
and the names of the built-in metric columns (``METRICS``, ``floor_metrics``).  Plain Python (no
numba): the scenario checks read ``signal_names`` and ``sensitivity_metrics``."""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence

import numpy as np

#: Signals a history row can hold (SCENARIOS.md, "Signals"): the name's stem, its code and what
#: its number counts (floors or absorbers, from 1; none).  ``x1`` is the roof (as in the
#: metrics), ``x_k`` floor ``k`` from the lowest; a signal is one entry here and one line of
#: ``signal_value``.
SIGNALS = {
    "x": (0, "floor"),        # a floor's displacement
    "v": (1, "floor"),        # a floor's velocity
    "drift": (2, "floor"),    # a storey's drift, x_k - x_{k-1} (x_1 for the first)
    "xa": (3, "absorber"),    # an absorber's displacement
    "va": (4, "absorber"),    # an absorber's velocity
    "stroke": (5, "absorber"),  # an absorber's displacement less its host floor's
    "e1": (6, None),          # the structure's energy E1
    "share": (7, None),       # the absorbers' share of the energy, E_abs / (E1 + E_abs)
    "contact": (8, "absorber"),  # an absorber's contact or impact force on its host (or walls' body)
}
(SIGNAL_X, SIGNAL_V, SIGNAL_DRIFT, SIGNAL_XA, SIGNAL_VA, SIGNAL_STROKE, SIGNAL_E1,
 SIGNAL_SHARE, SIGNAL_CONTACT) = range(len(SIGNALS))


def signal_names(n_floors: int, n_absorbers: int = 0) -> list[str]:
    """The signals a structure of ``n_floors`` floors and ``n_absorbers`` absorbers can record
    (``share`` where it has absorbers)."""
    names = ["x1", "e1"] + (["share"] if n_absorbers else [])
    for stem, (_, counts) in SIGNALS.items():
        if counts is not None:
            n = n_floors if counts == "floor" else n_absorbers
            names += [f"{stem}_{k}" for k in range(1, n + 1)]
    return names


def declare(names: Iterable[str], n_floors: int, n_absorbers: int = 0) -> np.ndarray:
    """The history columns of the signals ``names``: rows ``(code, index)`` (``index``: the
    body, or the absorber for a stroke or a contact force, from 0) that the loop driver
    evaluates at each history point (``signal_value``).  A name that is not a signal
    (``signal_names``) is a ``ValueError``."""
    allowed = signal_names(n_floors, n_absorbers)
    rows = []
    for name in names:
        if name not in allowed:
            raise ValueError(f"signals: {name!r} is not a signal of this structure "
                             f"(allowed: {', '.join(allowed)})")
        whole = {"x1": (SIGNAL_X, n_floors - 1), "e1": (SIGNAL_E1, 0), "share": (SIGNAL_SHARE, 0)}
        if name in whole:
            rows.append(whole[name])
            continue
        stem, k = name.rsplit("_", 1)
        code, counts = SIGNALS[stem]
        index = int(k) - 1
        if counts == "absorber" and code not in (SIGNAL_STROKE, SIGNAL_CONTACT):
            index += n_floors
        rows.append((code, index))
    return np.array(rows, dtype=np.int64).reshape(len(rows), 2)



#: How a declared metric reduces its signal ``q`` over the metrics window (``[output] metrics``),
#: by name and code: ``peak`` the largest ``|q|``, ``max`` and ``min`` the largest and smallest
#: ``q``, ``mean`` and ``rms`` the time average of ``q`` and the root of that of ``q^2`` (the
#: trapezoid rule over the step ends, as ``x1_rms``).
REDUCTIONS = {"peak": 0, "max": 1, "min": 2, "mean": 3, "rms": 4}
REDUCE_PEAK, REDUCE_MAX, REDUCE_MIN, REDUCE_MEAN, REDUCE_RMS = range(len(REDUCTIONS))
#: The names of the absorbers' energy share over the metrics window (MODEL.md section 4; Wei et
#: al. eq. 21) as a declared metric: the reductions of the signal ``share`` they stand for.
SHARE_METRICS = {"energy_share_mean": "mean", "energy_share_max": "max"}
#: Raw metric slots a declared metric takes: what it folds, and the signal at the last step end.
REDUCTION_SLOTS = 2
#: The names of declared metrics: ``<signal>_<reduction>``.
METRIC_NAME = re.compile(rf"(x1|e1|share|({'|'.join(stem for stem, (_, n) in SIGNALS.items() if n)})"
                         rf"_[1-9][0-9]*)"
                         rf"_({'|'.join(REDUCTIONS)})|{'|'.join(SHARE_METRICS)}")
#: The built-in metric columns (``METRICS``) that read as a declared metric's name: a
#: declared metric may not take them (``tests/unit/statistics`` checks the list).
BUILT_IN = ("x1_max", "x1_rms", "e1_max")


def declare_metrics(names: Iterable[str], n_floors: int, n_absorbers: int = 0,
                    taken: Iterable[str] = BUILT_IN) -> np.ndarray:
    """The rows ``(code, index, reduction)`` of the declared metrics ``names``, each
    ``<signal>_<reduction>`` (a signal of ``signal_names``, a reduction of ``REDUCTIONS``:
    ``stroke_1_peak``, ``va_2_rms``, ``e1_mean``; or one of ``SHARE_METRICS``), that the loop
    driver folds in at every step's end.  A name that is none, or one of ``taken`` (the built-in
    metric columns: ``BUILT_IN``), is a ``ValueError`` saying what is allowed."""
    rows = []
    for name in names:
        signal, _, reduction = name.rpartition("_")
        if name in SHARE_METRICS:
            signal, reduction = "share", SHARE_METRICS[name]
        if name in taken:
            raise ValueError(f"metrics: {name!r} is a built-in metric already")
        if reduction not in REDUCTIONS or not signal:
            raise ValueError(f"metrics: {name!r} must be <signal>_<reduction>, the reduction one of "
                             f"{', '.join(REDUCTIONS)}")
        (code, index), = declare([signal], n_floors, n_absorbers)
        rows.append((code, index, REDUCTIONS[reduction]))
    return np.array(rows, dtype=np.int64).reshape(len(rows), 3)


#: Metric columns of realizations.parquet, in order (then the per-floor columns of
#: ``floor_metrics``); each gets summary statistics.
METRICS = (
    "input_energy", "edm", "energy_integral", "e1_max", "x1_max", "x1_rms", "impacts",
    "energy_residual", "primary_dissipation", "absorber_dissipation", "impact_loss",
    "impacts_left", "impacts_right", "peak_force", "contact_time",
)

#: Per-floor metric columns, ``<name>_<k>`` for floor ``k = 1..n`` (MODEL.md section 4).
FLOOR_METRICS = ("x_max", "x_rms", "drift_max", "acc_max")


def floor_metrics(n_floors: int) -> list[str]:
    """The per-floor metric columns of a primary with ``n_floors`` floors, floor by floor."""
    return [f"{name}_{k}" for k in range(1, n_floors + 1) for name in FLOOR_METRICS]


#: The suffix naming the top floor in a per-floor metric: ``x_max_roof`` is ``x_max_n`` of an
#: n-floor primary (``x1_max``, the roof's peak displacement, by another name).
ROOF = "_roof"


def floor_name(name: str, n_floors: int) -> str:
    """``name`` with its ``_roof`` suffix as the top floor's number (``drift_ratio_max_roof`` ->
    ``drift_ratio_max_3`` on three floors; ``p_roof`` and other names as given)."""
    stem = name[:-len(ROOF)]
    return f"{stem}_{n_floors}" if name.endswith(ROOF) and f"{stem}_1" in _FLOORED and n_floors else name


#: The per-floor metrics' first columns, for ``floor_name`` (drift ratios with storey heights).
_FLOORED = {f"{m}_1" for m in (*FLOOR_METRICS, "drift_ratio_max")}


def floors_in(columns: Iterable[str]) -> int:
    """The floors of a table with per-floor columns ``x_max_k`` (0: none)."""
    names, n = set(columns), 0
    while f"x_max_{n + 1}" in names:
        n += 1
    return n


def sensitivity_metrics(n_floors: int, limits: Sequence[str], declared: Sequence[str]) -> set[str]:
    """What ``[sensitivity] metric`` may name: a metric column (``METRICS``, the floors', the
    declared ``[output] metrics``) or ``p_NAME`` for a limit NAME (its exceedance indicator)."""
    return {*METRICS, *floor_metrics(n_floors), *declared, *(f"p_{name}" for name in limits)}
