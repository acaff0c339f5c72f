"""Declared history signals (``signals.declare``): a history holds just the signals a run names,
each evaluated by the loop driver at the history points from the state there.  Checked against
the state itself: the last history row of a path whose last history point is its end is the
final state, row for row the same numbers."""

from __future__ import annotations

import numpy as np
import pytest

from tests.helpers import example_data, scene_from
from vines_stoch.kernels import history_columns, simulate
from vines_stoch.signals import declare, signal_names

#: Every signal of the seed 001 three-storey frame (three floors; linear, cubic and impact
#: absorbers on the top floor).
NAMES = ["x1", "e1", "x_1", "v_2", "drift_1", "drift_3", "xa_1", "va_2", "stroke_3", "v_3"]


def _frame(scheme: str):
    """The frame under its ground motion (kick-drift-kick), or kicked (RK4: deterministic)."""
    data = example_data("seed001_three_storey_frame", "sweep")
    if scheme == "rk4":
        data["loads"] = [{"type": "impulse", "velocity": 0.3}]
    return scene_from(data, changes={"simulation.duration": 2.0, "simulation.scheme": scheme})


@pytest.mark.parametrize("scheme", ["euler-maruyama", "rk4"])
def test_history_rows_hold_the_named_signals_of_the_state(scheme):
    scene = _frame(scheme)
    stride = scene.n_steps // 4
    history = np.full((5, len(NAMES)), np.nan)
    final = np.zeros((2, scene.mass.shape[0]))
    simulate(scene, np.random.default_rng(3), history=history, stride=stride, signals=NAMES, final=final)
    x, v = final
    nf = scene.n_floors
    last = dict(zip(NAMES, history[-1]))
    expected = {"x1": x[nf - 1], "x_1": x[0], "v_2": v[1], "drift_1": x[0], "drift_3": x[2] - x[1],
                "xa_1": x[nf], "va_2": v[nf + 1], "stroke_3": x[nf + 2] - x[2], "v_3": v[2]}
    for name, value in expected.items():
        assert last[name] == value, name
    assert last["e1"] > 0.0 and np.isfinite(history).all()
    assert history[0, NAMES.index("x1")] == scene.x0[nf - 1]  # (the first row: the start)


def test_a_history_without_names_keeps_its_columns_and_bad_names_are_refused():
    scene = _frame("euler-maruyama")
    nf = scene.n_floors
    assert history_columns(scene, np.zeros((3, 2)), None).tolist() == declare(["x1", "e1"], nf).tolist()
    assert history_columns(scene, np.zeros((3, 2 + nf)), None).tolist() == declare(
        ["x1", "e1", "x_1", "x_2", "x_3"], nf).tolist()
    with pytest.raises(ValueError, match="3 columns for 2 signals"):
        history_columns(scene, np.zeros((3, 3)), ["x1", "e1"])
    with pytest.raises(ValueError, match=r"'xa_4' is not a signal of this structure"):
        declare(["xa_4"], nf, 3)
    assert "stroke_3" in signal_names(nf, 3) and "stroke_4" not in signal_names(nf, 3)


def test_a_scenario_names_absorber_signals_for_its_history_and_paths():
    """``[simulation.history] signals`` and ``solve(signals=...)`` take the absorber signals: the
    history statistics get their columns, and one realisation's stroke is its absorber's
    displacement less the floor's, step by step."""
    from tests.helpers import two_dof_data
    from vines_stoch import run, solve

    data = {"name": "strokes", **two_dof_data(), "loads": [{"type": "white-noise", "intensity": 0.1}],
            "simulation": {"duration": 5.0, "dt": 0.01,
                           "history": {"points": 11, "signals": ["x1", "stroke_1", "va_1"]}},
            "ensemble": {"realizations": 8, "seed": 5}}
    results = run(data)
    h = results.history
    for name in ("x1", "stroke_1", "va_1"):
        assert np.isfinite(h[f"{name}_mean"]).all() and (h[f"{name}_std"].iloc[1:] > 0).all()
    one = solve(data, realization=2, signals=["x1", "xa_1", "stroke_1"])
    np.testing.assert_array_equal(one.ys["stroke_1"], one.ys["xa_1"] - one.ys["x1"])
    assert np.abs(one.ys["stroke_1"]).max() > 0.0


@pytest.mark.parametrize("scheme", ["rk4", "euler-maruyama"])
def test_an_impact_signal_is_its_impulse_on_the_host_over_the_step(scheme):
    """A free absorber (1 kg, 0.7 m/s) meets the wall of a resting host (50 kg, next to no spring)
    once: the host takes the Newton impulse ``(1 + e) mu w`` (``mu`` the reduced mass), the
    signal ``contact_1`` is that impulse over ``dt`` at the step that holds the impact and 0 at
    every other step end; so ``sum(contact_1) dt`` is the impulse, to rounding."""
    m1, ma, w, e = 50.0, 1.0, 0.7, 0.6
    data = {"name": "one-impact", "primary": {"mass": m1, "stiffness": 1e-6, "damping": 0.0},
            "absorbers": [{"type": "impact", "mass": ma, "clearance": 0.1, "restitution": e}],
            "loads": [{"type": "initial", "displacement": [0.0, 0.0], "velocity": [0.0, w]}],
            "simulation": {"duration": 0.3, "dt": 1e-3, "scheme": scheme}}
    scene = scene_from(data)
    history = np.full((scene.n_steps + 1, 1), np.nan)
    simulate(scene, history=history, stride=1, signals=["contact_1"])
    impulse = (1.0 + e) * m1 * ma / (m1 + ma) * w
    assert np.count_nonzero(history[:, 0]) == 1  # (the step of the one impact, 0.1 m / 0.7 m/s in)
    assert np.flatnonzero(history[:, 0])[0] == int(np.ceil(0.1 / w / scene.dt))
    assert history[:, 0].sum() * scene.dt == pytest.approx(impulse, rel=1e-12)


def test_a_hertz_signal_is_its_contact_force_on_the_host():
    """Seed 003's single-sided SSVI NES kicked into its walls: at every step end ``contact_1`` is
    ``-K_L z_L^1.5 + K_R z_R^1.5`` of the stroke there (``z_L = wall_lo - u``, ``z_R = u - wall_hi``,
    zero out of contact: the opposite of the force on the absorber), here written out."""
    from vines_stoch.physics.absorbers import K_LEFT, K_RIGHT, WALL_HI, WALL_LO

    data = example_data("seed003_ss60", "sweep")
    data["loads"] = [{"type": "initial", "displacement": [0.0, 0.0], "velocity": [0.0, 3.0]}]
    scene = scene_from(data, changes={"simulation.duration": 3.0, "simulation.metrics_from": 0.0})
    history = np.full((scene.n_steps + 1, 3), np.nan)
    simulate(scene, history=history, stride=1, signals=["contact_1", "xa_1", "x_1"])
    row = scene.rows[0]
    u = history[:, 1] - history[:, 2]
    left, right = np.maximum(row[WALL_LO] - u, 0.0), np.maximum(u - row[WALL_HI], 0.0)
    expected = -row[K_LEFT] * left**1.5 + row[K_RIGHT] * right**1.5
    assert np.count_nonzero(expected) > 10  # (in contact at some step ends)
    np.testing.assert_allclose(history[:, 0], expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())
