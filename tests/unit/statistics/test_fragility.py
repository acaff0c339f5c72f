"""Lognormal fragility fits (``vines_stoch.fragility``): synthetic stripes drawn from a known
curve, the maximum of the likelihood against a general-purpose optimiser, and the command on a
run."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy.optimize import minimize
from scipy.special import log_ndtr, ndtr

from tests.helpers import cli, sdof_fragility_run
from vines_stoch.fragility import fit, probit_fit, stripes

MEDIAN, BETA = 0.4, 0.5
IM = np.geomspace(0.1, 1.5, 8)
PER_STRIPE = 60


def synthetic(gen: np.random.Generator, failed: int = 0) -> pd.DataFrame:
    """A realisations table of stripes at ``IM``, each realisation exceeding with probability
    ``Phi(ln(im / MEDIAN) / BETA)``; ``failed`` realisations a stripe did not end ok."""
    rows = []
    for point, x in enumerate(IM):
        exceeded = gen.random(PER_STRIPE) < ndtr(math.log(x / MEDIAN) / BETA)
        for r, e in enumerate(exceeded):
            rows.append({"point": point, "realization": r, "loads.0.intensity": x,
                         "status": "diverged" if r < failed else "ok",
                         "first_passage_drift": 1.0 if e else np.nan})
    return pd.DataFrame(rows)


def test_fit_recovers_a_known_curve_within_its_bounds():
    """Over 200 synthetic data sets the 95 % bootstrap bounds cover the true median and beta
    in about 95 % of them: the count covering is binomial, 3 standard deviations (0.046) below
    0.95, and 0.03 more for the percentile bootstrap's undercoverage at 60 realisations a
    stripe, gives the floor 0.87.  The estimates average to the truth within 4 standard errors
    plus the maximum-likelihood bias of order 1/n."""
    gen = np.random.default_rng(2024)
    medians, betas, cover_m, cover_b = [], [], 0, 0
    runs = 200
    for k in range(runs):
        result = fit(stripes(synthetic(gen), "drift", "loads.0.intensity"), samples=400, seed=k)
        assert result["bootstrap_fitted"] >= 390, result["notes"]
        medians.append(result["median"])
        betas.append(result["beta"])
        cover_m += result["median_lo"] <= MEDIAN <= result["median_hi"]
        cover_b += result["beta_lo"] <= BETA <= result["beta_hi"]
    assert cover_m / runs > 0.87 and cover_b / runs > 0.87, (cover_m, cover_b)
    for estimates, truth in ((np.log(medians), math.log(MEDIAN)), (np.array(betas), BETA)):
        se = estimates.std(ddof=1) / math.sqrt(runs)
        assert abs(estimates.mean() - truth) < 4 * se + 0.02 * abs(truth), (estimates.mean(), truth, se)


def test_fisher_scoring_reaches_the_likelihood_maximum():
    """The fit against Nelder-Mead on Baker's (2015) eq. 11 in ``(ln median, ln beta)``."""
    table = stripes(synthetic(np.random.default_rng(7)), "drift", "loads.0.intensity")
    u, n, z = np.log(table["im"].to_numpy()), table["n"].to_numpy(float), table["exceeded"].to_numpy(float)

    def nll(p: np.ndarray) -> float:
        eta = (u - p[0]) / math.exp(p[1])
        return -float((z * log_ndtr(eta) + (n - z) * log_ndtr(-eta)).sum())

    best = minimize(nll, [0.0, 0.0], method="Nelder-Mead",
                    options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 20000})
    result = fit(table, samples=0)
    assert result["median"] == pytest.approx(math.exp(best.x[0]), rel=1e-6)
    assert result["beta"] == pytest.approx(math.exp(best.x[1]), rel=1e-6)
    assert result["log_likelihood"] == pytest.approx(-best.fun, abs=1e-8)
    a, b, ok = probit_fit(u, n, z)
    assert ok and b == pytest.approx(1 / result["beta"])


def test_separating_replicates_widen_the_bounds_to_a_step():
    """Few realisations a stripe: some bootstrap replicates separate; they count as beta = 0
    (the lower bound), not dropped."""
    table = pd.DataFrame({"im": [0.2, 0.25, 0.3, 0.35, 0.4], "n": [3] * 5, "exceeded": [0, 1, 2, 1, 3]})
    result = fit(table, samples=500)
    assert np.isfinite(result["beta"]) and result["beta_lo"] == 0.0 < result["beta"] < result["beta_hi"]
    assert "separate" in result["notes"] and result["bootstrap_fitted"] == 500
    assert result["median_lo"] < result["median"] < result["median_hi"]


def test_stripes_count_realisations_that_did_not_end_ok_only_when_asked():
    frame = synthetic(np.random.default_rng(3), failed=5)
    kept = stripes(frame, "drift", "loads.0.intensity")
    counted = stripes(frame, "drift", "loads.0.intensity", diverged="exceed")
    assert (kept["n"] == PER_STRIPE - 5).all() and (counted["n"] == PER_STRIPE).all()
    assert (counted["exceeded"] == kept["exceeded"] + 5).all()
    assert (kept["n_diverged"] == 5).all()
    lo, hi = kept["fraction_lo"], kept["fraction_hi"]
    assert ((lo <= kept["fraction"]) & (kept["fraction"] <= hi)).all()


