"""Per-realisation metrics (MODEL.md section 4) and the ensemble statistics of summary.parquet."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd

from .notices import DivergedWarning, EnergyBalanceWarning, Notice
from .outputs import (
    ACC_MAX_K,
    DRIFT_MAX_K,
    SLOTS,
    STATUS_DIVERGED,
    X_MAX_K,
    X_SQ_INT_K,
    declared_slots,
    passage_slots,
)
from .scenario.settings import REGIME_SAMPLES
from .scene import Scene
from .signals import (  # (the metric columns' names: beside the declared metrics')
    METRIC_NAME,
    METRICS,
    REDUCE_MEAN,
    REDUCE_RMS,
    REDUCTION_SLOTS,
    floor_metrics,
    floors_in,
)

#: Longest period (in forcing periods) the regime detection looks for.
MAX_PERIOD = 8
#: Poincare samples repeating to this fraction of the response amplitude count as periodic.
PERIODIC_TOLERANCE = 1e-3

#: Statistics of each metric in summary.parquet, as ``<metric>_<stat>``.
STATISTICS = ("mean", "std", "sem", "ci95_lo", "ci95_hi", "q05", "q50", "q95")

_S = {name: i for i, name in enumerate(SLOTS)}

def metric_columns(frame: pd.DataFrame) -> list[str]:
    """The metric columns present in a realisations table: ``METRICS``, the floors', then the
    declared ones (``[output] metrics``: ``signals.METRIC_NAME``)."""
    n = floors_in(frame.columns)
    declared = [c for c in frame.columns
                if isinstance(c, str) and METRIC_NAME.fullmatch(c) and c not in METRICS]
    ratios = [c for c in [*(f"drift_ratio_max_{k}" for k in range(1, n + 1)), "drift_ratio_max"]
              if c in frame]
    return list(METRICS) + floor_metrics(n) + ratios + declared


def regime(samples: np.ndarray, omega: float) -> str | None:
    """Regime ``nT,k,m`` of a periodically forced response (MODEL.md section 4) from Poincare
    samples (rows of positions, velocities, cumulative left and right impacts, one per forcing
    period): the smallest ``n <= MAX_PERIOD`` with which the samples repeat, and the left and
    right impacts over the last ``n`` periods.  ``"aperiodic"`` when none repeats (a run's table
    names those, ``dynamics.refine_regimes``); None without samples."""
    return regimes(samples[np.newaxis], np.array([omega]))[0]


def regimes(samples: np.ndarray, omega: np.ndarray) -> list[str | None]:
    """``regime`` of the Poincare samples of each realisation (``samples``: ``(rows, samples,
    columns)``, each row's samples a prefix of it, NaN after; ``omega``: one a row), read from
    each row's last ``REGIME_SAMPLES``, with numpy over the rows that hold as many samples (a
    chunk's realisations: one pass)."""
    nb = (samples.shape[2] - 2) // 2
    ends = (~np.isnan(samples[:, :, 0])).sum(axis=1)
    found: list[str | None] = [None] * samples.shape[0]
    for end in np.unique(ends[ends >= 3]):
        where = np.flatnonzero(ends == end)
        rows = samples[where, max(0, end - REGIME_SAMPLES):end]
        count = rows.shape[1]
        state = np.concatenate([rows[:, :, :nb], rows[:, :, nb:2 * nb] / omega[where, None, None]], axis=2)
        scale = np.abs(state).max(axis=(1, 2))
        scale[scale == 0] = 1.0
        period = np.zeros(where.shape[0], np.int64)  # (0: none found yet)
        for n in range(1, min(MAX_PERIOD, (count - 1) // 2) + 1):
            repeats = np.abs(state[:, n:] - state[:, :-n]).max(axis=(1, 2)) <= PERIODIC_TOLERANCE * scale
            period[(period == 0) & repeats] = n
        # impacts per n periods, averaged over every whole cycle sampled
        n = np.maximum(period, 1)
        cycles = (count - 1) // n
        earlier = rows[np.arange(where.shape[0]), count - 1 - cycles * n, 2 * nb:]
        impacts = (rows[:, -1, 2 * nb:] - earlier) / cycles[:, None]
        labels: dict[tuple, str] = {}
        for i, p, (left, right) in zip(where, period, impacts):
            key = (p, left, right) if p else (0,)
            if key not in labels:
                labels[key] = f"{'' if p == 1 else p}T,{left:.0f},{right:.0f}" if p else "aperiodic"
            found[i] = labels[key]
    return found


def finish_table(raw: np.ndarray, scene: Scene | Sequence[Scene],
                 samples: Sequence[np.ndarray | None] | np.ndarray | None = None) -> pd.DataFrame:
    """Metric columns of realisations, one a row of ``raw`` (a kernel's raw vector: ``SLOTS``,
    the per-floor blocks, the first passages): ``METRICS``, the floors' (``floor_metrics``),
    ``first_passage_<limit>``, ``status`` and ``regime`` (``"string"``, from the rows' Poincare
    ``samples`` where the scene is periodically forced).  ``scene``: that of every row, or one
    a row (an uncertain study's realisations: the same floors and limits, their own window and
    forcing period)."""
    raw = np.asarray(raw, dtype=np.float64)
    if raw.ndim != 2:
        raise ValueError(f"finish_table: raw must be 2-D (realisations, slots), not of shape {raw.shape}")
    n = raw.shape[0]
    if isinstance(scene, Scene):
        scenes, window = None, scene.window
    else:
        scenes = list(scene)
        if len(scenes) != n or len({(s.n_floors, s.limit_names) for s in scenes}) > 1:
            raise ValueError(f"finish_table: {len(scenes)} scenes for {n} rows; give one scene, or one "
                             "a row, all with the same floors and limits")
        scene, window = scenes[0], np.array([s.window for s in scenes])
    slots = np.ascontiguousarray(raw.T)  # (a slot's values contiguous: the columns are views)
    slot = {name: slots[i] for name, i in _S.items()}
    counts = slots[[_S["impacts"], _S["impacts_left"], _S["impacts_right"]]]
    if not (np.abs(counts) < 2.0**63).all():  # (as int() refuses them)
        raise ValueError("finish_table: impact counts must be finite integers")
    input_energy = slot["input_energy"]
    absorbed = slot["absorber_dissipation"] + slot["impact_loss"]
    dissipated = absorbed + slot["primary_dissipation"]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        positive = input_energy > 0  # (NaN where not: no energy in, or none defined)
        edm = np.where(positive, absorbed / input_energy, np.nan)
        imbalance = input_energy - slot["final_energy"] - dissipated
        residual = np.where(positive, imbalance / input_energy, np.nan)

        def rms(square_integral: np.ndarray) -> np.ndarray:  # (negative -> 0 as max(v, 0.0): NaN, -0.0 kept)
            return np.sqrt(np.where(square_integral < 0, 0.0, square_integral) / window)

        columns: dict[str, np.ndarray] = {
            "input_energy": input_energy,
            "edm": edm,
            "energy_integral": slot["energy_integral"],
            "e1_max": slot["e1_max"],
            "x1_max": slot["x1_max"],
            "x1_rms": rms(slot["x1_square_integral"]),
            "impacts": counts[0].astype(np.int64),
            "energy_residual": residual,
            "primary_dissipation": slot["primary_dissipation"],
            "absorber_dissipation": slot["absorber_dissipation"],
            "impact_loss": slot["impact_loss"],
            "impacts_left": counts[1].astype(np.int64),
            "impacts_right": counts[2].astype(np.int64),
            "peak_force": slot["peak_force"],
            "contact_time": slot["contact_time"],
        }
        nf = scene.n_floors
        for k in range(nf):
            floor = len(SLOTS) + k  # the floor's entry of the first per-floor block (FLOOR_SLOTS)
            columns[f"x_max_{k + 1}"] = slots[floor + X_MAX_K * nf]
            columns[f"x_rms_{k + 1}"] = rms(slots[floor + X_SQ_INT_K * nf])
            columns[f"drift_max_{k + 1}"] = slots[floor + DRIFT_MAX_K * nf]
            columns[f"acc_max_{k + 1}"] = slots[floor + ACC_MAX_K * nf]
        if scene.heights.size:  # inter-storey drift ratios (MODEL.md 1a) and their largest
            ratios = [columns[f"drift_max_{k + 1}"] / scene.heights[k] for k in range(nf)]
            for k, ratio in enumerate(ratios):
                columns[f"drift_ratio_max_{k + 1}"] = ratio
            columns["drift_ratio_max"] = np.max(ratios, axis=0)
    finite = np.ones(n, dtype=bool)
    for name, values in columns.items():
        if name not in ("edm", "energy_residual") and values.dtype.kind == "f":
            finite &= np.isfinite(values)
    passages = passage_slots(nf)
    for limit, name in enumerate(scene.limit_names):  # (NaN where a limit never passed)
        columns[f"first_passage_{name}"] = slots[passages + limit]
    declared = declared_slots(nf, len(scene.limit_names))
    dt = scene.dt if scenes is None else np.array([s.dt for s in scenes])
    for r, name in enumerate(scene.metric_names):  # (``signals.declare_metrics``)
        folded, last = slots[declared + REDUCTION_SLOTS * r], slots[declared + REDUCTION_SLOTS * r + 1]
        op = scene.reductions[r, 2]
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            if op == REDUCE_MEAN:  # (the trapezoid rule: the last step end at half weight, as x1_rms)
                folded = (folded - 0.5 * last) * dt / window
            elif op == REDUCE_RMS:
                folded = rms((folded - 0.5 * last * last) * dt)
        columns[name] = folded
        finite &= np.isfinite(folded)
    ok = finite & (slot["status"] != STATUS_DIVERGED) & ~failed_balance(slot, dissipated, imbalance)
    # string columns as codes into their few values (far faster than a string a row)
    columns["status"] = pd.Series(["diverged", "ok"]).array.take(ok.astype(np.intp))
    codes, labels = np.zeros(n, dtype=np.intp), {None: 0}
    stacked = _stacked(samples, n)
    if stacked is not None:
        kept = np.flatnonzero(ok)
        period = (np.full(n, scene.period) if scenes is None else np.array([s.period for s in scenes]))[kept]
        for i, label in zip(kept, regimes(stacked[kept], 2.0 * np.pi / period)):
            codes[i] = labels.setdefault(label, len(labels))
    columns["regime"] = pd.array(list(labels), dtype="string").take(codes)
    return pd.DataFrame(columns, copy=False)  # (the arrays are this table's alone)


def failed_balance(slot: dict[str, np.ndarray], dissipated: np.ndarray, imbalance: np.ndarray) -> np.ndarray:
    """Whether each row's energy accounts say its scheme failed (``FAILED_BALANCE``), given the
    rows' accounts (``slot``), their dissipation in all and their ``imbalance`` (input less final
    energy less dissipation; ``finish_table``'s): where energy went in, a balance off by more than
    that share of the input (``|energy_residual|``); where none did (no residual is defined), a
    balance off by more than that share of the largest account; and anywhere a dissipation
    negative by more than it (a dashpot or an impact gives energy back only within the scheme's
    error).  A row with no energy at all passes."""
    input_energy = slot["input_energy"]
    accounts = (input_energy, slot["final_energy"], slot["primary_dissipation"], slot["absorber_dissipation"],
                slot["impact_loss"])
    with np.errstate(invalid="ignore", over="ignore"):
        scale = np.where(input_energy > 0, input_energy, np.max(np.abs(accounts), axis=0))
        return (np.abs(imbalance) > FAILED_BALANCE * scale) | (dissipated < -FAILED_BALANCE * scale)


def _stacked(samples: Sequence[np.ndarray | None] | np.ndarray | None, n: int) -> np.ndarray | None:
    """Rows' Poincare samples as one array ``(n, samples, columns)`` (a row given None or none:
    NaN; a row with fewer samples than the longest: NaN after them), or None where no row has
    any."""
    if isinstance(samples, np.ndarray):
        return samples if samples.ndim == 3 and samples.shape[1] else None
    given = [np.asarray(s, dtype=float) for s in samples or () if s is not None and np.size(s)]
    if not given:
        return None
    stacked = np.full((n, max(s.shape[0] for s in given), given[0].shape[1]), np.nan)
    for i, s in enumerate(samples):
        if s is not None and np.size(s):
            stacked[i, :len(s)] = s
    return stacked


def finish(raw: np.ndarray, scene: Scene, samples: np.ndarray | None = None) -> dict[str, float | str | None]:
    """The row of one realisation (``finish_table``) as a dict of Python values, ``regime``
    None where undefined."""
    row = finish_table(raw[np.newaxis], scene, None if samples is None else [samples]).to_dict("records")[0]
    row["regime"] = None if row["regime"] is pd.NA else row["regime"]
    return row


def ground_intensity(scene: Scene, streams) -> dict[str, float]:
    """``sa`` and ``pga`` (``ground_intensities``) of one realisation, from its streams (a
    fresh copy of those it ran with: ``kernels.load_history`` gives the same path)."""
    from .kernels import load_history

    _, _, ground = load_history(scene, streams)
    return {key: float(values[0]) for key, values in ground_intensities(scene, ground[np.newaxis]).items()}


def ground_intensities(scene: Scene, ground: np.ndarray | None) -> dict[str, np.ndarray]:
    """``sa`` (pseudo-spectral acceleration at ``scene.im_period``, ``im_damping``) and ``pga``
    of ground acceleration paths on the scene's time grid (``ground``: one a row), or nothing
    where the scene asks for no intensity measure."""
    from .physics.spectra import peak, pseudo_acceleration

    if scene.im_period <= 0 or ground is None:
        return {}
    sa = pseudo_acceleration(ground, scene.dt, scene.im_period, scene.im_damping)
    return {"sa": np.asarray(sa, dtype=float), "pga": np.asarray(peak(ground), dtype=float)}


def undefined_notes(ok: pd.DataFrame, metrics: list[str]) -> str:
    """Why statistics of a sweep point are undefined (NaN), one reason per cause ("" if none):
    no realisation ended ok, one did (no spread), or metrics undefined in some realisations
    (``edm`` and ``energy_residual`` where the loads put no energy in)."""
    notes = []
    if len(ok) == 0:
        notes.append("no realisation ended ok (see status in realizations.parquet): "
                     "every statistic undefined")
    elif len(ok) == 1:
        notes.append("one realisation ended ok: std, sem and ci95 undefined")
    idle = int((ok["input_energy"] <= 0).sum()) if "input_energy" in ok else 0
    if idle:
        notes.append(f"{idle} realisation(s) without input energy (the loads put none in): edm and "
                     "energy_residual undefined there and in their statistics")
    explained = {"edm", "energy_residual"} if idle else set()
    for m in metrics:
        bad = int(ok[m].isna().sum()) if m in ok else 0
        if bad and m not in explained:
            notes.append(f"{m} undefined in {bad} realisation(s)")
    return "; ".join(notes)


def residual_notes(ok: pd.DataFrame, tolerance: float) -> str:
    """The realisations ended ok whose energy balance does not close: ``|energy_residual|``
    above ``tolerance`` ("" if none), their count and the largest (MODEL.md section 4)."""
    if "energy_residual" not in ok or len(ok) == 0:
        return ""
    residual = ok["energy_residual"].abs()
    over = residual > tolerance
    if not over.any():
        return ""
    return (f"{int(over.sum())} of {len(ok)} realisation(s) with |energy_residual| above {tolerance:g} "
            f"(largest {residual.max():.3g}): their energy balance does not close; a smaller "
            "simulation.dt makes it")


#: The share of the input energy an energy balance may miss before a realisation counts as
#: diverged rather than ok (MODEL.md section 4: ``energy_residual``): far above any accuracy
#: tolerance (``simulation.residual_tolerance``, 1e-3 by default), an error that large means the
#: scheme failed (a step past what the scene's stiffest law allows), not that it is coarse.
FAILED_BALANCE = 0.5


def residual_warnings(realizations: pd.DataFrame, source: str, tolerance: float) -> list[Notice]:
    """One line per sweep point with realisations that diverged, and one per sweep point with
    realisations ended ok whose energy balance does not close (``residual_notes``, the same words
    as the summary's ``notes``), from the file ``source``."""
    lines = []
    points = realizations.groupby("point", sort=True)
    for point, group in points:
        where = f"sweep point {point}: " if len(points) > 1 else ""
        failed = int((group["status"] != "ok").sum())
        if failed:
            why = ("status: a path that grew without bound, a metric not finite, or energy accounts that say "
                   "the scheme failed, such as a balance off by more than half the input")
            lines.append(Notice(f"{source}: {where}{failed} of {len(group)} realisation(s) diverged ({why}); "
                                "a smaller simulation.dt makes them run", DivergedWarning))
        note = residual_notes(group[group["status"] == "ok"], tolerance)
        if note:
            lines.append(Notice(f"{source}: {where}{note} (simulation.residual_tolerance = {tolerance:g})",
                                EnergyBalanceWarning))
    return lines


def limit_names(frame: pd.DataFrame) -> list[str]:
    """The limits of a realisations table (its ``first_passage_NAME`` columns), in order."""
    return [c[len("first_passage_"):] for c in frame.columns if c.startswith("first_passage_")]


def exceedance(passed: float, n: int) -> tuple[float, float, float]:
    """Fraction ``passed / n`` of realisations whose peak exceeded a limit, with its 95 % Wilson
    score interval (``scipy.stats.binomtest``; Wilson, J. Am. Stat. Assoc. 22 (1927) 209,
    DOI 10.1080/01621459.1927.10502953): its coverage stays close to 95 % for small ``n`` and
    fractions near 0 or 1, where the normal approximation fails.  NaN for ``n = 0``.  A count
    that is not whole (a rare-event estimate's count of equal information,
    ``fragility.rare_counts``) takes Wilson's closed form."""
    from scipy.stats import binomtest, norm  # (scipy.stats takes about 0.5 s to import)

    if n == 0:
        return math.nan, math.nan, math.nan
    if passed != int(passed):
        z, p = float(norm.isf(0.025)), passed / n
        centre, half = p + z * z / (2 * n), z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
        return p, (centre - half) / (1 + z * z / n), (centre + half) / (1 + z * z / n)
    ci = binomtest(int(passed), n).proportion_ci(confidence_level=0.95, method="wilson")
    return passed / n, float(ci.low), float(ci.high)


def _quantiles(values: np.ndarray) -> list[float]:
    """``np.quantile(values, [0.05, 0.5, 0.95])`` (NaN where there are none), bit for bit: NaN
    where a value is NaN, the value where all are the same finite number (a metric the scene
    does not exercise: impacts of a bare structure), else ``order.quantiles``."""
    if not values.size:
        return [np.nan] * 3
    low, high = values.min(), values.max()
    if np.isnan(low):
        return [np.nan] * 3
    if low == high and np.isfinite(low):
        return [float(low)] * 3
    from .order import quantiles  # (compiled: numba is imported on first use)

    return [float(v) for v in quantiles(values, np.array([0.05, 0.5, 0.95]))]


def summarise(realizations: pd.DataFrame, parameters: list[str],
              residual_tolerance: float = 1e-3) -> pd.DataFrame:
    """One row per sweep point: parameters, ``n_ok``, ``n_failed``, ``notes`` (why statistics
    are undefined: ``undefined_notes``; realisations whose energy residual is above
    ``residual_tolerance``: ``residual_notes``) and ``M_<stat>`` per metric
    (``STATISTICS``; ``sem`` is the standard error of the mean and ``ci95_lo``, ``ci95_hi`` its
    95 % Student-t confidence interval); per limit (``first_passage_NAME`` columns) ``p_NAME``,
    ``p_NAME_lo``, ``p_NAME_hi``: the fraction of the realisations ended ok whose peak exceeded
    it, with its 95 % interval (``exceedance``).

    Failed realisations are counted, never averaged in.
    """
    from functools import cache

    from scipy.stats import t as student_t  # (scipy.stats takes about 0.5 s to import)

    @cache
    def t_bounds(n: int) -> tuple[float, float]:
        """The 95 % interval of Student's t with ``n - 1`` degrees of freedom (NaN for ``n < 2``)."""
        return tuple(map(float, student_t.interval(0.95, n - 1))) if n > 1 else (np.nan, np.nan)

    rows = []
    points = realizations["point"].to_numpy()
    one = points.size > 0 and points.min() == points.max()  # (one point: its rows as they are)
    for point, group in [(points[0], realizations)] if one else realizations.groupby("point", sort=True):
        fine = (group["status"] == "ok").to_numpy()
        ok = group if fine.all() else group[fine]  # (no copy where every realisation ended ok)
        row: dict[str, float | int] = {"point": int(point)}
        for p in parameters:
            row[p] = group[p].iloc[0]
        row["n_ok"] = len(ok)
        row["n_failed"] = len(group) - len(ok)
        notes = (undefined_notes(ok, metric_columns(realizations)), residual_notes(ok, residual_tolerance))
        row["notes"] = "; ".join(n for n in notes if n)
        for m in metric_columns(realizations):
            values = ok[m].to_numpy(dtype=float)
            n = values.size
            std = float(np.std(values, ddof=1)) if n > 1 else np.nan
            q = _quantiles(values)
            row[f"{m}_mean"] = float(values.mean()) if n else np.nan
            row[f"{m}_std"] = std
            sem = std / np.sqrt(n) if n > 1 else np.nan
            row[f"{m}_sem"] = sem
            low, high = t_bounds(n)
            mean = row[f"{m}_mean"]
            row[f"{m}_ci95_lo"], row[f"{m}_ci95_hi"] = mean + low * sem, mean + high * sem
            row[f"{m}_q05"], row[f"{m}_q50"], row[f"{m}_q95"] = (float(v) for v in q)
        for name in limit_names(realizations):
            passed = int(ok[f"first_passage_{name}"].notna().sum())
            row[f"p_{name}"], row[f"p_{name}_lo"], row[f"p_{name}_hi"] = exceedance(passed, len(ok))
        rows.append(row)
    return pd.DataFrame(rows)
