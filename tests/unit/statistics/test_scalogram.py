"""The wavelet scalogram (``psd.scalogram``, PyWavelets' continuous transform) of a signal whose
frequency and amplitude change, against the values put in: its ridge follows each stretch's
frequency and its height each stretch's amplitude; and of a run's kept path
(``Results.plot.scalogram``), whose ridge sits at the primary's natural frequency after an
impulse.

Tolerances: the ridge is read on a grid 0.01 rad/s apart, so its frequency is exact to half a
grid step; the Morlet wavelet's Gaussian envelope is sampled 100 times a period of the slower
wave, so the height of a pure sinusoid's ridge is its amplitude to the transform's quadrature
error (measured 2e-5), held at 1e-3, away from the record's edges and the frequency change by
more than five of the slower wave's periods."""

from __future__ import annotations

import math

import numpy as np
import pytest

pywt = pytest.importorskip("pywt")

from vines_stoch import run  # noqa: E402
from vines_stoch.psd import scalogram  # noqa: E402

DT = 0.01


def test_the_ridge_follows_frequency_and_amplitude():
    t = np.arange(0.0, 100.0, DT)
    signal = np.where(t < 50.0, 1.0 * np.sin(2.0 * t), 0.5 * np.sin(5.0 * t))
    omega = np.round(np.arange(1.0, 8.0, 0.01), 2)
    amplitude = scalogram(signal, DT, omega)
    assert amplitude.shape == (omega.size, t.size)
    for time, frequency, height in ((25.0, 2.0, 1.0), (75.0, 5.0, 0.5)):
        column = amplitude[:, int(round(time / DT))]
        assert abs(omega[column.argmax()] - frequency) <= 0.005
        assert column.max() == pytest.approx(height, rel=1e-3)


def test_bad_frequencies_are_named():
    with pytest.raises(ValueError, match="omega must be a list of angular frequencies > 0"):
        scalogram(np.zeros(10), DT, np.array([0.0, 1.0]))


def test_a_kept_path_has_its_scalogram():
    omega_n = 2.0 * math.pi
    data = {"name": "ring", "primary": {"mass": 1.0, "stiffness": omega_n**2, "damping": 0.02 * omega_n},
            "loads": [{"type": "impulse", "velocity": 1.0}],
            "simulation": {"duration": 20.0, "dt": 1e-3, "history": {"points": 2001, "signals": ["x1"]}}}
    results = run(data, paths=True)
    ax = results.plot.scalogram("x1", omega=np.linspace(3.0, 12.0, 91))
    mesh = ax.collections[0].get_array().reshape(91, -1)
    ridge = np.linspace(3.0, 12.0, 91)[mesh[:, mesh.shape[1] // 2].argmax()]
    assert abs(ridge - omega_n) <= 0.1 and ax.get_ylabel() == "angular frequency [rad/s]"
