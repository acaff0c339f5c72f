"""The Runge-Kutta step under harmonic loads: its stages read the loads at the step's start,
midpoint and end from the step's phasors (``rk4.rk4_step``: the cosine and sine of each row's
phase at the step's start, turned by half a step twice), not from a cosine a stage.  Against the
closed-form response of a damped oscillator to two harmonic loads from rest, the end state's
error falls by the scheme's fourth order as the step halves (a stage that read a load at the
wrong time would leave a first-order error), and stays at the step's truncation error."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.helpers import scene_from
from vines_stoch.kernels import simulate

M, K, C = 2.0, 5.0, 0.3
#: (amplitude, frequency rad/s, phase) of the two loads.
LOADS = ((1.0, 1.3, 0.4), (0.5, 3.1, -1.0))
DURATION = 20.0


def exact(t: float) -> tuple[float, float]:
    """Displacement and velocity at ``t`` of ``M x'' + C x' + K x = sum P cos(w t + phi)`` from
    rest: each load's steady response plus the free vibration that starts the sum from rest."""
    wn = math.sqrt(K / M)
    zeta = C / (2.0 * math.sqrt(K * M))
    wd = wn * math.sqrt(1.0 - zeta**2)
    x = v = x0 = v0 = 0.0
    for p, w, phi in LOADS:
        amp, lag = p / math.hypot(K - M * w * w, C * w), math.atan2(C * w, K - M * w * w)
        x += amp * math.cos(w * t + phi - lag)
        v -= amp * w * math.sin(w * t + phi - lag)
        x0 += amp * math.cos(phi - lag)
        v0 -= amp * w * math.sin(phi - lag)
    a = -x0
    b = (zeta * wn * a - v0) / wd
    decay = math.exp(-zeta * wn * t)
    x += decay * (a * math.cos(wd * t) + b * math.sin(wd * t))
    v += decay * ((-zeta * wn * a + wd * b) * math.cos(wd * t) + (-zeta * wn * b - wd * a) * math.sin(wd * t))
    return x, v


def end_state(dt: float) -> np.ndarray:
    data = {"name": "rk4-harmonic", "primary": {"mass": M, "stiffness": K, "damping": C},
            "loads": [{"type": "harmonic", "amplitude": p, "frequency": w, "phase": phi}
                      for p, w, phi in LOADS],
            "simulation": {"duration": DURATION, "dt": dt, "scheme": "rk4"}}
    scene = scene_from(data)
    final = np.zeros((2, 1))
    simulate(scene, None, final=final)
    return final[:, 0]


def test_rk4_under_harmonic_loads_converges_at_fourth_order():
    reference = np.array(exact(DURATION))
    errors = [float(np.max(np.abs(end_state(dt) - reference))) for dt in (0.04, 0.02, 0.01)]
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    # fourth order: each halving divides the error by about 16 (15-17 for these steps)
    assert all(12.0 < r < 20.0 for r in ratios), (errors, ratios)
    assert errors[2] < 1e-8, errors


@pytest.mark.parametrize("t", [0.0, 0.7, 5.0])
def test_the_closed_form_starts_at_rest_and_solves_the_equation(t):
    # (the reference checked: from rest, and its residual by central differences)
    x0, v0 = exact(0.0)
    assert abs(x0) < 1e-15 and abs(v0) < 1e-15
    h = 1e-4
    (xm, _), (x, v), (xp, _) = exact(t - h), exact(t), exact(t + h)
    force = sum(p * math.cos(w * t + phi) for p, w, phi in LOADS)
    residual = M * (xp - 2 * x + xm) / h**2 + C * v + K * x - force
    assert abs(residual) < 1e-5
