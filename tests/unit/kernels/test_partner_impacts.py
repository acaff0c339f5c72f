"""Impacts between two absorbers (``impacts_with``: an impact absorber in another absorber's
cavity, the vibro-impact dual-mass damper of seed 001 Table 5), against two independent
references:

- the same system written as a shear building: an absorber ``p`` joined to floor 1 by a spring and
  a dashpot, holding an impact absorber in its cavity, is a second floor on a storey of that spring
  and dashpot with the impact absorber hosted on it (the tested floor impacts), under the same
  harmonic load and, for kick-drift-kick, the same white noise and Brownian trees;
- a tight-tolerance scipy solution (DOP853 between impacts, each impact located by its event and
  resolved by Newton's law between the two absorbers), written here.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from tests.helpers import study_from
from vines_stoch.ensemble import solve
from vines_stoch.scenario import ScenarioError


def cavity_in_absorber(scheme: str, r: float, noise: float) -> dict:
    """A primary (m = 1) hosting a linear absorber ``p`` (m = 0.1) whose cavity holds a free
    impact absorber (m = 0.03, clearance 0.05), under a harmonic load (and white noise)."""
    loads = [{"type": "harmonic", "amplitude": 0.3, "frequency": 1.0}]
    loads += [{"type": "white-noise", "intensity": noise}] if noise else []
    return {"name": "cavity-in-absorber", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.02},
            "absorbers": [{"type": "linear", "mass": 0.1, "stiffness": 0.12, "damping": 0.004},
                          {"type": "impact", "mass": 0.03, "clearance": 0.05, "restitution": r,
                           "impacts_with": 1}],
            "loads": loads, "simulation": {"duration": 20.0, "dt": 1e-3, "scheme": scheme},
            "ensemble": {"realizations": 1, "seed": 5}}


def as_second_floor(data: dict) -> dict:
    """``cavity_in_absorber`` written as a two-storey primary: absorber ``p`` is floor 2, the
    impact absorber is hosted on it, the loads act on floor 1."""
    p, impact = data["absorbers"]
    primary = data["primary"]
    return {**data, "name": "second-floor",
            "primary": {"masses": [primary["mass"], p["mass"]],
                        "stiffnesses": [primary["stiffness"], p["stiffness"]],
                        "dampings": [primary["damping"], p["damping"]]},
            "absorbers": [{key: value for key, value in impact.items() if key != "impacts_with"}
                          | {"floor": 2}],
            "loads": [load | {"floor": 1} for load in data["loads"]]}


@pytest.mark.parametrize("scheme, noise", [("rk4", 0.0), ("euler-maruyama", 0.3)], ids=["rk4", "kdk-noise"])
@pytest.mark.parametrize("r", [0.7, 0.0], ids=["r0.7", "r0-sticking"])
def test_a_cavity_in_an_absorber_is_a_floor_above(scheme, noise, r):
    """The two scenes compute the same equations with the forces summed in another order: they
    (and the impact force on the body that holds the walls, ``contact_j``) agree to round-off
    amplified by the impacts (measured at most 4e-11 of the response over
    20 s, with noise and with chatter ending in sticking at r = 0), tested at 1e-8; the impacts,
    their losses and the work of the loads agree to 1e-9."""
    data = cavity_in_absorber(scheme, r, noise)
    ours = solve(data, signals=["x1", "xa_1", "xa_2", "contact_2"])
    floors = solve(as_second_floor(data), signals=["x_1", "x_2", "xa_1", "contact_1"])
    assert ours.metrics["impacts"] > 10
    # (contact_j: the impulses on the body that holds the walls, over dt)
    for a, b in (("x1", "x_1"), ("xa_1", "x_2"), ("xa_2", "xa_1"), ("contact_2", "contact_1")):
        scale = np.abs(floors.ys[b]).max()
        assert np.abs(ours.ys[a] - floors.ys[b]).max() < 1e-8 * scale, a
    assert ours.metrics["impacts"] == floors.metrics["impacts"]
    for metric in ("impact_loss", "input_energy"):
        assert ours.metrics[metric] == pytest.approx(floors.metrics[metric], rel=1e-9), metric
    # the cavity holds: the impact absorber never leaves it
    assert np.abs(ours.ys["xa_2"] - ours.ys["xa_1"]).max() <= 0.05 * (1 + 1e-12)


M1, K1, C1 = 1.0, 1.0, 0.02     # primary
MP, KP, CP = 0.1, 0.12, 0.004   # the absorber holding the cavity
MA, KA, CA = 0.03, 0.5, 0.001   # the impact absorber, sprung to the primary
CLEARANCE, R, V0, T = 0.05, 0.9, 1.0, 5.0


def reference(ts: np.ndarray) -> tuple[np.ndarray, int, float]:
    """The scipy solution at ``ts``: positions (x1, x_p, x_a), impacts, impact losses."""

    def rhs(t, y):
        x1, xp, xa, v1, vp, va = y
        fp = -KP * (xp - x1) - CP * (vp - v1)
        fa = -KA * (xa - x1) - CA * (va - v1)
        return [v1, vp, va, (-K1 * x1 - C1 * v1 - fp - fa) / M1, fp / MP, fa / MA]

    def right(t, y):
        return y[2] - y[1] - CLEARANCE

    def left(t, y):
        return y[2] - y[1] + CLEARANCE

    right.terminal = left.terminal = True
    right.direction, left.direction = 1, -1
    y, t, impacts, loss, speeds = np.array([0.0, 0.0, 0.0, V0, 0.0, 0.0]), 0.0, 0, 0.0, []
    positions = np.full((3, ts.shape[0]), np.nan)
    while True:
        sol = solve_ivp(rhs, (t, T), y, method="DOP853", rtol=1e-12, atol=1e-14, events=(right, left),
                        dense_output=True)
        inside = (ts >= t) & (ts <= sol.t[-1])
        positions[:, inside] = sol.sol(ts[inside])[:3]
        if sol.status != 1:
            break
        side = 0 if sol.t_events[0].size else 1
        t, y = sol.t_events[side][0], sol.y_events[side][0].copy()
        y[2] = y[1] + (CLEARANCE if side == 0 else -CLEARANCE)
        w, total = y[5] - y[4], MP + MA
        y[4] += MA * (1 + R) * w / total
        y[5] -= MP * (1 + R) * w / total
        loss += 0.5 * (1 - R * R) * MP * MA / total * w * w
        impacts += 1
        speeds.append(abs(w))
    assert min(speeds) > 0.1  # well-separated impacts: no chatter, no sticking to model here
    return positions, impacts, loss


def test_impacts_between_absorbers_against_scipy():
    """RK4 at dt = 1e-3 (largest frequency 4.1 rad/s) with located impacts against DOP853 at
    rtol 1e-12: the impacts amplify any difference (at 2 s the paths agree to 2e-13, at 5 s to
    1.3e-11, at 20 s to 7e-5: measured), so the check runs over 5 s with 23 impacts, at 1e-8."""
    data = {"name": "vidm", "primary": {"mass": M1, "stiffness": K1, "damping": C1},
            "absorbers": [{"type": "linear", "mass": MP, "stiffness": KP, "damping": CP},
                          {"type": "impact", "mass": MA, "stiffness": KA, "damping": CA,
                           "clearance": CLEARANCE, "restitution": R, "impacts_with": 1}],
            "loads": [{"type": "impulse", "velocity": V0}],
            "simulation": {"duration": T, "dt": 1e-3, "scheme": "rk4"}}
    ours = solve(data, signals=["x1", "xa_1", "xa_2"], points=1001)
    positions, impacts, loss = reference(ours.ts)
    assert impacts >= 20 and ours.metrics["impacts"] == impacts
    assert ours.metrics["impact_loss"] == pytest.approx(loss, rel=1e-8)
    for i, name in enumerate(("x1", "xa_1", "xa_2")):
        assert np.abs(ours.ys[name] - positions[i]).max() < 1e-8, name


@pytest.mark.parametrize("impacts_with, message", [
    (2, "must name another absorber"),
    (3, "must name another absorber"),
])
def test_impacts_with_must_name_another_absorber(impacts_with, message):
    data = cavity_in_absorber("rk4", 0.7, 0.0)
    data["absorbers"][1]["impacts_with"] = impacts_with
    with pytest.raises(ScenarioError, match=f"absorbers.1.impacts_with.*{message}"):
        study_from(data)


def test_impacts_with_refuses_an_impact_absorber_and_other_laws():
    data = cavity_in_absorber("rk4", 0.7, 0.0)
    data["absorbers"][0] = {"type": "impact", "mass": 0.1, "clearance": 0.1, "restitution": 0.5}
    with pytest.raises(ScenarioError, match="absorbers.1.impacts_with.*absorber 1 is an impact absorber"):
        study_from(data)
    data = cavity_in_absorber("rk4", 0.7, 0.0)
    data["absorbers"][0]["impacts_with"] = 2
    with pytest.raises(ScenarioError, match="impacts_with"):
        study_from(data)
