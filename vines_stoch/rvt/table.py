"""``estimate(scenario)``: one row a sweep point of the response's second-order statistics and the
metrics that follow from them, without an ensemble (MODEL.md section 6), and ``beside``: those
estimates next to a run's Monte Carlo summary, with the distance in standard errors."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from ..physics.absorbers import BISTABLE, HERTZ, K_CUBIC, SHAPED
from . import energy, linearization, moments, passage
from .system import Model, NotApplicable, bare, build, check_laws

#: Grid steps of the time-varying moments: linear scenes, at most, and nonlinear ones (one
#: linearisation a step), at most; at least this many points a period of the fastest mode.
LINEAR_STEPS, NONLINEAR_STEPS, STEPS_PER_PERIOD, MIN_STEPS = 1600, 200, 12, 100
#: Frequency points of the spectral moment ``lambda_1`` (Vanmarcke's bandwidth).
SPECTRUM_POINTS = 1500
#: Metrics of the realisations table an estimate row may carry (per floor: ``_k``).
METHODS = ("exact-linear", "statistical-linearization", "not-applicable")


@dataclass
class _Output:
    """A linear read-out ``y = row . z + feed(t)``: ``name`` (``x_3``, ``drift_1``, ...)."""

    name: str
    row: np.ndarray
    feed: int | None = None  # body whose deterministic force accelerations add to y (accelerations)


def _outputs(model: Model, scene) -> list[_Output]:
    nf = model.n_floors
    out = [_Output(f"x_{k + 1}", model.x(k)) for k in range(nf)]
    out += [_Output(f"drift_{k + 1}", model.x(k) - (model.x(k - 1) if k else 0.0)) for k in range(nf)]
    out += [_Output(f"stroke_{a + 1}", model.x(nf + a) - model.x(int(scene.host[a])))
            for a in range(len(scene.kind))]
    out += [_Output(f"acc_{k + 1}", model.acceleration(k), feed=k) for k in range(nf)
            if k not in model.white_floors]
    return out


def _grid(model: Model, duration: float, nonlinear: bool) -> int:
    """Steps of the time grid over the scene's duration (``STEPS_PER_PERIOD`` a period of its
    fastest mode or harmonic force, within ``MIN_STEPS`` and the cap)."""
    fastest = max([float(np.abs(np.linalg.eigvals(model.a).imag).max(initial=0.0))]
                  + [w for w, _, _ in model.harmonics])
    steps = math.ceil(duration * fastest / (2.0 * math.pi) * STEPS_PER_PERIOD)
    return int(min(max(steps, MIN_STEPS), NONLINEAR_STEPS if nonlinear else LINEAR_STEPS))


def _forcing(path: moments.Trajectory) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``b(t)`` (T, N) and the force accelerations ``feed(t)`` and their rates (T, bodies) on the
    path's grid (the constant parts of the model of each time: a linearised law's mean force)."""
    t = path.t
    if len(path.models) > 1:
        b = np.array([m.constant for m in path.models])
        feed = np.array([m.feed for m in path.models])
    else:
        b = np.repeat(path.models[0].constant[None], len(t), axis=0)
        feed = np.repeat(path.models[0].feed[None], len(t), axis=0)
    rate = np.zeros_like(feed)
    for w, g, force in path.models[0].harmonics:
        e = np.exp(1j * w * t)[:, None]
        b += np.real(e * g[None])
        feed += np.real(e * force[None])
        rate += np.real(1j * w * e * force[None])
    return b, feed, rate


def _nonlinear(scene) -> np.ndarray:
    """The absorbers whose law is not linear: a cubic term, a shaped spring (geometric, gap) or
    Hertz contact (a ``cubic`` absorber of zero cubic stiffness is a linear one)."""
    return ((scene.rows[:, K_CUBIC] != 0.0) | (scene.rows[:, SHAPED] != 0.0).any(axis=1)
            | (scene.kind == HERTZ))


