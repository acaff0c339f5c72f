"""The loads catalogue against theory (MODEL.md section 3).

- Half-sine and pulse trains on a linear primary against the Duhamel integral in closed form.
- Chirp against a tight scipy solution.
- A record as base excitation against the equivalent force ``-m1 a_g(t)`` (round-off).
- Filtered noise: the force's stationary variance and Welch PSD, a linear primary's
  stationary response variance against the Lyapunov solution of the augmented system; the
  same for Kanai-Tajimi and Clough-Penzien ground motion.

Monte Carlo checks use 4 standard errors of the ensemble mean (chance failure 6e-5 per
check); the schemes' bias at the chosen dt is O((omega dt)^2) of the variance, below 1e-3
relative, two orders under the tolerance.
"""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit
from scipy.integrate import solve_ivp
from scipy.signal import welch

from tests.helpers import raw_metrics, scene_from, study_from
from vines_stoch.kernels import load_history, simulate
from vines_stoch.kernels.common import CHECK_EVERY
from vines_stoch.kernels.loads import phasors, rotations, turn
from vines_stoch.outputs import INPUT
from vines_stoch.physics.filters import oscillator, stationary_covariance
from vines_stoch.physics.loads import HARMONIC
from vines_stoch.scenario.loads import SOILS

M, K, C = 2.0, 50.0, 0.3


def primary_data(loads: list[dict], duration: float, dt: float = 1e-3, **simulation) -> dict:
    """The primary (``M``, ``K``, ``C``) alone under ``loads``; ``simulation``: more keys of its table."""
    return {"name": "loads",
            "primary": {"mass": M, "stiffness": K, "damping": C},
            "loads": loads,
            "simulation": {"duration": duration, "dt": dt, **simulation}}


def duhamel(t: float, pieces) -> tuple[float, float]:
    """Displacement and velocity at ``t`` of the primary from rest under a force that is a sum
    of pieces ``A exp(mu tau)`` on ``[a, b]`` (complex, summing to a real force):
    ``x = Im int F(tau) exp(lam (t - tau)) dtau / (m wd)``, ``lam = -zeta w + i wd``."""
    w = np.sqrt(K / M)
    zeta = C / (2.0 * np.sqrt(K * M))
    wd = w * np.sqrt(1.0 - zeta**2)
    lam = -zeta * w + 1j * wd
    x = v = 0j
    for amplitude, mu, a, b in pieces:
        b = min(b, t)
        if b > a:
            integral = (amplitude * np.exp(lam * t) * (np.exp((mu - lam) * b) - np.exp((mu - lam) * a))
                        / (mu - lam))
            x += integral
            v += lam * integral
    return x.imag / (M * wd), v.imag / (M * wd)


def half_sine_pieces(f0, td, t0):
    omega = np.pi / td  # sin(W (t - t0)) = (e^{iW(t-t0)} - e^{-iW(t-t0)}) / 2i
    return [(f0 / 2j * np.exp(-1j * omega * t0), 1j * omega, t0, t0 + td),
            (-f0 / 2j * np.exp(1j * omega * t0), -1j * omega, t0, t0 + td)]


SHOCKS = {
    "half-sine": ({"type": "half-sine", "amplitude": 3.0, "duration": 0.4567, "start": 0.1234},
                  half_sine_pieces(3.0, 0.4567, 0.1234)),
    "pulse-train": ({"type": "pulse-train", "amplitude": 2.0, "width": 0.2033, "period": 0.5071,
                     "start": 0.0517, "count": 3},
                    [(2.0, 0.0, 0.0517 + k * 0.5071, 0.0517 + k * 0.5071 + 0.2033) for k in range(3)]),
}


