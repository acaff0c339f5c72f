"""The largest Lyapunov exponent (``dynamics.largest_lyapunov``, Benettin's two trajectories)
against a damped linear oscillator's exact exponent and the Ueda oscillator's published one; the
envelope frequency (``dynamics.envelope_frequency``, Hilbert transform) of a beating linear
two-degree-of-freedom system against its closed form; the regime classes of a run's table
(``dynamics.refine_regimes``) on periodic, chaotic, beating, late-settling and irregular
responses."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from tests.helpers import scene_from, study_from
from vines_stoch import ScenarioError, dynamics, run
from vines_stoch.dynamics import EDGE, envelope_frequency, largest_lyapunov
from vines_stoch.kernels import simulate

ZETA, OMEGA = 0.05, 2.0 * math.pi


def oscillator(duration: float = 120.0, metrics_from: float = 20.0) -> dict:
    """A damped linear oscillator forced at its natural frequency (forcing does not change a
    linear system's exponents; it gives the Poincare scaling ``omega``)."""
    return {"name": "linear", "primary": {"mass": 1.0, "stiffness": OMEGA**2, "damping": 2 * ZETA * OMEGA},
            "loads": [{"type": "harmonic", "amplitude": 1.0, "frequency": OMEGA}],
            "simulation": {"duration": duration, "dt": 0.005, "metrics_from": metrics_from, "scheme": "rk4"}}


def test_a_damped_linear_oscillator_has_the_exponent_minus_zeta_omega():
    """A perturbation decays as a free vibration, ``e^(-zeta omega t)`` times a factor whose norm
    (``x``, ``v / omega``) stays within ``sqrt(1 -+ zeta)`` over a cycle: the estimate over a
    window ``W`` is ``-zeta omega`` within ``ln((1 + zeta) / (1 - zeta)) / (2 W)`` (RK4's own
    damping error at ``omega dt = 0.03`` is below 1e-9 of it)."""
    scene = scene_from(oscillator())
    window = scene.window
    bound = 0.5 * math.log((1 + ZETA) / (1 - ZETA)) / window
    exponent = largest_lyapunov(scene)
    assert abs(exponent + ZETA * OMEGA) <= bound
    # another renormalisation interval (a third of a period) gives the same limit
    assert abs(largest_lyapunov(scene, interval=67) + ZETA * OMEGA) <= bound


def ueda(duration: float = 3000.0) -> dict:
    """Ueda's oscillator ``x'' + 0.05 x' + x^3 = 7.5 cos t`` (Ueda, J. Stat. Phys. 20 (1979) 181,
    DOI 10.1007/BF01011512): a cubic absorber of unit mass on a primary of 1e6 its mass and
    natural frequency 100 rad/s (its host hardly moves: 7.5e-4 m under the base acceleration,
    1e-4 of the forcing), driven by a harmonic base acceleration of amplitude 7.5."""
    mass, w1 = 1e6, 100.0
    primary = {"mass": mass, "stiffness": mass * w1**2, "damping": 2 * 0.05 * w1 * mass}
    return {"name": "ueda", "primary": primary,
            "absorbers": [{"type": "cubic", "mass": 1.0, "stiffness": 1.0, "damping": 0.05}],
            "loads": [{"type": "base-harmonic", "amplitude": 7.5, "frequency": 1.0}],
            "simulation": {"duration": duration, "dt": 0.005, "metrics_from": 200.0, "scheme": "rk4"}}


#: The scatter of the exponent estimated over an 800 s window of Ueda's attractor (its standard
#: deviation over eight windows starting 150 to 325 s after rest: 0.016, about 13 % of it; a
#: rounding change of the last bits moves a window's estimate across that scatter).
WINDOW_SCATTER = 0.016


def test_the_ueda_oscillator_has_its_published_exponent():
    """Published: 0.10 (Sprott, Chaos and Time-Series Analysis, Oxford University Press 2003,
    the Ueda oscillator; 0.0999 by RK4 at dt = 0.001 with Gram-Schmidt renormalisation), within
    10 %.  The attractor is chaotic: the exponent is positive, and well above the linear
    oscillator's finite-window spread (about 1e-3).  A window's estimate scatters about the
    exponent (``WINDOW_SCATTER`` over 800 s, shrinking as the window's square root): over the
    19,800 s here, 0.0032, so that 10 % is three times it."""
    exponent = largest_lyapunov(scene_from(ueda(20_000.0)))
    assert exponent == pytest.approx(0.10, rel=0.10)


def test_the_exponent_is_the_same_whatever_the_run():
    scene = scene_from(ueda(400.0))
    assert largest_lyapunov(scene) == largest_lyapunov(scene)  # deterministic, bitwise
    assert math.isnan(largest_lyapunov(scene_from(oscillator(1.0, 0.0)), d0=0.0))  # no distance to grow


def test_the_envelope_frequency_of_a_beating_two_body_system():
    """An undamped primary with a tuned linear absorber of 5 % its mass, released from a
    displacement of the primary: ``x1 = A cos(w_a t) + B cos(w_b t)``, whose envelope (the modulus
    of its analytic signal) ``sqrt(A^2 + B^2 + 2 A B cos((w_b - w_a) t))`` beats at ``w_b - w_a``
    (the eigenvalues of ``M^-1 K``).  The discrete Hilbert transform takes the record as periodic:
    at a distance ``s`` from an end its error is about ``(A + B) / (pi w_a s)`` (the missing
    tail of the kernel ``1 / (pi t)``), at most that at ``s = EDGE * L``, which moves a crossing
    by at most that over the envelope's least slope at its mean; the fitted period moves by at
    most twice that over the span of the crossings."""
    m2, k2 = 0.05, 0.05
    data = {"name": "beat", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.0},
            "absorbers": [{"type": "linear", "mass": m2, "stiffness": k2, "damping": 0.0}],
            "loads": [{"type": "initial", "displacement": [1.0, 0.0], "velocity": [0.0, 0.0]}],
            "simulation": {"duration": 400.0, "dt": 0.01, "scheme": "rk4"}}
    scene = scene_from(data)
    history = np.full((scene.n_steps + 1, 2), np.nan)
    simulate(scene, history=history, stride=1)
    values, vectors = np.linalg.eig(np.linalg.solve(np.diag([1.0, m2]), [[1.0 + k2, -k2], [-k2, k2]]))
    order = np.argsort(values)
    w_a, w_b = np.sqrt(values[order])
    delta = w_b - w_a
    # modal amplitudes of x1 from x(0) = (1, 0), v(0) = 0
    a, b = (vectors[0, order] * np.linalg.solve(vectors[:, order], [1.0, 0.0]))
    phase = np.linspace(0.0, 2.0 * math.pi, 10_001)
    envelope = np.sqrt(a * a + b * b + 2 * a * b * np.cos(phase))
    slope = np.abs(np.gradient(envelope, phase / delta))
    least_slope = slope[np.abs(envelope - envelope.mean()) < 0.05 * np.ptp(envelope)].min()
    length = scene.n_steps * scene.dt
    shift = (abs(a) + abs(b)) / (math.pi * w_a * EDGE * length) / least_slope
    span = (1.0 - 2.0 * EDGE) * length
    found = envelope_frequency(history[:, 0], scene.dt)
    assert abs(found - delta) <= delta * 2.0 * shift / span
    assert math.isnan(envelope_frequency(np.cos(np.arange(40_000) * 0.01), 0.01))  # no modulation