def _statistics(path: moments.Trajectory, out: _Output, b: np.ndarray, feed: np.ndarray,
                rate: np.ndarray) -> dict[str, np.ndarray] | None:
    """The output's moments on the grid: mean, standard deviation, the derivative's mean and
    standard deviation, their covariance; None for the derivative's where ``y`` is not
    differentiable (a noise column reaches it directly)."""
    c = out.row
    a = (np.array([path.model_at(i).a for i in range(len(path.t))]) if len(path.models) > 1
         else path.models[0].a)
    ca = c @ a if a.ndim == 2 else np.einsum("j,tjk->tk", c, a)
    m = path.m @ c
    s = np.sqrt(np.maximum(np.einsum("j,tjk,k->t", c, path.p, c), 0.0))
    if out.feed is not None:
        m = m + feed[:, out.feed]
    stats = {"m": m, "s": s}
    noise = path.models[-1].noise
    if noise.size and np.abs(c @ noise).max() > 1e-12 * max(np.abs(ca).max(), 1e-300):
        return stats
    if a.ndim == 2:
        dm = path.m @ ca + b @ c
        ds = np.sqrt(np.maximum(np.einsum("j,tjk,k->t", ca, path.p, ca), 0.0))
        cov = np.einsum("j,tjk,k->t", c, path.p, ca)
    else:
        dm = np.einsum("tk,tk->t", path.m, ca) + b @ c
        ds = np.sqrt(np.maximum(np.einsum("tj,tjk,tk->t", ca, path.p, ca), 0.0))
        cov = np.einsum("j,tjk,tk->t", c, path.p, ca)
    if out.feed is not None:
        dm = dm + rate[:, out.feed]
    stats.update(dm=dm, ds=ds, cov=cov)
    return stats