@pytest.mark.parametrize("kind", SHOCKS)
def test_shocks_match_the_duhamel_closed_form(kind):
    """Break points off the time grid: sub-steps end at them, so RK4 keeps its order."""
    load, pieces = SHOCKS[kind]
    peak = max(abs(duhamel(t, pieces)[0]) for t in np.linspace(0.0, 3.0, 3001))
    for duration in (0.3, 0.61, 1.0, 2.345):
        scene = scene_from(primary_data([load], duration))
        final = np.zeros((2, 1))
        simulate(scene, final=final)
        x_ref, v_ref = duhamel(scene.n_steps * scene.dt, pieces)
        assert abs(final[0, 0] - x_ref) < 1e-6 * peak
        assert abs(final[1, 0] - v_ref) < 1e-6 * peak * np.sqrt(K / M)


HARMONICS = ((1.5, 3.1, 0.4), (0.8, 11.0, -1.2))  # amplitude, frequency (rad/s), phase


@pytest.mark.parametrize("scheme, order", [("euler-maruyama", 1), ("sra", 3)])
def test_harmonic_loads_on_the_step_grid_converge_at_the_schemes_order(scheme, order):
    """On the step grid, harmonic rows come from turned phasors (kernels/loads.py): two rows of
    different frequencies and phases through the kick-drift-kick and SRA3 loops (no noise)
    against the closed form.  The error falls by about ``2^order`` per halving of dt; a wrong
    phase, row or half-step turn would leave an error that does not fall.  (Kick-drift-kick
    is first order on a damped primary: its closing half kick takes the damping force at the
    half-step velocity.)"""
    loads = [{"type": "harmonic", "amplitude": a, "frequency": w, "phase": p} for a, w, p in HARMONICS]
    pieces = [piece for a, w, p in HARMONICS
              for piece in ((a / 2 * np.exp(1j * p), 1j * w, 0.0, np.inf),
                            (a / 2 * np.exp(-1j * p), -1j * w, 0.0, np.inf))]
    errors = []
    for dt in (4e-3, 2e-3):
        scene = scene_from(primary_data(loads, 20.0, dt, scheme=scheme))
        final = np.zeros((2, 1))
        simulate(scene, final=final)
        x_ref, v_ref = duhamel(scene.n_steps * scene.dt, pieces)
        errors.append(abs(final[0, 0] - x_ref) + abs(final[1, 0] - v_ref) / np.sqrt(K / M))
    assert errors[1] < 1e-2 * max(abs(x_ref), abs(v_ref) / np.sqrt(K / M))
    assert 0.7 * 2**order < errors[0] / errors[1] < 1.3 * 2**order


def test_phasor_recurrence_stays_at_round_off():
    """The phasors the step loops turn one step at a time, set exactly every ``CHECK_EVERY``
    steps, against ``cos`` and ``sin`` at each step: 10^6 steps of a fast row (64 rad/s) and
    a slow one (0.75 rad/s).  dt = 2^-10 and these frequencies make every phase ``omega i dt``
    exact in binary, so the reference carries only the rounding of ``cos`` itself.  Each turn
    adds a few units of round-off: after at most ``CHECK_EVERY`` turns the error stays below
    ``4 CHECK_EVERY eps`` (9e-13)."""
    forces = np.array([[HARMONIC, 1.0, 64.0, 0.0, 0.0, 0.0], [HARMONIC, 1.0, 0.75, 0.0, 0.0, 0.0]])
    error = phasor_error(forces, 2.0**-10, 1_000_000)
    assert 0.0 < error < 4 * CHECK_EVERY * np.finfo(float).eps  # (0: the recurrence is not cos itself)


@njit
def phasor_error(forces, dt, n):
    pc, ps, rc, rs = np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2)
    rotations(forces, dt, rc, rs)
    worst = 0.0
    for i in range(n):
        if i % CHECK_EVERY == 0:
            phasors(i * dt, forces, pc, ps)
        for r in range(2):
            phase = forces[r, 2] * (i * dt)
            worst = max(worst, abs(pc[r] - np.cos(phase)), abs(ps[r] - np.sin(phase)))
        turn(pc, ps, rc, rs, pc, ps)
    return worst


