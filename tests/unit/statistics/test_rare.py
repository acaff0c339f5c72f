"""Rare-event estimates (``vines_stoch/rare.py``) against the exact first-passage probability of
a linear oscillator's discrete-time Gaussian process, computed by an independent method
(``validation/first_passage.py``: importance sampling using elementary events, Au and Beck,
Probab. Eng. Mech. 16 (2001) 193, on the response's linear map; about 1 % coefficient of
variation), crude Monte Carlo and each other.

The oscillator: omega = 2 pi, zeta = 0.05, white noise scaled to a stationary standard deviation
of 1, from rest, T = 10 s, dt = 0.01; the peak of |x| over the step ends.

Tolerances: an estimate and the reference agree within ``Z`` standard errors of their difference
(the estimator's reported ``cov`` and the reference's own standard error).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from tests.helpers import scene_from, study_from
from vines_stoch import rare, run
from vines_stoch.scenario.errors import ScenarioError
from vines_stoch.validation.first_passage import isee, response_matrix

OMEGA, ZETA = 2 * math.pi, 0.05
#: The white-noise intensity of a stationary standard deviation of 1: ``sigma^2 / (4 zeta omega^3)``.
SIGMA = math.sqrt(4 * ZETA * OMEGA ** 3)
#: Standard errors of a difference within which two estimates agree (a two-sided 0.3 % test for each).
Z = 3.0
#: The limit of p about 7e-4 of the 3 s oscillator with a lognormal stiffness (cov 0.3).
VALUE_UNCERTAIN = 4.0


def oscillator(value: float, duration: float = 10.0) -> dict:
    """The linear oscillator of the module with a limit ``roof`` on the peak of ``|x|``."""
    return {"name": "oscillator",
            "primary": {"mass": 1.0, "stiffness": OMEGA ** 2, "damping": 2 * ZETA * OMEGA},
            "loads": [{"type": "white-noise", "intensity": SIGMA}],
            "simulation": {"duration": duration, "dt": 0.01, "scheme": "euler-maruyama"},
            "ensemble": {"realizations": 10, "seed": 3},
            "limits": {"roof": {"metric": "x1_max", "value": value}}}


@pytest.fixture(scope="module")
def matrix() -> np.ndarray:
    return response_matrix(scene_from(oscillator(1.0)))


def agree(p: float, cov: float, reference: float, se: float) -> bool:
    """Whether an estimate with coefficient of variation ``cov`` agrees with the reference."""
    return abs(p - reference) <= Z * math.hypot(p * cov, se)


@pytest.mark.parametrize("value, p_about, particles, target", [(4.2, 1e-3, 100, 0.1), (5.3, 1e-5, 200, 0.2),
                                                               (5.75, 1e-6, 200, 0.15)])
def test_splitting_against_the_exact_first_passage(matrix, value, p_about, particles, target):
    """Each estimate reaches its target within 30,000 path-equivalents (at 1e-6 the target is
    0.15: the energy score's replica of 200 paths spends about 1,100 path-equivalents at a
    coefficient of variation of about 0.34, so about 6,000 in all) and agrees with the exact
    probability."""
    reference, se = isee(matrix, value)
    assert p_about / 3 < reference < 3 * p_about
    scene = scene_from(oscillator(value))
    e = rare.estimate(lambda j: scene, 0, "splitting", 11, 0, particles=particles, target_cov=target,
                      max_paths=30_000)
    assert e.cov <= target and e.paths <= 30_000, (e.cov, e.paths)
    assert agree(e.p, e.cov, reference, se), (e.p, e.cov, reference, se)
    assert e.p_lo <= e.p <= e.p_hi


def test_subset_simulation_against_the_exact_first_passage(matrix):
    value = 5.3
    reference, se = isee(matrix, value)
    scene = scene_from(oscillator(value))
    e = rare.estimate(lambda j: scene, 0, "subset", 11, 0, particles=500, target_cov=0.2, max_paths=60_000)
    assert agree(e.p, e.cov, reference, se), (e.p, e.cov, reference, se)
    assert len(e.replicas[0].levels) >= 4  # (P0 = 0.1: four levels below 1e-5)


def test_the_reference_against_crude_monte_carlo(matrix, monkeypatch):
    """At p about 1e-3 the ensemble's own exceedance fraction (its Wilson interval) holds the
    reference: the reference is that of the engine's process, its limit included.  (On the
    general loop, the same numbers bitwise: 10^8 path-steps would compile a lane loop of their
    own, 16 s, for 4 s saved.)"""
    monkeypatch.setenv("VINES_STOCH_GENERAL_WORK", "inf")
    value = 4.2
    reference, se = isee(matrix, value)
    summary = run(oscillator(value) | {"ensemble": {"realizations": 100_000, "seed": 5}}).summary
    assert summary.p_roof_lo[0] <= reference <= summary.p_roof_hi[0]


def impact_oscillator(value: float, realizations: int = 10) -> dict:
    """The oscillator for 2 s with a vibro-impact absorber (about 17 impacts a path)."""
    data = oscillator(value, duration=2.0)
    data["absorbers"] = [{"type": "impact", "mass": 0.05, "clearance": 0.2, "restitution": 0.6}]
    data["ensemble"] = {"realizations": realizations, "seed": 8}
    return data


def welch_agree(p: float, se: float, dof: float, q: float, se_q: float, dof_q: float) -> bool:
    """Whether two estimates agree in Welch's test at ``Z``'s two-sided level: their difference
    within Student's ``t`` quantile of the Welch-Satterthwaite degrees of freedom times its
    standard error, for standard errors estimated from ``dof`` and ``dof_q`` degrees of freedom
    (a replica count less one; ``inf``: a standard error known, as crude Monte Carlo's)."""
    var, var_q = se * se, se_q * se_q
    nu = (var + var_q) ** 2 / ((var * var / dof if math.isfinite(dof) else 0.0)
                               + (var_q * var_q / dof_q if math.isfinite(dof_q) else 0.0) + 1e-300)
    return abs(p - q) <= stats.t.ppf(stats.norm.cdf(Z), nu) * math.sqrt(var + var_q)


@pytest.mark.slow  # (500,000 paths and 24 replicas: about 60 s on 2 cores)
def test_splitting_subset_and_crude_monte_carlo_agree_on_a_scene_with_impacts():
    """p about 2e-4: crude Monte Carlo on 500,000 paths (its Wilson interval's half-width over
    1.96 as its standard error), splitting and subset simulation (12 replicas each), pairwise in
    Welch's test at ``Z``'s level: the replicas' spread estimates each method's standard error
    from 11 degrees of freedom.  (With the 5 to 8 replicas the target stops at, the splitting's
    spread came out at a quarter of its usual size on one set of streams, a 1 % event of a
    chi-square of 4 degrees of freedom, and a normal ``Z`` band took it at its word.)"""
    value = 3.35
    summary = run(impact_oscillator(value, 500_000)).summary
    crude, crude_se = summary.p_roof[0], (summary.p_roof_hi[0] - summary.p_roof_lo[0]) / (2 * 1.96)
    scene = scene_from(impact_oscillator(value))
    assert scene.has_impact
    split = rare.estimate(lambda j: scene, 0, "splitting", 2, 0, particles=200, target_cov=0.25,
                          max_paths=1e9, replicas=12)
    sub = rare.estimate(lambda j: scene, 0, "subset", 2, 0, particles=500, target_cov=0.15, max_paths=1e9,
                        replicas=12)
    assert 1e-4 < crude < 4e-4
    split_se, sub_se = split.p * split.cov, sub.p * sub.cov
    known = math.inf  # (crude Monte Carlo's standard error)
    assert welch_agree(split.p, split_se, 11, crude, crude_se, known), (split.p, split.cov, crude, crude_se)
    assert welch_agree(sub.p, sub_se, 11, crude, crude_se, known), (sub.p, sub.cov, crude, crude_se)
    assert welch_agree(split.p, split_se, 11, sub.p, sub_se, 11), (split.p, split.cov, sub.p, sub.cov)


def test_the_reported_cov_matches_the_spread_of_repeated_estimates(matrix):
    """20 estimates on 20 seeds: the spread of the estimates against the coefficient of variation
    each reports.  Under normality ``s / sigma`` of 20 values lies in [0.57, 1.45] with 99 %
    probability (chi-square, 19 degrees of freedom): the band of the ratio."""
    scene = scene_from(oscillator(2.6, duration=3.0))
    estimates = [rare.estimate(lambda j: scene, 0, "splitting", seed, 0, particles=50, target_cov=0.25,
                               max_paths=20_000) for seed in range(20)]
    ps = np.array([e.p for e in estimates])
    spread = ps.std(ddof=1) / ps.mean()
    reported = np.sqrt(np.mean([e.cov ** 2 for e in estimates]))
    low, high = (math.sqrt(stats.chi2.ppf(q, 19) / 19) for q in (0.005, 0.995))
    assert low <= spread / reported <= high, (spread, reported)


def test_an_estimate_depends_on_its_seed_and_point_alone():
    scene = scene_from(oscillator(3.5, duration=3.0))
    first = rare.estimate(lambda j: scene, 0, "splitting", 4, 2, particles=40, target_cov=0.5, max_paths=1e9,
                          replicas=3)
    again = rare.estimate(lambda j: scene, 0, "splitting", 4, 2, particles=40, target_cov=0.5, max_paths=1e9,
                          replicas=2)
    other = rare.estimate(lambda j: scene, 0, "splitting", 4, 3, particles=40, target_cov=0.5, max_paths=1e9,
                          replicas=2)
    assert [r.p for r in again.replicas] == [r.p for r in first.replicas[:2]]
    assert [r.p for r in other.replicas] != [r.p for r in again.replicas]


def test_a_branch_replays_its_parent_up_to_the_level():
    """A branch starts from its parent's state at the first step the parent's score (the running
    peak of ``E1``) exceeded the level (bitwise: the parent replayed from its start), and leaves
    it after."""
    from vines_stoch.kernels import advance

    scene = scene_from(oscillator(3.0, duration=3.0))
    split = rare._Splitting(lambda j: scene, 0, 1, 0, 0, 1)
    assert split.score.energy
    (parent,) = split.start()
    level = 0.6 * parent.score
    (child,) = split.branch([parent], level)
    shared = next(i for i, (a, b) in enumerate(zip(child.snaps, parent.snaps)) if a is not b)
    start = child.snaps[shared]  # (the child at its branching step)
    replay = parent.snaps[0].branch()
    advance(replay, start.step - 1)
    assert split._peak(replay) <= level
    advance(replay, start.step)
    assert split._peak(replay) > level
    assert np.array_equal(replay.x, start.x) and np.array_equal(replay.v, start.v)
    assert child.score > level and child.score != parent.score


def frame(limit: str, value: float, duration: float = 3.0) -> dict:
    """Two storeys (1 kg each, 40 and 30 N/m, 2 % Rayleigh), a cubic NES on the roof, white noise
    on the roof; a limit ``roof`` on ``limit``."""
    return {"name": "frame", "primary": {"masses": [1.0, 1.0], "stiffnesses": [40.0, 30.0],
                                         "rayleigh": {"ratio": 0.02, "modes": [1, 2]}},
            "absorbers": [{"type": "cubic", "mass": 0.1, "stiffness": 20.0, "damping": 0.05}],
            "loads": [{"type": "white-noise", "intensity": 2.0}],
            "simulation": {"duration": duration, "dt": 0.01, "scheme": "euler-maruyama"},
            "ensemble": {"realizations": 10, "seed": 3},
            "limits": {"roof": {"metric": limit, "value": value}}}


@pytest.mark.parametrize("limit, signal, springs, unsprung", [
    ("x_max_1", "x_1", [40.0], [0.0, 30.0]),
    ("x_max_2", "x_2", [40.0, 30.0], [40.0, 0.0]),
    ("drift_max_2", "drift_2", [30.0], [40.0, 0.0]),
])
def test_the_energy_score_bounds_the_limited_displacement(limit, signal, springs, unsprung):
    """``x_k^2 <= 2 E1 / K`` at every step of a path (``K``: the series stiffness of the storeys
    below floor ``k``; a drift's own storey), so that every path above the limit has passed the
    splitting's last level; acceleration limits and a storey without a spring keep the metric's
    own peak."""
    from vines_stoch.ensemble import solve

    data = frame(limit, 1.0, duration=20.0)
    scene = scene_from(data)
    bound = rare.energy_bound(scene, 0)
    assert bound == pytest.approx(1.0 / sum(1.0 / k for k in springs), rel=1e-15)
    path = solve(data, signals=[signal, "e1"])
    ratio = 0.5 * bound * path.ys[signal][1:] ** 2 / path.ys["e1"][1:]  # (from the first step: E1(0) = 0)
    assert ratio.max() <= 1.0 + 1e-12
    assert ratio.max() > 0.5  # (not a loose bound: the scores of a level track the displacement)
    assert rare.energy_bound(scene_from(frame("acc_max_2", 1.0)), 0) is None
    assert rare.energy_bound(scene_from(frame(limit, 1.0) | {"primary": {"masses": [1.0, 1.0],
                                                                       "stiffnesses": unsprung}}), 0) is None


def test_splitting_with_the_energy_score_against_crude_monte_carlo_on_two_storeys():
    """The roof's displacement of the two-storey frame at p about 1e-3: crude Monte Carlo on
    200,000 paths (its Wilson interval's half-width over 1.96 as its standard error) and splitting
    on the energy score agree within ``Z`` standard errors of their difference."""
    data = frame("x_max_2", 1.55)
    summary = run(data | {"ensemble": {"realizations": 200_000, "seed": 5}}).summary
    crude, crude_se = summary.p_roof[0], (summary.p_roof_hi[0] - summary.p_roof_lo[0]) / (2 * 1.96)
    assert 3e-4 < crude < 3e-3
    scene = scene_from(data)
    split = rare.estimate(lambda j: scene, 0, "splitting", 6, 0, particles=100, target_cov=0.15,
                          max_paths=40_000)
    assert agree(split.p, split.cov, crude, crude_se), (split.p, split.cov, crude, crude_se)


def rare_data(method: str = "splitting", **rare_keys) -> dict:
    return oscillator(3.5, duration=3.0) | {"rare": {"limit": "roof", "method": method, "target_cov": 0.3,
                                                     "max_paths": 3000, "particles": 50, **rare_keys}}


def test_rare_parquet_in_memory_and_from_the_folder(tmp_path):
    from vines_stoch import read_results

    results = run(rare_data(), tmp_path / "out")
    again = read_results(tmp_path / "out")
    assert list(results.rare.columns[:8]) == ["point", "p", "cov", "p_lo", "p_hi", "paths", "levels",
                                              "replicas"]
    assert results.rare.equals(again.rare)
    row = results.rare.iloc[0]
    assert row.method == "splitting" and 0 < row.p < 1 and row.paths > 0
    assert len(row.replica_p) == row.replicas and np.isclose(np.mean(row.replica_p), row.p)


@pytest.mark.parametrize("changes, key", [
    ({"rare.limit": "floor"}, "rare.limit"),
    ({"rare.target_cov": 1.5}, "rare.target_cov"),
    ({"rare.method": "importance"}, "rare.method"),
    ({"rare.particles": 55, "rare.method": "subset"}, "rare.particles"),
    ({"loads": [{"type": "harmonic", "amplitude": 1.0, "frequency": 1.0}]}, "rare"),
])
def test_bad_rare_tables_are_refused_by_name(changes, key):
    with pytest.raises(ScenarioError, match=key.replace(".", r"\.")):
        study_from(rare_data(), changes)


@pytest.mark.slow  # (100,000 paths and a subset run: about 35 s on 2 cores)
def test_subset_simulation_samples_the_uncertain_parameters():
    """The oscillator for 3 s with a lognormal stiffness (cov 0.3) at p about 7e-4: subset
    simulation on the noise and the parameter's normal (through a run's ``[rare]`` table) and
    crude Monte Carlo on 100,000 paths (each its own stiffness) agree within ``Z`` standard errors
    of their difference.  The stiffness matters: at its median the probability is about a
    tenth of that (measured 6.5e-5 on 200,000 paths), far outside the tolerance."""
    stiffness = {"distribution": "lognormal", "median": OMEGA ** 2, "cov": 0.3}
    data = oscillator(VALUE_UNCERTAIN, duration=3.0) | {"uncertain": {"primary.stiffness": stiffness}}
    summary = run(data | {"ensemble": {"realizations": 100_000, "seed": 5}}).summary
    crude, crude_se = summary.p_roof[0], (summary.p_roof_hi[0] - summary.p_roof_lo[0]) / (2 * 1.96)
    assert 3e-4 < crude < 3e-3
    results = run(data | {"rare": {"limit": "roof", "method": "subset", "particles": 500, "target_cov": 0.15,
                                   "max_paths": 40_000}})
    row = results.rare.iloc[0]
    p, cov = row["p"], row["cov"]
    assert row["method"] == "subset" and cov <= 0.15
    assert agree(p, cov, crude, crude_se), (p, cov, crude, crude_se)


def filtered_oscillator(value: float, realizations: int = 10) -> dict:
    """The oscillator for 5 s under a filtered noise (a second-order filter at 6 rad/s, damping
    0.3, from its stationary law) of a response standard deviation of about 1, no white noise."""
    data = oscillator(value, duration=5.0)
    data["loads"] = [{"type": "filtered-noise", "intensity": 170.0, "frequency": 6.0, "damping": 0.3,
                      "start": "stationary"}]
    data["ensemble"] = {"realizations": realizations, "seed": 6}
    return data


def test_subset_simulation_on_filtered_loads_against_the_exact_first_passage():
    """Subset simulation samples the filters' normals (replayed from a tape): at p about 6e-4
    against the exact probability of the discrete process, linear in those normals
    (``response_matrix`` reads the map from the loop); the reference itself against crude Monte
    Carlo on 20,000 paths at p about 2e-2 (its Wilson interval's half-width over 1.96 as its
    standard error), and from a run's ``[rare]`` table."""
    a = response_matrix(scene_from(filtered_oscillator(1.0)))
    reference, se = isee(a, 4.0)
    assert 3e-4 < reference < 1.2e-3
    scene = scene_from(filtered_oscillator(4.0))
    assert scene.has_filters and not scene.has_white_noise
    e = rare.estimate(lambda j: scene, 0, "subset", 11, 0, particles=500, target_cov=0.15, max_paths=60_000)
    assert e.cov <= 0.15 and agree(e.p, e.cov, reference, se), (e.p, e.cov, reference, se)
    crude_reference, crude_se_ref = isee(a, 3.0)
    summary = run(filtered_oscillator(3.0, 20_000)).summary
    crude, crude_se = summary.p_roof[0], (summary.p_roof_hi[0] - summary.p_roof_lo[0]) / (2 * 1.96)
    assert abs(crude - crude_reference) <= Z * math.hypot(crude_se, crude_se_ref), (crude, crude_reference)
    data = filtered_oscillator(3.0) | {"rare": {"limit": "roof", "method": "subset", "particles": 200,
                                                "target_cov": 0.3, "max_paths": 5000}}
    row = run(data).rare.iloc[0]
    assert row["method"] == "subset" and agree(row["p"], row["cov"], crude_reference, crude_se_ref)


def test_subset_simulation_refuses_a_scene_without_noise():
    scene = scene_from(oscillator(1.0) | {"loads": [{"type": "impulse", "velocity": 1.0}]})
    with pytest.raises(ValueError, match=r"subset.*has none"):
        rare.subset(scene, 0, 100, 1, 0, 0)


def test_fragility_takes_the_rare_estimates_as_stripes(tmp_path):
    """A sweep over the noise's intensity whose weakest point crude Monte Carlo (200 paths) sees
    no exceedance at: the rare estimates join the stripes as counts of equal information, and
    the stripe's fraction is then the estimate's."""
    from vines_stoch.fragility import fragility

    data = oscillator(3.0, duration=3.0) | {
        "ensemble": {"realizations": 200, "seed": 1},
        "sweep": {"loads.0.intensity": [0.6 * SIGMA, 0.8 * SIGMA, SIGMA]},
        "rare": {"limit": "roof", "target_cov": 0.3, "max_paths": 20_000, "particles": 50}}
    results = run(data, tmp_path / "out")
    weakest = results.realizations[results.realizations.point == 0]
    assert weakest.first_passage_roof.notna().sum() == 0
    rows = fragility(tmp_path / "out", "roof", "loads.0.intensity", samples=200, plot=False)
    assert (rows.n_rare > 0).all()
    estimate = results.rare.set_index("point")
    first = rows.iloc[0]
    assert first.fraction == pytest.approx(estimate.p[0], rel=1e-3)  # (200 crude paths beside some 1e7)
    assert np.isfinite(first["median"]) and first["beta"] > 0


def test_an_interrupted_estimate_resumes_from_its_saved_replicas(tmp_path, monkeypatch):
    """Ctrl-C during the third replica: the folder keeps the two run (``parts/studies.npz``); the
    resumed run runs only the others, and its estimate is that of a run in one go, bitwise."""
    from vines_stoch import ensemble

    data = rare_data()
    whole = run(data).rare
    calls, real = [], rare.splitting

    def counting(*args, **kwargs):
        calls.append(args[6])  # (the replica)
        if interrupt and len(calls) == 3:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(rare, "splitting", counting)
    interrupt = True
    with pytest.raises(ensemble.Interrupted):
        run(data, tmp_path / "out")
    assert (tmp_path / "out" / "parts" / "studies.npz").exists()
    interrupt, calls[:] = False, []
    resumed = run(data, tmp_path / "out", resume=True).rare
    assert calls == list(range(2, whole.replicas[0]))
    assert resumed.equals(whole)
