"""Seed 002's staged seven-parameter optimisation in both its versions as the example scenarios
``seed002_optimize_v1_stage{1,2,3}`` (section 3.1: objective at 7.23 rad/s, from the paper's
22.68 kg design) and ``seed002_optimize_stage{1,2,3}`` (section 3.2: at 6.3 rad/s, from its
39.67 kg design): each stage's ``[optimize]`` table names parameters the study can set and
starts from the printed design; stage 2 of the second version searches overlapping ranges of D
and C, and the ``from-primary`` obstacle's coupled constraint D < C (the absorber's own rule)
makes the candidates with D >= C infeasible: never run, never the optimum.

Each stage's outcome, run in full (60 evaluations, about 5 s each): the paper prints no bound
and no intermediate result, so the stages ask whether the printed design is a local optimum of
their parameters.  It is not of the first stage's: in both versions the mass climbs to its upper
bound (70 kg; held within 5 % of it) and the objective falls by more than 30 % (measured: 884 to
494 J at 6.3 rad/s; 76.3 to 18.0 J at 7.23 rad/s); the second version's stage 2 (c2, D, C) too
(884 to 464 J); the first version's stage 2 (c2, D) and both stage 3s (the moduli) move it by
under 10 % (measured 3.0 %, 0.5 %, 0.5 %).  The objective is deterministic (one realisation) but
impacting and in places chaotic, so a search's path may differ in its last bits from host to
host: the outcomes are held with wide margins."""

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
FIRST_VERSION = [ROOT / "scenarios" / f"seed002_optimize_v1_stage{n}.toml" for n in (1, 2, 3)]
#: Each stage's outcome (module text): the most the objective keeps of its start's, whether the
#: mass reaches its upper bound, and the least it keeps (a stage that barely moves the design).
OUTCOMES = {"seed002_optimize_stage1": (0.7, True, 0.0), "seed002_optimize_stage2": (0.7, False, 0.0),
            "seed002_optimize_stage3": (1.0, False, 0.9), "seed002_optimize_v1_stage1": (0.7, True, 0.0),
            "seed002_optimize_v1_stage2": (1.0, False, 0.9),
            "seed002_optimize_v1_stage3": (1.0, False, 0.9)}
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


@pytest.mark.parametrize("path", FIRST_VERSION, ids=lambda p: Path(p).stem)
def test_first_version_stage_starts_from_the_printed_design(path):
    study = load_scenario(path)
    printed = study_from(example_data("seed002_m22", "sweep"), {"loads.0.frequency": 7.23}).points[0]
    assert study.base.absorbers == printed.absorbers and study.base.loads == printed.loads
    for key, bound in study.base.optimize.parameters.items():
        assert bound.initial == _get(printed, key), key


@pytest.mark.parametrize("path", STAGES + FIRST_VERSION, ids=lambda p: Path(p).stem)
def test_each_stage_outcome(path, tmp_path):
    most, to_bound, least = OUTCOMES[Path(path).stem]
    study = load_scenario(path)
    best = optimize(study, tmp_path, workers=1)
    start = float(best.history[study.base.optimize.objective].iloc[0])
    assert least * start <= best.objective <= most * start
    mass = study.base.optimize.parameters.get("absorbers.0.mass")
    assert (mass is not None and best.values["absorbers.0.mass"] >= 0.95 * mass.high) == to_bound


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
