"""Seed 001 (Lizunov, Pogorelova, Postnikova, "Choice of the model for vibro-impact nonlinear
sink"): its three frames, the scenarios ``seed001_two_storey_ssvi`` (Fig. 4a), ``seed001_three_
storey_frame`` (Tables 3-5) and ``seed001_nine_storey_ssvi`` (section 4.1, Table 1), run and checked
against references built here.  Seed 001 prints no response of any frame (no table or figure value
to reproduce), so the checks are physics with independent references:

- natural frequencies of each primary against ``scipy.linalg.eigh(K, M)`` of the matrices written
  here from Table 3 (three storeys) and from the assumed values of the scenario headers (two and
  nine storeys), and the frequencies the headers print;
- each bare frame (absorbers removed) against an exact linear solution of the same load: the
  closed-form steady frequency response for harmonic forces (two and three storeys), the exact
  state-transition solution of the piecewise-linear record (nine storeys);
- the energy balance of each frame with its absorbers;
- the absorbers reducing the roof's response: seed 001 calls the SSVI NES "the most effective and
  efficient" (two and nine storeys) and Tables 4-5 list control devices (three storeys);
- each device of Tables 4-5 alone on the six- and four-column frames (``seed001_frame_devices``,
  ``seed001_frame_vitmd``): its parameters as printed, and its cut of the roof's rms under the
  same ground motions as the bare frame, at 3 standard errors; the zero-clearance VITMD against the
  frame with its mass locked on the roof; the VIDM (``seed001_frame_vidm``: the Table 5 DM pair
  whose masses strike each other) against the bare frame and against its pair without impacts.
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from scipy.linalg import eigh, expm

from tests.helpers import ROOT, example_data, study_from
from vines_stoch.ensemble import sample
from vines_stoch.validation.reproduce import (
    FRAME_DEVICES,
    FRAME_STIFFNESSES,
    VIDM_NONLINEAR,
    ZERO_CLEARANCE,
    frame_devices,
)

SCENARIOS = ROOT / "scenarios"


def storey_matrix(values) -> np.ndarray:
    """Tridiagonal matrix of storey springs or dashpots (storey ``k`` joins floor ``k-1``, the
    ground for ``k = 1``, to floor ``k``)."""
    n = len(values)
    a = np.diag(np.asarray(values, float) + np.append(np.asarray(values[1:], float), 0.0))
    for k in range(1, n):
        a[k - 1, k] = a[k, k - 1] = -values[k]
    return a


def rayleigh(m: np.ndarray, k: np.ndarray, ratio: float = 0.02) -> np.ndarray:
    """Rayleigh damping ``alpha M + beta K`` with ``ratio`` at modes 1 and 2."""
    w1, w2 = np.sqrt(eigh(k, m, eigvals_only=True)[:2])
    return 2 * ratio * w1 * w2 / (w1 + w2) * m + 2 * ratio / (w1 + w2) * k


#: The primaries: masses (kg) and storey stiffnesses (N/m), lowest floor first.  Three storeys:
#: seed 001 Table 3 (six-column frame; the four-column one below).  Two and nine storeys: the
#: scenario headers' assumptions (seed 001 prints neither frame's floors).
FRAMES = {
    "seed001_two_storey_ssvi": ([1000.0, 1000.0], [1.0341e5, 1.0341e5]),
    "seed001_three_storey_frame": ([29.61, 29.61, 32.40], [2.62e4, 2.40e4, 2.55e4]),
    "seed001_nine_storey_ssvi": ([1222.2] * 9, [7.08e6] * 9),
}
FOUR_COLUMN = [1.55e4, 1.47e4, 1.62e4]
#: The frequencies the headers print (rad/s, 5 significant digits).
PRINTED = {
    "seed001_two_storey_ssvi": [6.285, 16.454],
    "seed001_three_storey_frame": [12.687, 36.111, 51.857],
    "seed001_nine_storey_ssvi": [12.570, 37.368, 61.147, 83.257, 103.097, 120.124, 133.875, 143.974,
                                 150.145],
}


def frequencies(name: str, stiffnesses=None) -> np.ndarray:
    masses, springs = FRAMES[name]
    return np.sqrt(eigh(storey_matrix(stiffnesses or springs), np.diag(masses), eigvals_only=True))


@pytest.mark.parametrize("name", list(FRAMES))
def test_frame_frequencies_against_eigh(name):
    expected = frequencies(name)
    data = example_data(name, "absorbers", "sweep")
    got = np.asarray(study_from(data, directory=SCENARIOS).points[0].natural_frequencies(), float)
    # 1e-10: the same well-conditioned symmetric eigenproblem, round-off ~1e-15
    np.testing.assert_allclose(got, expected, rtol=1e-10)
    # the header's figures, printed to 5 significant digits (half a unit of the last: 4e-4)
    np.testing.assert_allclose(PRINTED[name], expected, rtol=4e-4)


def test_header_figures_of_the_three_and_nine_storey_frames():
    # four-column frame of Table 3 (not run): 9.861, 28.351, 40.773 rad/s
    np.testing.assert_allclose(frequencies("seed001_three_storey_frame", FOUR_COLUMN),
                               [9.861, 28.351, 40.773], rtol=4e-4)
    # nine storeys: mode 1 effective mass 9369 kg (85 % of 11,000 kg)
    masses, springs = FRAMES["seed001_nine_storey_ssvi"]
    m = np.diag(masses)
    _, modes = eigh(storey_matrix(springs), m)
    phi = modes[:, 0]
    effective = (phi @ m @ np.ones(9)) ** 2 / (phi @ m @ phi)
    assert effective == pytest.approx(9369.0, abs=0.5)


def steady_amplitudes(masses, k, c, floor: int, amplitude: float, omega: float) -> np.ndarray:
    """Steady floor amplitudes under ``amplitude cos(omega t)`` on ``floor``: ``|(K - w^2 M +
    i w C)^-1 F|``."""
    force = np.zeros(len(masses))
    force[floor - 1] = amplitude
    return np.abs(np.linalg.solve(k - omega**2 * np.diag(masses) + 1j * omega * c, force))


# ----------------------------------------------------------------------------- two storeys

TWO = "seed001_two_storey_ssvi"


@cache
def two_storey(with_absorber: bool):
    data = example_data(TWO) if with_absorber else example_data(TWO, "absorbers")
    return sample(study_from(data), workers=1)


def test_two_storey_bare_frame_matches_the_frequency_response():
    masses, springs = FRAMES[TWO]
    dashpots = example_data(TWO)["primary"]["dampings"]
    frame = two_storey(False)
    for omega, (_, row) in zip([5.8, 6.3, 6.8], frame.iterrows()):
        exact = steady_amplitudes(masses, storey_matrix(springs), storey_matrix(dashpots), 2, 800.0, omega)
        # window [100, 200] s: the slowest transient (mode 1, 3.6 %) has decayed by exp(-22.6);
        # the peak sampled every 0.01 s falls short by at most 1 - cos(omega dt / 2) = 6e-5;
        # RK4 at omega dt = 0.068 adds ~1e-7: band 1e-4 (measured within 1.6e-5)
        for floor in (1, 2):
            assert row[f"x_max_{floor}"] == pytest.approx(exact[floor - 1], rel=1e-4), (omega, floor)
    # the header's figures: 0.091, 0.203, 0.077 m
    np.testing.assert_allclose(frame["x_max_2"], [0.091, 0.203, 0.077], atol=5e-4)


def test_two_storey_ssvi_reduces_the_roof_response_at_resonance():
    bare, nes = two_storey(False), two_storey(True)
    assert (nes["status"] == "ok").all()
    # RK4 with sub-stepped Hertz contacts: the balance closes to ~2e-7 (measured), 1e-6 allowed
    assert (nes["energy_residual"].abs() < 1e-6).all()
    # at 6.3 rad/s (mode 1) the NES impacts and cuts the roof's steady peak (measured 33 %)
    assert nes["impacts"].iloc[1] > 0
    assert nes["x_max_2"].iloc[1] < 0.85 * bare["x_max_2"].iloc[1]


# ----------------------------------------------------------------------------- three storeys

THREE = "seed001_three_storey_frame"
#: Harmonic force on the roof at mode 1 (the bare frame's resonance): the same for both.
ROOF_FORCE = 1.0


@cache
def three_storey_harmonic(with_devices: bool):
    """The frame (Table 4 devices or none) under ``ROOF_FORCE cos(w1 t)`` N on floor 3, window
    [45, 60] s: mode 1 (2 %, 0.254 1/s) has decayed by exp(-11.4) at 45 s."""
    data = example_data(THREE, "sweep") if with_devices else example_data(THREE, "sweep", "absorbers")
    changes = {"loads": [{"type": "harmonic", "floor": 3, "amplitude": ROOF_FORCE,
                          "frequency": float(frequencies(THREE)[0])}],
               "simulation.duration": 60.0, "simulation.metrics_from": 45.0, "ensemble.realizations": 1}
    return sample(study_from(data, changes), workers=1).iloc[0]


def test_three_storey_bare_frame_matches_the_frequency_response():
    masses, springs = FRAMES[THREE]
    m, k = np.diag(masses), storey_matrix(springs)
    exact = steady_amplitudes(masses, k, rayleigh(m, k), 3, ROOF_FORCE, frequencies(THREE)[0])
    row = three_storey_harmonic(False)
    # 2e-4: the left transient exp(-11.4) = 1e-5, peak sampling 1 - cos(w1 dt / 2) = 8e-5, the
    # kick-drift-kick amplitude error at w1 dt = 0.025 ~1e-6 (measured within 7.4e-7)
    for floor in (1, 2, 3):
        assert row[f"x_max_{floor}"] == pytest.approx(exact[floor - 1], rel=2e-4), floor


def test_three_storey_table_4_devices_reduce_the_resonant_roof_response():
    bare, devices = three_storey_harmonic(False), three_storey_harmonic(True)
    assert devices["impacts"] == 0  # Table 4's TMD: stops out of reach
    # the TMD and the DM's linear half are tuned near mode 1 (12.36, 12.13 rad/s): a large cut
    assert devices["x_max_3"] < 0.5 * bare["x_max_3"]


@cache
def three_storey_ground_motion(dt: float):
    """The scenario's frame and devices, ground motion of intensity 0.1, 4 realisations a point."""
    data = example_data(THREE)
    data["sweep"]["loads.0.intensity"] = [0.1]
    return sample(study_from(data, {"ensemble.realizations": 4, "simulation.dt": dt}), workers=1)