def forced(frequency: float, natural: float = 1.0, zeta: float = 0.0, duration: float = 1000.0,
           metrics_from: float = 0.0, **output) -> dict:
    """A linear oscillator of unit mass from rest under a unit harmonic force."""
    primary = {"mass": 1.0, "stiffness": natural**2, "damping": 2 * zeta * natural}
    return {"name": "forced", "primary": primary,
            "loads": [{"type": "harmonic", "amplitude": 1.0, "frequency": frequency}],
            "simulation": {"duration": duration, "dt": 0.01, "metrics_from": metrics_from, "scheme": "rk4"},
            "output": output}


def regime_row(data: dict) -> pd.Series:
    return run(data).realizations.iloc[0]


def test_a_periodic_response_keeps_its_label_and_gets_its_exponent_when_asked():
    row = regime_row(forced(0.5, zeta=0.05, metrics_from=500.0))
    assert row["regime"] == "T,0,0" and math.isnan(row["lyapunov"])  # (not needed to name it)
    assert math.isnan(row["envelope_frequency"]) and math.isnan(row["settling_time"])
    row = regime_row(forced(0.5, zeta=0.05, metrics_from=500.0, lyapunov=True))
    assert row["regime"] == "T,0,0"
    # -zeta omega_n, within the norm's spread over a free cycle: velocities over the forcing
    # frequency 0.5 make it between (1 - zeta) and 2 (1 + zeta) times the displacement's amplitude
    assert abs(row["lyapunov"] + 0.05) <= math.log(2.0 * 1.05 / 0.95) / 500.0


