"""Event logs of an ensemble (``[output] events``, events.parquet): each realisation's impacts
and contact onsets against the metrics that count and sum them, the same table in memory,
from the folder, whatever the chunks and after a resume, and refused out of range."""

from __future__ import annotations

import pandas as pd
import pytest

from tests.helpers import changed, study_from
from tests.integration.test_ensemble import DATA
from vines_stoch import read_results, run
from vines_stoch.scenario import ScenarioError

#: The ensemble test's impact scene, with an event log long enough for every impact.
LOGGED = changed(DATA, {"output.events": 10_000, "ensemble.realizations": 9})


def test_the_event_log_of_each_realisation_details_its_impacts(tmp_path):
    results = run(study_from(LOGGED), tmp_path)
    realizations, events = results.realizations, results.events
    assert "event_t" not in realizations.columns  # (the logs live in events.parquet)
    assert list(events.columns) == ["point", "loads.1.intensity", "realization", "t", "absorber", "wall",
                                    "speed", "loss"]
    assert len(events) == realizations["impacts"].sum() > 0
    for (point, r), rows in events.groupby(["point", "realization"]):
        row = realizations[(realizations["point"] == point) & (realizations["realization"] == r)].iloc[0]
        assert (rows["wall"] == "left").sum() == row["impacts_left"]
        assert (rows["wall"] == "right").sum() == row["impacts_right"]
        assert rows["loss"].sum() == pytest.approx(row["impact_loss"], rel=1e-12)
        assert rows["t"].is_monotonic_increasing
        assert (rows["absorber"] == 2).all()  # the impact NES, second in the file
    pd.testing.assert_frame_equal(read_results(tmp_path).events, events, check_exact=True)


def test_the_event_log_is_the_same_in_memory_in_chunks_and_after_a_resume(tmp_path):
    study = study_from(LOGGED)
    whole = run(study, tmp_path / "whole").events
    pd.testing.assert_frame_equal(run(study).events, whole, check_exact=True)
    chunked = run(study, tmp_path / "chunks", chunk=2, workers=2)
    pd.testing.assert_frame_equal(chunked.events, whole, check_exact=True)
    parts = sorted((tmp_path / "chunks" / "parts").glob("*.parquet"))
    parts[-1].unlink()  # as if interrupted before the last chunk
    resumed = run(study, tmp_path / "chunks", chunk=2, resume=True)
    pd.testing.assert_frame_equal(resumed.events, whole, check_exact=True)


def test_a_short_log_keeps_the_first_events():
    study = study_from(changed(LOGGED, {"output.events": 2}))
    full = run(study_from(LOGGED)).events
    short = run(study).events
    first = full.groupby(["point", "realization"]).head(2).reset_index(drop=True)
    pd.testing.assert_frame_equal(short, first, check_exact=True)


def test_an_event_log_out_of_range_is_refused():
    with pytest.raises(ScenarioError, match="output.events = -1"):
        study_from(changed(LOGGED, {"output.events": -1}))
