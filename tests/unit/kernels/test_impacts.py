"""Two-body impacts: loss per impact, energy conservation at r = 1, the geometric sequence."""

from __future__ import annotations

import pytest

from tests.helpers import raw_metrics, scene_from
from vines_stoch.physics.impact import restitution_impact


def two_body(stiffness: float, r: float, clearance: float, v1: float, duration: float, dt: float = 1e-3,
             scheme: str | None = None) -> dict:
    """A primary (m = 1) with an impact absorber (m = 0.05), the primary's impulse ``v1``."""
    simulation = {"duration": duration, "dt": dt} | ({"scheme": scheme} if scheme else {})
    return {"name": "two-body",
            "primary": {"mass": 1.0, "stiffness": stiffness},
            "absorbers": [{"type": "impact", "mass": 0.05, "clearance": clearance, "restitution": r}],
            "loads": [{"type": "impulse", "velocity": v1}],
            "simulation": simulation}


@pytest.mark.parametrize("r", [0.0, 0.3, 0.6, 0.95])
def test_loss_per_impact_matches_formula(r):
    m1, ma, v1, va = 1.3, 0.07, 0.4, -0.9
    v1n, van, loss = restitution_impact(m1, ma, v1, va, r)

    def kinetic(a, b):
        return 0.5 * m1 * a * a + 0.5 * ma * b * b

    formula = (1 - r * r) * m1 * ma / (2 * (m1 + ma)) * (va - v1) ** 2
    assert m1 * v1n + ma * van == pytest.approx(m1 * v1 + ma * va, rel=1e-14)
    assert (van - v1n) == pytest.approx(-r * (va - v1), rel=1e-13, abs=1e-15)
    if r < 1:
        assert loss == pytest.approx(formula, rel=1e-12)
        assert kinetic(v1, va) - kinetic(v1n, van) == pytest.approx(formula, rel=1e-12)


@pytest.mark.parametrize("scheme", ["rk4", "euler-maruyama"])
def test_single_impact_loss_inside_the_solver(scheme):
    # a free primary at V hits the resting absorber once before T: loss is the formula's
    m = raw_metrics(scene_from(two_body(0.0, 0.5, 0.1, 1.0, 0.15, dt=1e-3, scheme=scheme)))
    m1, ma = 1.0, 0.05
    assert m["impacts"] == 1
    assert m["impact_loss"] == pytest.approx((1 - 0.25) * m1 * ma / (2 * (m1 + ma)) * 1.0, rel=1e-12)


def test_elastic_impacts_conserve_energy():
    # r = 1, no damping, linear primary: more than 10^4 located impacts, energy drift < 1e-6
    m = raw_metrics(scene_from(two_body(1.0, 1.0, 0.005, 1.0, 110.0)))
    assert m["impacts"] > 1e4
    assert abs(m["final_energy"] - m["input_energy"]) / m["input_energy"] < 1e-6


def geometric_sequence(v: float, r: float, clearance: float, m1: float, ma: float, duration: float):
    """Impact count and absorbed energy of a free primary at ``v`` hitting a resting absorber."""
    t, w, count, lost = clearance / v, v, 0, 0.0
    while t <= duration:
        count += 1
        lost += (1 - r * r) * m1 * ma / (2 * (m1 + ma)) * w * w
        w *= r
        t += 2 * clearance / w
    return count, lost / (0.5 * m1 * v * v)


@pytest.mark.parametrize("scheme", ["rk4", "euler-maruyama"])
@pytest.mark.parametrize("r", [0.6, 0.9])
def test_free_primary_geometric_impact_sequence(scheme, r):
    duration = 7.77
    m = raw_metrics(scene_from(two_body(0.0, r, 0.1, 1.0, duration, scheme=scheme)))
    count, edm = geometric_sequence(1.0, r, 0.1, 1.0, 0.05, duration)
    assert count >= 4
    assert m["impacts"] == count
    assert m["impact_loss"] / m["input_energy"] == pytest.approx(edm, rel=1e-12)
