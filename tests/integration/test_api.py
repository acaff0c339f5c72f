"""The Python API as a notebook uses it: a dict in, a results object out, nothing written; the
same results from a folder; one realisation's time histories; clear errors for bad arguments."""

from __future__ import annotations

import os

import numpy as np
import pandas as pd
import pytest

import vines_stoch
from tests.helpers import two_dof_data
from vines_stoch import Results, ScenarioError, read_results, run, solve

#: A noisy sweep of two points with history statistics and a limit (a few seconds a run).
DATA = {
    "name": "api",
    **two_dof_data(0.02, 1.0),
    "loads": [{"type": "white-noise", "intensity": 0.05}],
    "simulation": {"duration": 10.0, "dt": 1e-2, "history": {"points": 21}},
    "ensemble": {"realizations": 12, "seed": 5},
    "limits": {"drift": {"metric": "x1_max", "value": 0.3}},
    "sweep": {"loads.0.intensity": [0.02, 0.08]},
}


@pytest.fixture(scope="module")
def in_memory(tmp_path_factory) -> tuple[Results, list[str]]:
    """The run of ``DATA`` in memory, and what its working folder held after it (started empty)."""
    folder = tmp_path_factory.mktemp("cwd")
    before = os.getcwd()
    os.chdir(folder)
    try:
        results = run(DATA, workers=2)
        return results, sorted(os.listdir(folder))
    finally:
        os.chdir(before)


def test_dict_in_results_out_nothing_written(in_memory):
    results, written = in_memory
    assert written == []
    assert results.directory is None and results.paths is None
    assert isinstance(results.realizations, pd.DataFrame) and len(results.realizations) == 24
    assert list(results.summary["loads.0.intensity"]) == [0.02, 0.08]
    assert {"p_drift", "p_drift_lo", "p_drift_hi"} <= set(results.summary.columns)
    assert set(results.history["point"]) == {0, 1} and len(results.history) == 2 * 21
    assert results.metadata["vines_stoch.source"] == "<dict>"
    assert results.scenario.base.name == "api"
    realizations, summary = results  # (as the tuple run used to return)
    assert realizations is results.realizations and summary is results.summary


def test_folder_results_equal_those_in_memory(in_memory, tmp_path):
    results, _ = in_memory
    written = run(DATA, tmp_path / "out", workers=1, chunk=5)
    again = read_results(tmp_path / "out")
    for other in (written, again):
        pd.testing.assert_frame_equal(other.realizations, results.realizations, check_exact=True)
        pd.testing.assert_frame_equal(other.summary, results.summary, check_exact=True)
        pd.testing.assert_frame_equal(other.history, results.history, check_exact=True)
    assert written.directory == again.directory == tmp_path / "out" and again.paths is written.paths is None
    assert written.metadata == again.metadata and written.metadata["vines_stoch.seed"] == "5"
    assert again.scenario.base.ensemble.seed == 5  # (parsed from the metadata)


def test_paths_are_the_histories_whose_statistics_history_holds(in_memory):
    results, _ = in_memory
    kept = run(DATA, realizations=12, paths=True, workers=2)
    pd.testing.assert_frame_equal(kept.realizations, results.realizations, check_exact=True)
    paths = kept.paths
    assert len(paths) == 24 * 21 and list(paths.columns[-3:]) == ["t", "x1", "e1"]
    ok = kept.realizations.loc[kept.realizations["status"] == "ok", ["point", "realization"]]
    chosen = paths.merge(ok, on=["point", "realization"])
    mean = chosen.groupby(["point", "t"])["e1"].mean().to_numpy()
    np.testing.assert_allclose(mean, results.history["e1_mean"].to_numpy(), rtol=1e-12)


def test_solve_gives_the_ensembles_realisation_and_its_histories(in_memory):
    results, _ = in_memory
    solution = solve(DATA, point=1, realization=3)
    row = results.realizations.query("point == 1 and realization == 3").iloc[0]
    assert solution.metrics["e1_max"] == row["e1_max"] and solution.metrics["edm"] == row["edm"]
    assert solution.ts[0] == 0.0 and solution.ts[-1] == pytest.approx(10.0)
    assert len(solution.ts) == 1001 and set(solution.ys) == {"x1", "e1"}
    # every step is on the grid: the peak of the history is the realisation's e1_max
    assert np.nanmax(solution.ys["e1"]) == pytest.approx(row["e1_max"], rel=1e-12)
    assert list(solution.frame().columns) == ["t", "x1", "e1"]


@pytest.mark.parametrize(("arguments", "error", "words"), [
    ({"realizations": -5}, ValueError, "realizations = -5: must be a whole number [1, 10000000]"),
    ({"realizations": 0}, ValueError, "realizations = 0: must be a whole number [1, 10000000]"),
    ({"realizations": 2.5}, TypeError, "realizations = 2.5 (float): must be a whole number"),
    ({"realizations": True}, TypeError, "realizations = True (bool)"),
    ({"workers": 0}, ValueError, "workers = 0: must be a whole number >= 1"),
    ({"chunk": "5"}, TypeError, "chunk = '5' (str)"),
    ({"paths": "yes"}, TypeError, "paths = 'yes': must be True or False"),
    ({"out": 3}, TypeError, "out = 3: give a folder's path"),
    ({"backend": "tpu"}, ValueError, "backend 'tpu': must be one of cpu, cuda"),
    ({"resume": True}, ValueError, "resume: needs a folder"),
])
def test_bad_arguments_name_the_argument_value_and_range(arguments, error, words):
    with pytest.raises(error) as caught:
        run(DATA, **arguments)
    assert words in str(caught.value)


def test_bad_scenarios_are_named():
    with pytest.raises(TypeError, match=r"scenario = 42 \(int\): give a scenario file's path, a dict"):
        run(42)
    with pytest.raises(ScenarioError, match=r"<dict>: .*ensemble.realizations"):
        run({**DATA, "ensemble": {"realizations": -1}})
    with pytest.raises(ScenarioError, match=r"<dict>: not a scenario's tables \(Keys must be strings\)"):
        run({1: 2})
    with pytest.raises(ScenarioError, match="no-such.toml"):
        run("no-such.toml")
    with pytest.raises(ValueError, match=r"point = 2: must be a whole number \[0, 1\]"):
        solve(DATA, point=2)
    with pytest.raises(ValueError, match="signals: 'x_3' is not a signal"):
        solve(DATA, signals=["x_3"])


def test_public_names():
    assert {"run", "solve", "read_results", "Results", "Solution"} <= set(vines_stoch.__all__)
    assert vines_stoch.Results is Results
