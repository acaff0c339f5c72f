"""Sobol indices (``vines_stoch/sensitivity.py``): the estimator against the Ishigami function's
closed forms, and on a scene a parameter that cannot matter against 0."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.helpers import study_from
from vines_stoch import read_results, run
from vines_stoch.scenario.errors import ScenarioError
from vines_stoch.sensitivity import parameter_values, sobol_indices

#: Ishigami and Homma (1990): ``sin x1 + A sin^2 x2 + B x3^4 sin x1`` on ``[-pi, pi]^3``.
A, B = 7.0, 0.1


def ishigami(unit: np.ndarray) -> np.ndarray:
    x = -math.pi + 2 * math.pi * unit
    return np.sin(x[:, 0]) + A * np.sin(x[:, 1]) ** 2 + B * x[:, 2] ** 4 * np.sin(x[:, 0])


def ishigami_indices() -> tuple[np.ndarray, np.ndarray]:
    """The closed forms (Sobol' and Levitan 1999): partial variances ``V1 = (1 + B pi^4 / 5)^2 / 2``,
    ``V2 = A^2 / 8``, ``V13 = B^2 pi^8 (1/18 - 1/50)``, ``V3 = 0``."""
    v1 = 0.5 * (1 + B * math.pi ** 4 / 5) ** 2
    v2 = A ** 2 / 8
    v13 = B ** 2 * math.pi ** 8 * (1 / 18 - 1 / 50)
    v = v1 + v2 + v13
    return np.array([v1, v2, 0.0]) / v, np.array([v1 + v13, v2, v13]) / v


def test_the_estimator_against_the_ishigami_closed_forms():
    """Each index within twice its bootstrap 95 % half-width (about four standard errors) of the
    closed form, the half-widths below 0.05 at 2^13 base points (the test is not vacuous: the
    indices are 0.24 to 0.56)."""
    s1, st = ishigami_indices()
    frame = sobol_indices(ishigami, 3, 1 << 13, seed=1, bootstrap=500)
    for name, exact in (("s1", s1), ("st", st)):
        half = (frame[f"{name}_hi"] - frame[f"{name}_lo"]).to_numpy() / 2
        assert np.all(half < 0.05)
        assert np.all(np.abs(frame[name].to_numpy() - exact) <= 2 * half), (name, frame[name], exact)


def test_the_unit_cube_maps_onto_the_laws():
    """Each coordinate is its parameter's probability: the law's quantile (median at 0.5)."""
    study = study_from(scene_data())
    values = parameter_values(study.base.uncertain, np.array([[0.5, 0.5], [0.025, 0.975]]))
    k = values["primary.stiffness"]
    assert k[0] == pytest.approx(OMEGA2) and k[1] == pytest.approx(0.8 * OMEGA2 + 0.025 * 0.4 * OMEGA2)
    mass = values["absorbers.0.mass"]
    assert mass[0] == pytest.approx(0.05) and mass[1] == pytest.approx(0.05 * math.exp(1.959964 * math.sqrt(
        math.log(1 + 0.2 ** 2))), rel=1e-5)


OMEGA2 = (2 * math.pi) ** 2


def scene_data(metric: str = "x1_max") -> dict:
    """An oscillator under white noise with an uncertain stiffness and an absorber joined to it by
    nothing (no stiffness, no damping): the absorber's uncertain mass cannot move the roof."""
    return {"name": "sobol", "primary": {"mass": 1.0, "stiffness": OMEGA2, "damping": 0.2 * math.pi},
            "absorbers": [{"type": "cubic", "mass": 0.05, "stiffness": 0.0, "damping": 0.0}],
            "loads": [{"type": "white-noise", "intensity": 2.0}],
            "simulation": {"duration": 3.0, "dt": 0.01},
            "ensemble": {"realizations": 4, "seed": 2},
            # (near the median of the roof's peak, 0.3-0.6: its exceedance moves with the stiffness)
            "limits": {"roof": {"metric": "x1_max", "value": 0.45}},
            "uncertain": {"primary.stiffness": {"distribution": "uniform", "low": 0.8 * OMEGA2,
                                                "high": 1.2 * OMEGA2},
                          "absorbers.0.mass": {"distribution": "lognormal", "median": 0.05, "cov": 0.2}},
            "sensitivity": {"metric": metric, "samples": 64, "realizations": 8, "bootstrap": 200}}


@pytest.mark.parametrize("metric", ["x1_max", "p_roof"])
def test_a_parameter_without_a_load_path_has_no_index(tmp_path, metric):
    results = run(scene_data(metric), tmp_path / "out")
    frame = results.sensitivity.set_index("parameter")
    dead, live = frame.loc["absorbers.0.mass"], frame.loc["primary.stiffness"]
    assert dead.st_lo <= 0.0 <= dead.st_hi and abs(dead.st) < 1e-12
    assert live.st_lo > 0.1  # (the stiffness moves the roof's peak and its exceedance)
    assert read_results(tmp_path / "out").sensitivity.equals(results.sensitivity)


@pytest.mark.parametrize("changes, key", [({"sensitivity.metric": "nothing"}, "sensitivity.metric"),
                                          ({"uncertain": {}}, "sensitivity"),
                                          ({"sensitivity.samples": 4}, "sensitivity.samples")])
def test_bad_sensitivity_tables_are_refused_by_name(changes, key):
    data = scene_data()
    if "uncertain" in changes:
        data = data | changes
        changes = None
    with pytest.raises(ScenarioError, match=key.replace(".", r"\.")):
        study_from(data, changes)


def test_an_interrupted_design_resumes_from_its_saved_outputs(tmp_path, monkeypatch):
    """Ctrl-C at the 100th of the 256 design points: the 64 saved are not run again, and the
    indices are those of a run in one go."""
    from vines_stoch import ensemble, sensitivity
    from vines_stoch.ensemble import running

    data = scene_data()
    whole = run(data).sensitivity
    calls, real = [], running._design_output

    def counting(*args):
        output = real(*args)

        def counted(point, values):
            calls.append(point)
            if interrupt and len(calls) == 100:
                raise KeyboardInterrupt
            return output(point, values)
        return counted

    monkeypatch.setattr(running, "_design_output", counting)
    interrupt = True
    with pytest.raises(ensemble.Interrupted):
        run(data, tmp_path / "out")
    interrupt, calls[:] = False, []
    resumed = run(data, tmp_path / "out", resume=True).sensitivity
    assert len(calls) == 4 * 64 - sensitivity.SAVE_EVERY
    assert resumed.equals(whole)


def test_progress_in_a_log_is_lines_not_carriage_returns(capsys):
    """Where standard error is not a terminal (a log, a batch job), the design's progress is
    whole lines, never a carriage return."""
    from vines_stoch.sensitivity import table

    study = study_from(scene_data())
    table(study, lambda point, values: sum(values.values()), progress=True)
    err = capsys.readouterr().err
    assert "\r" not in err
    lines = [line for line in err.splitlines() if line.startswith("sensitivity: point 0:")]
    assert len(lines) >= 2 and lines[-1].endswith("parameter sets")
