"""The bistable and the geometric NES (MODEL.md section 2): their formulae, the engine's paths
against a tight scipy ``solve_ivp`` solution written here, and their energy balance under noise.

The primary (m1 = k1 = 1, c1 = 0.02) carries one absorber (m = 0.05, c = 0.01) and starts with a
velocity.  The reference integrates the same two equations with DOP853 at ``rtol = 1e-12``;
classical RK4 at ``dt = 1e-3`` (``omega dt <= 1.5e-3`` here) has a global error near
``T (omega dt)^4 ~ 1e-10``, so the engine's RK4 path must agree to ``1e-8`` of the amplitude; the
kick-drift-kick (velocity Verlet) path's error must fall four times when ``dt`` halves,
without dashpots: its closing half kick takes the dashpot forces at the half-kicked velocities,
which leaves an error of first order in ``c dt`` (measured: the error halves with ``dt`` for the
cubic NES as for these laws).  The tests also check that they can fail: the cubic
approximation of the geometric law, or the bistable law with its linear stiffness dropped, is far
outside those tolerances.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from tests.helpers import scene_from, study_from
from vines_stoch import ScenarioError
from vines_stoch.ensemble import run_chunk
from vines_stoch.kernels import simulate
from vines_stoch.physics.absorbers import (
    FREE_LENGTH,
    GEOMETRIC,
    K_CUBIC,
    K_GEO,
    K_LIN,
    LAWS,
    LENGTH,
    geometric_energy,
    geometric_force,
)
from vines_stoch.scene import build_scene

M1, K1, C1, MA, CA, V0, T = 1.0, 1.0, 0.02, 0.05, 0.01, 0.6, 30.0
GEOMETRIC_NES = {"type": "geometric", "mass": MA, "damping": CA, "stiffness": 0.02, "free_length": 0.2,
                 "length": 0.2}
BISTABLE_NES = {"type": "bistable", "mass": MA, "damping": CA, "stiffness": 2.0, "linear_stiffness": -0.02}


def _data(absorber: dict, dt: float, scheme: str, start: list[float] | None = None, c1: float = C1) -> dict:
    loads = [{"type": "impulse", "velocity": V0}]
    if start is not None:
        loads = [{"type": "initial", "displacement": start, "velocity": [V0, 0.0]}]
    return {"name": "laws", "primary": {"mass": M1, "stiffness": K1, "damping": c1}, "absorbers": [absorber],
            "loads": loads, "simulation": {"duration": T, "dt": dt, "scheme": scheme}}


def _coupling(absorber: dict):
    """The absorber's spring force as a plain Python function of ``u`` (MODEL.md section 2)."""
    if absorber["type"] == "geometric":
        k, l0, ln = absorber["stiffness"], absorber["free_length"], absorber["length"]
        return lambda u: -2.0 * k * u * (1.0 - l0 / math.sqrt(u * u + ln * ln))
    k3, k1 = absorber["stiffness"], absorber["linear_stiffness"]
    return lambda u: -k1 * u - k3 * u ** 3


def _reference(spring, start: list[float] | None = None, c1: float = C1, ca: float = CA) -> np.ndarray:
    """``(x1, xa, v1, va)`` at ``T`` by DOP853 at ``rtol = 1e-12``."""
    def rhs(t, y):
        x1, xa, v1, va = y
        f = spring(xa - x1) - ca * (va - v1)
        return [v1, va, (-K1 * x1 - c1 * v1 - f) / M1, f / MA]

    y0 = [0.0, 0.0, V0, 0.0] if start is None else [*start, V0, 0.0]
    sol = solve_ivp(rhs, (0.0, T), y0, method="DOP853", rtol=1e-12, atol=1e-14)
    assert sol.success
    return sol.y[:, -1]


def _engine(absorber: dict, dt: float, scheme: str, start: list[float] | None = None,
            c1: float = C1) -> np.ndarray:
    final = np.zeros((2, 2))
    simulate(scene_from(_data(absorber, dt, scheme, start, c1)), final=final)
    return final.reshape(-1)


CASES = {"geometric": (GEOMETRIC_NES, None),
         "bistable": (BISTABLE_NES, [0.0, 0.1])}  # the absorber starting in its right well


