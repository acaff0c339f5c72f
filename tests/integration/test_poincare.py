"""Poincare sections (``[output] poincare``): the state once a forcing period, against the
closed-form steady state of a damped linear oscillator under harmonic forcing; the same table
in memory and from a folder, and in the report's plots; a scene without periodic forcing refused
by name."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from vines_stoch import ScenarioError, read_results, run
from vines_stoch.reports import report

M, ZETA, OMEGA_N, F = 1.0, 0.05, 2.0 * math.pi, 1.0
K, C = M * OMEGA_N**2, 2.0 * ZETA * OMEGA_N * M


def scene(omega: float) -> dict:
    """The oscillator under ``F cos(omega t)``, 250 rk4 steps a forcing period, for the whole
    periods in 100 s; the samples (every period of the metrics window) after 60 s, when the start-up transient
    has decayed by exp(-zeta omega_n t) < 1e-8."""
    period = 2.0 * math.pi / omega
    return {"name": "poincare", "primary": {"mass": M, "stiffness": K, "damping": C},
            "loads": [{"type": "harmonic", "amplitude": F, "frequency": omega}],
            "simulation": {"duration": math.ceil(100.0 / period) * period, "dt": period / 250,
                           "metrics_from": 60.0, "scheme": "rk4"},
            "output": {"poincare": True}}


@pytest.mark.parametrize("ratio", [0.8, 1.0, 1.3])
def test_one_point_at_the_closed_form_steady_state(ratio):
    omega = ratio * OMEGA_N
    section = run(scene(omega)).poincare
    # x(t) = Re(F H e^{i omega t}) with H = 1 / (k - m omega^2 + i c omega); at t = n T,
    # e^{i omega t} = 1: x = F Re H, v = Re(i omega F H) = -omega F Im H
    h = 1.0 / (K - M * omega**2 + 1j * C * omega)
    x, v = F * h.real, -omega * F * h.imag
    amplitude = F * abs(h)
    period = 2.0 * math.pi / omega
    first, last = math.ceil(60.0 / period - 1e-9), math.ceil(100.0 / period)
    assert list(section["period"]) == list(range(first, last))  # (every period of the window)
    np.testing.assert_allclose(section["t"], section["period"] * 2.0 * math.pi / omega, rtol=1e-12)
    # RK4's steady-state error: its local error (omega_n dt)^5 / 120 about 2.6e-10 a step of
    # the amplitude, over the 1 / (zeta omega_n dt) steps the damping remembers: about 2e-7
    np.testing.assert_allclose(section["x_1"], x, rtol=0, atol=1e-6 * amplitude)
    np.testing.assert_allclose(section["v_1"], v, rtol=0, atol=1e-6 * amplitude * omega)
    assert (section[["impacts_left", "impacts_right"]] == 0).all().all()


def test_poincare_periods_keeps_the_last_periods_of_the_window():
    """``[output] poincare_periods = 35``: the last 35 forcing periods before the end, at the
    same states as the whole window's samples."""
    data = scene(OMEGA_N)
    whole = run(data).poincare
    data["output"]["poincare_periods"] = 35
    last = run(data).poincare
    assert len(whole) == 40 and list(last["period"]) == list(whole["period"].iloc[-35:])
    np.testing.assert_array_equal(last["x_1"], whole["x_1"].iloc[-35:])


def test_the_same_section_in_memory_and_from_a_folder(tmp_path):
    data = {**scene(OMEGA_N), "absorbers": [{"type": "cubic", "mass": 0.05, "stiffness": 1.0,
                                             "damping": 0.01}],
            "sweep": {"loads.0.amplitude": [0.5, 1.0]}}
    in_memory = run(data).poincare
    run(data, tmp_path / "out")
    from_folder = read_results(tmp_path / "out").poincare
    pd.testing.assert_frame_equal(from_folder, in_memory, check_exact=True)
    assert list(in_memory.columns) == ["point", "loads.0.amplitude", "realization", "period", "t", "x_1",
                                       "xa_1", "v_1", "va_1", "impacts_left", "impacts_right"]
    assert set(in_memory["point"]) == {0, 1}
    assert run(scene(OMEGA_N) | {"output": {}}).poincare is None
    # the report draws them: against the swept amplitude, and in the roof's phase plane
    page = report([tmp_path / "out"], tmp_path / "report")
    for name in ("bifurcation.png", "poincare_section.png"):
        assert (page.parent / name).stat().st_size > 10_000  # (a rendered figure)
        assert f"]({name})" in page.read_text()


def test_a_scene_without_periodic_forcing_is_refused_by_name():
    data = scene(OMEGA_N) | {"loads": [{"type": "white-noise", "intensity": 0.1}]}
    data["simulation"] = {**data["simulation"], "scheme": "auto"}
    with pytest.raises(ScenarioError, match=r"output\.poincare.*periodically forced"):
        run(data)
