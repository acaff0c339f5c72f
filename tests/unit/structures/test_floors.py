"""Multi-storey primaries (shear buildings, MODEL.md 1a) against independent references.

- Stationary floor variances of a 3-storey building under white noise on floor 2 against the
  exact Lyapunov covariance ``A P + P A^T + B B^T = 0`` of its state-space model.
- ``natural_frequencies()`` against numpy's eigenvalues of ``M^-1 K`` built here, absorber DOF
  included, and the stability refusal naming the highest frequency.
- A deterministic 3-storey building with a cubic NES on floor 1 and an impact absorber on the
  roof against a tight scipy DOP853 path with located impacts (EDM, impact count, energy balance).
- Bad multi-storey input refused with the dotted key and the allowed range.
- A one-storey primary written as lists gives bit-identical metrics to the scalar form.
- A frame of more floors than a loop's stack room (``protocol.ROOM``) against scipy (RK4) and
  the exact mean input of its white noise (kick-drift-kick, impacts included).

Every reference (matrices, Lyapunov solution, event-located path) is built in this file from
the equations of MODEL.md, not from the package.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import solve_continuous_lyapunov

from tests.helpers import scene_from, study_from
from vines_stoch.ensemble import sample
from vines_stoch.kernels import simulate
from vines_stoch.kernels.protocol import ROOM
from vines_stoch.scenario import ScenarioError


def storey_matrix(values) -> np.ndarray:
    """Tridiagonal matrix of storey elements (springs or dashpots): storey ``k`` joins floor
    ``k-1`` (the ground for ``k = 1``) to floor ``k``."""
    n = len(values)
    a = np.zeros((n, n))
    for k, s in enumerate(values):
        a[k, k] += s
        if k > 0:
            a[k - 1, k - 1] += s
            a[k - 1, k] -= s
            a[k, k - 1] -= s
    return a


def floors(masses, stiffnesses, dampings) -> dict:
    """The ``primary`` table of a shear building (lowest floor first)."""
    return {"masses": list(masses), "stiffnesses": list(stiffnesses), "dampings": list(dampings)}


# ----------------------------------------------------------------------------- white noise

NOISE_M, NOISE_K, NOISE_C = [1.0, 1.0, 0.8], [30.0, 25.0, 20.0], [0.3, 0.3, 0.3]
SIGMA, NOISE_FLOOR = 1.0, 2
# omega = (2.444, 6.280, 8.921) rad/s, modal damping ratios (0.0139, 0.0416, 0.0552): the
# slowest decay time 1/(zeta_1 omega_1) is 29.4 s.  dt = 0.002 gives omega_max dt = 0.018; the
# kick-drift-kick map's own stationary variance (discrete Lyapunov equation of the linear map)
# is off by 1e-5 relative there, three orders below the standard error.  The window opens after
# 150 s (5.1 decay times: the start-from-rest covariance deficit exp(-2 t0 zeta_1 omega_1) is
# 4e-5 relative) and lasts 1000 s; 64 paths give a relative standard error of about 2 % (from
# (2/T) int_-inf^inf R(tau)^2 dtau, confirmed by a numpy simulation of the same map: z-scores
# 0.03, -1.2, -1.9 for three seeds, relative standard errors 0.019-0.022).
# Cost: 575,000 steps x 64 paths = 3.7e7 path-steps, a few seconds.
NOISE_DT, NOISE_FROM, NOISE_T, NOISE_N = 0.002, 150.0, 1150.0, 64


def test_stationary_floor_variances_match_lyapunov():
    study = study_from({
        "name": "three-storey-noise",
        "primary": floors(NOISE_M, NOISE_K, NOISE_C),
        "loads": [{"type": "white-noise", "intensity": SIGMA, "floor": NOISE_FLOOR}],
        "simulation": {"duration": NOISE_T, "dt": NOISE_DT, "metrics_from": NOISE_FROM},
        "ensemble": {"realizations": NOISE_N, "seed": 20240611},
    })
    assert study.points[0].scheme == "euler-maruyama"
    n = len(NOISE_M)
    m = np.diag(NOISE_M)
    k, c = storey_matrix(NOISE_K), storey_matrix(NOISE_C)
    minv = np.linalg.inv(m)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ k, -minv @ c]])
    b = np.zeros((2 * n, 1))
    b[n:, 0] = minv @ np.eye(n)[:, NOISE_FLOOR - 1] * SIGMA
    p = solve_continuous_lyapunov(a, -b @ b.T)
    exact = np.diag(p)[:n]  # (0.0488323, 0.178730, 0.306783) for these values
    assert np.allclose(a @ p + p @ a.T + b @ b.T, 0.0, atol=1e-12)

    frame = sample(study, workers=1)
    assert len(frame) == NOISE_N and (frame["status"] == "ok").all()
    for floor in range(1, n + 1):
        values = frame[f"x_rms_{floor}"].to_numpy() ** 2
        se = values.std(ddof=1) / np.sqrt(values.size)
        # power: the band must be narrow enough to catch a wrong floor or a wrong B (expected
        # about 0.02; floors' variances differ by factors 3.7 and 1.7)
        assert se / exact[floor - 1] < 0.05, (floor, se, exact[floor - 1])
        # 4 standard errors: a chance failure has probability 6e-5 per floor (the floors are
        # strongly correlated through mode 1, so hardly more for all three)
        assert abs(values.mean() - exact[floor - 1]) < 4 * se, (floor, values.mean(), exact[floor - 1], se)
    # the roof's column is the roof floor's
    assert (frame["x1_rms"] == frame[f"x_rms_{n}"]).all()


# ----------------------------------------------------------------------------- frequencies

ABS_MASS, ABS_K, ABS_C, ABS_FLOOR = 0.12, 2.0, 0.05, 2


def building_with_tmd(loads: list[dict] | None = None, dt: float = 1e-3) -> dict:
    return {"name": "three-storey-tmd",
            "primary": floors(NOISE_M, NOISE_K, NOISE_C),
            "absorbers": [{"type": "linear", "floor": ABS_FLOOR, "mass": ABS_MASS, "stiffness": ABS_K,
                           "damping": ABS_C}],
            "loads": loads or [],
            "simulation": {"duration": 10.0, "dt": dt}}


def full_matrices():
    """Mass and stiffness of the 3 floors plus the absorber DOF hung on floor ``ABS_FLOOR``."""
    n = len(NOISE_M)
    m = np.diag(NOISE_M + [ABS_MASS])
    k = np.zeros((n + 1, n + 1))
    k[:n, :n] = storey_matrix(NOISE_K)
    h = ABS_FLOOR - 1
    k[h, h] += ABS_K
    k[n, n] += ABS_K
    k[h, n] -= ABS_K
    k[n, h] -= ABS_K
    return m, k


def test_natural_frequencies_against_numpy():
    m, k = full_matrices()
    expected = np.sort(np.sqrt(np.linalg.eigvals(np.linalg.solve(m, k)).real))
    # (2.36368771, 4.16039787, 6.32579728, 8.98637999) rad/s: no two close, no coincidence
    scenario = study_from(building_with_tmd()).points[0]
    got = np.asarray(scenario.natural_frequencies(), dtype=float)
    # rtol 1e-10: both are eigenvalues of a well-conditioned 4x4 problem (round-off ~1e-15)
    np.testing.assert_allclose(got, expected, rtol=1e-10)
    assert scenario.highest_frequency() == pytest.approx(expected[-1], rel=1e-10)

    # a cubic NES without a linear spring is a free mass: one zero frequency, the rest are the
    # bare building's (atol 1e-6: sqrt of a round-off eigenvalue ~1e-14 is ~1e-7)
    cubic = {"name": "three-storey-nes",
             "primary": floors(NOISE_M, NOISE_K, NOISE_C),
             "absorbers": [{"type": "cubic", "floor": 1, "mass": 0.05, "stiffness": 1.0, "damping": 0.01}],
             "simulation": {"duration": 10.0, "dt": 1e-3}}
    bare = np.sort(np.sqrt(np.linalg.eigvals(np.linalg.solve(np.diag(NOISE_M), storey_matrix(NOISE_K))).real))
    got = np.asarray(study_from(cubic).points[0].natural_frequencies(), dtype=float)
    np.testing.assert_allclose(got, np.concatenate([[0.0], bare]), rtol=1e-10, atol=1e-6)

    # euler-maruyama (auto, with noise) is stable for omega_max dt < 2: 10 % past it is refused
    omega = expected[-1]
    noise = [{"type": "white-noise", "intensity": 0.1, "floor": 1}]
    study_from(building_with_tmd(noise, dt=float(f"{1.9 / omega:.6g}")))  # just inside: accepted
    with pytest.raises(ScenarioError) as err:
        study_from(building_with_tmd(noise, dt=float(f"{2.2 / omega:.6g}")))
    message = str(err.value)
    assert "simulation.dt" in message and f"{omega:.6g}" in message, message


# ----------------------------------------------------------------------------- impacts

# Building, absorbers and impulse of the deterministic comparison.  Chosen so that the path is
# well-posed: the reference's EDM moves by ~1.5e-7 for a 1e-7 relative change of X (no chaotic
# amplification), by < 5e-8 between rtol 1e-8 and 1e-12, and the impact count never changes;
# the slowest impact approaches at 0.149 X, the closest turning point that does not reach a wall
# stays 10.5 % of the clearance away from it, the last impact is 1.17 s before T.
# Reference (rtol 1e-11): EDM = 0.435290364632, 46 impacts (cubic viscous dissipation
# 0.00642498, impact losses 0.0131631, input 0.045).  The same reference with one floor matched
# the single-storey engine to 3e-11 in EDM with an identical impact count.
IMP_M, IMP_K, IMP_C = [1.0, 1.0, 1.0], [3.0, 2.5, 2.0], [0.01, 0.01, 0.01]
NES = dict(floor=1, mass=0.05, stiffness=3.0, damping=0.01)
VI = dict(floor=3, mass=0.05, clearance=0.08, restitution=0.7)
X, DURATION, DT = 0.3, 80.0, 1e-3


def reference_path(rtol: float = 1e-11, atol: float = 1e-13) -> dict:
    """DOP853 path of the building with the cubic NES and the impact absorber from a roof
    impulse; impacts located as terminal events, Newton map with the host floor, restart.

    State: floor positions, NES, VI positions, then the velocities in the same order, then the
    NES viscous dissipation and the storey dashpot dissipation (for the energy balance)."""
    n = len(IMP_M)
    nb = n + 2
    ic, ii = n, n + 1                       # body indices of the NES and the impact absorber
    hc, hi = NES["floor"] - 1, VI["floor"] - 1
    m = np.array(IMP_M)
    k, c = storey_matrix(IMP_K), storey_matrix(IMP_C)
    mc, kc, cc = NES["mass"], NES["stiffness"], NES["damping"]
    mi, gap, r = VI["mass"], VI["clearance"], VI["restitution"]
    storey_c = np.array(IMP_C)

    def rhs(t, y):
        x, v = y[:nb], y[nb:2 * nb]
        u, w = x[ic] - x[hc], v[ic] - v[hc]
        f = -kc * u**3 - cc * w             # force of the host floor on the NES
        acc = np.zeros(nb)
        acc[:n] = (-k @ x[:n] - c @ v[:n]) / m
        acc[hc] -= f / m[hc]
        acc[ic] = f / mc                    # the impact absorber flies freely between impacts
        drift_v = v[:n] - np.concatenate([[0.0], v[:n - 1]])
        return np.concatenate([v, acc, [cc * w * w, storey_c @ (drift_v * drift_v)]])

    def upper(t, y):                        # reaches +clearance while moving outward
        return y[ii] - y[hi] - gap

    def lower(t, y):                        # reaches -clearance while moving outward
        return y[ii] - y[hi] + gap

    def turn(t, y):                         # turning points of u (non-terminal, for margins)
        return y[nb + ii] - y[nb + hi]

    # direction: only outward crossings are impacts.  Right after the Newton map u sits on the
    # wall moving inward, so the same wall's function can only decrease: never retriggered.
    upper.terminal, upper.direction = True, 1.0
    lower.terminal, lower.direction = True, -1.0

    def energy(y):
        x, v = y[:nb], y[nb:2 * nb]
        d = x[:n] - np.concatenate([[0.0], x[:n - 1]])
        return (0.5 * m @ v[:n] ** 2 + 0.5 * mc * v[ic] ** 2 + 0.5 * mi * v[ii] ** 2
                + 0.5 * np.dot(IMP_K, d * d) + 0.25 * kc * (x[ic] - x[hc]) ** 4)

    y = np.zeros(2 * nb + 2)
    y[nb + n - 1] = X                       # roof impulse
    t, loss, speeds, times, turns = 0.0, 0.0, [], [], []
    while True:
        sol = solve_ivp(rhs, (t, DURATION), y, method="DOP853", rtol=rtol, atol=atol,
                        events=(upper, lower, turn))
        assert sol.status in (0, 1), sol.message
        turns.extend(np.abs(sol.y_events[2][:, ii] - sol.y_events[2][:, hi]) if sol.y_events[2].size else [])
        y, t = sol.y[:, -1].copy(), float(sol.t[-1])
        if sol.status == 0:
            break
        # guard: a retriggered wall would show as an impact right after the last one
        assert not times or t - times[-1] > 1e-6, (t, times[-1])
        assert len(times) < 1000, "chatter: the reference is not for sticking paths"
        vh, va = y[nb + hi], y[nb + ii]
        w = va - vh
        speeds.append(abs(w))
        times.append(t)
        loss += (1 - r * r) * m[hi] * mi / (2 * (m[hi] + mi)) * w * w
        vh_new = (m[hi] * vh + mi * va + mi * r * w) / (m[hi] + mi)  # momentum kept, w -> -r w
        y[nb + hi], y[nb + ii] = vh_new, vh_new - r * w
    input_energy = 0.5 * m[-1] * X**2
    residual = (input_energy - energy(y) - y[-2] - y[-1] - loss) / input_energy
    turns = np.array(turns)
    return dict(edm=(y[-2] + loss) / input_energy, impacts=len(times), speeds=np.array(speeds),
                times=np.array(times), residual=residual,
                closest_miss=gap - turns[turns < gap * (1 - 1e-9)].max())


def test_three_storey_cubic_and_impact_against_scipy():
    study = study_from({
        "name": "three-storey-nes-vi",
        "primary": floors(IMP_M, IMP_K, IMP_C),
        "absorbers": [{"type": "cubic", **NES}, {"type": "impact", **VI}],
        "loads": [{"type": "impulse", "velocity": X}],
        "simulation": {"duration": DURATION, "dt": DT},
    })
    assert study.points[0].scheme == "rk4"
    ref = reference_path()
    # the reference itself: its energy balance closes to round-off of rtol 1e-11 (about 2e-11)
    assert abs(ref["residual"]) < 1e-9
    # well-posed comparison: enough impacts, none grazing (no chatter), no near-miss of a wall
    # and none at the very end of the run, where the engine's tiny errors could flip the count
    assert ref["impacts"] >= 5
    assert ref["speeds"].min() > 1e-3 * X
    assert ref["closest_miss"] > 1e-3 * VI["clearance"]
    assert DURATION - ref["times"][-1] > 10 * DT

    frame = sample(study, workers=1)
    assert len(frame) == 1 and frame["status"].iloc[0] == "ok"
    row = frame.iloc[0]
    # 1e-4: the reference is good to ~1e-9 and the path is not chaotic, RK4 at dt = 1e-3 with
    # located impacts is good to ~1e-8 (3e-11 on the one-storey version of this scene); the
    # reference moves by 7e-4 with the NES on floor 2 instead of 1, by 5e-2 to 7e-2 with other
    # wrong host floors and by 1e-2 for r = 0.71, so the band still sees such mistakes
    assert abs(row["edm"] - ref["edm"]) < 1e-4, (row["edm"], ref["edm"])
    assert row["impacts"] == ref["impacts"]
    # 1e-6: the scheme's own balance error (RK4 at omega dt <= 0.005 plus located impacts)
    assert abs(row["energy_residual"]) < 1e-6
    assert row["input_energy"] == pytest.approx(0.5 * IMP_M[-1] * X**2, rel=1e-12)


# ----------------------------------------------------------------------------- bad input

def bad_data(primary: dict | None = None, absorber: dict | None = None, load: dict | None = None) -> dict:
    return {"name": "bad",
            "primary": primary or floors(NOISE_M, NOISE_K, NOISE_C),
            "absorbers": [absorber or {"type": "cubic", "mass": 0.05, "stiffness": 1.0, "damping": 0.01}],
            "loads": [load or {"type": "impulse", "velocity": 0.5}],
            "simulation": {"duration": 10.0, "dt": 1e-3}}


def rayleigh(modes: list[int]) -> dict:
    """Rayleigh damping of ratio 0.02 in ``modes``."""
    return {"ratio": 0.02, "modes": modes}


MASSES = {"masses": [1.0, 1.0, 0.8]}


@pytest.mark.parametrize("data, needles", [
    (bad_data(absorber={"type": "cubic", "floor": 5, "mass": 0.05, "stiffness": 1.0}),
     [("absorbers.0.floor",), ("[1, 3]",)]),
    (bad_data(load={"type": "harmonic", "amplitude": 0.1, "frequency": 1.0, "floor": 4}),
     [("loads.0.floor",), ("[1, 3]",)]),
    (bad_data(load={"type": "impulse", "velocity": 0.5, "floor": 0}),
     [("loads.0.floor",), ("[1, 3]",)]),
    # (no digit 3 in the values, so "3" can only be the expected length)
    (bad_data(primary=MASSES | {"stiffnesses": [20.0, 25.0], "dampings": [0.2, 0.2, 0.2]}),
     [("primary.stiffnesses",), ("3",)]),
    (bad_data(primary=MASSES | {"stiffnesses": [30.0, -25.0, 20.0], "dampings": [0.3, 0.3, 0.3]}),
     [("primary.stiffnesses",), (">= 0", "> 0")]),
    (bad_data(primary=MASSES | {"stiffnesses": [30.0, 25.0, 20.0], "rayleigh": rayleigh([1, 4])}),
     [("primary.rayleigh.modes",), ("[1, 3]",)]),
    (bad_data(primary=MASSES | {"stiffnesses": [30.0, 25.0, 20.0], "dampings": [0.3, 0.3, 0.3],
                                "rayleigh": rayleigh([1, 2])}),
     [("primary",), ("rayleigh", "dampings")]),
], ids=["absorber-floor", "force-load-floor", "impulse-floor", "lengths", "negative-storey",
        "rayleigh-modes", "dampings-and-rayleigh"])
def test_bad_multistorey_input(data, needles):
    """Each needle group is a set of alternatives, one of which the message must contain: the
    dotted key and the allowed range (the exact wording is the implementation's)."""
    with pytest.raises(ScenarioError) as err:
        study_from(data, source="<scenario>")
    message = str(err.value)
    assert message.startswith("<scenario>"), message
    for alternatives in needles:
        assert any(a in message for a in alternatives), (alternatives, message)


def test_bad_input_fixtures_are_otherwise_valid():
    """The bad scenarios differ from a runnable scenario only in the broken key."""
    study_from(bad_data())
    study_from(bad_data(primary=MASSES | {"stiffnesses": [30.0, 25.0, 20.0], "rayleigh": rayleigh([1, 3])}))


# ----------------------------------------------------------------------------- one storey

def one_storey(primary: dict):
    return study_from({"name": "one-storey",
                       "primary": primary,
                       "absorbers": [{"type": "cubic", "mass": 0.05, "stiffness": 1.0, "damping": 0.01}],
                       "loads": [{"type": "impulse", "velocity": 0.5}],
                       "simulation": {"duration": 50.0, "dt": 1e-3}})


def test_one_storey_lists_equal_scalars():
    lists = sample(one_storey(floors([1.0], [1.0], [0.02])), workers=1)
    scalars = sample(one_storey({"mass": 1.0, "stiffness": 1.0, "damping": 0.02}), workers=1)
    assert (lists["status"] == "ok").all()
    # exact: the same scene, so the same floating-point operations
    pd.testing.assert_frame_equal(lists, scalars, check_exact=True)
    for frame in (lists, scalars):
        assert (frame["x_max_1"] == frame["x1_max"]).all()
        assert (frame["x_rms_1"] == frame["x1_rms"]).all()
        assert (frame["drift_max_1"] == frame["x_max_1"]).all()  # d_1 = x_1 - 0


def floor_history(signals: list[str]):
    """The Study of the three-storey building of the Lyapunov test under noise (its loop) with
    the history of ``signals``."""
    return study_from({
        "name": "floor-history",
        "primary": floors(NOISE_M, NOISE_K, NOISE_C),
        "loads": [{"type": "white-noise", "intensity": 0.3, "floor": 1}],
        "simulation": {"duration": 5.0, "dt": 1e-2, "history": {"points": 51, "signals": signals}},
        "ensemble": {"realizations": 12, "seed": 3, "chunk": 5},
    })


def test_history_selects_floor_signals(tmp_path):
    """``history.signals`` names floor displacements and drifts: their ensemble means and
    standard deviations equal those of the stored paths (the kernel's rows of every floor's
    displacement, drift ``x_2 - x_1`` formed here) to round-off; ``x1`` is the roof's."""
    from vines_stoch.ensemble import run
    from vines_stoch.kernels import simulate
    from vines_stoch.kernels.chunk import realization_streams
    from vines_stoch.scene import build_scene

    study = floor_history(["x_1", "drift_2", "x1"])
    run(study, tmp_path, workers=1)
    h = pd.read_parquet(tmp_path / "history.parquet")
    scene = build_scene(study.points[0])
    stride = scene.n_steps // 50
    rows = np.empty((12, 51, 5))
    for r in range(12):
        rows[r] = np.nan
        simulate(scene, realization_streams(scene, 3, 0, r), history=rows[r], stride=stride)
    expected = {"x_1": rows[:, :, 2], "drift_2": rows[:, :, 3] - rows[:, :, 2], "x1": rows[:, :, 0]}
    np.testing.assert_array_equal(rows[:, :, 0], rows[:, :, 4])  # the roof is floor 3
    for name, paths in expected.items():
        np.testing.assert_allclose(h[f"{name}_mean"], paths.mean(axis=0), rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(h[f"{name}_std"], paths.std(axis=0, ddof=1), rtol=1e-11, atol=1e-15)
    assert "e1_mean" not in h.columns


def test_history_signal_out_of_range_is_refused():
    with pytest.raises(ScenarioError, match=r"simulation\.history\.signals.*'drift_4'.*\[1, 3\]"):
        floor_history(["drift_4"])


# ----------------------------------------------------------------------------- taller than a loop's room

#: Floors beyond what a loop's stack arrays hold when it reads the count at run time
#: (``protocol.ROOM``): such a structure runs a loop of its own sizes (``paths.spec_of``), whose
#: stack arrays hold those sizes (``protocol.rooms``).  Before, an array whose count numba typed
#: as a plain integer held ``ROOM`` items: 17 floors or more wrote past it (zero metrics or a crash).
TALL = ROOM + 4
TALL_K = 4.0 * TALL**2  # (the first mode near 1 rad/s, as make bench's floors)


def tall_frame(absorbers: list[dict], loads: list[dict], **simulation) -> dict:
    """A shear frame of ``TALL`` unit floors with ``absorbers`` and ``loads``."""
    return {"name": "tall", "primary": floors([1.0] * TALL, [TALL_K] * TALL, [0.05] * TALL),
            "absorbers": absorbers, "loads": loads, "simulation": simulation}


def test_a_frame_taller_than_the_loops_room_against_scipy():
    """RK4: a roof impulse on the frame with a cubic NES on the roof, against DOP853 at rtol
    1e-12 (which moves by 3e-10 from rtol 1e-10): the final state converges to it at the scheme's
    order, the largest error divided by 15.6 (4th order: 16; asked: 12 to 20) from dt = 1e-3 to
    5e-4, where it is 1.3e-6 of the largest state value (the roof's impulse excites the modes up
    to omega_max = 80 rad/s, omega_max dt = 0.04)."""
    nes = {"type": "cubic", "mass": 0.05, "stiffness": 50.0, "damping": 0.02}
    m, k, c = np.ones(TALL), storey_matrix([TALL_K] * TALL), storey_matrix([0.05] * TALL)

    def rhs(t, y):
        x, v = y[:TALL + 1], y[TALL + 1:]
        u, w = x[TALL] - x[TALL - 1], v[TALL] - v[TALL - 1]
        f = -nes["stiffness"] * u**3 - nes["damping"] * w  # (the roof's force on the NES)
        acc = np.append((-k @ x[:TALL] - c @ v[:TALL]) / m, f / nes["mass"])
        acc[TALL - 1] -= f
        return np.concatenate([v, acc])

    y0 = np.zeros(2 * (TALL + 1))
    y0[2 * TALL] = 1.0  # (the roof's velocity)
    ref = solve_ivp(rhs, (0.0, 5.0), y0, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
    errors = []
    for dt in (1e-3, 5e-4):
        final = np.zeros((2, TALL + 1))
        simulate(scene_from(tall_frame([nes], [{"type": "impulse", "velocity": 1.0}], duration=5.0, dt=dt,
                                       scheme="rk4")), final=final)
        errors.append(np.abs(np.concatenate([final[0], final[1]]) - ref).max())
    assert errors[1] < 2e-6 * np.abs(ref).max() and 12.0 < errors[0] / errors[1] < 20.0, errors


def test_a_frame_taller_than_the_loops_room_takes_the_input_of_its_noise():
    """Kick-drift-kick: white noise of intensity s on the roof feeds in ``s^2 T / (2 m)`` on average
    over a window T, whatever the structure (the roof's unit mass), with a cubic NES on the roof and
    an impact absorber below it: 32 paths within 4 standard errors, and each path's energy
    balance closed (``energy_residual`` below 1e-3)."""
    absorbers = [{"type": "cubic", "mass": 0.05, "stiffness": 50.0, "damping": 0.02},
                 {"type": "impact", "floor": TALL - 1, "mass": 0.05, "clearance": 0.002, "restitution": 0.7}]
    data = tall_frame(absorbers, [{"type": "white-noise", "intensity": 0.5}], duration=4.0, dt=1e-3)
    data["ensemble"] = {"realizations": 32, "seed": 3}
    frame = sample(study_from(data), workers=1)
    assert (frame["status"] == "ok").all() and (frame["energy_residual"].abs() < 1e-3).all()
    expected = 0.5**2 * 4.0 / 2.0
    mean, se = frame["input_energy"].mean(), frame["input_energy"].std(ddof=1) / np.sqrt(len(frame))
    assert abs(mean - expected) < 4.0 * se, (mean, expected, se)
    assert frame["impacts"].sum() > 0
