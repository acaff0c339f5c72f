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
realisations are resampled together) and is refitted; the bounds are the 2.5 and 97.5 % percentiles of the replicates' ``median`` and
``beta`` (Efron and Tibshirani, *An Introduction to the Bootstrap*, 13.3).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy.special import log_ndtr, ndtr, ndtri

from .metrics import exceedance, limit_names
from .store import read_results

#: Fisher-scoring iterations (a fit converges in well under 20; separated stripes never do).
ITERATIONS = 60
#: ``beta`` below this (stripes all 0 below an intensity and all 1 above it) is no fit.
BETA_MIN = 1e-3
#: Intensities past this many are pooled into this many bins in the plot (the fit uses them all).
PLOT_BINS = 20
#: How realisations that did not end ok are treated.
DIVERGED = ("exclude", "exceed")


def probit_fit(u: np.ndarray, n: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Maximum-likelihood ``(a, b)`` of ``z ~ Binomial(n, Phi(a + b u))`` over the last axis
    (the stripes; leading axes are independent fits), and whether each fit converged with
    ``b > 0`` and ``1 / b >= BETA_MIN`` (stripes that separate perfectly have no maximum)."""
    y = z / np.maximum(n, 1)
    # start: least squares of the probits of the (clipped) fractions
    eta0 = ndtri(np.clip(y, 0.02, 0.98))
    um = u.mean(axis=-1, keepdims=True)
    b = ((u - um) * eta0).sum(axis=-1) / max(float(((u - um) ** 2).sum()), 1e-300)
    b = np.where(b > 0, b, 1.0)
    a = eta0.mean(axis=-1) - b * um[..., 0]
    for _ in range(ITERATIONS):
        eta = a[..., None] + b[..., None] * u
        mu = np.clip(ndtr(eta), 1e-12, 1 - 1e-12)
        dens = np.exp(-0.5 * eta**2) / np.sqrt(2 * np.pi)
        w = n * dens**2 / (mu * (1 - mu))
        r = n * dens * (y - mu) / (mu * (1 - mu))  # the score's terms
        # Newton step with the Fisher information [[sum w, sum w u], [sum w u, sum w u^2]]
        s0, s1, s2 = w.sum(-1), (w * u).sum(-1), (w * u * u).sum(-1)
        g0, g1 = r.sum(-1), (r * u).sum(-1)
        det = s0 * s2 - s1 * s1
        ok = det > 1e-300
        da = np.where(ok, (s2 * g0 - s1 * g1) / np.where(ok, det, 1.0), 0.0)
        db = np.where(ok, (s0 * g1 - s1 * g0) / np.where(ok, det, 1.0), 0.0)
        a, b = a + da, b + db
        if np.all(np.abs(db) <= 1e-12 * np.maximum(np.abs(b), 1.0)) and np.all(
                np.abs(da) <= 1e-12 * np.maximum(np.abs(a), 1.0)):
            break
    converged = ((np.abs(db) <= 1e-8 * np.maximum(np.abs(b), 1.0)) & (b > 0)
                 & (1.0 / np.where(b > 0, b, 1.0) >= BETA_MIN))
    return a, b, converged


def log_likelihood(u: np.ndarray, n: np.ndarray, z: np.ndarray, a: float, b: float) -> float:
    """Binomial log-likelihood of the stripes at ``Phi(a + b u)`` (without the binomial
    coefficients)."""
    eta = a + b * u
    return float((z * log_ndtr(eta) + (n - z) * log_ndtr(-eta)).sum())


def stripes(realizations: pd.DataFrame, limit: str, im: str, diverged: str = "exclude") -> pd.DataFrame:
    """One row per intensity: the realisations whose column ``im`` holds it (a swept key: the
    sweep points at that value, e.g. every record of a suite scaled to one ``Sa``; or a
    realisation's own intensity, such as the ``sa`` column of generated ground motions), ``n``
    counted, ``exceeded``, the ``fraction`` with its 95 % Wilson interval (``fraction_lo``,
    ``fraction_hi``) and ``n_diverged`` (realisations that did not end ok: left out, or counted
    as exceedances with ``diverged = "exceed"``)."""
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
    for value, group in realizations.groupby(im, sort=True):
        ok = group["status"] == "ok"
        failed = int((~ok).sum())
        exceeded = int(group.loc[ok, column].notna().sum())
        n = int(ok.sum())
        if diverged == "exceed":
            exceeded, n = exceeded + failed, n + failed
        fraction, lo, hi = exceedance(exceeded, n)
        rows.append({"im": float(value), "n": n, "exceeded": exceeded, "fraction": fraction, "fraction_lo": lo,
                     "fraction_hi": hi, "n_diverged": failed})
    return pd.DataFrame(rows)


def _replicates(n: np.ndarray, z: np.ndarray, samples: int, gen: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
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
        counts = gen.multinomial(stripe.size, np.full(stripe.size, 1.0 / stripe.size), size=min(100, samples - start))
        for r, c in enumerate(counts, start=start):
            nb[r] = np.bincount(stripe, weights=c, minlength=n.size)
            zb[r] = np.bincount(stripe, weights=c * exceeded, minlength=n.size)
    return nb, zb


def fit(table: pd.DataFrame, samples: int = 1000, seed: int = 0) -> dict[str, object]:
    """The lognormal fragility of ``stripes`` rows: ``median``, ``beta``, their 95 % bootstrap
    bounds, the log-likelihood, the replicates that had a fit, and notes."""
    use = table[(table["n"] > 0) & (table["im"] > 0)]
    notes = []
    if len(use) < len(table):
        notes.append(f"{len(table) - len(use)} stripe(s) without realisations or with intensity <= 0 left out")
    u, n, z = (np.log(use["im"].to_numpy(float)), use["n"].to_numpy(float), use["exceeded"].to_numpy(float))
    nan = float("nan")
    result: dict[str, object] = {"median": nan, "beta": nan, "median_lo": nan, "median_hi": nan, "beta_lo": nan,
                                 "beta_hi": nan, "log_likelihood": nan, "bootstrap": samples, "bootstrap_fitted": 0}
    if len(use) < 2 or z.sum() == 0 or z.sum() == n.sum():
        notes.append("no fit: need two stripes or more and both exceedances and non-exceedances")
        result["notes"] = "; ".join(notes)
        return result
    a, b, converged = probit_fit(u, n, z)
    if not converged:
        notes.append(f"no fit: the stripes separate (all below an intensity and none above it: beta < {BETA_MIN:g}); "
                     "add stripes between them")
        result["notes"] = "; ".join(notes)
        return result
    result.update(median=float(np.exp(-a / b)), beta=float(1.0 / b), log_likelihood=log_likelihood(u, n, z, a, b))
    if samples > 0:
        nb, zb = _replicates(n, z, samples, np.random.default_rng(seed))
        ab, bb, cb = probit_fit(u, nb, zb)
        cb &= (zb.sum(-1) > 0) & (zb.sum(-1) < nb.sum(-1))
        result["bootstrap_fitted"] = int(cb.sum())
        if cb.sum() < samples:
            notes.append(f"{samples - int(cb.sum())} of {samples} bootstrap replicates had no fit (left out)")
        if cb.sum() >= 20:
            medians, betas = np.exp(-ab[cb] / bb[cb]), 1.0 / bb[cb]
            result["median_lo"], result["median_hi"] = (float(v) for v in np.percentile(medians, [2.5, 97.5]))
            result["beta_lo"], result["beta_hi"] = (float(v) for v in np.percentile(betas, [2.5, 97.5]))
    result["notes"] = "; ".join(notes)
    return result


def fragility(directory: str | Path, limit: str, im: str, diverged: str = "exclude", samples: int = 1000,
              seed: int = 0, plot: bool = True) -> pd.DataFrame:
    """Fit the fragility of ``limit`` against ``im`` for the run in ``directory``; writes
    ``directory/fragility.parquet`` (one row per stripe with the fit's columns, replacing the
    rows of an earlier fit of the same limit and intensity) and ``fragility_<limit>.png``;
    returns the rows written."""
    directory = Path(directory)
    realizations, _ = read_results(directory)
    table = stripes(realizations, limit, im, diverged)
    result = fit(table, samples, seed)
    policy = "counted as exceedances" if diverged == "exceed" else "excluded"
    rows = table.assign(limit=limit, im_key=im, diverged=policy, **result)
    if np.isfinite(result["median"]):
        rows["fitted"] = ndtr(np.log(rows["im"] / result["median"]) / result["beta"])
    else:
        rows["fitted"] = np.nan
    path = directory / "fragility.parquet"
    if path.is_file():
        old = pd.read_parquet(path)
        rows = pd.concat([old[(old["limit"] != limit) | (old["im_key"] != im)], rows], ignore_index=True)
    tmp = path.with_suffix(".parquet.tmp")
    rows.to_parquet(tmp, index=False)
    tmp.replace(path)
    if plot:
        _plot(table, result, limit, im, policy, directory / f"fragility_{limit}.png")
    return rows[(rows["limit"] == limit) & (rows["im_key"] == im)].reset_index(drop=True)


def _plot(table: pd.DataFrame, result: dict, limit: str, im: str, policy: str, path: Path) -> None:
    """The stripes' fractions with their intervals and the fitted curve."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    shown, what = table, "stripes"
    if len(table) > PLOT_BINS:  # intensities of their own (a cloud): pooled into bins for the eye
        bins = np.array_split(np.arange(len(table)), PLOT_BINS)
        shown = pd.DataFrame([{"im": float(np.exp(np.average(np.log(table["im"].iloc[b]), weights=table["n"].iloc[b]
                                                              + 1e-300))),
                               "n": int(table["n"].iloc[b].sum()), "exceeded": int(table["exceeded"].iloc[b].sum())}
                              for b in bins])
        shown[["fraction", "fraction_lo", "fraction_hi"]] = [exceedance(z, n) for z, n in
                                                              zip(shown["exceeded"], shown["n"])]
        what = f"{len(table)} intensities in {PLOT_BINS} bins"
    err = np.vstack([shown["fraction"] - shown["fraction_lo"], shown["fraction_hi"] - shown["fraction"]])
    ax.errorbar(shown["im"], shown["fraction"], yerr=err, fmt="o", capsize=3,
                label=f"{what} (95 % Wilson intervals; did not end ok: {policy})")
    if np.isfinite(result["median"]):
        x = np.geomspace(table["im"][table["im"] > 0].min() / 2, table["im"].max() * 2, 200)
        ax.plot(x, ndtr(np.log(x / result["median"]) / result["beta"]),
                label=f"lognormal fit: median {result['median']:.4g}, beta {result['beta']:.3g}")
    ax.set_xscale("log")
    ax.set_xlabel(im)
    ax.set_ylabel(f"P(exceed {limit})")
    ax.set_ylim(-0.02, 1.02)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