@pytest.mark.parametrize("point", [0, 1], ids=["table-4", "table-5"])
def test_three_storey_under_ground_motion_balances_energy(point):
    frame = three_storey_ground_motion(2e-3)
    rows = frame[frame["point"] == point]
    assert (rows["status"] == "ok").all()
    assert (rows["impacts"] > 0).all() == (point == 1)  # the VITMD's 1.5 mm stops are hit
    # kick-drift-kick at w_max dt = 0.104: the residual is the scheme's own error (the bare frame
    # alone leaves up to 4.2e-5), measured up to 3.2e-5 (Table 4) and 6.4e-5 (Table 5): 1e-4
    assert rows["energy_residual"].abs().max() < 1e-4
    # and it is discretisation error: at dt / 2 it falls at least 3-fold (measured 4- and 8-fold)
    finer = three_storey_ground_motion(1e-3)
    finer = finer[finer["point"] == point]
    assert finer["energy_residual"].abs().max() < rows["energy_residual"].abs().max() / 3


# ----------------------------------------------------------------------------- nine storeys

NINE = "seed001_nine_storey_ssvi"


def record_path(dt: float, duration: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact floor displacements of the bare nine-storey frame (Rayleigh 2 %) at ``t = j dt``
    under the shipped record, read here from the AT2 file (units g) and interpolated linearly,
    zero after its end: the state-transition map of ``x' = A x + b a(t)`` with ``a`` linear on
    each step (augmented matrix exponential); ``dt`` divides the record's 0.01 s."""
    lines = (SCENARIOS / "records/synthetic_cp_medium.AT2").read_text().splitlines()
    npts, step = (float(part.split("=")[1].split()[0]) for part in lines[3].split(","))
    values = np.array(" ".join(lines[4:]).split(), float) * 9.80665
    assert values.size == int(npts)
    masses, springs = FRAMES[NINE]
    m, k = np.diag(masses), storey_matrix(springs)
    n = len(masses)
    minv = np.linalg.inv(m)
    a = np.zeros((2 * n + 2, 2 * n + 2))
    a[:n, n:2 * n] = np.eye(n)
    a[n:2 * n, :n] = -minv @ k
    a[n:2 * n, n:2 * n] = -minv @ rayleigh(m, k)
    a[n:2 * n, 2 * n] = -1.0          # x'' = ... - 1 a_g (every floor, through its mass)
    a[2 * n, 2 * n + 1] = 1.0         # a_g' = slope (constant on a step)
    phi = expm(a * dt)
    steps = int(round(duration / dt))
    times = np.arange(steps + 1) * dt
    ground = np.interp(times, np.arange(values.size) * step, values, right=0.0)
    state = np.zeros(2 * n + 2)
    x = np.zeros((steps + 1, n))
    for j in range(steps):
        state[2 * n], state[2 * n + 1] = ground[j], (ground[j + 1] - ground[j]) / dt
        state = phi @ state
        x[j + 1] = state[:n]
    return times, x


@cache
def nine_storey(with_nes: bool):
    data = example_data(NINE, "sweep") if with_nes else example_data(NINE, "sweep", "absorbers")
    return sample(study_from(data, directory=SCENARIOS), workers=1).iloc[0]


def test_nine_storey_bare_frame_matches_the_exact_record_response():
    sim = study_from(example_data(NINE), directory=SCENARIOS).base.simulation
    times, x = record_path(sim.dt, sim.duration)
    row = nine_storey(False)
    drift = np.diff(np.hstack([np.zeros((times.size, 1)), x]), axis=1)
    for floor in range(1, 10):
        # both on the same 1e-3 s grid (the same sampling of the peak); RK4 at w_max dt = 0.150
        # with the record's slope jumping every 0.01 s: ~1e-7 on the response of modes 1-3 that
        # makes the peaks; band 1e-6 (measured within 6e-9 for x_max, 9e-8 for the drifts)
        assert row[f"x_max_{floor}"] == pytest.approx(np.abs(x[:, floor - 1]).max(), rel=1e-6), floor
        assert row[f"drift_max_{floor}"] == pytest.approx(np.abs(drift[:, floor - 1]).max(), rel=1e-6), floor


def test_nine_storey_table_1_nes_reduce_the_roof_response():
    bare, nes = nine_storey(False), nine_storey(True)
    assert nes["status"] == "ok" and nes["impacts_left"] > 0 and nes["impacts_right"] == 0
    # RK4 with sub-stepped preloaded Hertz contact: the bound of the Hertz path tests
    # (tests/unit/kernels/test_contact.py); measured 4.7e-7 (the bare frame: 9e-10)
    assert abs(nes["energy_residual"]) < 1e-6
    # optimised Table 1 parameters, record at scale 1: roof peak 0.048 against 0.062 m, RMS 0.0112
    # against 0.0148 m (measured): a cut of at least 15 % each
    assert nes["x1_max"] < 0.85 * bare["x1_max"]
    assert nes["x1_rms"] < 0.85 * bare["x1_rms"]


def test_two_storey_dsvi_cuts_less_as_the_force_grows():
    """``seed001_two_storey_dsvi`` (seed 001 Fig. 4b; DS-2(20) on the roof, 800-2400 N at 6.3
    rad/s): without impacts at 800 N (a tuned mass: the roof's steady peak cut by 46 %), from
    1200 N one impact on each obstacle a period (T,1,1), and the cut falling as the force grows
    (33, 21, 12 % measured; deterministic, so held in order with a margin of 2 points)."""
    from vines_stoch import run

    data = example_data("seed001_two_storey_dsvi")
    nes = run(data).realizations
    bare = run({**data, "absorbers": []}).realizations
    cut = 1.0 - nes["x1_max"].to_numpy() / bare["x1_max"].to_numpy()
    assert nes["impacts"].iloc[0] == 0 and cut[0] > 0.4
    assert list(nes["regime"].iloc[1:]) == ["T,1,1"] * 3
    assert (np.diff(cut) < -0.02).all() and cut[-1] > 0.05


def pulse_train_steady_peak(m: float, k: float, c: float, force: float, width: float, period: float) -> float:
    """The peak displacement of a linear oscillator's periodic steady state under rectangular
    pulses (``force`` for ``width``, then none, every ``period``): the fixed point of the exact
    one-period map (``expm``), the response then sampled 20,000 times a period."""
    a, b = np.array([[0.0, 1.0], [-k / m, -c / m]]), np.array([0.0, force / m])

    def pushed(z, t):  # (under the constant force for t)
        e = expm(a * t)
        return e @ z + np.linalg.solve(a, (e - np.eye(2)) @ b)

    start = np.linalg.solve(np.eye(2) - expm(a * (period - width)) @ expm(a * width),
                            expm(a * (period - width)) @ pushed(np.zeros(2), width))
    top = pushed(start, width)
    x = [pushed(start, t)[0] if t <= width else (expm(a * (t - width)) @ top)[0]
         for t in np.linspace(0.0, period, 20_001)]
    return float(np.abs(x).max())


def test_steady_pulse_train_on_a_vi_damper():
    """Seed 001 section 3.4 (Fig. 9), ``seed001_pulse_train_ssvi``: the primary alone at the exact
    periodic steady state's peak (within 1e-4: the pulses' edges fall on the step grid, RK4's
    error over the 1 / (zeta omega dt) = 4400 steps the damping remembers is far below; measured
    1e-8), and the damper, striking the primary once a period, cutting that peak by more than a
    third up to 4000 N (measured 39-42 %), by less at 8000 N where it strikes both walls (13 %)."""
    from vines_stoch import run

    data = example_data("seed001_pulse_train_ssvi")
    nes = run(data).realizations
    bare = run({**data, "absorbers": []}).realizations
    forces = data["sweep"]["loads.0.amplitude"]
    exact = [pulse_train_steady_peak(1000.0, 3.95e4, 452.0, f, 0.1, 1.0) for f in forces]
    np.testing.assert_allclose(bare["x1_max"], exact, rtol=1e-4)
    cut = 1.0 - nes["x1_max"].to_numpy() / bare["x1_max"].to_numpy()
    periods = 300  # (the window's)
    assert (cut[:3] > 1 / 3).all() and cut[3] < cut[2] - 0.1
    assert list(nes["impacts_left"].iloc[:3]) == [periods] * 3 and (nes["impacts_right"].iloc[:3] == 0).all()
    assert nes["impacts_right"].iloc[3] > 0


# ----------------------------------------------------------------------------- eq. (1): one barrier

ONE_BARRIER = "seed001_one_barrier_ssvi"


def equation_1(m1, k1, c1, m2, k2, c2, d, b, k, v1, v2, times, absolute=False):
    """Seed 001 eq. (1)-(3) integrated by DOP853 (rtol 1e-11), the contact's onset and end located
    as events, so no step crosses the ``z^1.5`` kink: ``(x1, x2 - x1)`` at ``times`` from
    ``x1 = 0, x2 = D, x1' = v1, x2' = v2``.  ``z = x2 - x1 - B`` (the barrier on the primary, the
    project's reading) or, with ``absolute``, ``z = x2 - B`` as printed."""
    from scipy.integrate import solve_ivp

    def approach(t, y):
        return y[1] - (0.0 if absolute else y[0]) - b

    def rhs(t, y):
        x1, x2, v1, v2 = y
        z = approach(t, y)
        f = k * z**1.5 if z > 0.0 else 0.0
        return [v1, v2, (-c1 * v1 - k1 * x1 - c2 * (v1 - v2) - k2 * (x1 - x2 + d) + f) / m1,
                (-c2 * (v2 - v1) - k2 * (x2 - x1 - d) - f) / m2]

    approach.terminal = True
    y, t, end, pieces = np.array([0.0, d, v1, v2]), 0.0, times[-1], []
    while t < end:
        z, dz = approach(t, y), y[3] - (0.0 if absolute else y[2])
        approach.direction = -1 if z > 1e-12 or (abs(z) <= 1e-12 and dz > 0) else 1
        sol = solve_ivp(rhs, (t, end), y, method="DOP853", rtol=1e-11, atol=1e-13, events=approach,
                        dense_output=True)
        pieces.append((t, sol.t[-1], sol.sol))
        t, y = sol.t[-1], sol.y[:, -1].copy()
    states = np.array([next(p for a, e, p in pieces if a <= s <= e)(s) for s in times])
    return states[:, 0], states[:, 1] - states[:, 0]


def one_barrier(velocities: list[float]):
    """``seed001_one_barrier_ssvi`` from the initial ``velocities`` (primary, damper): its path
    (``x1``, ``e1``, the stroke) and the parameters of ``equation_1`` read from the file."""
    from vines_stoch import solve
    from vines_stoch.physics.hertz import hertz_constant

    data = example_data(ONE_BARRIER)
    data["loads"][0]["velocity"] = velocities
    (a,), p = data["absorbers"], data["primary"]
    contact = a["contact_right"]
    k = hertz_constant(contact["young"], contact["poisson"], contact["radius"])
    parameters = (p["mass"], p["stiffness"], p["damping"], a["mass"], a["stiffness"], a["damping"],
                  a["offset"], a["gap"], k, *velocities)
    return solve(data, signals=["x1", "e1", "stroke_1"]), parameters


@pytest.mark.parametrize("velocities", [[0.5, 0.5], [0.5, -2.0]], ids=["V1 = V2", "through the primary"])
def test_one_barrier_ssvi_of_equation_1_against_scipy(velocities):
    """Seed 001 eq. (1), ``seed001_one_barrier_ssvi``: one barrier on the primary and no contact
    between damper and primary (``geometry = "one-barrier"``), under initial velocities.  The
    primary and the damper's stroke against eq. (1) written above: RK4 at ``omega dt = 6.3e-3``
    with sub-stepped contacts errs about ``T (omega dt)^4 ~ 5e-8`` of the amplitude (measured
    4e-8 of it for x1, 7e-8 m for the stroke), so 1e-6 of the amplitude and 1e-6 m.  With V1 = V2
    (section 3.1, the file's): eq. (1) read with the printed absolute ``z = x2 - B`` lies far
    outside (11 % of the amplitude); the design keeps the paper's ``x2 > x1`` (stroke above 0.07
    m), and the primary's motion fades out (Fig. 7) faster than the bare primary's (its energy 3x
    lower after 10 s, 5x after 20 s; measured 3.1x and 5.8x).  Thrown at 2 m/s towards the
    primary, the damper passes through it (the stroke below 0, where a single-sided absorber
    would strike the primary), as eq. (1) has it."""
    path, parameters = one_barrier(velocities)
    steps = np.arange(1, len(path.ts), 37)
    x1, stroke = equation_1(*parameters, path.ts[steps])
    amplitude = np.abs(x1).max()
    assert path.metrics["impacts_right"] >= 3 and path.metrics["impacts_left"] == 0
    assert np.abs(path.ys["x1"][steps] - x1).max() < 1e-6 * amplitude
    assert np.abs(path.ys["stroke_1"][steps] - stroke).max() < 1e-6
    if velocities[1] < 0.0:
        assert path.ys["stroke_1"].min() < -0.05
        return
    assert np.abs(path.ys["x1"][steps] - equation_1(*parameters, path.ts[steps], absolute=True)[0]).max() \
        > 0.05 * amplitude
    assert path.ys["stroke_1"].min() > 0.07
    from vines_stoch import solve

    bare = solve({**example_data(ONE_BARRIER), "absorbers": [],
                  "loads": [{"type": "initial", "velocity": [0.5]}]})
    for end, ratio in ((10.0, 3.0), (20.0, 5.0)):
        window = (path.ts > end - 2.0) & (path.ts <= end)
        assert path.ys["e1"][window].max() * ratio < bare.ys["e1"][window].max()


def test_nine_storey_nes_take_the_energy_of_a_blast():
    """``seed001_nine_storey_blast`` (the blast of Wierschem et al. 2017, ref. [17]; the pulse
    assumed): the energy balance closes (the bound above; measured 5e-7), the two SSVI NES
    dissipate a quarter of the input or more (EDM measured 0.33) and the frame's roof rms and
    time-integrated energy fall by at least a quarter (measured 41 % and 39 %).  The roof's peak
    is not cut (measured 0.0107 m with the NES against 0.0082 m without; not held)."""
    from vines_stoch import run

    data = example_data("seed001_nine_storey_blast")
    nes = run(data).realizations.iloc[0]
    bare = run({**data, "absorbers": []}).realizations.iloc[0]
    assert nes["status"] == "ok" and nes["impacts"] > 0 and abs(nes["energy_residual"]) < 1e-6
    assert nes["edm"] > 0.25
    assert nes["x1_rms"] < 0.75 * bare["x1_rms"] and nes["energy_integral"] < 0.75 * bare["energy_integral"]


def test_table2_rig_under_base_excitation():
    """Seed 001 Table 2 (``seed001_table2_rig``, reconstructed: the header says what is assumed).
    The bare LO settles to the closed-form amplitude of base excitation,
    ``A / sqrt((w^2 - W^2)^2 + (2 z w W)^2)``: after 20 s, 7.2 decay times ``1 / (z w)``, the
    transient is below ``e^-7.2 = 7.5e-4`` of it.  With the NES: at A = 0.5 m/s^2 the ball's
    stroke stays inside the cavity (no impact, the LO's motion unchanged); at 1 and 2 m/s^2 it
    impacts and its impacts take energy out, the balance closing to RK4's error, yet the LO's
    steady amplitude rises (measured by 12.6 % and 12.1 %; the header's claim, tested as more than
    10 %)."""
    data = example_data("seed001_table2_rig")
    bare = {key: value for key, value in data.items() if key != "absorbers"}
    m, k, c = (data["primary"][key] for key in ("mass", "stiffness", "damping"))
    omega = data["loads"][0]["frequency"]
    w, z = np.sqrt(k / m), c / (2 * np.sqrt(k * m))
    amplitudes = np.array(data["sweep"]["loads.0.amplitude"])
    steady = amplitudes / np.sqrt((w * w - omega * omega) ** 2 + (2 * z * w * omega) ** 2)
    alone = sample(study_from(bare)).sort_values("point")
    np.testing.assert_allclose(alone["x1_max"], steady, rtol=1e-3)
    nes = sample(study_from(data)).sort_values("point")
    assert nes["impacts"].tolist()[0] == 0 and nes["x1_max"].iloc[0] == pytest.approx(alone["x1_max"].iloc[0],
                                                                                       rel=1e-12)
    assert (nes["impacts"].iloc[1:] > 50).all() and (nes["edm"].iloc[1:] > 0.05).all()
    assert (nes["x1_max"].iloc[1:].to_numpy() > 1.1 * alone["x1_max"].iloc[1:].to_numpy()).all()
    assert nes["energy_residual"].abs().max() < 1e-9


# ----------------------------------------------------------------------------- each device alone


@cache
def devices():
    return frame_devices(SCENARIOS)


@pytest.mark.parametrize("name", list(FRAME_DEVICES))
def test_device_scenarios_carry_tables_3_to_5_as_printed(name):
    points = study_from(example_data(name), directory=SCENARIOS).points
    assert len(points) == len(FRAME_DEVICES[name])
    for (label, frame, mass, damping, stiffness, clearance), point in zip(FRAME_DEVICES[name], points):
        a = point.absorbers[0]
        assert point.primary.masses == FRAMES[THREE][0] and a.floor == 3
        assert tuple(point.primary.stiffnesses) == FRAME_STIFFNESSES[frame]
        assert (a.mass, a.damping) == (mass, damping), label
        if a.type == "cubic":  # the linear devices as k_lin, the nonlinear DM as the cubic k (N/m^3)
            assert (a.stiffness, a.linear_stiffness) == ((stiffness, 0.0) if "nonlinear" in label
                                                         else (0.0, stiffness)), label
        else:  # the VITMD (0 mm printed, run at ZERO_CLEARANCE) and the VIDM's linear DM
            assert a.stiffness == stiffness and a.clearance == (clearance or ZERO_CLEARANCE), label
        if name == "seed001_frame_vidm":  # the linear DM in the cavity of the nonlinear DM
            b = point.absorbers[1]
            assert a.impacts_with == 2 and b.type == "cubic" and b.floor == 3
            assert (b.mass, b.damping, b.stiffness) == VIDM_NONLINEAR[frame], label


def test_each_tuned_device_alone_cuts_the_roof_rms():
    """Seed 001 prints no response (Tables 4-5 are "optimal" and "physical" devices): the cut of the
    roof's rms displacement against the bare frame under the same 128 ground motions, tested at 3
    standard errors (one-sided, 0.13 % a device).  Measured (cut, its standard error): six-column
    26.9/2.0, 16.5/1.8, 18.1/2.4, 20.9/2.1 and 20.1/1.6 %; four-column nonlinear DM 15.7/1.9 %.  The
    four-column Table 5 linear DM is tuned to 13.24 rad/s, above that frame's 9.86 rad/s: its cut
    (-1.0/2.0 %) is within 3 standard errors of none.  (With 16 ground motions, as the scenarios
    ran before, a cut of about 18 % has a standard error of about 7 %: the test passed or failed
    with the streams' draws, 35.8/4.5 % for the TMD on one set and 21.5/8.3 % on another.)"""
    for r in devices():
        if r["name"] != "seed001_frame_devices":
            continue
        assert (r["rows"]["status"] == "ok").all() and r["impacts"] == 0
        cut, error = r["x_rms_3"]
        detuned = r["frame"] == "four-column" and "linear DM" in r["label"] and "non" not in r["label"]
        assert (abs(cut) < 3 * error) if detuned else (cut > 3 * error), (r["label"], r["frame"], cut, error)


def test_vidm_strikes_and_cuts_the_roof_rms():
    """The VIDM's two masses strike each other in every realisation (on average 413 and 264 impacts
    a realisation at 2 and 4 mm) and the pair without impacts never does; the energy balance closes
    to the frame's own 1e-4 (measured 3.7e-5 and 1.2e-5); the VIDM cuts the roof's rms against the
    bare frame at 3 standard errors over 128 ground motions (measured 31.5 +- 2.0 % and 18.1 +- 2.8
    %).  Against its pair without impacts it cuts a little more (+2.8 +- 1.7 % and +4.9 +- 1.0 %:
    reported by `vines-stoch reproduce`, not a claim of the paper, which prints no response)."""
    found = [r for r in devices() if r["name"] == "seed001_frame_vidm"]
    assert [r["frame"] for r in found] == ["six-column", "four-column"]
    for r in found:
        rows = r["rows"]
        assert (rows["status"] == "ok").all() and (rows["impacts"] > 0).all()
        assert (r["dm"]["impacts"] == 0).all()
        assert (rows["impact_loss"] > 0).all()
        assert rows["energy_residual"].abs().max() < 1e-4
        cut, error = r["x_rms_3"]
        assert cut > 3 * error, (r["frame"], cut, error)


def test_vitmd_alone_and_the_zero_clearance_limit():
    """The VITMD impacts its stops on both frames.  Its 1.5 mm stops (six-column) keep its stroke far
    below the TMD's: under this load it does not cut the roof's rms, tested as no cut beyond 3
    standard errors; it raises it (measured -9.0 +- 2.1 % over 128 ground motions; -4.9 +- 7.6 %
    over 16 on earlier streams).  Zero clearance (four-column, printed 0 mm) locks
    the mass on the roof: at 0.05 mm the roof's rms and peak of every realisation are within 3 % of
    the frame with 4.58 kg more on the roof (the largest of 128: 2.8 % and 2.6 %; of 16 on earlier
    streams 2.4 % and 1.8 %; the impacts' losses and the residual stroke make the difference)
    while the bare frame is up to 52 % away."""
    six, four = (r for r in devices() if r["name"] == "seed001_frame_vitmd")
    for r in (six, four):
        assert (r["rows"]["status"] == "ok").all() and (r["rows"]["impacts"] > 0).all()
    cut, error = six["x_rms_3"]
    assert cut < 3 * error
    assert max(four["locked"].values()) < 0.03
    bare = np.abs(four["rows"]["x_rms_3"].to_numpy() / four["bare"]["x_rms_3"].to_numpy() - 1.0).max()
    assert bare > 10 * four["locked"]["x_rms_3"]