def test_a_chaotic_response_is_named_by_its_exponent():
    """Named chaotic, its exponent the published 0.10 within three times a window's scatter
    (``test_the_ueda_oscillator_has_its_published_exponent`` holds a longer window to 10 %)."""
    row = regime_row(ueda(1000.0))
    assert row["regime"] == "chaotic" and abs(row["lyapunov"] - 0.10) <= 3 * WINDOW_SCATTER


def test_a_beating_response_is_modulated_at_its_envelope_frequency():
    """An undamped oscillator (natural frequency 1.23 rad/s) forced at 1 rad/s from rest:
    ``x = X (cos t - cos 1.23 t)``, whose envelope beats at 0.23 rad/s.  Its exponent is 0 (a
    linear system without damping), so it is not chaotic.  The envelope is read at one sample a
    forcing period ``T``: each upward crossing lies within its sample step, so the fitted period of
    ``K`` crossings is off by at most ``3 T / K`` (least squares over evenly counted crossings)."""
    natural = 1.23
    row = regime_row(forced(1.0, natural=natural))
    assert row["regime"] == "modulated" and abs(row["lyapunov"]) < 0.01
    delta, period = natural - 1.0, 2.0 * math.pi
    crossings = int(32 * period * delta / (2 * math.pi)) - 1  # (at least, over the 32 samples)
    envelope_period = 2.0 * math.pi / delta
    assert abs(2.0 * math.pi / row["envelope_frequency"] - envelope_period) <= 3.0 * period / crossings


def test_a_late_settling_response_is_transient_and_its_settling_time_starts_a_periodic_window():
    """A lightly damped oscillator (zeta 0.01) forced at half its natural frequency from rest:
    every forcing period the free vibration comes back in phase, 12 % smaller, so the samples
    repeat to 1e-3 of the amplitude once it is below about 0.8 % of the forced amplitude, by
    about 480 s.  Over 700 s the last 32 periods ([298, 700] s) settle in their first half; over
    600 s ([198, 600] s) they do not, and the exponent, -0.01 1/s, says it is still converging."""
    row = regime_row(forced(0.5, zeta=0.01, duration=700.0))
    first = 700.0 - 32 * 4.0 * math.pi
    assert row["regime"] == "transient" and first < row["settling_time"] <= first + 16 * 4.0 * math.pi
    later = regime_row(forced(0.5, zeta=0.01, duration=700.0, metrics_from=float(row["settling_time"])))
    assert later["regime"] == "T,0,0"
    earlier = regime_row(forced(0.5, zeta=0.01, duration=600.0))
    assert earlier["regime"] == "transient" and math.isnan(earlier["settling_time"])
    assert abs(earlier["lyapunov"] + 0.01) <= math.log(2.0 * 1.01 / 0.99) / 600.0  # (as above)


def test_an_irregular_response_that_is_not_chaotic_is_chatter_with_impacts(monkeypatch):
    """``refine_regimes`` on samples that do not repeat, with an exponent of 0 (stood in): with
    impacts and no envelope to read, chatter; without impacts, modulated."""
    scene = scene_from(forced(1.0, zeta=0.05, duration=100.0))
    monkeypatch.setattr(dynamics, "largest_lyapunov", lambda s, **options: 0.0)
    jitter = np.random.default_rng(5).normal(1.0, 0.01, (2, 32, 2))  # (x, v) of one body
    counts = np.cumsum(np.ones((32, 2)), axis=0)
    samples = np.stack([np.concatenate([jitter[0], counts], axis=1),
                        np.concatenate([jitter[1], 0.0 * counts], axis=1)])
    frame = pd.DataFrame({"status": ["ok", "ok"], "regime": pd.array(["aperiodic"] * 2, dtype="string")})
    dynamics.refine_regimes(frame, scene, samples)
    assert list(frame["regime"]) == ["chatter", "modulated"]
    assert frame["lyapunov"].tolist() == [0.0, 0.0] and frame["envelope_frequency"].isna().all()


def test_lyapunov_for_every_realisation_needs_a_periodically_forced_scene():
    data = forced(1.0, duration=10.0, lyapunov=True)
    data["loads"].append({"type": "white-noise", "intensity": 0.1})
    data["simulation"]["scheme"] = "auto"
    with pytest.raises(ScenarioError, match=r"output\.lyapunov = True: needs a periodically forced scene"):
        study_from(data)
