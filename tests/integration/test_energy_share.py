"""The absorbers' energy share ``E_abs / (E1 + E_abs)`` (MODEL.md section 4, Wei et al. eq. 21):
the signal ``share`` and the declared metrics ``energy_share_mean``, ``energy_share_max`` on a
linear two-body free vibration against the definition evaluated on its closed-form motion."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from vines_stoch import ScenarioError, run

M1, K1, M2, K2 = 1.0, 1.0, 0.1, 0.12   # an undamped primary and a linear absorber, detuned
DT, T, T0 = 0.005, 40.0, 10.0           # rk4 steps, duration, the metrics window's opening

DATA = {"name": "share", "primary": {"mass": M1, "stiffness": K1, "damping": 0.0},
        "absorbers": [{"type": "linear", "mass": M2, "stiffness": K2, "damping": 0.0}],
        "loads": [{"type": "initial", "displacement": [1.0, 0.0]}],
        "simulation": {"duration": T, "dt": DT, "metrics_from": T0, "scheme": "rk4",
                       "history": {"points": 801, "signals": ["share", "e1"]}},
        "output": {"metrics": ["energy_share_mean", "energy_share_max", "share_peak"]}}


def closed_form(t: np.ndarray) -> np.ndarray:
    """The energy share at times ``t`` from the exact motion ``exp(A t) y0`` of the linear
    system (state x1, x2, v1, v2)."""
    a = np.zeros((4, 4))
    a[0, 2] = a[1, 3] = 1.0
    a[2, :2] = [-(K1 + K2) / M1, K2 / M1]
    a[3, :2] = [K2 / M2, -K2 / M2]
    y = np.array([expm(a * s) @ [1.0, 0.0, 0.0, 0.0] for s in t])
    e1 = 0.5 * M1 * y[:, 2] ** 2 + 0.5 * K1 * y[:, 0] ** 2
    e_abs = 0.5 * M2 * y[:, 3] ** 2 + 0.5 * K2 * (y[:, 1] - y[:, 0]) ** 2
    return e_abs / (e1 + e_abs)


def test_share_signal_and_metrics_against_the_closed_form():
    results = run(DATA)
    history = results.history
    t = history["t"].to_numpy()
    # rk4 at omega dt < 0.01: its error on this 40 s motion is below 1e-8 of the energy (3e-10 seen)
    np.testing.assert_allclose(history["share_mean"], closed_form(t), rtol=0, atol=1e-8)
    row = results.realizations.iloc[0]
    steps = np.arange(round(T0 / DT), round(T / DT) + 1) * DT  # (the step ends of the window)
    exact = closed_form(steps)
    # the mean: the trapezoid rule over the step ends (as x1_rms), its own error O(dt^2)
    trapezoid = (exact.sum() - 0.5 * (exact[0] + exact[-1])) * DT / (T - T0)
    assert row["energy_share_mean"] == pytest.approx(trapezoid, abs=1e-8)
    assert row["energy_share_max"] == pytest.approx(exact.max(), abs=1e-8)
    assert row["share_peak"] == row["energy_share_max"]  # (the share is never negative)
    assert {"energy_share_mean_mean", "energy_share_max_q95"} <= set(results.summary.columns)
    assert 0.05 < row["energy_share_mean"] < row["energy_share_max"] < 1.0  # (energy goes back and forth)


def test_the_share_is_computed_where_asked_and_only_with_absorbers():
    # a scene that does not ask pays nothing: no column, and its loop does not compute it
    plain = run({**DATA, "output": {}}).realizations
    assert not any(c.startswith("energy_share") for c in plain.columns)
    bare = {**DATA, "absorbers": [], "loads": [{"type": "initial", "displacement": [1.0]}],
            "simulation": {**DATA["simulation"], "history": {"points": 11}}}
    with pytest.raises(ScenarioError, match=r"output\.metrics.*'share' is not a signal"):
        run(bare)
    with pytest.raises(ScenarioError, match="'share' is not a signal"):
        run({**bare, "output": {}, "simulation": {**bare["simulation"], "history": {"signals": ["share"]}}})
