"""The ``wind`` load (seed 001 section 3.7; README "Wind"; ``vines_stoch.wind``).

- (a) The rational turbulence filter: its Lyapunov variance equals the integral of its
  spectrum ``2 |H(i 2 pi n)|^2`` (quadrature) and the target variance (``6 kappa U10^2``,
  ``6 u*^2``, checked by integrating the Davenport and Kaimal spectra), its transfer function
  is the fitted zero-pole form, and its log error against the target over the fitting band
  stays at the documented figures.
- (b) Paths of the filter by its exact step (``filters.transition``), read out on every floor
  (``filters.block_diagonal`` with a profile): the force variance from independent paths within
  4 standard errors of ``(rho Cd A_k U(z_k))^2 sigma_u^2``; the averaged Welch spectrum of
  independent stationary paths within chi-square bounds of its expectation, which is the
  rational spectrum's closed form seen through the Hann window and the sampling.
- (c) End to end (``vines_stoch.run``): a three-floor shear building under wind; the ensemble
  mean floor displacement at the end equals the static ``K^-1 Fbar`` within 4 standard errors,
  its variance the Lyapunov variance of the building driven by the filter, and the mean of
  ``x_rms_k^2`` equals ``xbar_k^2 + var_k``.
- (d) Bad input: one line naming the key, its value and what is allowed.

Monte Carlo checks use 4 standard errors (chance failure 6e-5 each) from independent paths or
realisations; the Welch check a two-sided chi-square interval at family-wise level 1e-4
(Bonferroni over the bins compared).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import quad
from scipy.linalg import expm
from scipy.signal import get_window, welch
from scipy.stats import chi2

from tests.helpers import study_from, toml_text
from vines_stoch import ScenarioError, parse_scenario
from vines_stoch.physics import wind
from vines_stoch.physics.filters import block_diagonal, stationary_covariance, transition
from vines_stoch.scenario.bodies import shear_stiffness
from vines_stoch.scene import build_scene, wind_load

MASS, STOREY_K, STOREY_C = 1000.0, 4.0e5, 4.5e3
SPEED, HEIGHT, AREA, DRAG, RHO = 25.0, 3.0, 30.0, 1.3, 1.25

SPECTRA = {  # the spectrum's keys, and (sigma_u^2, T) by the formulas of the README
    "davenport": ({}, 6.0 * 0.005 * SPEED**2, 1200.0 / SPEED),  # z_ref = 10 m: U10 = speed
    "kaimal": ({"friction_velocity": 1.6}, 6.0 * 1.6**2, 10.0 / SPEED),
}


def frame(load: dict, duration: float = 10.0, dt: float = 2e-3, **simulation) -> dict:
    """A three-floor shear building (storey dashpots: 5 % damping in mode 1) under ``load``;
    ``simulation``: more keys of its table."""
    return {"name": "wind",
            "primary": {"masses": [MASS] * 3, "stiffnesses": [STOREY_K] * 3, "dampings": [STOREY_C] * 3},
            "loads": [load],
            "simulation": {"duration": duration, "dt": dt, **simulation}}


def wind_table(spectrum: str = "davenport", **more) -> dict:
    """The wind load table on every floor of ``frame`` (``more``: more of its keys)."""
    return {"type": "wind", "speed": SPEED, "height": HEIGHT, "area": AREA, "drag": DRAG,
            "spectrum": spectrum, **SPECTRA[spectrum][0], **more}


def the_load(spectrum: str, **more):
    return study_from(frame(wind_table(spectrum, **more))).points[0].loads[0]


def weights() -> np.ndarray:
    """``rho Cd A_k U(z_k)``: the turbulent force per unit ``u`` on each floor (power law 0.16)."""
    z = HEIGHT * np.arange(1, 4)
    return RHO * DRAG * AREA * SPEED * (z / 10.0) ** 0.16


# (a) ---------------------------------------------------------------------------------------

#: Largest |ln(rational / target)| over the default bands (README "Wind"), order 3 and 2.
FIT_ERROR = {("davenport", 3): 0.19, ("kaimal", 3): 0.17, ("davenport", 2): 0.73, ("kaimal", 2): 0.41}


@pytest.mark.parametrize("spectrum", ["davenport", "kaimal"])
def test_target_variance_closed_form(spectrum):
    """``int S dn = sigma_u^2``: 6 kappa U10^2 (Davenport), 6 u*^2 (Kaimal); quadrature to 1e-8."""
    _, variance, time_scale = SPECTRA[spectrum]
    load = the_load(spectrum)
    assert load.turbulence() == pytest.approx((variance, time_scale), rel=1e-14)
    f = lambda n: wind.target_spectrum(spectrum, n, variance, time_scale)  # noqa: E731
    # substitution n = e^s: int S dn = int S(e^s) e^s ds (both tails decay exponentially in s)
    value, error = quad(lambda s: f(np.exp(s)) * np.exp(s), -40.0, 40.0, limit=400, epsabs=0, epsrel=1e-11)
    assert error < 1e-9 * variance
    assert value == pytest.approx(variance, rel=1e-8)


@pytest.mark.parametrize("order", [3, 2])
@pytest.mark.parametrize("spectrum", ["davenport", "kaimal"])
def test_rational_filter_variance_and_fit(spectrum, order):
    _, variance, time_scale = SPECTRA[spectrum]
    band = tuple(b / time_scale for b in wind.BANDS[spectrum])
    a, b, c, error = wind.turbulence_filter(spectrum, variance, time_scale, band, order)
    lyapunov = c @ stationary_covariance(a, b) @ c
    # the designed match: the filter's variance is the target's (round-off of the rescaling)
    assert lyapunov == pytest.approx(variance, rel=1e-10)

    # Lyapunov against the integral of the rational spectrum, n = e^s as above
    def spectrum_at(s: float) -> float:
        return wind.rational_spectrum(a, b, c, np.exp(s))[0] * np.exp(s)

    poles = np.log(-np.linalg.eigvals(a).real / (2.0 * np.pi))
    integral, abserr = quad(spectrum_at, -40.0, 40.0, points=sorted(poles), limit=400, epsabs=0, epsrel=1e-10)
    assert abserr < 1e-8 * lyapunov
    assert integral == pytest.approx(lyapunov, rel=1e-8)

    # the cascade realises the fitted zero-pole form G prod (w^2 + z^2) / prod (w^2 + p^2)
    zeros, poles, fit_error = wind.rational_fit(spectrum, *wind.BANDS[spectrum], order)
    assert fit_error == pytest.approx(error, rel=1e-9) and len(zeros) == order - 1 and len(poles) == order
    n = np.geomspace(band[0], band[1], 2001)
    w2 = (2.0 * np.pi * n) ** 2
    zpk = 2.0 * b[0] ** 2 * np.prod([w2 + (z / time_scale) ** 2 for z in zeros], axis=0) \
        / np.prod([w2 + (p / time_scale) ** 2 for p in poles], axis=0)
    rational = wind.rational_spectrum(a, b, c, n)
    np.testing.assert_allclose(rational, zpk, rtol=1e-9)

    # the fit: largest log error on a grid 8x finer than the fitting grid, as documented
    log_error = np.abs(np.log(rational / wind.target_spectrum(spectrum, n, variance, time_scale)))
    assert log_error.max() == pytest.approx(error, abs=1e-3)
    assert log_error.max() < FIT_ERROR[spectrum, order]
    assert np.all(np.linalg.eigvals(a).real < 0)  # a stable filter: it has a stationary law


def test_a_given_band_moves_the_fit():
    """``band`` (Hz) is the fitting band: the fit over a narrow band near the first mode is
    closer to the target there than the default fit."""
    load = the_load("davenport", band=[0.5, 5.0])
    variance, time_scale = load.turbulence()
    n = np.geomspace(0.5, 5.0, 401)
    target = wind.target_spectrum("davenport", n, variance, time_scale)
    errors = []
    for band in [load.fit_band(), tuple(b / time_scale for b in wind.BANDS["davenport"])]:
        a, b, c, _ = wind.turbulence_filter("davenport", variance, time_scale, band)
        errors.append(np.abs(np.log(wind.rational_spectrum(a, b, c, n) / target)).max())
    assert load.fit_band() == (0.5, 5.0)
    assert errors[0] < 0.5 * errors[1], errors


# (b) ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("spectrum", ["davenport", "kaimal"])
def test_force_variance_from_exact_steps(spectrum):
    """Independent paths from rest, run 30 times the slowest time constant: each final force
    is a draw from the stationary law (the rest of the transient, computed, is < 1e-12 of it).
    Gaussian: the sample variance's standard error is ``var sqrt(2 / (n - 1))``."""
    load = the_load(spectrum)
    variance, time_scale = load.turbulence()
    mean, turbulence = wind_load(load, 3)
    np.testing.assert_allclose(mean, 0.5 * weights() * SPEED * (HEIGHT * np.arange(1, 4) / 10.0) ** 0.16,
                               rtol=1e-13)
    slowest = np.min(-np.linalg.eigvals(turbulence.a).real)
    dt, steps = 0.25 / slowest, 120  # 30 time constants
    arrays = block_diagonal([turbulence], dt, n_floors=3)
    phi, chol = transition(turbulence.a, turbulence.b, dt)
    np.testing.assert_array_equal(arrays["phi"], phi)
    np.testing.assert_allclose(arrays["c_force"], np.outer(weights(), turbulence.c), rtol=1e-13)
    p = stationary_covariance(turbulence.a, turbulence.b)
    left = np.linalg.matrix_power(phi, steps)
    assert abs(turbulence.c @ left @ p @ left.T @ turbulence.c) < 1e-12 * variance

    paths = 20_000
    rng = np.random.default_rng(11)
    z = np.zeros((paths, phi.shape[0]))
    for _ in range(steps):
        z = z @ phi.T + rng.standard_normal(z.shape) @ chol.T
    force = z @ arrays["c_force"].T  # (paths, floors)
    u = z @ turbulence.c  # fully correlated over the height: force = weights u (round-off)
    np.testing.assert_allclose(force, np.outer(u, weights()), rtol=1e-12, atol=1e-12 * force.std())
    expected = weights() ** 2 * variance
    se = expected * np.sqrt(2.0 / (paths - 1))
    sample = force.var(axis=0, ddof=1)
    assert np.all(np.abs(sample - expected) < 4.0 * se), (sample, expected)
    assert np.all(np.abs(force.mean(axis=0)) < 4.0 * np.sqrt(expected / paths))


