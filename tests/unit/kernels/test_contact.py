"""Hertz contact, chatter, regimes and the seed 003 SSVI design against scipy (MODEL.md sections 2 and
4); the seed 003 tables themselves are reproduced in ``tests/papers``."""

from __future__ import annotations

import time

import numpy as np
import pytest
from scipy.special import beta

from tests.helpers import changed, raw_metrics, scene_from
from vines_stoch import load_scenario
from vines_stoch.kernels import simulate
from vines_stoch.metrics import finish, regime
from vines_stoch.physics.hertz import hertz_constant
from vines_stoch.scene import build_scene
from vines_stoch.validation.reference import hertz_reference

#: Contact surfaces of the seed 003 designs (soft left and right barriers) and steel on steel.
SOFT_LEFT = {"young": [2.1e11, 2.21e7], "poisson": [0.3, 0.3], "radius": 1.0}
SOFT_RIGHT = {"young": [2.1e11, 2.05e7], "poisson": [0.3, 0.3], "radius": 1.0}
STEEL = {"young": [2.1e11, 2.1e11], "poisson": [0.3, 0.3], "radius": 1.0}


def seed_absorber(geometry: str, mass: float, k: float, c: float, d: float, g: float, left: dict,
                  right: dict) -> dict:
    """A Hertz absorber table: ``k``, ``c`` its spring and dashpot, ``d`` its offset, ``g`` its gap."""
    return {"type": "hertz", "geometry": geometry, "mass": mass, "stiffness": k, "damping": c, "offset": d,
            "gap": g, "contact_left": left, "contact_right": right}


def seed_data(absorber: dict, duration: float) -> dict:
    """The seed 003 primary under 800 cos(6.3 t) N with ``absorber``, from rest."""
    return {"name": "seed",
            "primary": {"mass": 1000.0, "stiffness": 3.95e4, "damping": 452.0},
            "absorbers": [absorber],
            "loads": [{"type": "harmonic", "amplitude": 800.0, "frequency": 6.3}],
            "simulation": {"duration": duration, "dt": 1e-3}}


def single_contact(k: float, approach: float, m1=1000.0, m2=60.0, gap=0.01):
    """A free primary and a free Hertz absorber approaching the right obstacle at ``approach``:
    one contact, then the absorber flies back across the cavity (no second contact)."""
    flight = gap / approach
    absorber = seed_absorber("double-sided", m2, 0.0, 0.0, 0.0, gap, {"k": k}, {"k": k})
    data = changed(seed_data(absorber, 3.0 * flight), {"primary.mass": m1, "primary.stiffness": 0.0,
                                                        "primary.damping": 0.0, "loads.0.amplitude": 0.0})
    data["loads"].append({"type": "initial", "velocity": [0.0, approach]})
    return scene_from(data)


@pytest.mark.parametrize("k, approach", [(hertz_constant([2.1e11, 2.05e7], [0.3, 0.3], 1.0), 1.0),
                                         (hertz_constant([2.1e11, 2.1e11], [0.3, 0.3], 1.0), 1.0),
                                         (hertz_constant([2.1e11, 2.1e11], [0.3, 0.3], 1.0), 0.05)])
def test_single_hertz_contact_matches_the_closed_form(k, approach):
    m1, m2 = 1000.0, 60.0
    scene = single_contact(k, approach, m1, m2)
    final = np.zeros((2, 2))
    raw = raw_metrics(scene, final=final)
    m = m1 * m2 / (m1 + m2)
    z_max = (5.0 * m * approach**2 / (4.0 * k)) ** 0.4
    duration = 2.0 * z_max / approach * 0.4 * beta(0.4, 0.5)
    assert raw["impacts"] == 1 and raw["impacts_right"] == 1
    assert raw["contact_time"] == pytest.approx(duration, rel=1e-2)
    assert raw["peak_force"] == pytest.approx(k * z_max**1.5, rel=1e-2)
    # elastic: the relative velocity comes back reversed and whole
    restitution = -(final[1, 1] - final[1, 0]) / approach
    assert abs(restitution - 1.0) < 1e-6
    # r within 1e-6 means the (relative) kinetic energy back within 2e-6
    assert abs(raw["final_energy"] / raw["input_energy"] - 1.0) < 2e-6