def test_chirp_matches_a_tight_scipy_solution():
    a, f0, f1, sweep, duration = 1.5, 0.2, 2.0, 4.0, 5.0
    chirp = {"type": "chirp", "amplitude": a, "f0": f0, "f1": f1, "duration": sweep}
    final = np.zeros((2, 1))
    simulate(scene_from(primary_data([chirp], duration)), final=final)

    def rhs(t, y):
        force = a * np.sin(2 * np.pi * (f0 * t + (f1 - f0) * t * t / (2 * sweep)))
        return [y[1], (force - C * y[1] - K * y[0]) / M]

    ref = solve_ivp(rhs, (0.0, duration), [0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
    assert abs(final[0, 0] - ref[0]) < 1e-8 * a / K
    assert abs(final[1, 0] - ref[1]) < 1e-8 * a / K * np.sqrt(K / M)


def test_base_excitation_equals_the_equivalent_force(tmp_path):
    """A primary alone under a ground record ``a_g`` and under the force ``-m1 a_g``."""
    t = np.arange(0.0, 4.0, 0.01)
    ag = np.sin(7.0 * t) * np.exp(-0.5 * t) + 0.3 * np.cos(23.0 * t)
    np.savetxt(tmp_path / "ground.txt", np.c_[t, ag])
    np.savetxt(tmp_path / "force.txt", np.c_[t, -M * ag])
    from vines_stoch.scene import build_scene

    results = {}
    for name, load in (("ground", {"type": "record", "file": "ground.txt", "units": "m/s2"}),
                       ("force", {"type": "force-record", "file": "force.txt"})):
        study = study_from(primary_data([load], 5.0, dt=1e-3), directory=tmp_path)  # (files beside it)
        final = np.zeros((2, 1))
        raw = simulate(build_scene(study.points[0]), final=final)
        results[name] = (final.copy(), raw)
    (fg, rg), (ff, rf) = results["ground"], results["force"]
    assert np.max(np.abs(fg)) > 1e-3
    np.testing.assert_allclose(fg, ff, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(rg[INPUT], rf[INPUT], rtol=1e-12)  # input energy (work of a_g vs of F)


def stationary_mean(data: dict, n: int, quantity) -> tuple[float, float]:
    """Ensemble mean of ``quantity(raw metrics)`` over ``n`` realisations and its standard error."""
    scene = scene_from(data)
    values = np.array([quantity(raw_metrics(scene, np.random.default_rng(1000 + r)), scene)
                       for r in range(n)])
    return values.mean(), values.std(ddof=1) / np.sqrt(n)


def window_variance(raw, scene) -> float:
    """Time average of x1^2 over the metrics window (stationary: its mean is Var x1)."""
    return raw["x1_square_integral"] / scene.window


def test_filtered_noise_force_variance_and_psd():
    """Exact filter steps: ``Var f = sigma^2 / (4 eta w0^3)``; one-sided Welch PSD of ``f`` in
    1/Hz is ``4 pi S(2 pi f)`` with ``S(w) = sigma^2 / (2 pi) / ((w0^2 - w^2)^2 + (2 eta w0 w)^2)``."""
    sigma, w0, eta, dt = 0.5, 2.0, 0.3, 0.05
    load = {"type": "filtered-noise", "intensity": sigma, "frequency": w0, "damping": eta,
            "start": "stationary"}
    variance = sigma**2 / (4.0 * eta * w0**3)
    # variance: final values of independent short paths (chi-square: SE = var sqrt(2 / (n - 1)))
    short = scene_from(primary_data([load], 1.0, dt=dt))
    finals = np.array([load_history(short, np.random.default_rng(r))[1][-1, 0] for r in range(4000)])
    assert abs(finals.var() - variance) < 4.0 * variance * np.sqrt(2.0 / 3999)
    # PSD of one long path: about 3900 Welch segments, 1.7 % scatter per bin
    long = scene_from(primary_data([load], 200_000.0, dt=dt))
    force = load_history(long, np.random.default_rng(5))[1][:, 0]  # (the primary's one floor)
    freq, psd = welch(force, fs=1.0 / dt, nperseg=2048)
    w = 2.0 * np.pi * freq
    theory = 4.0 * np.pi * sigma**2 / (2.0 * np.pi) / ((w0**2 - w**2) ** 2 + (2.0 * eta * w0 * w) ** 2)
    share = np.cumsum(theory) / theory.sum()
    band = (share >= 0.025) & (share <= 0.975)
    assert band.sum() > 20
    assert np.max(np.abs(psd[band] / theory[band] - 1.0)) < 0.10


def augmented_variance(load_rows: np.ndarray, noise: np.ndarray, coupling) -> float:
    """Var x1 of the primary driven by a filter (Lyapunov of the augmented linear system)."""
    n = load_rows.shape[0]
    a = np.zeros((2 + n, 2 + n))
    a[0, 1] = 1.0
    a[1, :2] = [-K / M, -C / M]
    a[1, 2:] = coupling
    a[2:, 2:] = load_rows
    return stationary_covariance(a, np.concatenate([[0.0, 0.0], noise]))[0, 0]


def test_filtered_noise_response_variance():
    sigma, w0, eta = 3.0, 4.0, 0.3
    load = {"type": "filtered-noise", "intensity": sigma, "frequency": w0, "damping": eta,
            "start": "stationary"}
    # the primary starts at rest: open the window after 15 of its decay times (2 m / c)
    data = primary_data([load], 300.0, dt=0.01, metrics_from=200.0)
    mean, se = stationary_mean(data, 300, window_variance)
    exact = augmented_variance(oscillator(w0, eta), np.array([0.0, sigma]), [1.0 / M, 0.0])
    assert abs(mean - exact) < 4.0 * se, (mean, se, exact)
    assert se < 0.05 * exact


@pytest.mark.parametrize("model", ["kanai-tajimi", "clough-penzien"])
def test_ground_motion_response_variance(model):
    """Relative displacement of the primary under ``-m1 a_g``; the soil filter's read-out
    ``a_g = c . z`` enters the augmented drift as ``-c`` in the primary's acceleration row."""
    sigma = 2.0
    wg, zg, wf, zf = SOILS["medium"]
    load = {"type": "ground-motion", "model": model, "soil": "medium", "intensity": sigma,
            "start": "stationary"}
    data = primary_data([load], 300.0, dt=0.005, metrics_from=200.0)
    mean, se = stationary_mean(data, 300, window_variance)
    from vines_stoch.physics.filters import clough_penzien, kanai_tajimi

    rows, noise, readout = (kanai_tajimi(sigma, wg, zg) if model == "kanai-tajimi"
                            else clough_penzien(sigma, wg, zg, wf, zf))
    exact = augmented_variance(rows, noise, -readout)
    assert abs(mean - exact) < 4.0 * se, (mean, se, exact)
    assert se < 0.05 * exact


def test_filtered_loads_close_the_energy_balance():
    """Base excitation work and filtered force work are booked with the kicks: enveloped ground
    motion alone, then with a filtered force (one compiled loop for both)."""
    impact = {"type": "impact", "mass": 0.1, "clearance": 0.02, "restitution": 0.6}
    jennings = {"type": "jennings", "rise": 2.0, "hold": 8.0, "decay": 0.3}
    force = {"type": "filtered-noise", "intensity": 3.0, "frequency": 4.0, "damping": 0.3}
    ground = {"type": "ground-motion", "soil": "firm", "intensity": 2.0, "envelope": jennings}
    for loads in ([ground], [force, ground]):
        data = primary_data(loads, 20.0, dt=0.005) | {"absorbers": [impact]}
        raw = raw_metrics(scene_from(data), np.random.default_rng(3))
        assert raw["impacts"] > 0
        residual = (raw["input_energy"] - raw["primary_dissipation"] - raw["absorber_dissipation"]
                    - raw["impact_loss"] - raw["final_energy"])
        assert abs(residual) < 1e-3 * raw["input_energy"]
