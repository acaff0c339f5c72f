"""Uncertain parameters: draws against their distributions, common random numbers across sweep
points, validation of supports."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from tests.helpers import study_from, two_dof_data
from vines_stoch import ScenarioError, run
from vines_stoch.ensemble import draw_parameters

WHITE_NOISE = {"type": "white-noise", "intensity": 0.1}

DISTRIBUTIONS = {
    "normal": ({"distribution": "normal", "mean": 0.3, "std": 0.05}, stats.norm(0.3, 0.05)),
    "lognormal": ({"distribution": "lognormal", "median": 1.0, "cov": 0.3},
                  stats.lognorm(math.sqrt(math.log1p(0.3 ** 2)), scale=1.0)),
    "uniform": ({"distribution": "uniform", "low": 0.005, "high": 0.02}, stats.uniform(0.005, 0.015)),
    "truncated-normal": ({"distribution": "truncated-normal", "mean": 0.01, "std": 0.01, "low": 0.0,
                          "high": 0.015}, stats.truncnorm(-1.0, 0.5, loc=0.01, scale=0.01)),
}
KEYS = {"normal": "loads.1.phase", "lognormal": "absorbers.0.stiffness",
        "uniform": "absorbers.0.damping", "truncated-normal": "primary.damping"}


def scenario(n: int = 100, common: bool = True, changes: dict | None = None):
    """The Study of the two-body scene under white noise, ``n`` realisations, with ``changes``."""
    return study_from({
        "name": "uncertain",
        **two_dof_data(),
        "loads": [WHITE_NOISE],
        "simulation": {"duration": 20.0, "dt": 1e-2},
        "ensemble": {"realizations": n, "seed": 17, "common_random_numbers": common},
    }, changes)


@pytest.mark.parametrize("name", DISTRIBUTIONS)
def test_draws_match_their_distribution_within_four_standard_errors(name):
    spec, reference = DISTRIBUTIONS[name]
    key = KEYS[name]
    harmonic = {"type": "harmonic", "amplitude": 0.01, "frequency": 1.0, "phase": 0.0}
    study = scenario(changes={"loads": [WHITE_NOISE, harmonic], "uncertain": {key: spec}})
    n = 4000
    values = np.array([draw_parameters(study, 17, 0, r)[key] for r in range(n)])
    mean, var, _, kurtosis = (float(m) for m in reference.stats(moments="mvsk"))
    assert abs(values.mean() - mean) <= 4 * math.sqrt(var / n)
    se_var = math.sqrt((kurtosis + 2.0) * var * var / n)  # (mu4 - sigma^4) / n, mu4 = (kurt + 3) sigma^4
    assert abs(values.var(ddof=1) - var) <= 4 * se_var
    lo, hi = reference.support()
    assert values.min() >= lo and values.max() <= hi


def test_common_random_numbers_shrink_the_error_of_differences(tmp_path):
    """Two neighbouring noise intensities with an uncertain absorber damping: the standard
    error of the paired EDM difference is >= 5x smaller with common random numbers than the
    error of the difference of independent ensembles; results do not depend on the chunks."""
    changes = {"sweep": {"loads.0.intensity": [0.10, 0.11]},
               "uncertain": {"absorbers.0.damping": {"distribution": "uniform", "low": 0.005, "high": 0.02}}}
    n = 200
    errors = {}
    for common in (True, False):
        realizations, _ = run(scenario(n, common, changes), tmp_path / str(common), workers=2)
        a = realizations[realizations["point"] == 0]["edm"].to_numpy()
        b = realizations[realizations["point"] == 1]["edm"].to_numpy()
        drawn = realizations.pivot(index="realization", columns="point", values="absorbers.0.damping")
        if common:
            assert (drawn[0] == drawn[1]).all()
            errors[common] = np.std(b - a, ddof=1) / math.sqrt(n)
        else:
            assert (drawn[0] != drawn[1]).all()
            errors[common] = math.sqrt((np.var(a, ddof=1) + np.var(b, ddof=1)) / n)
    assert errors[True] * 5 <= errors[False]
    again, _ = run(scenario(n, True, changes), tmp_path / "chunk7", chunk=7, workers=1)
    first = pd.read_parquet(tmp_path / "True" / "realizations.parquet")
    pd.testing.assert_frame_equal(first, again, check_exact=True)


def test_uncertain_parameters_alone_make_an_ensemble(tmp_path):
    """A deterministic load with an uncertain stiffness runs `realizations` realisations."""
    study = scenario(30, changes={
        "loads": [{"type": "impulse", "velocity": 0.5}],
        "uncertain": {"absorbers.0.stiffness": {"distribution": "lognormal", "median": 1.0, "cov": 0.2}}})
    realizations, summary = run(study, tmp_path, workers=1)
    assert len(realizations) == 30 and summary["n_ok"].iloc[0] == 30
    assert realizations["absorbers.0.stiffness"].nunique() == 30
    assert realizations["edm"].nunique() == 30


@pytest.mark.parametrize("changes,message", [
    ({"uncertain": {"absorbers.0.stiffness": {"distribution": "normal", "mean": 1.0, "std": 0.1}}},
     "uncertain.absorbers.0.stiffness = {'distribution': 'normal', 'mean': 1.0, 'std': 0.1}: "
     "normal draws reach -1e+15, but the value must be >= 0"),
    ({"uncertain": {"absorbers.0.spring": {"distribution": "uniform", "low": 0.0, "high": 1.0}}},
     "uncertain.absorbers.0.spring = {'distribution': 'uniform', 'low': 0.0, 'high': 1.0}: "
     "must name an existing numeric field"),
    ({"uncertain": {"absorbers.0.damping": {"distribution": "uniform", "low": 0.2, "high": 0.1}}},
     "uncertain.absorbers.0.damping.high = 0.1: must be > low (0.2)"),
    ({"sweep": {"absorbers.0.damping": [0.01, 0.02]},
      "uncertain": {"absorbers.0.damping": {"distribution": "uniform", "low": 0.01, "high": 0.02}}},
     "is also swept"),
    ({"uncertain": {"absorbers.0.damping": {"distribution": "gamma", "shape": 2.0}}},
     "uncertain.absorbers.0.damping.distribution = 'gamma': must be one of"),
])
def test_bad_uncertain_sections_are_refused(changes, message):
    with pytest.raises(ScenarioError) as exc:
        scenario(changes=changes)
    assert message in str(exc.value)