def test_no_fit_is_said_not_faked():
    frame = synthetic(np.random.default_rng(3))
    frame["first_passage_drift"] = np.where(frame["loads.0.intensity"] > MEDIAN, 1.0, np.nan)  # separated
    result = fit(stripes(frame, "drift", "loads.0.intensity"), samples=50)
    assert math.isnan(result["median"]) and "separate" in result["notes"]
    # quasi-separation (one mixed stripe between all-below and all-above) has no maximum either,
    # and stripes far apart must not pass for a fit once the weights underflow
    for exceeded in ([0, 0, 1, 20, 20], [0, 0, 20, 20, 20]):
        table = pd.DataFrame({"im": [0.01, 0.1, 1.0, 10.0, 100.0], "n": [20] * 5, "exceeded": exceeded})
        result = fit(table, samples=50)
        assert math.isnan(result["beta"]) and "separate" in result["notes"], exceeded
    falling = pd.DataFrame({"im": [0.1, 0.2, 0.4, 0.8], "n": [20] * 4, "exceeded": [15, 10, 5, 2]})
    assert "do not grow" in fit(falling, samples=0)["notes"]
    frame["first_passage_drift"] = np.nan
    result = fit(stripes(frame, "drift", "loads.0.intensity"), samples=50)
    assert math.isnan(result["beta"]) and "no fit" in result["notes"]
    with pytest.raises(KeyError, match="not a limit of this run"):
        stripes(frame, "roof", "loads.0.intensity")
    with pytest.raises(KeyError, match="not a numeric column"):
        stripes(frame, "drift", "status")


def test_points_at_one_intensity_make_one_stripe():
    """Sweep points sharing an intensity (the records of a suite scaled to one Sa) are pooled;
    an intensity of each realisation's own (a cloud) makes a stripe of one each."""
    frame = synthetic(np.random.default_rng(5))
    doubled = pd.concat([frame, frame.assign(point=frame["point"] + len(IM))], ignore_index=True)
    one, two = stripes(frame, "drift", "loads.0.intensity"), stripes(doubled, "drift", "loads.0.intensity")
    assert len(two) == len(IM) and (two["n"] == 2 * one["n"]).all()
    assert (two["exceeded"] == 2 * one["exceeded"]).all()
    cloud = frame.assign(sa=frame["loads.0.intensity"] * np.exp(0.01 * np.arange(len(frame))))
    table = stripes(cloud, "drift", "sa")
    assert len(table) == len(frame) and (table["n"] == 1).all()
    result = fit(table, samples=200)
    assert result["median_lo"] < result["median"] < result["median_hi"]


def test_fragility_command_on_a_run(tmp_path):
    """A linear SDOF under white noise swept over intensity: the exceedance of its peak
    displacement grows with the intensity; the command writes the table and the plot."""
    out = sdof_fragility_run(tmp_path, "sdof-fragility", realizations=200, points=6, samples=300)
    table = pd.read_parquet(out / "fragility.parquet")
    assert len(table) == 6 and (table["limit"] == "roof").all()
    first = table.iloc[0]
    assert first["median_lo"] < first["median"] < first["median_hi"]
    assert first["beta_lo"] < first["beta"] < first["beta_hi"]
    assert (out / "fragility_roof.png").stat().st_size > 0
    # the peak of a linear oscillator scales with the intensity: a limit b at intensity s is
    # the limit b / s at intensity 1, so the median intensity is where p(b / s) = 1/2 at s = 1
    assert 0.2 < first["median"] < 2.0
    code, err = cli("fragility", out, "--limit", "nope", "--im", "loads.0.intensity")
    assert code == 2 and "not a limit of this run" in err
    # the report shows the exceedances against intensity with the fitted curve
    code, err = cli("report", out, "--out", tmp_path / "reports")
    assert code == 0, err
    text = (tmp_path / "reports" / "sdof-fragility" / "report.md").read_text()
    assert "## Exceedance probabilities" in text and "p_roof_lo" in text and "## Fragility" in text
    assert f"{first['median']:.4g}" in text
    assert (tmp_path / "reports" / "sdof-fragility" / "exceedance.png").stat().st_size > 0


def test_results_fit_and_count_in_memory(tmp_path):
    """``Results.fragility`` fits the run in memory to the rows ``vines-stoch fragility`` wrote
    into its folder (the same stripes, median, beta and bounds), and ``Results.exceedance`` of
    the limit's metric at its value is the summary's ``p_roof`` with its interval."""
    import pandas as pd

    from tests.helpers import sdof_fragility_run
    from vines_stoch import read_results

    folder = sdof_fragility_run(tmp_path, "in-memory", 60, 5, 200)
    results = read_results(folder)
    written = pd.read_parquet(folder / "fragility.parquet")
    mine = results.fragility("roof", "loads.0.intensity", samples=200)
    for column in ("im", "n", "exceeded", "median", "beta", "median_lo", "median_hi", "beta_lo", "beta_hi",
                   "fitted"):
        np.testing.assert_array_equal(mine[column].to_numpy(), written[column].to_numpy(), err_msg=column)
    counted = results.exceedance("x1_max", 0.25)
    for suffix in ("", "_lo", "_hi"):
        np.testing.assert_allclose(counted[f"p{suffix}"], results.summary[f"p_roof{suffix}"], rtol=1e-12)
    assert list(counted.columns[:2]) == ["point", "loads.0.intensity"]
