"""Seed 002's staged seven-parameter optimisation (section 3.2, second version) as the example
scenarios ``seed002_optimize_stage{1,2,3}``: each stage's ``[optimize]`` table names parameters the
study can set, starts from the paper's 39.67 kg design, and its box keeps the ``from-primary``
obstacle's coupled constraint D < C everywhere (the scenario rejects D >= C)."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest

from tests.helpers import ROOT, example_data, study_from
from vines_stoch.scenario import load_scenario

STAGES = [ROOT / "scenarios" / f"seed002_optimize_stage{n}.toml" for n in (1, 2, 3)]


@pytest.mark.parametrize("path", STAGES, ids=lambda p: Path(p).stem)
def test_stage_starts_from_the_printed_design_and_every_corner_is_valid(path):
    study = load_scenario(path)
    spec = study.base.optimize
    printed = study_from(example_data("seed002_m40", "sweep"), {"loads.0.frequency": 6.3}).points[0]
    assert study.base.absorbers == printed.absorbers and study.base.loads == printed.loads
    for key, bound in spec.parameters.items():
        assert bound.initial == _get(printed, key) == _get(study.base, key), key
    # the box's corners: where D < C holds at every corner of a box with D below C, it holds inside
    for corner in itertools.product(*((b.low, b.high) for b in spec.parameters.values())):
        point = study.with_values(dict(zip(spec.parameters, corner))).points[0]
        a = point.absorbers[0]
        assert a.offset < a.gap


def test_stage_2_box_keeps_d_below_c_and_d_at_c_is_rejected():
    study = load_scenario(STAGES[1])
    bounds = study.base.optimize.parameters
    assert bounds["absorbers.0.offset"].high < bounds["absorbers.0.gap"].low
    with pytest.raises(ValueError, match="offset"):
        study.with_values({"absorbers.0.offset": 0.12, "absorbers.0.gap": 0.12})


def _get(scenario, key: str) -> float:
    node = scenario.model_dump(mode="python")
    for part in key.split("."):
        node = node[int(part)] if isinstance(node, list) else node[part]
    return node
