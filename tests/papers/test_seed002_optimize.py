"""Seed 002's staged seven-parameter optimisation (section 3.2, second version) as the example
scenarios ``seed002_optimize_stage{1,2,3}``: each stage's ``[optimize]`` table names parameters the
study can set and starts from the paper's 39.67 kg design; stage 2 searches overlapping ranges
of D and C, and the ``from-primary`` obstacle's coupled constraint D < C (the absorber's own rule)
makes the candidates with D >= C infeasible: never run, never the optimum."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

import vines_stoch.optimize
from tests.helpers import ROOT, example_data, study_from
from vines_stoch import ScenarioError
from vines_stoch.optimize import optimize
from vines_stoch.scenario import load_scenario

STAGES = [ROOT / "scenarios" / f"seed002_optimize_stage{n}.toml" for n in (1, 2, 3)]
D, C = "absorbers.0.offset", "absorbers.0.gap"


@pytest.mark.parametrize("path", STAGES, ids=lambda p: Path(p).stem)
def test_stage_starts_from_the_printed_design(path):
    study = load_scenario(path)
    spec = study.base.optimize
    printed = study_from(example_data("seed002_m40", "sweep"), {"loads.0.frequency": 6.3}).points[0]
    assert study.base.absorbers == printed.absorbers and study.base.loads == printed.loads
    for key, bound in spec.parameters.items():
        assert bound.initial == _get(printed, key) == _get(study.base, key), key
    start = study.with_values({key: bound.initial for key, bound in spec.parameters.items()})
    assert start.points[0].absorbers[0].offset < start.points[0].absorbers[0].gap


def test_stage_2_ranges_overlap_and_d_at_or_past_c_is_refused():
    study = load_scenario(STAGES[1])
    bounds = study.base.optimize.parameters
    d, c = bounds[D], bounds[C]
    assert d.high > c.low                                           # overlapping: no disjoint workaround
    for offset, gap in ((0.1002, 0.1244), (1e-6, 0.0498)):          # the 39.67 and 62.02 kg designs
        assert d.low <= offset <= d.high and c.low <= gap <= c.high
        study.with_values({D: offset, C: gap})
    for offset, gap in ((0.12, 0.12), (0.3, 0.1)):                  # inside the box, past the rule
        with pytest.raises(ScenarioError, match=f"{D} = {offset:g}: must be < gap"):
            study.with_values({D: offset, C: gap})


def test_stage_2_never_runs_its_infeasible_candidates(monkeypatch, tmp_path):
    # the stage's box and start, a short run: its starting simplex steps D past C
    data = example_data("seed002_optimize_stage2")
    study = study_from(data, {"simulation.duration": 20.0, "simulation.metrics_from": 10.0,
                              "optimize.max_evaluations": 4})
    run, real = [], vines_stoch.optimize.sample

    def sample(candidate, workers):  # the real ensemble, counted
        absorber = candidate.points[0].absorbers[0]
        run.append((absorber.offset, absorber.gap))
        return real(candidate, workers)

    monkeypatch.setattr(vines_stoch.optimize, "sample", sample)
    best = optimize(study, tmp_path, workers=1)
    history = pd.read_parquet(tmp_path / "optimization.parquet")
    skipped = history[history["infeasible"] != ""]
    assert len(skipped) >= 1 and (skipped[D] >= skipped[C]).all()
    assert len(run) == len(history) - len(skipped) and all(offset < gap for offset, gap in run)
    assert best.values[D] < best.values[C]


def _get(scenario, key: str) -> float:
    node = scenario.model_dump(mode="python")
    for part in key.split("."):
        node = node[int(part)] if isinstance(node, list) else node[part]
    return node
