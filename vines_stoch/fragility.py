"""Lognormal fragility curves from the exceedances of a limit at the sweep points of a run
(multiple-stripe analysis).

The probability that a limit is exceeded at intensity ``x`` is modelled as
``P(x) = Phi(ln(x / median) / beta)``, fitted by maximum likelihood to the stripes' counts
(Baker, Earthquake Spectra 31 (2015) 579, DOI 10.1193/021113EQS025M, eq. 11): ``z_j`` of the
``n_j`` realisations at intensity ``x_j`` exceeded the limit, ``z_j ~ Binomial(n_j, P(x_j))``.
With ``a = -ln(median) / beta`` and ``b = 1 / beta`` this is probit regression on ``ln x``,
solved by Fisher scoring (iteratively reweighted least squares, McCullagh and Nelder,
*Generalized Linear Models*, 2nd ed., section 4.4), for all bootstrap replicates at once.

Confidence bounds come from the bootstrap over realisations: each replicate resamples every
stripe's realisations with replacement (its count is then ``Binomial(n_j, z_j / n_j)``; with
stripes of single realisations, as for intensities of each realisation's own, all
realisations are resampled together) and is refitted; the bounds are the 2.5 and 97.5 %
percentiles of the replicates' ``median`` and ``beta`` (Efron and Tibshirani, *An Introduction
to the Bootstrap*, 13.3).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy.special import log_ndtr, ndtr, ndtri

from .metrics import exceedance, limit_names
from .plotting import label, legend, pyplot, save
from .store import KEY, ForeignFiles, check_folder, png_text, read_metadata, write_table

#: Fisher-scoring iterations (a fit converges in well under 20; separated stripes never do).
ITERATIONS = 60
#: Intensities past this many are pooled into this many bins in the plot (the fit uses them all).
PLOT_BINS = 20
#: How realisations that did not end ok are treated.
DIVERGED = ("exclude", "exceed")


def probit_fit(u: np.ndarray, n: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Maximum-likelihood ``(a, b)`` of ``z ~ Binomial(n, Phi(a + b u))`` over the last axis
    (the stripes; leading axes are independent fits), and whether each fit converged with
    ``b > 0``.  The weights use the ratios ``phi / Phi`` in logarithms, so no term underflows;
    stripes that separate (``separation``) have no maximum and are not to be given here."""
    y = z / np.maximum(n, 1)
    # start: least squares of the probits of the (clipped) fractions
    eta0 = ndtri(np.clip(y, 0.02, 0.98))
    um = u.mean(axis=-1, keepdims=True)
    b = ((u - um) * eta0).sum(axis=-1) / max(float(((u - um) ** 2).sum()), 1e-300)
    b = np.where(b > 0, b, 1.0)
    a = eta0.mean(axis=-1) - b * um[..., 0]
    log_dens0 = -0.5 * np.log(2 * np.pi)
    step = np.full(np.shape(a), np.inf)
    for _ in range(ITERATIONS):
        eta = a[..., None] + b[..., None] * u
        log_dens = log_dens0 - 0.5 * eta**2
        up, down = np.exp(log_dens - log_ndtr(eta)), np.exp(log_dens - log_ndtr(-eta))  # phi/Phi, phi/(1-Phi)
        w = n * up * down
        r = n * (y * up - (1 - y) * down)  # the score's terms
        # Newton step with the Fisher information [[sum w, sum w u], [sum w u, sum w u^2]]
        s0, s1, s2 = w.sum(-1), (w * u).sum(-1), (w * u * u).sum(-1)
        g0, g1 = r.sum(-1), (r * u).sum(-1)
        det = s0 * s2 - s1 * s1
        ok = det > 0
        safe = np.where(ok, det, 1.0)
        da = np.where(ok, (s2 * g0 - s1 * g1) / safe, np.nan)
        db = np.where(ok, (s0 * g1 - s1 * g0) / safe, np.nan)
        a, b = a + da, b + db
        step = np.maximum(np.abs(da) / np.maximum(np.abs(a), 1.0), np.abs(db) / np.maximum(np.abs(b), 1.0))
        if not np.any(step > 1e-12):  # (NaN steps, a singular information, end the loop too)
            break
    converged = (step <= 1e-8) & (b > 0)
    return a, b, converged


