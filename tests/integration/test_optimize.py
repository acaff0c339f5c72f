"""Robust design: the optimiser against the closed-form optimal tuning of a TMD under white
noise, its output files, the validation of ``[optimize]`` tables, and the candidates that break
a rule between fields (infeasible: never run, never the optimum)."""

from __future__ import annotations

import math
import tomllib

import pandas as pd
import pytest

import vines_stoch.optimize
from tests.helpers import cli, example_data, study_from, toml_text
from vines_stoch import ScenarioError
from vines_stoch.optimize import from_unit, optimize, to_unit
from vines_stoch.scenario import Bound

MU = 0.05

#: Undamped primary (m = k = 1) with a linear TMD of mass ratio MU under a white-noise force;
#: x1_rms is the root mean square displacement over 2000 s of stationary response.
TMD = {
    "name": "tmd-white-noise",
    "primary": {"mass": 1.0, "stiffness": 1.0},
    "absorbers": [{"type": "linear", "mass": MU, "stiffness": 0.05, "damping": 0.01}],
    "loads": [{"type": "white-noise", "intensity": 1.0}],
    "simulation": {"duration": 2100.0, "dt": 0.05, "metrics_from": 100.0},
    "ensemble": {"realizations": 32, "seed": 7},
}

#: The ``[optimize]`` table: the absorber's stiffness and (log-scaled) damping for the least x1_rms.
OPTIMIZE = {
    "objective": "x1_rms",
    "parameters": {"absorbers.0.stiffness": {"low": 0.03, "high": 0.07},
                   "absorbers.0.damping": {"low": 0.002, "high": 0.05, "scale": "log"}},
}


def warburton() -> tuple[float, float]:
    """Optimal frequency ratio and damping ratio of a TMD on an undamped primary for the least
    displacement variance under a white-noise force (Warburton 1982)."""
    return (math.sqrt(1 + MU / 2) / (1 + MU),
            math.sqrt(MU * (1 + 3 * MU / 4) / (4 * (1 + MU) * (1 + MU / 2))))


def test_finds_the_closed_form_tmd_tuning_within_two_percent(write, tmp_path):
    path = write(toml_text(TMD | {"optimize": OPTIMIZE}))
    out = tmp_path / "opt"
    code, err = cli("optimize", path, "--out", out)
    assert code == 0, err
    optimum = tomllib.loads((out / "optimum.toml").read_text())["absorbers"][0]
    f = math.sqrt(optimum["stiffness"] / MU)            # absorber frequency / primary frequency
    zeta = optimum["damping"] / (2 * MU * f)
    f_opt, zeta_opt = warburton()
    assert abs(f / f_opt - 1) < 0.02, (f, f_opt)
    assert abs(zeta / zeta_opt - 1) < 0.02, (zeta, zeta_opt)
    # the objective history holds every evaluation; the optimum is its best, rerun as a scenario
    history = pd.read_parquet(out / "optimization.parquet")
    assert len(history) >= 10 and history["n_failed"].eq(0).all()
    best = history.loc[history["x1_rms"].idxmin()]
    assert best["absorbers.0.stiffness"] == optimum["stiffness"]
    summary = pd.read_parquet(out / "summary.parquet")
    assert summary["x1_rms_mean"].iloc[0] == pytest.approx(best["x1_rms"], rel=1e-12)
    report = (out / "report.md").read_text()
    assert "## Optimum" in report and (out / "objective_history.png").stat().st_size > 1000
    assert "[optimize]" not in (out / "optimum.toml").read_text()


def test_common_random_numbers_make_the_objective_a_function_of_the_parameters(write, tmp_path):
    from vines_stoch.ensemble import sample
    from vines_stoch.optimize import objective

    study = study_from(TMD, {"ensemble.realizations": 4, "simulation.duration": 300.0, "optimize": OPTIMIZE})
    values = {"absorbers.0.stiffness": 0.046, "absorbers.0.damping": 0.0105}
    first = objective(sample(study.with_values(values), workers=1), "x1_rms")
    again = objective(sample(study.with_values(values), workers=2), "x1_rms")
    assert first == again


@pytest.mark.parametrize("scale", ["linear", "log"])
def test_scaled_coordinates_round_trip(scale):
    bound = Bound(low=0.002, high=0.05, scale=scale)
    for value in (0.002, 0.01, 0.05):
        assert from_unit(bound, to_unit(bound, value)) == pytest.approx(value, rel=1e-12)
    assert from_unit(bound, 1.5) == 0.05 and from_unit(bound, -0.5) == 0.002


@pytest.mark.parametrize("parameters, message", [
    ({"absorbers.0.damping": {"low": -0.01, "high": 0.05}},
     "optimize.parameters.absorbers.0.damping = {'low': -0.01, 'high': 0.05}: "
     "the bound -0.01 is not allowed: the value must be >= 0"),
    ({"absorbers.0.damping": {"low": 0.0, "high": 0.05, "scale": "log"}}, "must be > 0 with scale = 'log'"),
    ({"absorbers.0.damping": {"low": 0.05, "high": 0.01}}, "must be > low (0.05)"),
    ({"absorbers.0.damping": {"low": 0.01, "high": 0.05, "start": 0.1}}, "must be in [0.01, 0.05]"),
    ({"absorbers.0.colour": {"low": 0.01, "high": 0.05}}, "must name an existing numeric field"),
    ({"loads.0.intensity": {"low": 0.5, "high": 2.0}}, "is swept or uncertain"),
])
def test_bad_optimize_tables_are_named(parameters, message):
    changes = {"sweep": {"loads.0.intensity": [1.0, 2.0]}, "optimize": {"parameters": parameters}}
    with pytest.raises(ScenarioError) as err:
        study_from(TMD, changes, source="tmd.toml")
    assert message in str(err.value)
    assert str(err.value).startswith("tmd.toml: optimize.parameters.")


