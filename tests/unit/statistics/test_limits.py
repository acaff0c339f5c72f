"""Limits (SCENARIOS.md ``[limits]``): first passages recorded in the step loops, exceedance
fractions with their 95 % intervals.

The exceedance probability of a linear SDOF from rest under white noise is checked against
an independent Monte Carlo estimate drawn here from the exact Gaussian transition of ``(x, v)``
over one step (Van Loan's matrix exponential: C. F. Van Loan, IEEE Trans. Autom. Control 23
(1978) 395, DOI 10.1109/TAC.1978.1101743), monitored on the same grid as the kernel's peaks
(the step ends), so the two estimate one number up to the scheme's weak error (``omega dt =
0.031``: the stationary variance of the kick-drift-kick step is exact to ``O((omega dt)^2)``,
far below the standard errors).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy.linalg import expm
from scipy.optimize import brentq

from tests.helpers import study_from
from vines_stoch.ensemble import sample
from vines_stoch.metrics import exceedance, summarise

OMEGA, ZETA, SIGMA, T, DT, LIMIT = 2.0 * math.pi, 0.05, 1.0, 5.0, 0.005, 0.25
N, GROUP = 8000, 40


def sdof(limits: dict, realizations: int = N, omega: float = OMEGA, zeta: float = ZETA,
         load: dict | None = None, duration: float = T, dt: float = DT) -> dict:
    """A unit-mass oscillator of ``omega`` and ``zeta`` under ``load`` (white noise ``SIGMA`` by
    default) with ``limits``."""
    return {"name": "sdof-limits",
            "primary": {"mass": 1.0, "stiffness": omega**2, "damping": 2 * zeta * omega},
            "loads": [load or {"type": "white-noise", "intensity": SIGMA}],
            "simulation": {"duration": duration, "dt": dt},
            "ensemble": {"realizations": realizations, "seed": 11},
            "limits": limits}


def exact_transition_exceedance(n_paths: int, seed: int) -> float:
    """Fraction of paths of ``dx = v dt, dv = (-omega^2 x - 2 zeta omega v) dt + sigma dW``
    from rest whose ``|x|`` exceeds ``LIMIT`` at a step end, drawn step by step from the exact
    Gaussian transition (mean ``Phi X``, covariance ``Q`` from Van Loan's exponential)."""
    f = np.array([[0.0, 1.0], [-OMEGA**2, -2.0 * ZETA * OMEGA]])
    qc = np.array([[0.0, 0.0], [0.0, SIGMA**2]])
    block = expm(np.block([[-f, qc], [np.zeros((2, 2)), f.T]]) * DT)
    phi = block[2:, 2:].T
    q = phi @ block[:2, 2:]
    root = np.linalg.cholesky(0.5 * (q + q.T))
    gen = np.random.default_rng(seed)
    state = np.zeros((2, n_paths))
    passed = np.zeros(n_paths, bool)
    for _ in range(round(T / DT)):
        state = phi @ state + root @ gen.standard_normal((2, n_paths))
        passed |= np.abs(state[0]) > LIMIT
    return float(passed.mean())


def test_exceedance_of_a_linear_oscillator_against_the_exact_gaussian_transition():
    frame = sample(study_from(sdof({"roof": {"metric": "x1_max", "value": LIMIT}})))
    summary = summarise(frame, [])
    p = float(summary["p_roof"].iloc[0])
    n_ref = 100_000
    p_ref = exact_transition_exceedance(n_ref, seed=5)
    assert 0.2 < p_ref < 0.8  # a limit that tells something
    se = math.sqrt(p * (1 - p) / N + p_ref * (1 - p_ref) / n_ref)
    assert abs(p - p_ref) < 4 * se, (p, p_ref, se)
    assert summary["p_roof_lo"].iloc[0] < p < summary["p_roof_hi"].iloc[0]

    # coverage of the 95 % interval over independent ensembles of GROUP realisations (the
    # realisations' streams are independent, as other seeds' would be): the count covering
    # p_ref is binomial(groups, c) with c the interval's coverage, which for Wilson's interval
    # at n = 40 stays within 0.03 of 95 % (Brown, Cai and DasGupta, Stat. Sci. 16 (2001) 101,
    # DOI 10.1214/ss/1009213286); a band of 3 binomial standard deviations on top
    groups = frame.assign(point=frame["realization"] // GROUP)
    per_group = summarise(groups, [])
    covered = ((per_group["p_roof_lo"] <= p_ref) & (p_ref <= per_group["p_roof_hi"])).mean()
    sd = math.sqrt(0.95 * 0.05 / len(per_group))
    assert len(per_group) == N // GROUP
    assert 0.95 - 0.03 - 3 * sd < covered, covered


def test_exceedance_interval_at_the_ends():
    """No exceedance: the interval is [0, hi > 0]; every realisation: [lo < 1, 1]; no
    realisation ended ok: undefined."""
    p, lo, hi = exceedance(0, 50)
    assert p == 0.0 and lo == 0.0 and 0.0 < hi < 0.1
    p, lo, hi = exceedance(50, 50)
    assert p == 1.0 and 0.9 < lo < 1.0 and hi == 1.0
    assert all(math.isnan(v) for v in exceedance(0, 0))


IMPACT = [{"type": "impact", "floor": 1, "mass": 0.1, "stiffness": 5.0, "clearance": 0.05,
           "restitution": 0.7}]
NOISE = [{"type": "white-noise", "intensity": 2.0, "floor": 1}, {"type": "white-noise", "intensity": 1.0}]
IMPULSE = [{"type": "impulse", "velocity": 1.0}]

WATCHED = ["x1_max", "e1_max", "x_max_1", "drift_max_1", "drift_max_2", "acc_max_1", "acc_max_2"]


def _building(absorbers: list[dict], loads: list[dict], simulation: dict, sweep: dict,
              limits: dict[str, float]) -> pd.DataFrame:
    """A sample of the two-storey building (one realisation a sweep point, else 60) with a limit
    ``w<i>`` on each metric of ``limits`` at its value; ``simulation``: more keys of its table."""
    return sample(study_from({
        "name": "two-storey-limits",
        "primary": {"masses": [2.0, 1.0], "stiffnesses": [200.0, 120.0], "dampings": [0.8, 0.5]},
        "absorbers": absorbers,
        "loads": loads,
        "simulation": {"duration": 8.0, "dt": 0.002, "metrics_from": 1.0, **simulation},
        "ensemble": {"realizations": 1 if sweep else 60, "seed": 4},
        "sweep": sweep,
        "limits": {f"w{i}": {"metric": m, "value": v} for i, (m, v) in enumerate(limits.items())},
    }))


def test_first_passage_exactly_when_the_peak_exceeds_the_limit():
    """Limits at the median of their metric: a first passage in [metrics_from, duration]
    exactly in the realisations whose metric exceeds the value, every other column the
    same as without limits (the check does not touch the motion); kick-drift-kick with an
    impact absorber under noise, SRA3 under noise, RK4 with impacts over a sweep."""
    cases = [
        (IMPACT, NOISE, {}, {}),
        ([], NOISE, {"scheme": "sra"}, {}),
        (IMPACT, IMPULSE, {"scheme": "rk4"}, {"loads.0.velocity": {"linspace": [0.2, 2.0, 15]}}),
    ]
    for absorbers, loads, simulation, sweep in cases:
        scheme = simulation.get("scheme", "auto")
        plain = _building(absorbers, loads, simulation, sweep, {})
        assert (plain["status"] == "ok").all()
        medians = {m: float(plain[m].median()) for m in WATCHED}
        frame = _building(absorbers, loads, simulation, sweep, medians)
        pd.testing.assert_frame_equal(frame[plain.columns], plain)
        for i, (m, value) in enumerate(medians.items()):
            first = frame[f"first_passage_w{i}"]
            assert (first.notna() == (frame[m] > value)).all(), (scheme, m)
            assert 0 < first.notna().sum() < len(frame), (scheme, m)
            assert first.dropna().between(1.0, 8.0).all(), (scheme, m)
        summary = summarise(frame, ["loads.0.velocity"] if sweep else [])
        if not sweep:
            assert summary["p_w0"].iloc[0] == (frame["x1_max"] > medians["x1_max"]).mean()


def test_first_passage_time_of_free_vibration():
    """A damped SDOF after an impulse, ``x = (v0 / omega_d) exp(-zeta omega t) sin(omega_d t)``:
    the first passage of ``|x| > b`` (b below the first peak) is the root of ``x(t) = b`` on
    the first rise; RK4 records the end of the step in which the peak passes it."""
    omega, zeta, v0, dt = 3.0, 0.04, 1.0, 1e-3
    wd = omega * math.sqrt(1 - zeta**2)

    def x(t: float) -> float:
        return v0 / wd * math.exp(-zeta * omega * t) * math.sin(wd * t)

    peak_time = math.atan(wd / (zeta * omega)) / wd
    b = 0.8 * x(peak_time)
    exact = brentq(lambda t: x(t) - b, 0.0, peak_time, xtol=1e-14)
    limits = {"b": {"metric": "x1_max", "value": b},
              "never": {"metric": "x1_max", "value": 1.01 * x(peak_time)}}
    frame = sample(study_from(sdof(limits, 1, omega, zeta, {"type": "impulse", "velocity": v0}, 3.0, dt)))
    first = float(frame["first_passage_b"].iloc[0])
    assert exact <= first < exact + dt + 1e-12, (first, exact)
    assert math.isnan(frame["first_passage_never"].iloc[0])


def test_bad_limits_are_named_with_their_key_value_and_range():
    from vines_stoch.scenario import ScenarioError

    def message(limits: dict) -> str:
        try:
            study_from(sdof(limits, realizations=1), source="x.toml")
        except ScenarioError as error:
            return str(error)
        raise AssertionError(f"accepted: {limits}")

    text = message({"r": {"metric": "x_max_2", "value": 0.1}})
    assert "x.toml: limits.r.metric = 'x_max_2'" in text and "k in [1, 1]" in text
    text = message({"r": {"metric": "x1_rms", "value": 0.1}})
    assert "limits.r.metric" in text and "peak metric" in text
    assert "limits.r.value = 0" in message({"r": {"metric": "x1_max", "value": 0}})
    assert "limits.r.value" in message({"r": {"metric": "x1_max", "value": math.nan}})
    text = message({"2nd": {"metric": "x1_max", "value": 0.1}})
    assert "limits = '2nd'" in text and "start with a letter" in text
    assert "limits.r.level" in message({"r": {"metric": "x1_max", "value": 0.1, "level": 2}})
