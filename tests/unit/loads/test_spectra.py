"""Spectral intensity measures (``vines_stoch.spectra``), records scaled to a spectral
acceleration, suites of records swept as texts, and the ``sa`` / ``pga`` columns."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from tests.helpers import ROOT, changed, study_from, toml_text
from vines_stoch.ensemble import sample
from vines_stoch.physics.spectra import displacement, pseudo_acceleration, uniform
from vines_stoch.records import G
from vines_stoch.scenario import ScenarioError, load_scenario

RECORDS = ROOT / "scenarios" / "records"


def test_sa_of_a_harmonic_record_against_the_closed_form():
    """``a_g = A sin(W t)`` from rest: ``u = C sin Wt + D cos Wt + exp(-z w t) (E cos wd t +
    F sin wd t)`` (Chopra 3.2); ``Sa = w^2 max |u|`` on a fine grid.  The record is sampled at
    dt = 5 ms: the piecewise-linear samples differ from the sine by at most ``A (W dt)^2 / 8``
    (8e-5 A) and the peak between samples from the sampled one by ``(w dt)^2 / 8`` relative
    (1e-4), so 1e-3 holds with margin."""
    amplitude, big_w, period, zeta, dt = 2.0, 5.0, 0.8, 0.05, 0.005
    w = 2 * math.pi / period
    wd = w * math.sqrt(1 - zeta**2)
    delta = (w**2 - big_w**2) ** 2 + (2 * zeta * w * big_w) ** 2
    c, d = -amplitude * (w**2 - big_w**2) / delta, amplitude * 2 * zeta * w * big_w / delta
    e = -d
    f = (zeta * w * e - c * big_w) / wd
    t = np.arange(0.0, 12.0, 1e-4)
    u = (c * np.sin(big_w * t) + d * np.cos(big_w * t)
         + np.exp(-zeta * w * t) * (e * np.cos(wd * t) + f * np.sin(wd * t)))
    exact = w**2 * np.abs(u).max()
    samples = np.arange(0.0, 12.0, dt)
    sa = pseudo_acceleration(amplitude * np.sin(big_w * samples), dt, period, zeta)
    assert sa == pytest.approx(exact, rel=1e-3)
    # and the transient matters here: the steady state alone is lower
    assert exact > 1.01 * w**2 * math.hypot(c, d)


def test_the_recursion_is_exact_for_piecewise_linear_input():
    """Against solve_ivp (DOP853, rtol 1e-12) on the linearly interpolated record, a first
    sample not zero included."""
    gen = np.random.default_rng(1)
    dt = 0.02
    ag = np.cumsum(gen.standard_normal(400)) * 0.1 + 0.7
    t = dt * np.arange(ag.size)
    period, zeta = 0.5, 0.02
    w = 2 * math.pi / period
    ref = solve_ivp(lambda s, y: [y[1], -np.interp(s, t, ag) - 2 * zeta * w * y[1] - w * w * y[0]],
                    (0, t[-1]), [0, 0], t_eval=t, method="DOP853", rtol=1e-12, atol=1e-14, max_step=dt / 2)
    u = displacement(ag, dt, period, zeta)
    assert np.abs(u - ref.y[0]).max() < 1e-8 * np.abs(ref.y[0]).max()


def test_uniform_grid_of_an_uneven_record():
    values, dt = uniform(np.array([0.0, 0.1, 0.3]), np.array([0.0, 1.0, 3.0]))
    assert dt == pytest.approx(0.1) and values == pytest.approx([0.0, 1.0, 2.0, 3.0])


def suite_data(k: float, c: float, scaling: dict, sweep: dict) -> dict:
    """A primary (m = 1, ``k``, ``c``) under a record (``scaling``: its scale or sa keys) with
    ``Sa(1 s)`` columns, swept over ``sweep``."""
    return {"name": "suite",
            "primary": {"mass": 1.0, "stiffness": k, "damping": c},
            "loads": [{"type": "record", "file": "synthetic_cp_medium.AT2", "units": "g", **scaling}],
            "simulation": {"duration": 30.0, "dt": 0.002, "scheme": "rk4"},
            "intensity_measures": {"period": 1.0},
            "sweep": sweep}


def _suite(tmp_path: Path, scaling: dict, sweep: dict, changes: dict | None = None):
    """The scenario file ``suite.toml`` of a 1 s, 5 % primary written beside the two records it
    may name, with ``changes``, read back."""
    for name in ("synthetic_cp_medium.AT2", "synthetic_cp_medium_1941.AT2"):
        shutil.copy(RECORDS / name, tmp_path / name)
    w = 2 * math.pi
    path = tmp_path / "suite.toml"
    path.write_text(toml_text(changed(suite_data(w * w, 2 * 0.05 * w, scaling, sweep), changes)))
    return load_scenario(path)


def test_records_scaled_to_sa_and_a_suite_swept_over_files(tmp_path):
    """A suite (two files) x two Sa(1 s) levels: each point's record has the Sa asked for; on a
    1 s, 5 % primary the peak relative displacement is Sa / w^2 (the same oscillator, RK4 at
    w dt = 0.013: error (w dt)^4 / 120 ~ 1e-10 a step, 1e-4 tolerance for the step-end peak),
    and the ``sa`` column, computed from the ground path on the time grid, agrees with both."""
    study = _suite(tmp_path, {"sa": {"period": 1.0, "value": 0.2}},
                   {"loads.0.file": ["synthetic_cp_medium.AT2", "synthetic_cp_medium_1941.AT2"],
                    "loads.0.sa.value": [0.2, 0.3]})
    assert len(study.points) == 4
    for point, values in zip(study.points, study.grid):
        load = point.loads[0]
        assert load.file == values["loads.0.file"]
        t, a = load.samples()
        grid, dt = uniform(t, a)
        assert pseudo_acceleration(grid, dt, 1.0) == pytest.approx(values["loads.0.sa.value"] * G, rel=1e-12)
    frame = sample(study)
    files = ["synthetic_cp_medium.AT2"] * 2 + ["synthetic_cp_medium_1941.AT2"] * 2
    assert list(frame["loads.0.file"]) == files
    target = frame["loads.0.sa.value"] * G
    w2 = (2 * math.pi) ** 2
    assert np.allclose(frame["sa"], target, rtol=2e-3)  # (the grid runs 2 s past the record's end)
    assert np.allclose(frame["x1_max"] * w2, frame["sa"], rtol=1e-4)
    assert (frame["pga"] > 0).all() and frame["pga"].nunique() == 4


def test_per_record_scale_factors_zipped_with_the_files(tmp_path):
    study = _suite(tmp_path, {"scale": 1.0},
                   {"loads.0.file": ["synthetic_cp_medium.AT2", "synthetic_cp_medium_1941.AT2"],
                    "loads.0.scale": [0.5, 2.0], "zip": ["loads.0.file", "loads.0.scale"]})
    assert [(g["loads.0.file"], g["loads.0.scale"]) for g in study.grid] == [
        ("synthetic_cp_medium.AT2", 0.5), ("synthetic_cp_medium_1941.AT2", 2.0)]
    frame = sample(study)
    for row, point in zip(frame.itertuples(), study.points):
        t, a = point.loads[0].samples()
        assert row.pga == pytest.approx(np.abs(a).max(), rel=1e-12)


def test_bad_spectral_scaling_and_text_sweeps_are_named(tmp_path):
    with pytest.raises(ScenarioError, match="give scale or sa, not both"):
        _suite(tmp_path, {"scale": 2.0, "sa": {"period": 1.0, "value": 0.2}}, {})
    with pytest.raises(ScenarioError, match=r"loads.0.sa.period = 0"):
        _suite(tmp_path, {"sa": {"period": 0.0, "value": 0.2}}, {})
    with pytest.raises(ScenarioError, match="texts sweep an existing text field"):
        _suite(tmp_path, {}, {"loads.0.scale": ["a", "b"]})
    with pytest.raises(ScenarioError, match=r"loads.0.file = 'missing.AT2'"):
        _suite(tmp_path, {}, {"loads.0.file": ["synthetic_cp_medium.AT2", "missing.AT2"]})
    with pytest.raises(ScenarioError, match="intensity_measures.period"):
        study_from(suite_data(1.0, 0.1, {}, {}), {"intensity_measures.period": -1.0})


def test_optimize_a_record_suite_into_another_folder(tmp_path):
    """The optimum's file names its records (and the suite swept) relative to its own folder,
    and the final run reads them."""
    from vines_stoch.optimize import optimize_scenario

    scenario = tmp_path / "study"
    scenario.mkdir()
    optimize = {"objective": "x1_max", "max_evaluations": 3,
                "parameters": {"primary.damping": {"low": 0.2, "high": 0.8}}}
    study = _suite(scenario, {"scale": 1.0},
                   {"loads.0.file": ["synthetic_cp_medium.AT2", "synthetic_cp_medium_1941.AT2"]},
                   {"simulation.duration": 3.0, "optimize": optimize})
    out = tmp_path / "elsewhere" / "optimum"
    out.mkdir(parents=True)
    best, report = optimize_scenario(study, out)
    final = load_scenario(out / "optimum.toml")
    assert [p.loads[0].file for p in final.points] == ["../../study/synthetic_cp_medium.AT2",
                                                       "../../study/synthetic_cp_medium_1941.AT2"]
    assert report.is_file() and (out / "realizations.parquet").is_file()
