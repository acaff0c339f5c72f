"""Declared metrics (``[output] metrics``: a signal reduced over the metrics window,
``signals.declare_metrics``): against the built-in metrics they repeat, against the same signal
kept at every step end (a history of stride 1) and reduced in numpy, through the ensemble's
tables with their statistics, on the cuda backend's simulator, and refused with a message where
a name is not one."""

from __future__ import annotations

import numpy as np
import pytest

from tests.helpers import example_data, example_scene, study_from
from vines_stoch.ensemble import run
from vines_stoch.kernels import simulate
from vines_stoch.metrics import METRICS, finish_table, floor_metrics
from vines_stoch.scenario import ScenarioError
from vines_stoch.signals import BUILT_IN, METRIC_NAME

#: Every reduction, on floor and absorber signals and the energy.
DECLARED = ["x_1_rms", "e1_mean", "stroke_1_peak", "va_1_max", "va_1_min", "x1_peak", "stroke_2_rms",
            "v_1_mean"]
#: The example scenes and schemes: impacts and a cubic NES (kick-drift-kick, under white noise;
#: RK4, deterministic), and Hertz contact beside a plastic impact NES under noise.
CASES = {"kdk, noise": ("parallel_nes_noise", None), "rk4": ("parallel_nes_impulse", "rk4"),
         "kdk, contact": ("contact_noise_parallel", None)}


def _scene(name: str, scheme: str | None):
    return example_scene(name, {"simulation.duration": 4.0, "simulation.metrics_from": 1.0,
                                "output.metrics": DECLARED}, scheme)


@pytest.mark.parametrize("case", list(CASES))
def test_declared_metrics_reduce_their_signals_over_the_window(case):
    scene = _scene(*CASES[case])
    assert scene.mass.shape[0] == 3  # (two absorbers: stroke_2 is the second's)
    generator = np.random.default_rng(4)
    signals = ["x_1", "e1", "stroke_1", "va_1", "x1", "stroke_2", "v_1"]
    history = np.full((scene.n_steps + 1, len(signals)), np.nan)
    raw = simulate(scene, generator, history=history, stride=1, signals=signals)
    row = finish_table(raw[np.newaxis], scene).iloc[0]
    window = history[scene.i0:]  # the step ends from the window's opening on
    q = dict(zip(signals, window.T))

    def mean(values):  # the trapezoid rule over the window's step ends
        return (values.sum() - 0.5 * (values[0] + values[-1])) / (len(values) - 1)

    expected = {"x_1_rms": np.sqrt(mean(q["x_1"] ** 2)), "e1_mean": mean(q["e1"]),
                "stroke_1_peak": np.abs(q["stroke_1"]).max(), "va_1_max": q["va_1"].max(),
                "va_1_min": q["va_1"].min(), "x1_peak": np.abs(q["x1"]).max(),
                "stroke_2_rms": np.sqrt(mean(q["stroke_2"] ** 2)), "v_1_mean": mean(q["v_1"])}
    for name, value in expected.items():  # (sums in another order: to rounding)
        assert row[name] == pytest.approx(value, rel=1e-11, abs=1e-14 * abs(value)), name
    assert row["stroke_1_peak"] > 0 and row["va_1_min"] < 0 < row["va_1_max"]
    if CASES[case][1] == "rk4":  # (its built-in metrics: integrated with its stages, peaks at sub-steps)
        return
    # the built-in metrics they repeat: the same sums (the rms of the roof, the mean energy)
    assert row["x_1_rms"] == pytest.approx(row["x1_rms"], rel=1e-12)
    assert row["x1_peak"] == pytest.approx(row["x1_max"], rel=1e-12)
    assert row["e1_mean"] == pytest.approx(row["energy_integral"] / scene.window, rel=1e-12)


def test_an_ensemble_tabulates_and_summarises_declared_metrics(tmp_path):
    data = example_data("parallel_nes_noise")
    study = study_from(data, {"simulation.duration": 3.0, "simulation.metrics_from": 1.0,
                              "ensemble.realizations": 12, "output.metrics": ["stroke_1_peak", "e1_mean"]})
    realizations, summary = run(study, tmp_path)
    assert len(summary) == len(study.points) > 1
    for name in ("stroke_1_peak", "e1_mean"):
        assert realizations[name].notna().all() and (realizations[name] > 0).all()
        for point, group in realizations.groupby("point"):
            mean = summary.loc[summary["point"] == point, f"{name}_mean"].item()
            assert mean == pytest.approx(group[name].mean(), rel=1e-12)


def test_the_built_in_metrics_a_declared_name_could_take_are_listed():
    built_in = [m for m in (*METRICS, *floor_metrics(9)) if METRIC_NAME.fullmatch(m)]
    assert sorted(built_in) == sorted(BUILT_IN)


@pytest.mark.parametrize(("metric", "message"), [
    ("stroke_3_peak", "'stroke_3' is not a signal"),
    ("x_1_median", "must be <signal>_<reduction>"),
    ("x1_max", "is a built-in metric already"),
])
def test_a_metric_that_is_not_one_is_refused_with_what_is_allowed(metric, message):
    data = example_data("parallel_nes_noise")
    with pytest.raises(ScenarioError, match=message) as error:
        study_from(data, {"output.metrics": [metric]})
    assert "output.metrics" in str(error.value)
    assert "stroke_j or contact_j with j in [1, 2]" in str(error.value)
