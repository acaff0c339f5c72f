"""Time histories of chosen realisations (``[output] paths``, paths.parquet): the paths those
realisations ran in the ensemble (the same as ``solve`` gives), every signal named, the stroke
the absorber's displacement less its host's, in memory and from a folder alike."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tests.helpers import two_dof_data
from vines_stoch import ScenarioError, read_results, run, solve
from vines_stoch.reports import phase_pairs, report

SIGNALS = ["x1", "xa_1", "stroke_1", "share", "e1"]
DATA = {
    "name": "chosen-paths",
    **two_dof_data(0.02, 1.0),
    "loads": [{"type": "white-noise", "intensity": 0.05}],
    "simulation": {"duration": 20.0, "dt": 1e-2},
    "ensemble": {"realizations": 9, "seed": 7, "chunk": 4},
    "sweep": {"loads.0.intensity": [0.02, 0.08]},
    "output": {"paths": {"realizations": [0, 5], "signals": SIGNALS, "points": 201}},
}


def test_chosen_paths_are_those_of_the_ensemble(tmp_path):
    results = run(DATA, workers=2)
    paths = results.paths
    assert list(paths.columns) == ["point", "loads.0.intensity", "realization", "t", *SIGNALS]
    assert sorted(set(zip(paths["point"], paths["realization"]))) == [(0, 0), (0, 5), (1, 0), (1, 5)]
    for (point, r), rows in paths.groupby(["point", "realization"]):
        one = solve(DATA, point=point, realization=r, points=201, signals=SIGNALS)
        np.testing.assert_array_equal(rows["t"], one.ts)
        for name in SIGNALS:
            np.testing.assert_array_equal(rows[name], one.ys[name])
        # the realisation's metrics in the ensemble are those of the same path
        row = results.realizations.query(f"point == {point} and realization == {r}").iloc[0]
        assert row["x1_max"] == one.metrics["x1_max"] and row["e1_max"] == one.metrics["e1_max"]
    np.testing.assert_array_equal(paths["stroke_1"], paths["xa_1"] - paths["x1"])
    assert ((paths["share"] >= 0) & (paths["share"] <= 1)).all() and paths["share"].max() > 0.01
    written = run(DATA, tmp_path / "out", workers=1)
    pd.testing.assert_frame_equal(read_results(tmp_path / "out").paths, paths, check_exact=True)
    pd.testing.assert_frame_equal(written.paths, paths, check_exact=True)


def test_a_realization_past_the_ensemble_is_refused_by_name():
    data = {**DATA, "output": {"paths": {"realizations": [9]}}}
    with pytest.raises(ScenarioError, match=r"output\.paths\.realizations.*must be in \[0, 8\]"):
        run(data)


def test_the_report_draws_time_histories_phase_portraits_and_impact_zones(tmp_path):
    """A vibro-impact NES swept in clearance under harmonic forcing (small clearances: impacts on
    both walls; a clearance past the stroke: none): the report draws the chosen path's time
    histories, the phase portraits of the bodies whose displacement and velocity it holds, and
    the zones of walls met against the clearance."""
    data = {"name": "vi-zones", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.02},
            "absorbers": [{"type": "impact", "mass": 0.1, "clearance": 0.05, "restitution": 0.6}],
            "loads": [{"type": "harmonic", "amplitude": 0.1, "frequency": 1.0}],
            "simulation": {"duration": 60.0, "dt": 1e-2, "scheme": "euler-maruyama"},
            "sweep": {"absorbers.0.clearance": [0.05, 100.0]},
            "output": {"paths": {"realizations": [0], "signals": ["x_1", "v_1", "xa_1", "va_1"]}}}
    run(data, tmp_path / "out")
    realizations = read_results(tmp_path / "out").realizations
    assert (realizations.loc[0, ["impacts_left", "impacts_right"]] > 0).all()
    assert realizations.loc[1, "impacts"] == 0
    page = report([tmp_path / "out"], tmp_path / "report")
    for name in ("paths.png", "phase_portrait.png", "impact_zones.png"):
        assert (page.parent / name).stat().st_size > 10_000  # (a rendered figure)
        assert f"]({name})" in page.read_text()
    assert phase_pairs(["x_1", "v_1", "xa_1", "e1", "v_2"]) == [("x_1", "v_1")]