def test_unknown_objective_lists_the_allowed_ones():
    with pytest.raises(ScenarioError, match="optimize.objective = 'impacts': must be 'edm', 'e1_max'"):
        study_from(TMD, {"optimize": OPTIMIZE | {"objective": "impacts"}}, source="tmd.toml")


def test_optimize_without_table_is_refused(write):
    code, err = cli("optimize", write(toml_text(TMD)))
    assert code == 2 and "no [optimize] table" in err


#: Seed 002's single-sided Hertz absorber with a 'from-primary' obstacle: its offset D must stay
#: below its gap C (the absorber would start inside the obstacle), a rule of the absorber.
OBSTACLE = example_data("seed002_optimize_stage2", "optimize")
D, C = "absorbers.0.offset", "absorbers.0.gap"


def _obstacle(offset: dict, gap: dict):
    return study_from(OBSTACLE, {"optimize": {"objective": "e1_max", "max_evaluations": 40,
                                              "parameters": {D: offset, C: gap}}}, source="hertz.toml")


def test_candidates_past_a_coupled_rule_are_never_run_nor_the_optimum(monkeypatch, tmp_path):
    # overlapping ranges: D < C is kept by the absorber's own rule, candidate by candidate
    study = _obstacle({"low": 0.0, "high": 0.2, "start": 0.02}, {"low": 0.04, "high": 0.4, "start": 0.3})
    run: list[tuple[float, float]] = []

    def sample(candidate, workers):  # stands in for the ensemble: the objective C - D drives D towards C
        absorber = candidate.points[0].absorbers[0]
        run.append((absorber.offset, absorber.gap))
        return pd.DataFrame({"point": [0], "status": ["ok"], "e1_max": [absorber.gap - absorber.offset]})

    monkeypatch.setattr(vines_stoch.optimize, "sample", sample)
    best = optimize(study, tmp_path)
    history = pd.read_parquet(tmp_path / "optimization.parquet")
    skipped = history[history["infeasible"] != ""]
    assert len(skipped) >= 3 and (skipped[D] >= skipped[C]).all()
    assert skipped["infeasible"].str.startswith(f"{D} = ").all()
    assert skipped["infeasible"].str.contains("must be < gap").all() and skipped["e1_max"].isna().all()
    assert run and all(offset < gap for offset, gap in run)      # no infeasible candidate simulated
    assert len(run) == len(history) - len(skipped)
    assert best.values[D] < best.values[C]
    assert best.objective == pytest.approx(best.values[C] - best.values[D])
    assert best.objective == min(gap - offset for offset, gap in run)
    assert best.objective < 0.05                                  # the search went up to the constraint


def test_a_start_design_past_a_coupled_rule_is_named():
    with pytest.raises(ScenarioError) as err:
        _obstacle({"low": 0.0, "high": 0.2, "start": 0.13}, {"low": 0.04, "high": 0.4, "start": 0.1244})
    assert str(err.value) == (
        "hertz.toml: optimize.parameters: the start design (absorbers.0.offset = 0.13, absorbers.0.gap = "
        "0.1244) is not valid: absorbers.0.offset = 0.13: must be < gap (0.1244) with obstacle = "
        "'from-primary' (the absorber would start inside the obstacle); set each parameter's start "
        "(within [low, high]) where the design is valid")


@pytest.mark.parametrize("parameters, message", [
    # no candidate can take D = 0.5: C stays below 0.4
    ({D: {"low": 0.0, "high": 0.5, "start": 0.1}, C: {"low": 0.04, "high": 0.4, "start": 0.2}},
     f"optimize.parameters.{D} = {{'low': 0.0, 'high': 0.5, 'start': 0.1}}: the bound 0.5 is not allowed: "
     "the value must be < gap (0.2) with obstacle = 'from-primary' (the absorber would start inside the "
     "obstacle) (with the other optimised parameters at their starts; no corner of their ranges allows it "
     "either)"),
    # C alone: D stays at the file's 0.1002
    ({C: {"low": 0.04, "high": 0.4, "start": 0.2}},
     f"optimize.parameters.{C} = {{'low': 0.04, 'high': 0.4, 'start': 0.2}}: the bound 0.04 is not allowed: "
     f"{D} = 0.1002: must be < gap (0.04) with obstacle = 'from-primary'"),
])
def test_bounds_no_candidate_can_take_are_named(parameters, message):
    with pytest.raises(ScenarioError) as err:
        study_from(OBSTACLE, {"optimize": {"objective": "e1_max", "parameters": parameters}},
                   source="hertz.toml")
    assert str(err.value).startswith(f"hertz.toml: {message}")
