"""Seed 000 (Wei et al. 2019), Figs. 7-11: the primary under a harmonic force at its natural frequency,
the same force plus white noise (eq. 22) and second-order filtered noise (eq. 23, eta = 0.002), each
with no NES, the cubic NES alone and the parallel NES (``scenarios/seed000_<case>_<twin>.toml``, a
reconstruction: their headers say what is assumed).  The paper prints no number for these figures; the
tests hold what its text says: both absorbers suppress the primary's displacement and the parallel NES
suppresses it more than the cubic NES, under each load.

Tolerances.  The harmonic scenes are deterministic: the bare primary's steady displacement rms is
``f / (c1 omega sqrt(2))``, and the window starts after five decay times (the start-up transient down
to e^-5 = 0.7 % of the steady amplitude): within 1 %.  Under noise a twin's steady ``x1_rms`` is compared
with another's over the same realisations (the twins draw the same forcing path: same seed, point and
realisation), so the paired differences give the standard error; a difference is tested at four
standard errors (a false failure once in 15,000 runs), on 32 realisations (the filtered noise
is correlated over 500 time units, the window's length: its gaps are the noisiest, 10 standard errors)."""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest

from tests.helpers import example_data, study_from
from vines_stoch.ensemble import run_chunk
from vines_stoch.scene import build_scene

#: Realisations of each noisy twin in these tests.
REALIZATIONS = 32
#: Standard errors a tested difference must exceed.
Z = 4.0
TWINS = ("none", "cubic", "parallel")


@cache
def metrics(case: str, twin: str) -> dict[str, np.ndarray]:
    """Steady ``x1_rms`` and ``edm`` of each realisation of sweep point 0 of
    ``scenarios/seed000_<case>_<twin>.toml`` (the reconstruction's load)."""
    data = example_data(f"seed000_{case}_{twin}")
    point = study_from(data).points[0]
    seed = data.get("ensemble", {}).get("seed", 0)
    realizations = 1 if case == "harmonic" else REALIZATIONS
    rows = run_chunk(build_scene(point), seed, 0, 0, realizations)[0]
    assert (rows["status"] == "ok").all()
    return {"x1_rms": rows["x1_rms"].to_numpy(), "edm": rows["edm"].to_numpy()}


def test_harmonic_bare_primary_is_the_closed_form_steady_state():
    data = example_data("seed000_harmonic_none")
    (load,) = data["loads"]
    steady = load["amplitude"] / (data["primary"]["damping"] * load["frequency"] * math.sqrt(2.0))
    assert metrics("harmonic", "none")["x1_rms"][0] == pytest.approx(steady, rel=0.01)


def test_harmonic_each_absorber_suppresses_the_primary_the_parallel_most():
    """Fig. 8: the parallel NES's primary swings less than the cubic NES's (held at a factor 5;
    measured 7.5)."""
    none, cubic, parallel = (metrics("harmonic", twin)["x1_rms"][0] for twin in TWINS)
    assert cubic < 0.7 * none
    assert parallel < 0.2 * cubic


def paired_gap(case: str, metric: str, larger: str, smaller: str) -> tuple[float, float]:
    """Mean and standard error of ``metric(larger) - metric(smaller)`` over the same realisations."""
    gap = metrics(case, larger)[metric] - metrics(case, smaller)[metric]
    return float(gap.mean()), float(gap.std(ddof=1) / math.sqrt(len(gap)))


@pytest.mark.parametrize("case", ["harmonic_noise", "filtered_noise"])
@pytest.mark.parametrize("larger, smaller", [("none", "cubic"), ("cubic", "parallel")])
def test_noise_the_parallel_nes_suppresses_the_primary_most(case, larger, smaller):
    """Figs. 9-11: no NES > cubic NES > parallel NES in the primary's steady displacement rms."""
    mean, sem = paired_gap(case, "x1_rms", larger, smaller)
    assert mean > Z * sem


@pytest.mark.parametrize("case", ["harmonic_noise", "filtered_noise"])
def test_noise_the_parallel_nes_takes_more_of_the_input(case):
    """Figs. 10-11: "the parallel NES works better through the energy exchange of impact"."""
    mean, sem = paired_gap(case, "edm", "parallel", "cubic")
    assert mean > Z * sem


def test_harmonic_the_parallel_nes_shows_a_strongly_modulated_response():
    """Fig. 7's SMR at the assumed values of ``seed000_harmonic_parallel_smr.toml`` (k2 = 1,
    clearance 0.1): the primary's amplitude once a period, ``|x + i v|``, swings by more than a
    factor 3 over the window and repeats at no period up to 8T; the parallel NES's peak
    displacement is below the cubic NES alone's (its twin without the impact NES), both far
    below the bare primary's, as Figs. 7-8 say.  The label (``modulated`` or ``chaotic``) is not
    held: the exponent sits within a factor 2 of the chaos threshold."""
    from vines_stoch import run

    data = example_data("seed000_harmonic_parallel_smr")
    parallel = run(data)
    amplitude = np.hypot(parallel.poincare["x_1"], parallel.poincare["v_1"])
    row = parallel.realizations.iloc[0]
    assert amplitude.max() > 3 * amplitude.min()
    assert row["regime"] in ("modulated", "chaotic")
    cubic = run({**data, "absorbers": data["absorbers"][:1]}).realizations.iloc[0]
    bare = run({**data, "absorbers": []}).realizations.iloc[0]
    assert row["x1_max"] < cubic["x1_max"] and cubic["x1_max"] < 0.5 * bare["x1_max"]  # (0.89, 0.26 measured)
