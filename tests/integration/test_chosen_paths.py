"""Time histories of chosen realisations (``[output] paths``, paths.parquet): the paths those
realisations ran in the ensemble (the same as ``solve`` gives), every signal named, the stroke
the absorber's displacement less its host's, in memory and from a folder alike."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tests.helpers import two_dof_data
from vines_stoch import ScenarioError, read_results, run, solve

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
