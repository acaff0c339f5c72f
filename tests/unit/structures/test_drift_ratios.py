"""Storey heights and inter-storey drift ratios (``[primary] heights``; MODEL.md 1a)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import vines_stoch
from vines_stoch.scenario import ScenarioError

HEIGHTS = [4.0, 3.0, 3.0]


def frame(**limits) -> dict:
    """A 3-storey frame under white noise on the roof, with storey heights."""
    return {"name": "frame",
            "primary": {"masses": [2.0, 2.0, 1.5], "stiffnesses": [900.0, 800.0, 700.0],
                        "dampings": [3.0, 2.5, 2.0], "heights": HEIGHTS},
            "loads": [{"type": "white-noise", "intensity": 1.0}],
            "simulation": {"duration": 20.0, "dt": 0.005},
            "ensemble": {"realizations": 16, "seed": 1}, "limits": limits}


def test_drift_ratios_are_the_peak_drifts_over_the_heights():
    """``drift_ratio_max_k = drift_max_k / h_k`` and ``drift_ratio_max`` their largest, realisation
    by realisation (the hand calculation on each row); the summary carries their statistics."""
    results = vines_stoch.run(frame())
    r = results.realizations
    ratios = np.array([r[f"drift_max_{k + 1}"] / h for k, h in enumerate(HEIGHTS)])
    for k in range(3):
        np.testing.assert_array_equal(r[f"drift_ratio_max_{k + 1}"], ratios[k])
    np.testing.assert_array_equal(r["drift_ratio_max"], ratios.max(axis=0))
    assert results.summary["drift_ratio_max_mean"].iloc[0] == pytest.approx(ratios.max(axis=0).mean())


def test_a_drift_ratio_limit_is_the_storey_drift_limit():
    """A limit on storey 2's drift ratio (at the median of its peaks) passes exactly where the
    limit on its drift at the ratio times the height does, at the same times."""
    value = float(np.median(vines_stoch.run(frame()).realizations["drift_ratio_max_2"]))  # (half pass)
    drift = vines_stoch.run(frame(storey={"metric": "drift_max_2", "value": value * HEIGHTS[1]})).realizations
    ratio = vines_stoch.run(frame(storey={"metric": "drift_ratio_max_2", "value": value})).realizations
    assert drift["first_passage_storey"].notna().any() and drift["first_passage_storey"].isna().any()
    np.testing.assert_array_equal(drift["first_passage_storey"], ratio["first_passage_storey"])


def test_heights_are_checked():
    data = frame()
    data["primary"]["heights"] = [4.0, 3.0]
    with pytest.raises(ScenarioError, match=r"primary.heights = \[4.0, 3.0\]: must list 3 storey height"):
        vines_stoch.run(data)
    data = frame(storey={"metric": "drift_ratio_max_2", "value": 0.004})
    del data["primary"]["heights"]
    with pytest.raises(ScenarioError, match="drift_ratio_max_k with primary.heights"):
        vines_stoch.run(data)


def test_the_estimate_gives_drift_ratios():
    row = vines_stoch.estimate(frame()).iloc[0]
    for k, h in enumerate(HEIGHTS):
        assert row[f"drift_ratio_max_{k + 1}"] == pytest.approx(row[f"drift_max_{k + 1}"] / h, rel=1e-12)
        assert row[f"drift_ratio_rms_{k + 1}"] == pytest.approx(row[f"drift_rms_{k + 1}"] / h, rel=1e-12)


def test_roof_names_the_top_floor():
    """``_roof`` names the top floor: a limit on ``drift_ratio_max_roof`` is the limit on
    ``drift_ratio_max_3`` (the same first passages), ``x_max_roof`` the roof's ``x1_max``, in
    ``Results.exceedance`` and ``Results.plot.metric`` as in limits; other names are refused."""
    results = vines_stoch.run(frame(top={"metric": "drift_ratio_max_roof", "value": 0.002},
                                    three={"metric": "drift_ratio_max_3", "value": 0.002}))
    r = results.realizations
    assert r["first_passage_top"].notna().any()
    np.testing.assert_array_equal(r["first_passage_top"], r["first_passage_three"])
    np.testing.assert_array_equal(r["x_max_3"], r["x1_max"])
    pd.testing.assert_frame_equal(results.exceedance("x_max_roof", 0.01), results.exceedance("x1_max", 0.01))
    ax = results.plot.metric("drift_max_roof")
    assert ax.get_ylabel().startswith("peak drift of storey 3")
    with pytest.raises(ScenarioError, match="limits.top.metric = 'roof_max': must be a peak metric"):
        vines_stoch.run(frame(top={"metric": "roof_max", "value": 0.01}))