def expected_welch(a, b, c, dt: float, nperseg: int) -> np.ndarray:
    """The expectation of scipy's one-sided Welch density (Hann window, one segment, no
    detrending) of the stationary sampled output ``c . z``: ``2 sum_m r(m) rho(m) cos(2 pi k
    m / N) / (fs sum w^2)`` with the closed-form autocovariance ``r(m) = c exp(A m dt) P c``
    and the window's autocorrelation ``rho``."""
    p = stationary_covariance(a, b)
    step = expm(a * dt)
    v = p @ c
    r = np.empty(nperseg)
    for m in range(nperseg):
        r[m] = c @ v
        v = step @ v
    w = get_window("hann", nperseg)
    rho = np.correlate(w, w, "full")[nperseg - 1:]
    lagged = r * rho
    sums = 2.0 * np.fft.rfft(lagged).real - lagged[0]
    return 2.0 * sums * dt / np.sum(w * w)


@pytest.mark.parametrize("spectrum", ["davenport", "kaimal"])
def test_welch_spectrum_of_exact_steps(spectrum):
    """The Welch density averaged over ``K`` independent stationary paths (one Hann segment
    each) is, bin by bin, ``E chi^2_{2K} / (2K)``: checked in the two-sided interval of level
    1e-4 / (bins) (about +-8.5 % at K = 4000).  Its expectation ``E`` (the rational spectrum's
    autocovariance through the window) is the rational closed form ``2 |H(i 2 pi n)|^2``
    aliased by the sampling, to within 1 % (Hann leakage: measured 0.2 % Davenport, 0.8 %
    Kaimal from bin 8 up)."""
    load = the_load(spectrum, start="stationary")
    variance, time_scale = load.turbulence()
    _, turbulence = wind_load(load, 3)
    a, b, c = turbulence.a, turbulence.b, turbulence.c
    fs = 1.6 * load.fit_band()[1]
    dt, nperseg, paths = 1.0 / fs, 4096, 4000
    arrays = block_diagonal([turbulence], dt, n_floors=3)
    assert arrays["p0"].any()
    rng = np.random.default_rng(12)
    z = rng.standard_normal((paths, a.shape[0])) @ arrays["p0"].T  # the stationary start of the kernels
    force = np.empty((nperseg, paths))
    for i in range(nperseg):
        force[i] = z @ arrays["c_force"][0]
        z = z @ arrays["phi"].T + rng.standard_normal(z.shape) @ arrays["chol"].T
    freq, psd = welch(force, fs=fs, window="hann", nperseg=nperseg, noverlap=0, detrend=False, axis=0)
    estimate = psd.mean(axis=1)
    expected = expected_welch(a, b, c * weights()[0], dt, nperseg)
    bins = slice(4, nperseg // 2 - 4)  # off the zero and Nyquist bins (exponential law of each bin)
    count = len(range(*bins.indices(nperseg // 2 + 1)))
    alpha = 1e-4 / count
    lo, hi = chi2.ppf(alpha / 2, 2 * paths) / (2 * paths), chi2.ppf(1 - alpha / 2, 2 * paths) / (2 * paths)
    ratio = estimate[bins] / expected[bins]
    assert lo < ratio.min() and ratio.max() < hi, (ratio.min(), ratio.max(), lo, hi)

    # E is the rational closed form aliased by the sampling, sum_k S(|n + k fs|) (|k| <= 1000:
    # the rest of the n^-2 tail is < 3e-4), up to the window's leakage (largest at the low bins)
    shifts = fs * np.arange(-1000, 1001)
    low = np.arange(8, nperseg // 2 - 4)
    aliased = np.array([wind.rational_spectrum(a, b, c, np.abs(n + shifts)).sum() for n in freq[low]])
    leakage = np.abs(expected[low] / (weights()[0] ** 2 * aliased) - 1.0)
    assert leakage.max() < 0.01, leakage.max()


# (c) ---------------------------------------------------------------------------------------


def augmented(turbulence) -> tuple[np.ndarray, np.ndarray]:
    """Drift and noise of the building (displacements, velocities) driven by the filter: the
    force on floor ``k`` is ``weights[k] c . z``."""
    n, m = 3, turbulence.a.shape[0]
    k = shear_stiffness([STOREY_K] * 3)
    damping = shear_stiffness([STOREY_C] * 3)
    a = np.zeros((2 * n + m, 2 * n + m))
    a[:n, n:2 * n] = np.eye(n)
    a[n:2 * n, :n] = -k / MASS
    a[n:2 * n, n:2 * n] = -damping / MASS
    a[n:2 * n, 2 * n:] = np.outer(weights(), turbulence.c) / MASS
    a[2 * n:, 2 * n:] = turbulence.a
    return a, np.concatenate([np.zeros(2 * n), turbulence.b])


def test_building_under_wind_end_to_end(tmp_path):
    """``run`` on 400 realisations, the filter started from its stationary law, the building
    from rest; 20 s = 9 decay times of mode 1 (5 %) before the metrics window and the last
    history point.  The kick-drift-kick scheme keeps the static equilibrium exactly and biases
    the variance by O((w dt)^2) < 0.6 %, a tenth of a standard error (7 %)."""
    from vines_stoch import run

    realizations = 400
    data = frame(wind_table("davenport", start="stationary"), 40.0, 2e-3, metrics_from=20.0,
                 history={"points": 11, "signals": ["x_1", "x_2", "x_3"]})
    study = study_from(data | {"ensemble": {"realizations": realizations, "seed": 5}})
    rows, _ = run(study, tmp_path, workers=1)
    history = pd.read_parquet(tmp_path / "history.parquet")
    last = history.iloc[-1]
    assert last["t"] >= 20.0 and (last["n"] == realizations)

    load = study.points[0].loads[0]
    mean_force, turbulence = wind_load(load, 3)
    static = np.linalg.solve(shear_stiffness([STOREY_K] * 3), mean_force)
    a, b = augmented(turbulence)
    var = np.diag(stationary_covariance(a, b))[:3]
    assert np.all(np.sqrt(var) > 0.05 * static)  # the turbulence is not negligible here
    for k in range(3):
        mean, std = last[f"x_{k + 1}_mean"], last[f"x_{k + 1}_std"]
        assert abs(mean - static[k]) < 4.0 * std / np.sqrt(realizations), (k, mean, static[k])
        assert abs(std**2 - var[k]) < 4.0 * var[k] * np.sqrt(2.0 / (realizations - 1)), (k, std**2, var[k])
        square = rows[f"x_rms_{k + 1}"].to_numpy() ** 2
        se = square.std(ddof=1) / np.sqrt(realizations)
        exact = static[k] ** 2 + var[k]
        assert abs(square.mean() - exact) < 4.0 * se, (k, square.mean(), exact)


def test_scene_of_a_wind_load():
    """The scene: one harmonic row of frequency 0 (the mean force) per floor, the filter read
    out on every floor, Euler-Maruyama (noise)."""
    scene = build_scene(study_from(frame(wind_table("kaimal"))).points[0])
    mean, turbulence = wind_load(study_from(frame(wind_table("kaimal"))).points[0].loads[0], 3)
    np.testing.assert_array_equal(scene.forces[:, 1], mean)
    np.testing.assert_array_equal(scene.forces[:, [0, 2, 3]], 0.0)  # HARMONIC, frequency 0, phase 0
    np.testing.assert_array_equal(scene.forces[:, 6], [0, 1, 2])
    np.testing.assert_allclose(scene.filters["c_force"], np.outer(weights(), turbulence.c), rtol=1e-13)
    assert scene.scheme == "euler-maruyama" and scene.has_filters and not scene.filters["p0"].any()


# (d) ---------------------------------------------------------------------------------------

BAD = [
    ("speed = 25.0", "speed = -5.0", "loads.0.speed = -5.0: must be > 0"),
    ('spectrum = "davenport"', 'spectrum = "von-karman"',
     "loads.0.spectrum = 'von-karman': must be 'davenport' or 'kaimal'"),
    ("height = 3.0", "heights = [3.0, 3.0]",
     "loads.0.heights = [3.0, 3.0]: must list 3 values (one per floor"),
    ("height = 3.0", "height = 3.0\nheights = [3.0, 3.0, 3.0]",
     "loads.0.height = 3.0: give either height (every floor) or heights = [...]"),
    ("area = 30.0", "", "loads.0.area: give either area (every floor) or areas = [...]"),
    ("drag = 1.3", "drag = 0.0", "loads.0.drag = 0.0: must be > 0"),
    ("drag = 1.3", "", "loads.0.drag: missing required key"),
    ("speed = 25.0", "speed = 25.0\nexponent = 1.5", "loads.0.exponent = 1.5: must be in [0, 1]"),
    ("speed = 25.0", "speed = 25.0\norder = 4", "loads.0.order = 4: must be 2 or 3"),
    ("speed = 25.0", "speed = 25.0\nband = [5.0, 0.5]",
     "loads.0.band = [5.0, 0.5]: must be [low, high] in Hz"),
    ("speed = 25.0", "speed = 25.0\nfriction_velocity = 1.0", "loads.0.friction_velocity = 1.0: only with "
     "spectrum = 'kaimal'"),
    ("speed = 25.0", 'speed = 25.0\nprofile = "log"\nroughness = 4.0',
     "loads.0.roughness = 4.0: must be below the lowest floor (3 m)"),
    ("speed = 25.0", 'speed = 25.0\nstart = "stationary"\nenvelope = { type = "saragoni-hart", peak = 3.0, '
     'shape = 2.0 }', "loads.0.start = 'stationary': a stationary start needs a load without envelope"),
    ("speed = 25.0", "speed = 25.0\nfloor = 2", "loads.0.floor = 2: unknown key; allowed keys: type, speed"),
]


@pytest.mark.parametrize("old, new, message", BAD, ids=[b[2].split(":")[0] + " " + b[1][:12] for b in BAD])
def test_bad_wind_input_names_the_key(old, new, message):
    text = toml_text(frame(wind_table("davenport")))  # (a message names the key of a changed line)
    assert old in text
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text.replace(old, new, 1), source="w.toml")
    assert f"w.toml: {message}" in str(info.value)
