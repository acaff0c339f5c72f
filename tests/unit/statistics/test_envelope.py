"""The envelope frequency of modulated responses (``dynamics.envelope_frequency`` for a path,
``envelope_frequency`` in a run's table) against independent references:

- the strongly modulated response (SMR) of a forced linear oscillator with a light cubic NES
  (``scenarios/smr_cubic_nes.toml``; Gendelman, Starosvetsky and Feldman, Nonlinear Dyn. 51
  (2008) 31-46), against a scipy DOP853 solution written here (rtol 1e-10), whose slow cycle is
  read by another method: the mean spacing of the stroboscopic amplitude's peaks over 40 cycles;
- seed 003's Fig. 5 (SS-2(60) at 6.2 rad/s, the amplitude-modulated regime with bilateral
  impacts), against the spacing of the peaks of the run's own stroboscopic amplitude.  The
  paper prints 0.31 rad/s, read off its Hilbert envelope; ours turns at 0.282, 9 % slower.
  0.31 rad/s is 2 pi / 20 s, the fifth bin of the spectrum of a 100-s record: the spectrum of
  our envelope over any 100-s window of the steady motion peaks there too, while a longer
  window or a zero-padded transform resolves 0.282 (tested; the paper does not say how it read
  its value, and the seed ledger's Fig. 5 row gives this as the likely cause).

Tolerance 5 % (the issue's): the peak spacing is resolved to a forcing period per cycle, so over
``n`` cycles to ``1 / n`` of a period, 0.05 % of a 49-period cycle over 40 cycles; the rest is the
difference of the two integrators (1e-10 against RK4 at 64 steps a period, a relative phase
error of about 1e-8 a period)."""

from __future__ import annotations

import math
import tomllib

import numpy as np
from scipy.integrate import solve_ivp
from scipy.signal import find_peaks, hilbert

from tests.helpers import ROOT
from vines_stoch import run
from vines_stoch.dynamics import envelope_frequency

EPS, LAMBDA, A = 0.01, 0.2, 0.5
#: Forcing periods run and left out as the start-up (the scenario's).
PERIODS, SETTLE = 3000, 1000


def peak_frequency(amplitude: np.ndarray, period: float) -> float:
    """Angular frequency of the slow cycle of a stroboscopic amplitude (one sample a forcing
    ``period``): the mean spacing of its peaks of at least half its range's prominence."""
    peaks, _ = find_peaks(amplitude, prominence=0.5 * np.ptp(amplitude))
    assert peaks.shape[0] >= 10, peaks
    return 2.0 * math.pi / (float(np.diff(peaks).mean()) * period)


def smr_reference() -> float:
    """The SMR's slow-cycle frequency from a scipy solution of the nondimensional equations."""
    def rhs(t, y):
        x, v, z, w = y
        f = EPS * LAMBDA * (v - w) + (4.0 / 3.0) * EPS * (x - z) ** 3
        return [v, -x - f + EPS * A * math.cos(t), w, f / EPS]

    period = 2.0 * math.pi
    times = np.arange(SETTLE, PERIODS) * period
    sol = solve_ivp(rhs, (0.0, times[-1]), [0.0, 0.0, 0.0, 0.0], t_eval=times, method="DOP853",
                    rtol=1e-10, atol=1e-12)
    return peak_frequency(np.hypot(sol.y[0], sol.y[1]), period)


def test_the_strongly_modulated_response_is_modulated_at_the_reference_frequency():
    data = tomllib.loads((ROOT / "scenarios" / "smr_cubic_nes.toml").read_text())
    data["simulation"]["history"] = {"points": 20 * (PERIODS - SETTLE) + 1, "signals": ["x1"]}
    results = run(data, paths=True)
    row = results.realizations.iloc[0]
    reference = smr_reference()
    assert 0.019 < reference < 0.022  # (a cycle of about 49 forcing periods)
    assert row["regime"] == "modulated"
    assert abs(row["envelope_frequency"] / reference - 1.0) < 0.05
    path = results.paths
    dt = float(path["t"].iloc[1] - path["t"].iloc[0])
    assert abs(envelope_frequency(path["x1"].to_numpy(), dt) / reference - 1.0) < 0.05


def test_seed003_fig5_envelope_turns_at_its_peaks_spacing():
    data = tomllib.loads((ROOT / "scenarios" / "seed003_ss60_paths.toml").read_text())
    data["absorbers"][0]["gap"] = 0.36  # SS-2(60) (Table 2)
    data["loads"][0]["frequency"] = 6.2
    data["simulation"] = {"duration": 1000.0, "dt": 1e-3, "metrics_from": 200.0, "scheme": "rk4",
                          "history": {"points": 80_001, "signals": ["x1"]}}
    data["output"] = {"poincare": True}
    results = run(data, paths=True)
    row = results.realizations.iloc[0]
    section = results.poincare
    omega = 6.2
    amplitude = np.hypot(section["x_1"], section["v_1"] / omega).to_numpy()
    reference = peak_frequency(amplitude, 2 * math.pi / omega)
    assert row["regime"] == "modulated"
    assert abs(row["envelope_frequency"] / reference - 1.0) < 0.05
    path = results.paths
    dt = float(path["t"].iloc[1] - path["t"].iloc[0])
    assert abs(envelope_frequency(path["x1"].to_numpy(), dt) / reference - 1.0) < 0.05
    assert abs(reference / 0.31 - 1.0) > 0.05  # (the paper's 0.31: a difference the report states)
    # the envelope's spectrum over 100-s windows: its peak on the fifth bin, 2 pi / 20 s (to the
    # window's sample count, 8000 +- 1: the neighbouring bins lie 20 % away); resolved finer (the
    # windows' transforms zero-padded eightfold), within 2 % of the peak spacing
    t, x = path["t"].to_numpy(), path["x1"].to_numpy()
    envelope = np.abs(hilbert(x))
    for start in (200.0, 300.0, 400.0, 500.0, 600.0):
        window = envelope[(t >= start) & (t < start + 100.0)]
        for pad, expected, tolerance in ((1, 2 * math.pi / 20.0, 1e-3), (8, reference, 0.02)):
            size = pad * window.size
            power = np.abs(np.fft.rfft(window - window.mean(), size))
            omega = 2 * math.pi * np.fft.rfftfreq(size, dt)
            low = omega > 0.05  # (past the mean's leakage)
            assert abs(omega[low][np.argmax(power[low])] / expected - 1.0) < tolerance, (start, pad)


def test_a_ripple_about_the_mean_is_not_counted_as_cycles():
    """An envelope ``cos(W t) + 0.2 sin(15 W t)`` crosses its mean upward three times a slow
    cycle (the ripple's slope, 3 W, beats the slow one's, W): the hysteresis counts one, so the
    frequency is W, not about 3 W (what counting every crossing gives)."""
    from vines_stoch.dynamics import crossing_frequency

    slow, dt = 0.28, 0.01
    t = np.arange(0.0, 40 * 2 * math.pi / slow, dt)
    envelope = 2.0 + np.cos(slow * t) + 0.2 * np.sin(15 * slow * t)
    e = envelope - envelope.mean()
    assert np.count_nonzero((e[:-1] < 0) & (e[1:] >= 0)) >= 100  # (about three a cycle)
    assert abs(crossing_frequency(envelope, dt) / slow - 1.0) < 1e-3