def _bandwidth(model: Model, rows: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Vanmarcke's bandwidth of each stationary output (``rows``): ``lambda_0``, ``lambda_2`` from the
    stationary covariance ``p``, ``lambda_1`` from the one-sided spectrum on a log grid."""
    lam, v = np.linalg.eig(model.a)
    eig = np.abs(lam[np.abs(lam) > 0])
    omega = np.geomspace(eig.min() * 1e-3, eig.max() * 1e3, SPECTRUM_POINTS)
    # H(w) = rows V (i w - L)^-1 V^-1 B, mode by mode (a defective drift is left to rounding here:
    # the bandwidth only shapes Vanmarcke's factor)
    left, right = rows @ v, np.linalg.solve(v, model.noise.astype(complex))
    modes = 1.0 / (1j * omega[None, :] - lam[:, None])  # (n, omega)
    h = np.einsum("ok,kw,kq->owq", left, modes, right)
    spectrum = (np.sum(np.abs(h) ** 2, axis=2) / np.pi).T  # one-sided: 2 S(omega)
    lam1 = np.trapezoid(omega[:, None] * spectrum, omega, axis=0)
    lam0 = np.einsum("ij,jk,ik->i", rows, p, rows)
    ra = rows @ model.a
    lam2 = np.einsum("ij,jk,ik->i", ra, p, ra)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.sqrt(np.clip(1.0 - lam1**2 / (lam0 * lam2), 0.0, 1.0))


def _mean_square_spread(path: moments.Trajectory, rows: np.ndarray, i0: int) -> np.ndarray:
    """``Var(int_{t0}^{T} y^2 dt)`` of the zero-mean part of each output ``y = rows[i] . z``:
    ``4 int g_s^T G(T - s) g_s ds``, ``g_s = P(s) c``, ``G(tau) = G_inf - e^{A^T tau} G_inf e^{A tau}``
    the output's Gramian over ``tau`` (Gaussian fourth moments, ``Cov(y_t^2, y_s^2) = 2 R(t, s)^2``;
    the model of the window's end, exact for a linear scene); NaN without a stationary law."""
    a = path.models[-1].a
    if not moments.stable(a):
        return np.full(len(rows), math.nan)
    from scipy.linalg import solve_continuous_lyapunov

    grams = [solve_continuous_lyapunov(a.T, -np.outer(r, r)) for r in rows]
    t = path.t[i0:]
    if len(t) < 2:
        return np.zeros(len(rows))
    phi = moments.expm(a * (t[1] - t[0]))
    vectors = np.einsum("tjk,ik->tji", path.p[i0:], rows)  # (T, n, outputs)
    values = np.empty((len(t), len(rows)))
    power = np.eye(a.shape[0])
    for i in range(len(t) - 1, -1, -1):  # e^{A (T - s_i)} g_i
        w, far = vectors[i], power @ vectors[i]
        for o, gram in enumerate(grams):
            values[i, o] = w[:, o] @ gram @ w[:, o] - far[:, o] @ gram @ far[:, o]
        power = power @ phi
    return 4.0 * np.trapezoid(values, t, axis=0)


def _point(scenario, limits: dict) -> dict[str, Any]:
    """The estimate row of one sweep point (``method``, ``note`` and the columns it can give)."""
    from ..scene import build_scene, scene_filters

    scene = build_scene(scenario)
    filters = scene_filters(scenario)
    limits = {name: _storey_limit(metric, value, scene.heights) for name, (metric, value) in limits.items()}
    path, stationary, nonlinear, notes = _moments(scene, filters)
    random = bool(scene.sigma.any() or filters)
    i0 = min(int(np.searchsorted(path.t, scene.i0 * scene.dt - 1e-9 * scene.dt)), len(path.t) - 2)
    t = path.t[i0:]
    b, feed, rate = _forcing(path)
    row: dict[str, Any] = {"method": "statistical-linearization" if nonlinear else "exact-linear",
                           "stationary_law": stationary is not None}
    outputs = _outputs(path.models[-1], scene)  # (accelerations: the end's linearised forces)
    deltas = {}
    if stationary is not None:
        rows = np.array([o.row for o in outputs])
        deltas = dict(zip((o.name for o in outputs), _bandwidth(stationary[0], rows, stationary[2])))
    spreads = {}
    floors = [o for o in outputs if o.name.startswith("x_")]
    if random and t[-1] > t[0]:
        values = _mean_square_spread(path, np.array([o.row for o in floors]), i0) / (t[-1] - t[0]) ** 2
        spreads = dict(zip((o.name for o in floors), values))
    for out in outputs:
        stats = {k: v[i0:] for k, v in _statistics(path, out, b, feed, rate).items()}
        row.update(_output_columns(out.name, t, stats, spreads.get(out.name), deltas.get(out.name), random))
        row.update(_limit_columns(out.name, t, stats, deltas.get(out.name), random, limits, scene.n_floors))
    base = bare(scene, filters)
    b_external, _, _ = _forcing(moments.Trajectory(path.t, path.m, path.p, [base]))
    row.update(energy.accounts(path, i0, scene, base, b_external))
    _aliases(row, scene)
    row["note"] = "; ".join(notes)
    return row


def _moments(scene, filters: list) -> tuple[moments.Trajectory, tuple | None, bool, list[str]]:
    """``(path, stationary, nonlinear, notes)``: the moments on the time grid from the scene's start
    (exact for a linear scene, the time-varying statistical linearisation otherwise, a bistable
    law's reported fixed point), the stationary law ``(model, mean, covariance)`` where there is
    one, whether a law is nonlinear, and the notes (the bistable law's fixed points)."""
    check_laws(scene)
    nonlinear = bool(_nonlinear(scene).any())
    random = bool(scene.sigma.any() or filters)
    if nonlinear and not random:
        raise NotApplicable("a deterministic load on a nonlinear absorber: statistical linearisation "
                            "needs a random load (vines_stoch.solve integrates the path)")
    zero = np.zeros(len(scene.kind))
    model = linearization.linearized(scene, filters, zero, zero)
    notes, stationary = [], None
    if nonlinear:
        stationary, note = _stationary_fixed_point(scene, filters, model)
        notes += [note] if note else []
    elif random and moments.stable(model.a):
        stationary = (model, moments.constant_response(model), moments.stationary_covariance(model))
    duration = scene.n_steps * scene.dt
    steps = _grid(stationary[0] if stationary else model, duration, nonlinear)

    def relinearize(m: np.ndarray, p: np.ndarray) -> Model:
        mu, s = linearization.strokes(model, scene, m, p)
        return linearization.linearized(scene, filters, linearization.settle(scene, mu, s), s)

    if stationary is not None and (scene.kind == BISTABLE).any():
        # (from its symmetric start the Gaussian closure cannot choose a well: the window's
        # statistics are those of the reported stationary fixed point)
        _, mean, cov = stationary
        path = moments.Trajectory(np.linspace(0.0, duration, steps + 1),
                                  np.repeat(mean[None], steps + 1, axis=0),
                                  np.repeat(cov[None], steps + 1, axis=0), [stationary[0]])
    elif nonlinear:
        path = moments.propagate_linearized(model, duration, steps, relinearize)
    else:
        path = moments.propagate(model, duration, steps)
    if nonlinear and not _settled(path, stationary):
        raise NotApplicable("the time-varying linearisation ran away from its stationary fixed point")
    return path, stationary, nonlinear, notes


#: Peak metrics of the outputs' kinds.
PEAKS = {"x": "x_max", "drift": "drift_max", "acc": "acc_max"}


def _output_columns(name: str, t: np.ndarray, stats: dict, spread: float | None, delta: float | None,
                    random: bool) -> dict[str, float]:
    """An output's window rms (a floor's with the second-order correction of Jensen's gap from the
    ``spread``, the variance of its window mean square) and mean peak (Vanmarcke's crossings with
    the bandwidth ``delta`` for a zero-mean response, else Poisson's; a deterministic one's
    largest ``|mean|``)."""
    kind, k = name.split("_")
    square = stats["m"] ** 2 + stats["s"] ** 2
    window = t[-1] - t[0]
    rms = math.sqrt(float(np.trapezoid(square, t) / window) if window > 0 else float(square[0]))
    out = {f"{kind}_rms_{k}": rms}
    if spread is not None and np.isfinite(spread) and spread >= 0 and rms > 0:  # E[sqrt(ms)] to second order
        out[f"x_rms_{k}"] = rms * (1.0 - spread / (8.0 * rms**4))
        out[f"x_rms_sd_{k}"] = math.sqrt(spread) / (2.0 * rms)
    if "ds" in stats and kind in PEAKS:
        out[f"{PEAKS[kind]}_{k}"] = (passage.mean_peak(t, stats, _zero_mean(stats, delta)) if random
                                     else float(np.max(np.abs(stats["m"]))))
    return out


def _zero_mean(stats: dict, delta: float | None) -> float | None:
    """``delta`` where the response is zero-mean over the window (Vanmarcke's factor applies), else None."""
    zero = float(np.max(np.abs(stats["m"]))) <= 1e-9 * float(np.max(stats["s"]) or 1.0)
    return delta if zero else None


def _limit_columns(name: str, t: np.ndarray, stats: dict, delta: float | None, random: bool, limits: dict,
                   n_floors: int) -> dict[str, float]:
    """The first-passage columns of the limits on this output's peak (``p_NAME``, Poisson's
    ``p_NAME_poisson`` and the window's mean rate of outward crossings ``upcrossing_rate_NAME``;
    a deterministic response's ``p_NAME`` is 0 or 1)."""
    kind, k = name.split("_")
    out: dict[str, float] = {}
    if "ds" not in stats or kind not in PEAKS:
        return out
    for limit, (metric, value) in limits.items():
        if metric != f"{PEAKS[kind]}_{k}" and not (metric == "x1_max" and name == f"x_{n_floors}"):
            continue
        if not random:
            out[f"p_{limit}"] = float(np.max(np.abs(stats["m"])) > value)
            continue
        delta = _zero_mean(stats, delta)
        out[f"p_{limit}_poisson"] = float(passage.exceedance(t, [value], stats, None)[0])
        out[f"p_{limit}"] = (float(passage.exceedance(t, [value], stats, delta)[0]) if delta is not None
                             else out[f"p_{limit}_poisson"])
        rates = passage.barrier_rate(value, *(stats[q] for q in ("m", "s", "dm", "ds", "cov")))
        window = t[-1] - t[0]
        out[f"upcrossing_rate_{limit}"] = float(np.trapezoid(rates, t) / window) if window > 0 else math.nan
    return out


def _aliases(row: dict[str, Any], scene) -> None:
    """The roof's columns under the realisations table's names (``x1_rms``, ``x1_max``) and, with
    storey heights, the drift ratios (``drift_ratio_max_k``, ``drift_ratio_rms_k``)."""
    roof = scene.n_floors
    for name in ("x_rms", "x_max", "x_rms_sd"):
        if f"{name}_{roof}" in row:
            row[name.replace("x_", "x1_")] = row[f"{name}_{roof}"]
    if scene.heights.size and all(f"drift_max_{k + 1}" in row for k in range(roof)):
        for k in range(roof):
            row[f"drift_ratio_max_{k + 1}"] = row[f"drift_max_{k + 1}"] / scene.heights[k]
            row[f"drift_ratio_rms_{k + 1}"] = row[f"drift_rms_{k + 1}"] / scene.heights[k]


#: Largest ratio of a variance at the end of the time-varying linearisation to the stationary one.
RUNAWAY = 10.0


def _settled(path: moments.Trajectory, stationary: tuple | None) -> bool:
    """False where the time-varying moments are not finite, or end far above the stationary
    fixed point's variances (``RUNAWAY``)."""
    if not np.all(np.isfinite(path.p)):
        return False
    if stationary is None:
        return True
    end, fixed = np.diagonal(path.p[-1]), np.diagonal(stationary[2])
    return bool(np.all(end <= RUNAWAY * fixed + 1e-300))


def _storey_limit(metric: str, value: float, heights: np.ndarray) -> tuple[str, float]:
    """A limit on a storey's drift ratio as the limit on its drift (``scene.limit_row``)."""
    if metric.startswith("drift_ratio_max_"):
        k = int(metric.rsplit("_", 1)[1])
        return f"drift_max_{k}", value * heights[k - 1]
    return metric, value


def _stationary_fixed_point(scene, filters: list, model: Model) -> tuple[tuple | None, str]:
    """The stationary fixed point of statistical linearisation (``linearization.stationary``) from a
    start at the bare structure's roof motion; a bistable absorber is tried from both branches
    (intra-well, about a stable position; cross-well, about the barrier's top) and the note names
    the fixed points found and which is reported (intra-well where it exists)."""
    from ..physics.absorbers import K_LIN

    na = len(scene.kind)
    guess = _bare_rms(scene, filters)
    starts = [("", np.zeros(na), np.full(na, guess))]
    bistable = np.flatnonzero(scene.kind == BISTABLE)
    if bistable.size:
        well = np.zeros(na)
        well[bistable] = np.sqrt(-scene.rows[bistable, K_LIN] / scene.rows[bistable, K_CUBIC])
        starts = [("intra-well", well, np.full(na, 0.1 * guess)),
                  ("cross-well", np.zeros(na), np.full(na, guess))]
    found = []
    for label, mu, s in starts:
        try:
            fixed = linearization.stationary(scene, filters, mu, s)
        except NotApplicable:
            continue
        m_mu, _ = linearization.strokes(fixed[0], scene, fixed[1], fixed[2])
        if label == "intra-well" and np.all(np.abs(m_mu[bistable]) < 1e-6 * well[bistable]):
            continue  # (it fell to the symmetric branch)
        found.append((label, fixed[:3]))
    if not found:
        return None, "no stationary fixed point of statistical linearisation"
    if bistable.size:
        names = ", ".join(label for label, _ in found)
        return found[0][1], (f"bistable: stationary fixed points {names}; the window's statistics are "
                             f"the {found[0][0]} one's")
    return found[0][1], ""


def _bare_rms(scene, filters: list) -> float:
    """A start for the iteration: the roof's stationary displacement rms with the absorbers held
    by a spring of the primary's first storey (so that the model is stable)."""
    na = len(scene.kind)
    slope = np.full(na, -float(scene.storey_k[-1]) * 1e-2)
    model = build(scene, filters, slope, np.zeros(na))
    try:
        p = moments.stationary_covariance(model)
    except NotApplicable:
        return 1.0
    roof = scene.n_floors - 1
    value = math.sqrt(max(p[roof, roof], 0.0))
    return value if value > 0 else 1.0


def estimate(scenario, *, point: int | None = None) -> pd.DataFrame:
    """Estimates without an ensemble (MODEL.md section 6): one row a sweep point (``point``: that one
    only) with its swept values, ``method`` (``exact-linear``, ``statistical-linearization`` or
    ``not-applicable``), ``note`` (why not applicable, the fixed points of a bistable law), the rms
    of each floor's displacement (``x_rms_k``; ``x1_rms`` the roof's: the mean over realisations of
    the window's rms, with the spread's second-order correction) and drift (``drift_rms_k``), the
    absorbers' strokes (``stroke_rms_j``), floor accelerations (``acc_rms_k``), the mean peaks
    (``x_max_k``, ``drift_max_k``, ``acc_max_k``, ``x1_max``) and, per limit, the exceedance
    probability over the window (``p_NAME``: Vanmarcke's where the response is zero-mean and
    stationary-banded, else Poisson's ``p_NAME_poisson``) and the mean rate of outward crossings.

    ``scenario``: a file's path, a dict of its tables or a loaded study (as ``run``)."""
    from ..results import as_study

    study = as_study(scenario)
    limits = {name: (limit.metric, limit.value) for name, limit in study.base.limits.items()}
    rows = []
    points = range(len(study.points)) if point is None else [point]
    for p in points:
        scenario_p = study.points[p]
        limits_p = {name: (limit.metric, limit.value) for name, limit in scenario_p.limits.items()} or limits
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                row = _point(scenario_p, limits_p)
        except NotApplicable as exc:
            row = {"method": "not-applicable", "note": str(exc)}
        except (np.linalg.LinAlgError, FloatingPointError) as exc:
            row = {"method": "not-applicable", "note": f"the moments failed: {exc}"}
        if study.base.uncertain:
            row["note"] = "; ".join(filter(None, [row.get("note", ""),
                                                   "uncertain parameters at their values in the file"]))
        rows.append({"point": p, **study.grid[p], **row})
    return pd.DataFrame(rows)


#: Distance (standard errors) beyond which an estimate and the Monte Carlo mean are said to part.
APART = 3.0


def beside(summary: pd.DataFrame, estimates: pd.DataFrame) -> pd.DataFrame:
    """``summary`` with ``M_estimate`` and ``M_z`` for every metric ``M`` both tables hold (``M_mean``
    in the summary): the estimate and the Monte Carlo mean's distance from it in standard errors,
    ``(M_mean - M_estimate) / M_sem``; for a limit's ``p_NAME``, its binomial standard error at the
    estimate, ``sqrt(p (1 - p) / n_ok)``; and ``estimate_method``."""
    out = summary.copy()
    by_point = estimates.set_index("point")
    out["estimate_method"] = out["point"].map(by_point["method"]).fillna("not-applicable")
    columns = {}
    for metric in by_point.columns:
        value = out["point"].map(by_point[metric])
        if f"{metric}_mean" in out and f"{metric}_sem" in out:
            est = pd.to_numeric(value, errors="coerce")
            with np.errstate(divide="ignore", invalid="ignore"):
                z = (out[f"{metric}_mean"] - est) / out[f"{metric}_sem"]
        elif metric.startswith("p_") and metric in out and not metric.endswith("_poisson"):
            est = pd.to_numeric(value, errors="coerce")
            with np.errstate(divide="ignore", invalid="ignore"):
                z = (out[metric] - est) / np.sqrt(est * (1.0 - est) / out["n_ok"])
        else:
            continue
        columns[f"{metric}_estimate"], columns[f"{metric}_z"] = est.astype(float), z.astype(float)
    return pd.concat([out, pd.DataFrame(columns, index=out.index)], axis=1)


def with_estimates(summary: pd.DataFrame, study) -> pd.DataFrame:
    """``beside`` of a run's summary and ``estimate`` of its study.  An estimate that fails
    unexpectedly leaves the ensemble's results whole: the summary keeps no estimates, and a
    ``RuntimeWarning`` says why (a defect to report)."""
    try:
        estimates = estimate(study)
    except Exception as exc:  # noqa: BLE001 (the ensemble's results come first)
        warnings.warn(f"the estimates without an ensemble were left out of the summary ({exc!r}); "
                      "please report it", RuntimeWarning, stacklevel=2)
        return summary.assign(estimate_method="not-applicable")
    return beside(summary, estimates)


def parted(summary: pd.DataFrame) -> list[str]:
    """Lines for the metrics whose Monte Carlo mean lies more than ``APART`` standard errors from
    its estimate (the sign of a non-Gaussian response, or of a linearisation that misses it)."""
    lines = []
    for column in summary.columns:
        if not column.endswith("_z"):
            continue
        metric = column[:-2]
        far = summary[column].abs() > APART
        for i in np.flatnonzero(far.to_numpy()):
            method = summary["estimate_method"].iloc[i]
            lines.append(f"point {int(summary['point'].iloc[i])}: {metric} Monte Carlo "
                         f"{summary[metric + ('_mean' if metric + '_mean' in summary else '')].iloc[i]:.4g}"
                         f" against the {method} estimate {summary[metric + '_estimate'].iloc[i]:.4g} "
                         f"({summary[column].iloc[i]:+.1f} standard errors): a non-Gaussian response, "
                         "or an approximation (linearisation, crossings) that misses it")
    return lines
