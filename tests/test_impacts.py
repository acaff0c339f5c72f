"""Two-body impacts: loss per impact, energy conservation at r = 1, the geometric sequence."""

from __future__ import annotations

import numpy as np
import pytest

from vines_stoch.kernels import simulate
from vines_stoch.physics import restitution_impact

from .conftest import raw_metrics, scene_of


def two_body(stiffness: float, r: float, clearance: float, v1: float, duration: float,
             dt: float = 1e-3) -> str:
    return f"""
name = "two-body"
[primary]
mass = 1.0
stiffness = {stiffness}
[[absorbers]]
type = "impact"
mass = 0.05
clearance = {clearance}
restitution = {r}
[[loads]]
type = "impulse"
velocity = {v1}
[simulation]
duration = {duration}
dt = {dt}
"""


@pytest.mark.parametrize("r", [0.0, 0.3, 0.6, 0.95])
def test_loss_per_impact_matches_formula(r):
    m1, ma, v1, va = 1.3, 0.07, 0.4, -0.9
    v1n, van, loss = restitution_impact(m1, ma, v1, va, r)
    kinetic = lambda a, b: 0.5 * m1 * a * a + 0.5 * ma * b * b
    formula = (1 - r * r) * m1 * ma / (2 * (m1 + ma)) * (va - v1) ** 2
    assert m1 * v1n + ma * van == pytest.approx(m1 * v1 + ma * va, rel=1e-14)
    assert (van - v1n) == pytest.approx(-r * (va - v1), rel=1e-13, abs=1e-15)
    if r < 1:
        assert loss == pytest.approx(formula, rel=1e-12)
        assert kinetic(v1, va) - kinetic(v1n, van) == pytest.approx(formula, rel=1e-12)


@pytest.mark.parametrize("scheme", ["rk4", "euler-maruyama"])
def test_single_impact_loss_inside_the_solver(scheme):
    # a free primary at V hits the resting absorber once before T: loss is the formula's
    text = two_body(0.0, 0.5, 0.1, 1.0, 0.15, dt=1e-3).replace(
        "dt = 1e-3", f'dt = 1e-3\nscheme = "{scheme}"')
    m = raw_metrics(scene_of(text))
    m1, ma = 1.0, 0.05
    assert m["impacts"] == 1
    assert m["impact_loss"] == pytest.approx((1 - 0.25) * m1 * ma / (2 * (m1 + ma)) * 1.0, rel=1e-12)


def test_elastic_impacts_conserve_energy():
    # r = 1, no damping, linear primary: more than 10^4 located impacts, energy drift < 1e-6
    m = raw_metrics(scene_of(two_body(1.0, 1.0, 0.005, 1.0, 110.0)))
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
    text = two_body(0.0, r, 0.1, 1.0, duration).replace("dt = 1e-3", f'dt = 1e-3\nscheme = "{scheme}"')
    m = raw_metrics(scene_of(text))
    count, edm = geometric_sequence(1.0, r, 0.1, 1.0, 0.05, duration)
    assert count >= 4
    assert m["impacts"] == count
    assert m["impact_loss"] / m["input_energy"] == pytest.approx(edm, rel=1e-12)


def test_strong_error_of_a_stochastic_impact_scene_decreases_with_dt():
    """Coarse solutions on the Brownian path of a fine one (dt = 2^-14): the mean error of x1(T)
    decreases with dt.  Measured order about 0.2-0.4 (bridge values at impacts are drawn
    independently of the fine path, which alone limits the order to 1/2)."""
    text = """
name = "strong"
[primary]
mass = 1.0
stiffness = 1.0
damping = 0.02
[[absorbers]]
type = "impact"
mass = 0.1
clearance = 0.1
restitution = 0.9
[[loads]]
type = "initial"
velocity = [0.0, 1.0]
[[loads]]
type = "white-noise"
intensity = 0.1
[simulation]
duration = 2.0
dt = {dt}
"""
    levels, fine, paths = [6, 8, 10], 14, 40
    rng = np.random.default_rng(5)
    errors = np.zeros((paths, len(levels)))
    for m in range(paths):
        z = rng.standard_normal(2 * 2**fine)

        def x1_end(level):
            k = 2 ** (fine - level)
            scene = scene_of(text.format(dt=2.0**-level))
            final = np.zeros((2, 2))
            simulate(scene, np.random.default_rng(m), normals=z.reshape(-1, k).sum(axis=1) / np.sqrt(k), final=final)
            return final[0, 0]

        reference = x1_end(fine)
        errors[m] = [abs(x1_end(level) - reference) for level in levels]
    mean = errors.mean(axis=0)
    assert mean[0] > mean[1] > mean[2]
    order = np.polyfit(np.log(2.0 ** -np.array(levels)), np.log(mean), 1)[0]
    assert order > 0.15