@pytest.mark.parametrize("law", sorted(CASES))
def test_rk4_paths_match_a_tight_scipy_solution(law):
    absorber, start = CASES[law]
    ref = _reference(_coupling(absorber), start)
    got = _engine(absorber, 1e-3, "rk4", start)
    scale = np.max(np.abs(ref))
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-8 * scale)
    # a wrong law is far outside that tolerance: the cubic approximation of the geometric law,
    # the bistable law without its negative linear stiffness
    if law == "geometric":
        wrong = lambda u: -absorber["stiffness"] / absorber["free_length"] ** 2 * u ** 3  # noqa: E731
    else:
        wrong = lambda u: -absorber["stiffness"] * u ** 3  # noqa: E731
    assert np.max(np.abs(_reference(wrong, start) - ref)) > 1e-3 * scale


@pytest.mark.parametrize("law", sorted(CASES))
def test_kick_drift_kick_converges_at_second_order(law):
    absorber, start = CASES[law]
    absorber = {**absorber, "damping": 0.0}
    ref = _reference(_coupling(absorber), start, 0.0, 0.0)
    errors = [np.max(np.abs(_engine(absorber, dt, "euler-maruyama", start, 0.0) - ref))
              for dt in (4e-3, 2e-3)]
    assert 3.8 < errors[0] / errors[1] < 4.2, errors
    assert errors[1] < 1e-4 * np.max(np.abs(ref))


def test_geometric_formulae():
    k, l0 = 3.0, 0.5
    # the force is minus the energy's derivative (central differences at h = 1e-3 |u|: a relative
    # error near (h / u)^2 = 1e-6)
    for length in (l0, 0.8):
        for u in (-0.7, -1e-3, 0.2, 1.5):
            h = 1e-3 * abs(u)
            rise = geometric_energy(u + h, k, l0, length) - geometric_energy(u - h, k, l0, length)
            assert geometric_force(u, k, l0, length) == pytest.approx(-rise / (2 * h), rel=1e-5)
        assert geometric_energy(0.0, k, l0, length) == 0.0
    # springs at their free length: the cubic law k / l0^2 at small u, to a relative O(u^2 / l0^2)
    for u in (1e-6, 1e-4, 1e-2):
        cubic = -k / l0 ** 2 * u ** 3
        assert abs(geometric_force(u, k, l0, l0) / cubic - 1.0) < 2.0 * (u / l0) ** 2
    # pretensioned springs: the linear stiffness 2 k (1 - l0 / l) at small u
    u = 1e-7
    assert geometric_force(u, k, l0, 0.8) / -u == pytest.approx(2 * k * (1 - l0 / 0.8), rel=1e-9)


def test_rows_and_codes():
    scene = scene_from(_data(GEOMETRIC_NES, 1e-3, "rk4"))
    row = scene.rows[0]
    assert scene.kind[0] == LAWS["geometric"] == GEOMETRIC
    assert (row[K_GEO], row[FREE_LENGTH], row[LENGTH]) == (0.02, 0.2, 0.2)
    assert row[K_LIN] == row[K_CUBIC] == 0.0
    scene = scene_from(_data(BISTABLE_NES, 1e-3, "rk4"))
    assert (scene.rows[0, K_LIN], scene.rows[0, K_CUBIC], scene.rows[0, K_GEO]) == (-0.02, 2.0, 0.0)


@pytest.mark.parametrize("law", sorted(CASES))
def test_energy_balance_under_white_noise(law):
    """Every realisation's balance (work in = dissipation + stored energy change) closes to the
    scheme's own error, 1e-3 of the energy that flowed (``energy_residual``, as for every law)."""
    absorber, start = CASES[law]
    data = _data(absorber, 2e-3, "euler-maruyama", start)
    data["loads"].append({"type": "white-noise", "intensity": 0.1})
    data["ensemble"] = {"realizations": 6, "seed": 7}
    study = study_from(data)
    frame, _ = run_chunk(build_scene(study.points[0]), 7, 0, 0, 6)
    assert (frame["status"] == "ok").all()
    assert frame["absorber_dissipation"].min() > 0.0
    assert frame["energy_residual"].abs().max() < 1e-3


def test_bad_parameters_are_refused():
    with pytest.raises(ScenarioError, match=r"absorbers.0.linear_stiffness = 0.02: must be < 0"):
        study_from(_data({**BISTABLE_NES, "linear_stiffness": 0.02}, 1e-3, "rk4"))
    with pytest.raises(ScenarioError, match=r"length.*free_length"):
        study_from(_data({**GEOMETRIC_NES, "length": 0.1}, 1e-3, "rk4"))
    # the dt check sees the bistable absorber's stiffness in its wells, -2 k_lin
    stiff = {**BISTABLE_NES, "linear_stiffness": -2e5}
    with pytest.raises(ScenarioError, match=r"simulation.dt.*stability limit"):
        study_from(_data(stiff, 1e-2, "rk4"))
