"""The numerical stability suite (vines_stoch/validation/stability.py): every case ends within
its time bound with a result whose energy balance closes, or with a clear error; a diverging
realisation is counted, not averaged."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.helpers import study_from
from vines_stoch import ScenarioError, run
from vines_stoch.validation import stability
from vines_stoch.validation.stability import CASES, run_case


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_case_ends_in_time_with_a_result_or_a_clear_error(case):
    """Bounds include compiling the case's kernel on a cold cache (up to about 30 s)."""
    outcome = run_case(case)
    assert outcome.seconds < case.bound_s
    if case.expect == "error":
        assert "simulation.dt" in outcome.error and "stability limit" in outcome.error
        return
    assert outcome.error == ""
    assert outcome.n_failed == 0 and outcome.n_ok == case.realizations
    assert outcome.residual < case.tolerance
    assert 0.0 <= outcome.edm[0] <= outcome.edm[1] <= 1.0 + case.tolerance
    if case.order:  # the residual is the scheme's own error: it falls like dt^order
        assert run_case(case.halved()).residual <= 1.5 * outcome.residual / 2 ** case.order


def test_step_past_the_stability_limit_names_the_limit():
    case = next(c for c in CASES if c.expect == "error")
    with pytest.raises(ScenarioError) as err:
        case.study("coarse.toml")
    message = str(err.value)
    # absorber m = 0.05 on k = 1e6 over a primary m = k = 1: omega^2 = k (1/m1 + 1/m2) + ...
    omega = math.sqrt(np.linalg.eigvalsh(np.array([[1.0 + 1e6, -1e6 / math.sqrt(0.05)],
                                                   [-1e6 / math.sqrt(0.05), 1e6 / 0.05]])).max())
    assert message.startswith("coarse.toml: simulation.dt = 0.001: "
                              "is past the stability limit of the rk4 scheme")
    assert f"{omega:.6g} rad/s" in message and f"{2 * math.sqrt(2) / omega:.4g}" in message


#: A linear absorber whose drawn stiffness can put kick-drift-kick past its stability limit
#: (with a little white noise: the loop of the other noisy two-body scenes, no loop of its own).
DIVERGING = {
    "name": "diverging",
    "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.02},
    "absorbers": [{"type": "linear", "mass": 0.05, "stiffness": 1.0}],
    "loads": [{"type": "impulse", "velocity": 0.5}, {"type": "white-noise", "intensity": 0.01}],
    "simulation": {"duration": 200.0, "dt": 0.1, "scheme": "euler-maruyama"},
}


@pytest.mark.parametrize("n, seed, law, expected", [
    # one of 20 draws has omega dt = 2.07 > 2 (the next largest 1.94)
    (20, 3, {"distribution": "uniform", "low": 0.5, "high": 20.5}, 1),
    (40, 2, {"distribution": "lognormal", "median": 1.0, "cov": 10.0}, None),
])
def test_diverging_realisations_are_counted_not_averaged(tmp_path, n, seed, law, expected):
    """Realisations whose drawn absorber stiffness puts velocity Verlet past its stability limit
    (omega_max dt > 2) overflow: those, and only those, are marked "diverged", counted in
    n_failed and left out of every statistic."""
    study = study_from(DIVERGING, {"ensemble": {"realizations": n, "seed": seed},
                                   "uncertain": {"absorbers.0.stiffness": law}})
    realizations, summary = run(study, tmp_path, workers=1)
    k = realizations["absorbers.0.stiffness"].to_numpy()
    root_m = math.sqrt(0.05)
    omega = np.array([math.sqrt(np.linalg.eigvalsh(np.array([[1.0 + ka, -ka / root_m],
                                                             [-ka / root_m, ka / 0.05]])).max())
                      for ka in k])
    unstable = omega * 0.1 > 2.0
    assert 0 < unstable.sum() < n and (expected is None or unstable.sum() == expected)
    assert ((realizations["status"] == "diverged") == unstable).all()
    ok = realizations[~unstable]
    assert summary["n_failed"].iloc[0] == unstable.sum() and summary["n_ok"].iloc[0] == len(ok)
    for m in ("edm", "e1_max", "x1_rms", "energy_integral"):
        assert summary[f"{m}_mean"].iloc[0] == pytest.approx(ok[m].mean(), rel=1e-12)
        assert np.isfinite(summary[f"{m}_std"].iloc[0])


def test_the_report_times_each_case_with_its_loops_compiled(monkeypatch):
    """``section`` (the bench's table) runs each case once before the run it times, so that the
    time column is the run's own and not the compiling of a cold cache."""
    calls = []
    case = CASES[0]

    def timed(c, directory=None):
        calls.append(c)
        return stability.Outcome(c, seconds=100.0 if len(calls) == 1 else 0.25, n_ok=1, residual=1e-13,
                                 edm=(0.5, 0.5))

    monkeypatch.setattr(stability, "CASES", (case,))
    monkeypatch.setattr(stability, "run_case", timed)
    text = stability.section()
    assert calls == [case, case]
    assert f"| {case.name} | {case.bound_s:.0f} | 0.25 | 1 ok, 0 failed |" in text