def separation(u: np.ndarray, n: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Whether stripes separate, over the last axis: no non-exceedance at an intensity above
    an exceedance (all exceedances at or above ``hi``, all non-exceedances at or below ``lo``;
    ``lo = -inf`` without non-exceedances, ``hi = inf`` without exceedances).  Then the
    likelihood has no maximum: it grows as ``beta -> 0`` with the median in ``[lo, hi]``
    (Albert and Anderson, Biometrika 71 (1984) 1, DOI 10.1093/biomet/71.1.1).  Returns
    ``(separated, lo, hi)`` in ``ln`` intensity."""
    lo = np.where((z < n) & (n > 0), u, -np.inf).max(axis=-1)
    hi = np.where(z > 0, u, np.inf).min(axis=-1)
    return lo <= hi, lo, hi


def log_likelihood(u: np.ndarray, n: np.ndarray, z: np.ndarray, a: float, b: float) -> float:
    """Binomial log-likelihood of the stripes at ``Phi(a + b u)`` (without the binomial
    coefficients)."""
    eta = a + b * u
    return float((z * log_ndtr(eta) + (n - z) * log_ndtr(-eta)).sum())


def rare_counts(rare: pd.DataFrame | None, limit: str, im: str) -> dict[float, tuple[int, float]]:
    """The rare-event estimates of ``limit`` (rare.parquet's rows) at the values of the swept key
    ``im``, each as the binomial counts that carry the same information: ``n = (1 - p) / (p
    cov^2)`` trials (rounded) of which ``p n`` exceed, the crude Monte Carlo sample whose
    estimate has the same mean and coefficient of variation.  Estimates without an exceedance
    (``p = 0``, no finite ``cov``) carry none and are left out."""
    if rare is None or im not in rare or "limit" not in rare:
        return {}
    counts: dict[float, tuple[int, float]] = {}
    for _, row in rare[rare["limit"] == limit].iterrows():
        if row.p > 0 and np.isfinite(row["cov"]) and row["cov"] > 0:
            n = max(2, round((1 - row.p) / (row.p * row["cov"] ** 2)))
            exceeded = row.p * n
            old = counts.get(float(row[im]), (0, 0.0))
            counts[float(row[im])] = (old[0] + n, old[1] + exceeded)
    return counts


def stripes(realizations: pd.DataFrame, limit: str, im: str, diverged: str = "exclude",
            rare: pd.DataFrame | None = None) -> pd.DataFrame:
    """One row per intensity: the realisations whose column ``im`` holds it (a swept key: the
    sweep points at that value, e.g. every record of a suite scaled to one ``Sa``; or a
    realisation's own intensity, such as the ``sa`` column of generated ground motions), ``n``
    counted, ``exceeded``, the ``fraction`` with its 95 % Wilson interval (``fraction_lo``,
    ``fraction_hi``) and ``n_diverged`` (realisations that did not end ok: left out, or counted
    as exceedances with ``diverged = "exceed"``).  With ``rare`` (rare.parquet of the run), the
    rare-event estimates of ``limit`` add their counts of equal information (``rare_counts``,
    ``n_rare`` of ``n``) to the stripes of their intensities: a curve can rest on intensities
    where the crude sample saw no exceedance."""
    column = f"first_passage_{limit}"
    if column not in realizations:
        known = ", ".join(limit_names(realizations)) or "none: the scenario has no [limits]"
        raise KeyError(f"--limit {limit}: not a limit of this run (its limits: {known})")
    if im not in realizations or not pd.api.types.is_numeric_dtype(realizations[im]):
        raise KeyError(f"--im {im}: not a numeric column of realizations.parquet (give a swept key, e.g. "
                       f"{next((c for c in realizations.columns if '.' in c), 'loads.0.intensity')}, or sa)")
    if diverged not in DIVERGED:
        raise ValueError(f"--diverged {diverged}: must be one of {', '.join(DIVERGED)}")
    rows = []
    extra = rare_counts(rare, limit, im)
    # (NaN: a stripe that fit leaves out)
    for value, group in realizations.groupby(im, sort=True, dropna=False):
        ok = group["status"] == "ok"
        failed = int((~ok).sum())
        exceeded = int(group.loc[ok, column].notna().sum())
        n = int(ok.sum())
        if diverged == "exceed":
            exceeded, n = exceeded + failed, n + failed
        n_rare, z_rare = extra.get(float(value), (0, 0.0))
        n, exceeded = n + n_rare, exceeded + z_rare
        fraction, lo, hi = exceedance(exceeded, n)
        rows.append({"im": float(value), "n": n, "exceeded": exceeded, "fraction": fraction,
                     "fraction_lo": lo, "fraction_hi": hi, "n_diverged": failed, "n_rare": n_rare})
    return pd.DataFrame(rows, columns=["im", "n", "exceeded", "fraction", "fraction_lo", "fraction_hi",
                                       "n_diverged", "n_rare"])


def _replicates(n: np.ndarray, z: np.ndarray, samples: int,
                gen: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Bootstrap counts ``(n*, z*)``, shape ``(samples, stripes)``: each stripe's realisations
    resampled within the stripe (``z* ~ Binomial(n, z / n)``) where every stripe has two or
    more; otherwise (intensities of single realisations, a cloud) all realisations resampled
    together, each stripe then getting a random count."""
    if n.min() >= 2:
        return np.broadcast_to(n, (samples, n.size)), gen.binomial(n.astype(np.int64), z / n,
                                                                   size=(samples, n.size)).astype(float)
    stripe = np.repeat(np.arange(n.size), n.astype(np.int64))
    exceeded = np.concatenate([np.arange(k) < e for k, e in zip(n.astype(np.int64), z.astype(np.int64))])
    nb, zb = np.empty((samples, n.size)), np.empty((samples, n.size))
    for start in range(0, samples, 100):  # (the draws of 100 replicates at a time)
        counts = gen.multinomial(stripe.size, np.full(stripe.size, 1.0 / stripe.size),
                                 size=min(100, samples - start))
        for r, c in enumerate(counts, start=start):
            nb[r] = np.bincount(stripe, weights=c, minlength=n.size)
            zb[r] = np.bincount(stripe, weights=c * exceeded, minlength=n.size)
    return nb, zb


def fit(table: pd.DataFrame, samples: int = 1000, seed: int = 0, keep: bool = False) -> dict[str, object]:
    """The lognormal fragility of ``stripes`` rows: ``median``, ``beta``, their 95 % bootstrap
    bounds, the log-likelihood, the replicates used for the bounds, and notes (with ``keep``,
    also ``replicates``: the ``(medians, betas)`` of the replicates used, for ``band``).

    Stripes that separate (``separation``) have no fit: NaN, and the notes give the gap.  A
    bootstrap replicate that separates counts as ``beta = 0`` with its median in the middle of
    its gap (``0`` or ``inf`` where it has no exceedance or only exceedances), so the bounds are
    not narrowed by leaving out the replicates that say the curve may be a step."""
    use = table[(table["n"] > 0) & (table["im"] > 0) & np.isfinite(table["im"])]
    notes = []
    if len(use) < len(table):
        notes.append(f"{len(table) - len(use)} stripe(s) without realisations or with an intensity not > 0 "
                     "left out")
    u, n, z = (np.log(use["im"].to_numpy(float)), use["n"].to_numpy(float), use["exceeded"].to_numpy(float))
    nan = float("nan")
    result: dict[str, object] = {"median": nan, "beta": nan, "median_lo": nan, "median_hi": nan,
                                 "beta_lo": nan, "beta_hi": nan, "log_likelihood": nan, "bootstrap": samples,
                                 "bootstrap_fitted": 0}
    separated, lo, hi = separation(u, n, z)
    if len(use) < 2 or z.sum() == 0 or z.sum() == n.sum():
        notes.append("no fit: need two stripes or more and both exceedances and non-exceedances")
    elif separated:
        notes.append(f"no fit: the stripes separate (no exceedance below {np.exp(hi):.4g}, none short of the "
                     f"limit above {np.exp(lo):.4g}: the likelihood grows as beta -> 0); add stripes or "
                     "realisations between")
    else:
        a, b, converged = probit_fit(u, n, z)
        if not converged:
            notes.append("no fit: the exceedances do not grow with the intensity" if b <= 0 else
                         "no fit: Fisher scoring did not converge")
        else:
            result.update(median=float(np.exp(-a / b)), beta=float(1.0 / b),
                          log_likelihood=log_likelihood(u, n, z, a, b))
    if samples == 0 or not np.isfinite(result["median"]):
        result["notes"] = "; ".join(notes)
        return result
    nb, zb = _replicates(n, z, samples, np.random.default_rng(seed))
    sep, lo_b, hi_b = separation(u, nb, zb)
    medians, betas = np.full(samples, np.nan), np.full(samples, np.nan)
    if (~sep).any():
        ab, bb, cb = probit_fit(u, nb[~sep], zb[~sep])
        medians[~sep] = np.where(cb, np.exp(-ab / np.where(cb, bb, 1.0)), np.nan)
        betas[~sep] = np.where(cb, 1.0 / np.where(cb, bb, 1.0), np.nan)
    gap = np.where(np.isfinite(lo_b) & np.isfinite(hi_b), 0.5 * (lo_b + hi_b),
                   np.where(np.isfinite(hi_b), -np.inf, np.inf))
    medians[sep], betas[sep] = np.exp(gap[sep]), 0.0
    used = np.isfinite(betas)
    result["bootstrap_fitted"] = int(used.sum())
    if keep:
        result["replicates"] = (medians[used], betas[used])
    if sep.any():
        notes.append(f"{int(sep.sum())} of {samples} bootstrap replicates separate (counted as beta = 0, "
                     "median in their gap)")
    if (~used).any():
        notes.append(f"{int((~used).sum())} of {samples} bootstrap replicates did not converge (left out)")
    if used.sum() >= 20:
        # (order statistics, not interpolation: medians of replicates without exceedances are inf)
        result["median_lo"] = float(np.percentile(medians[used], 2.5, method="lower"))
        result["median_hi"] = float(np.percentile(medians[used], 97.5, method="higher"))
        result["beta_lo"] = float(np.percentile(betas[used], 2.5, method="lower"))
        result["beta_hi"] = float(np.percentile(betas[used], 97.5, method="higher"))
    result["notes"] = "; ".join(notes)
    return result


def fitted(realizations: pd.DataFrame, rare: pd.DataFrame | None, limit: str, im: str,
           diverged: str = "exclude", samples: int = 1000,
           seed: int = 0) -> tuple[pd.DataFrame, pd.DataFrame, dict, tuple | None]:
    """The fragility of ``limit`` against ``im`` fitted to a run's realisations table (and its
    rare-event estimates, ``rare``): ``(rows, stripes, fit, replicates)``, the rows one per stripe
    with the fit's columns and the fitted curve at the stripe (``fitted``)."""
    table = stripes(realizations, limit, im, diverged, rare)
    result = fit(table, samples, seed, keep=True)
    replicates = result.pop("replicates", None)
    policy = "counted as exceedances" if diverged == "exceed" else "excluded"
    rows = table.assign(limit=limit, im_key=im, diverged=policy, **result)
    if np.isfinite(result["median"]):
        rows["fitted"] = ndtr(np.log(rows["im"] / result["median"]) / result["beta"])
    else:
        rows["fitted"] = np.nan
    return rows, table, result, replicates


def fragility(directory: str | Path, limit: str, im: str, diverged: str = "exclude", samples: int = 1000,
              seed: int = 0, plot: bool = True) -> pd.DataFrame:
    """Fit the fragility of ``limit`` against ``im`` for the run in ``directory``; writes
    ``directory/fragility.parquet`` (one row per stripe with the fit's columns, replacing the
    rows of an earlier fit of the same limit and intensity) and ``fragility_<limit>.png`` (where
    matplotlib is installed); returns the rows written."""
    directory = Path(directory)
    check_folder(directory)  # (one run's tables, and fragility.parquet, if there, this run's)
    meta = read_metadata(directory / "summary.parquet")
    rare = directory / "rare.parquet"
    realizations, rare = (pd.read_parquet(directory / "realizations.parquet"),
                          pd.read_parquet(rare) if rare.is_file() else None)
    figure = directory / f"fragility_{limit}.png"
    if plot and figure.exists() and KEY not in png_text(figure):
        raise ForeignFiles(f"{figure}: not a plot vines-stoch wrote; move it out of the folder to fit "
                           f"{limit}")
    rows, table, result, replicates = fitted(realizations, rare, limit, im, diverged, samples, seed)
    policy = rows["diverged"].iloc[0]
    path = directory / "fragility.parquet"
    if path.is_file():
        old = pd.read_parquet(path)
        rows = pd.concat([old[(old["limit"] != limit) | (old["im_key"] != im)], rows], ignore_index=True)
    write_table(rows, path, meta)  # (the run's provenance and key: fitted to this run)
    if plot:
        _plot(table, result, replicates, limit, im, policy, figure, meta)
    return rows[(rows["limit"] == limit) & (rows["im_key"] == im)].reset_index(drop=True)


def band(x: np.ndarray, medians: np.ndarray, betas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pointwise 95 % bootstrap band of the fragility curve at intensities ``x``: the 2.5 and
    97.5 % percentiles over the replicates' curves (a replicate with ``beta = 0`` is the step at
    its median)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.log(x[None, :] / medians[:, None]) / betas[:, None]
    curves = np.where(betas[:, None] > 0, ndtr(z), (x[None, :] >= medians[:, None]).astype(float))
    return np.percentile(curves, 2.5, axis=0), np.percentile(curves, 97.5, axis=0)


def _plot(table: pd.DataFrame, result: dict, replicates: tuple[np.ndarray, np.ndarray] | None, limit: str,
          im: str, policy: str, path: Path, meta: dict[str, str]) -> None:
    """The stripes' fractions with their intervals, the fitted curve and its bootstrap band
    (where matplotlib is installed), as PNG and SVG, the run's key among their text entries."""
    import tomllib

    plt = pyplot(str(path))
    if plt is None:
        return
    fig, ax = plt.subplots()
    shown, what = table, "stripes"
    if len(table) > PLOT_BINS:  # intensities of their own (a cloud): pooled into bins for the eye
        bins = np.array_split(np.arange(len(table)), PLOT_BINS)
        shown = pd.DataFrame([{"im": float(np.exp(np.average(np.log(table["im"].iloc[b]),
                                                             weights=table["n"].iloc[b] + 1e-300))),
                               "n": int(table["n"].iloc[b].sum()),
                               "exceeded": int(table["exceeded"].iloc[b].sum())}
                              for b in bins])
        shown[["fraction", "fraction_lo", "fraction_hi"]] = [exceedance(z, n) for z, n in
                                                              zip(shown["exceeded"], shown["n"])]
        what = f"{len(table)} intensities in {PLOT_BINS} bins"
    err = np.vstack([shown["fraction"] - shown["fraction_lo"], shown["fraction_hi"] - shown["fraction"]])
    ax.errorbar(shown["im"], shown["fraction"], yerr=err, fmt="o", capsize=3, color="C0",
                label=f"{what} (95 % Wilson intervals; did not end ok: {policy})")
    if np.isfinite(result["median"]):
        x = np.geomspace(table["im"][table["im"] > 0].min() / 2, table["im"].max() * 2, 200)
        ax.plot(x, ndtr(np.log(x / result["median"]) / result["beta"]), color="C1",
                label=f"lognormal fit: median {result['median']:.4g}, beta {result['beta']:.3g}")
        if replicates is not None and replicates[0].size >= 20:
            low, high = band(x, *replicates)
            ax.fill_between(x, low, high, color="C1", alpha=0.2, lw=0,
                            label=f"95 % bootstrap band ({replicates[0].size} replicates)")
    ax.set_xscale("log")
    ax.set_xlabel(label(im, tomllib.loads(meta.get("vines_stoch.scenario", ""))))
    ax.set_ylabel(f"probability of exceeding {limit}")
    ax.set_ylim(-0.02, 1.02)
    legend(ax)
    save(fig, path, {KEY: meta[KEY]})
