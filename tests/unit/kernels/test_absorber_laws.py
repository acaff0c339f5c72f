"""The bistable, the geometric and the piecewise-linear (gap spring) NES (MODEL.md section 2):
their formulae, the engine's paths against a tight scipy ``solve_ivp`` solution written here, and
their energy balance under noise.

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

The gap spring's force has a kink at ``|u| = g``: the step that crosses it loses the schemes'
order (the state's second derivative jumps), so its paths are checked by their convergence to
the same reference rather than against one step's error bound.  The reference itself needs no
event location: DOP853's error control shrinks its steps at each crossing (restarting it at
every crossing, located by ``solve_ivp``'s events, moved the final state by 3e-11).
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
    GAP,
    GAP_SPRING,
    GEOMETRIC,
    K_CUBIC,
    K_GAP,
    K_GEO,
    K_LIN,
    LAWS,
    LENGTH,
    ROW,
    gap_energy,
    gap_force,
    geometric_energy,
    geometric_force,
)
from vines_stoch.rvt.energy import coupling_energy as mean_energy
from vines_stoch.rvt.linearization import law as linearised
from vines_stoch.scene import build_scene

M1, K1, C1, MA, CA, V0, T = 1.0, 1.0, 0.02, 0.05, 0.01, 0.6, 30.0
GEOMETRIC_NES = {"type": "geometric", "mass": MA, "damping": CA, "stiffness": 0.02, "free_length": 0.2,
                 "length": 0.2}
BISTABLE_NES = {"type": "bistable", "mass": MA, "damping": CA, "stiffness": 2.0, "linear_stiffness": -0.02}
GAP_NES = {"type": "gap", "mass": MA, "damping": CA, "stiffness": 0.5, "gap": 0.1}


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
    if absorber["type"] == "gap":
        k, g, k1 = absorber["stiffness"], absorber["gap"], absorber.get("linear_stiffness", 0.0)
        return lambda u: -k1 * u - k * math.copysign(max(abs(u) - g, 0.0), u)
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
    scene = scene_from(_data({**GAP_NES, "linear_stiffness": 0.3}, 1e-3, "rk4"))
    assert scene.kind[0] == LAWS["gap"] == GAP_SPRING and scene.has_shaped
    assert (scene.rows[0, K_GAP], scene.rows[0, GAP], scene.rows[0, K_LIN]) == (0.5, 0.1, 0.3)
    assert not scene_from(_data(BISTABLE_NES, 1e-3, "rk4")).has_shaped


def test_gap_spring_paths_converge_to_a_tight_scipy_solution():
    """Over the 24 crossings of ``|u| = g`` in this path, RK4's error falls more than 16-fold when
    ``dt`` falls 4-fold (a smooth law's falls 256-fold; a crossing step's local error is of third
    order, so the global error of second order at worst) and is below 1e-7 of the amplitude at
    ``dt = 2.5e-4``; kick-drift-kick's falls more than 8-fold (second order, with a factor 2 for
    where the crossings fall within their steps).  A wrong law, the gap left out (a linear spring),
    is far outside."""
    ref = _reference(_coupling(GAP_NES))
    scale = np.max(np.abs(ref))
    rk4 = [np.max(np.abs(_engine(GAP_NES, dt, "rk4") - ref)) for dt in (1e-3, 2.5e-4)]
    assert rk4[0] / rk4[1] > 16.0 and rk4[1] < 1e-7 * scale, rk4
    free = {**GAP_NES, "damping": 0.0}
    ref0 = _reference(_coupling(free), None, 0.0, 0.0)
    kdk = [np.max(np.abs(_engine(free, dt, "euler-maruyama", None, 0.0) - ref0)) for dt in (2e-3, 5e-4)]
    assert kdk[0] / kdk[1] > 8.0 and kdk[1] < 1e-5 * scale, kdk
    assert np.max(np.abs(_reference(_coupling({**GAP_NES, "gap": 0.0})) - ref)) > 1e-3 * scale


def test_gap_formulae():
    k, g = 3.0, 0.2
    for u in (-0.7, -0.25, 0.3, 1.5):  # beyond the gap: minus the energy's derivative
        h = 1e-4
        rise = gap_energy(u + h, k, g) - gap_energy(u - h, k, g)
        assert gap_force(u, k, g) == pytest.approx(-rise / (2 * h), rel=1e-9)
    for u in (-0.2, -0.1, 0.0, 0.15, 0.2):  # within it: nothing
        assert gap_force(u, k, g) == 0.0 and gap_energy(u, k, g) == 0.0
    assert gap_force(0.5, k, g) == pytest.approx(-k * 0.3, rel=1e-15)
    assert gap_force(-0.5, k, g) == -gap_force(0.5, k, g)
    # its Gaussian expectations (statistical linearisation, the expected energy) against
    # adaptive quadrature of the law itself
    from scipy import integrate, stats

    row = np.zeros(ROW)
    row[K_GAP], row[GAP], row[K_LIN] = k, g, 0.4
    spring = _coupling({"type": "gap", "stiffness": k, "gap": g, "linear_stiffness": 0.4})
    energy = lambda u: 0.2 * u * u + gap_energy(u, k, g)  # noqa: E731
    for mu, s in ((0.0, 0.05), (0.1, 0.3), (-0.5, 0.1), (0.0, 2.0)):
        def expect(f, mu=mu, s=s):
            return integrate.quad(lambda u: f(u) * stats.norm.pdf(u, mu, s), mu - 12 * s, mu + 12 * s,
                                  points=[-g, g], limit=200, epsabs=1e-13, epsrel=1e-11)[0]
        slope = -0.4 - k * (stats.norm.sf(g, mu, s) + stats.norm.cdf(-g, mu, s))
        mean, k_eq = linearised(row, mu, s)
        assert mean == pytest.approx(expect(spring), rel=1e-9, abs=1e-14)
        assert k_eq == pytest.approx(slope, rel=1e-9)
        assert mean_energy(row, mu, s) == pytest.approx(expect(energy), rel=1e-9)


@pytest.mark.parametrize("law", [*sorted(CASES), "gap"])
def test_energy_balance_under_white_noise(law):
    """Every realisation's balance (work in = dissipation + stored energy change) closes to the
    scheme's own error, 1e-3 of the energy that flowed (``energy_residual``, as for every law)."""
    absorber, start = CASES.get(law, (GAP_NES, None))
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
    with pytest.raises(ScenarioError, match=r"absorbers.0.gap = -0.1: must be >= 0"):
        study_from(_data({**GAP_NES, "gap": -0.1}, 1e-3, "rk4"))
    with pytest.raises(ScenarioError, match=r"absorbers.0.stiffness = 0.0: must be > 0"):
        study_from(_data({**GAP_NES, "stiffness": 0.0}, 1e-3, "rk4"))
    # the dt check sees the gap spring engaged, k_lin + k (at rest the absorber is a free mass)
    with pytest.raises(ScenarioError, match=r"simulation.dt.*stability limit"):
        study_from(_data({**GAP_NES, "stiffness": 5e5}, 1e-2, "rk4"))