def test_steel_contact_at_the_default_step_is_stable():
    """Steel on steel (contact of about 0.5 ms) at dt = 1e-3 on a seed design: finite, balanced."""
    absorber = seed_absorber("single-sided", 60.0, 215.0, 232.0, 0.06, 0.3, STEEL, STEEL)
    scene = scene_from(seed_data(absorber, 60.0))
    row = finish(simulate(scene), scene)
    assert row["status"] == "ok" and row["impacts"] > 10
    assert abs(row["energy_residual"]) < 1e-6


def test_ssvi_seed_design_matches_a_tight_scipy_reference():
    """SS-1(60) from rest for 12 s (about 10 contacts): x1 and e1_max against DOP853 with events."""
    duration = 12.0
    times = np.linspace(1.0, duration, 12)
    absorber = seed_absorber("single-sided", 60.0, 215.0, 232.0, 0.06, 0.3, SOFT_LEFT, SOFT_RIGHT)
    x1 = []
    for t in times:
        scene = scene_from(seed_data(absorber, float(t)))
        final = np.zeros((2, 2))
        raw = raw_metrics(scene, final=final)
        x1.append(final[0, 0])
    k_left = hertz_constant([2.1e11, 2.21e7], [0.3, 0.3], 1.0)
    k_right = hertz_constant([2.1e11, 2.05e7], [0.3, 0.3], 1.0)
    ref_x1, ref_e1 = hertz_reference(1000.0, 3.95e4, 452.0, 60.0, 215.0, 232.0, 0.06, k_left, k_right,
                                     (0.0, 0.36), 800.0, 6.3, 0.06, times)
    assert raw["impacts"] >= 5
    amplitude = np.abs(ref_x1).max()
    assert np.abs(np.array(x1) - ref_x1).max() < 1e-4 * amplitude
    assert raw["e1_max"] == pytest.approx(ref_e1, rel=1e-4)


@pytest.mark.parametrize("restitution", [0.5, 0.0])
def test_chatter_ends_in_sticking(restitution):
    """An absorber in a small cavity of a strongly forced primary: chatter sequences end in
    sticking and separation; bounded time, bounded impacts, closed energy balance."""
    scene = scene_from({
        "name": "chatter",
        "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.05},
        "absorbers": [{"type": "impact", "mass": 0.2, "clearance": 0.01, "restitution": restitution}],
        "loads": [{"type": "harmonic", "amplitude": 1.0, "frequency": 1.0}],
        "simulation": {"duration": 60.0, "dt": 1e-3}})
    raw = raw_metrics(scene)  # compiles the kernel on a cold cache
    start = time.perf_counter()
    row = finish(simulate(scene), scene)
    assert time.perf_counter() - start < 30.0  # the run itself, JIT compilation left out
    periods = 60.0 / (2 * np.pi)
    assert raw["capped_steps"] == 0
    assert 2 * periods <= raw["impacts"] <= 100 * periods
    assert abs(row["energy_residual"]) < 1e-6


def test_regime_from_poincare_samples():
    rng = np.random.default_rng(0)
    rows = []
    for k in range(12):  # a 2T orbit: two alternating states, one left impact every 2 periods
        state = [0.1, 0.2] if k % 2 else [0.3, -0.1]
        rows.append(state + [0.5, 0.0] + [k // 2, 0])
    assert regime(np.array(rows), 1.0) == "2T,1,0"
    noisy = np.array(rows)
    noisy[:, :2] += rng.normal(0, 0.05, size=(12, 2))
    assert regime(noisy, 1.0) == "aperiodic"


def test_steady_primary_is_period_one_without_impacts():
    scene = build_scene(load_scenario("scenarios/seed003_primary.toml").points[0])
    from vines_stoch.ensemble import run_chunk

    assert run_chunk(scene, 0, 0, 0, 1)[0]["regime"].iloc[0] == "T,0,0"
