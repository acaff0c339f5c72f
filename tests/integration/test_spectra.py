"""Spectra (``[output] spectra``): the ensemble-averaged Welch PSD of a linear oscillator under
white and under filtered noise against the closed forms ``|H|^2 S``, inside the band the
estimator gives; the same spectra in memory, from a folder and for any chunk size; drawn in the
report."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from tests.helpers import run_interrupted
from vines_stoch import ScenarioError, read_results, run
from vines_stoch.reports import report

M, K, C, SIGMA = 1.0, 1.0, 0.4, 1.0   # (damping ratio 0.2: a resonance 0.4 rad/s wide)
W0, ETA = 2.0, 0.3                     # the force filter of the filtered-noise case


def oscillator(load: dict, realizations: int = 40) -> dict:
    """The oscillator under ``load``, 2,000 s of stationary response a realisation (after 100 s
    from rest: the start-up decays as exp(-0.2 t)), Welch segments of 200 s (0.031 rad/s apart)."""
    return {"name": "spectra", "primary": {"mass": M, "stiffness": K, "damping": C}, "loads": [load],
            "simulation": {"duration": 2100.0, "dt": 0.02, "metrics_from": 100.0},
            "ensemble": {"realizations": realizations, "seed": 3},
            "output": {"spectra": {"signals": ["x1", "v_1"], "segment": 200.0}}}


def response(omega: np.ndarray) -> np.ndarray:
    """|H|^2 of the oscillator's displacement to its force."""
    return 1.0 / np.abs(K - M * omega**2 + 1j * C * omega) ** 2


CASES = {
    # white noise F dt = sigma dW: one-sided force PSD sigma^2 / pi per rad/s
    "white": ({"type": "white-noise", "intensity": SIGMA}, lambda w: SIGMA**2 / math.pi * response(w)),
    # filtered noise f'' + 2 eta w0 f' + w0^2 f = sigma xi, F = f: the same through the filter
    "filtered": ({"type": "filtered-noise", "intensity": SIGMA, "frequency": W0, "damping": ETA},
                 lambda w: SIGMA**2 / math.pi * response(w) / np.abs(W0**2 - w**2 + 2j * ETA * W0 * w) ** 2),
}


@pytest.mark.parametrize("case", CASES)
def test_psd_of_a_linear_oscillator_against_its_closed_form(case):
    load, exact = CASES[case]
    spectra = run(oscillator(load)).spectra
    x = spectra[spectra["signal"] == "x1"]
    shown = x[(x["omega"] > 0.05) & (x["omega"] < 5.0)]
    w = shown["omega"].to_numpy()
    theory = exact(w)
    outside = (theory < shown["psd_lo"].to_numpy()) | (theory > shown["psd_hi"].to_numpy())
    # a 95 % band: about 5 % of the frequencies outside it; neighbouring Welch estimates are
    # correlated (Hann segments overlapping by half), so the fraction scatters more than a
    # binomial's (about 0.02 over these 158 frequencies): at most 12 %
    assert outside.mean() <= 0.12, (case, outside.mean(), w[outside])
    # and the band is narrow: 40 realisations of 19 segments, a relative standard error of about
    # 1 / sqrt(40 * 19 / 1.06) = 0.037 a frequency
    half = 0.5 * (shown["psd_hi"] - shown["psd_lo"]) / shown["psd"]
    assert 0.05 < half.median() < 0.1
    # the variance: the integral of the one-sided density over all frequencies
    total = np.trapezoid(x["psd"], x["omega"])
    wide = np.linspace(0.0, x["omega"].max(), 400_001)
    assert total == pytest.approx(np.trapezoid(exact(wide), wide), rel=0.05)
    # the velocity's density is omega^2 times the displacement's
    v = spectra[spectra["signal"] == "v_1"]
    v = v[(v["omega"] > 0.05) & (v["omega"] < 5.0)]
    inside = (v["psd_lo"] <= exact(w) * w**2) & (exact(w) * w**2 <= v["psd_hi"])
    assert inside.to_numpy().mean() >= 0.88


def test_the_same_spectra_in_memory_from_a_folder_and_in_any_chunks(tmp_path):
    data = oscillator(CASES["white"][0], realizations=6)
    data["simulation"] = {**data["simulation"], "duration": 300.0, "history": {"points": 11}}
    data["output"] = {"spectra": {"signals": ["x1"]}}
    whole = run(data, workers=1)
    run(data, tmp_path / "out", chunk=2, workers=2)
    back = read_results(tmp_path / "out")
    pd.testing.assert_frame_equal(back.spectra, whole.spectra, check_exact=True)
    pd.testing.assert_frame_equal(back.history, whole.history, check_exact=True)
    assert list(whole.spectra.columns) == ["point", "signal", "omega", "psd", "psd_lo", "psd_hi"]
    # the default segments: 15 in the 200 s window, overlapping by half (25 s, 0.25 rad/s apart)
    assert np.diff(whole.spectra["omega"].to_numpy()[:2])[0] == pytest.approx(2 * math.pi / 25.0)
    page = report([tmp_path / "out"], tmp_path / "report")  # (drawn with their bands)
    assert (page.parent / "spectra.png").stat().st_size > 10_000 and "](spectra.png)" in page.read_text()


def test_a_signal_that_is_none_and_a_segment_past_the_window_are_refused():
    data = oscillator(CASES["white"][0])
    data["output"] = {"spectra": {"signals": ["x2"]}}
    with pytest.raises(ScenarioError, match=r"output\.spectra\.signals.*'x2' is not a signal"):
        run(data)
    data["output"] = {"spectra": {"segment": 5000.0}}
    with pytest.raises(ScenarioError, match=r"output\.spectra\.segment = 5000.*must be in"):
        run(data)


def test_an_interrupted_run_resumes_its_spectra_from_the_checkpoint(tmp_path, monkeypatch):
    """The spectra's running sums are checkpointed as the history's are: an interruption after
    some chunks and a resume give the spectra of an uninterrupted run, bit for bit."""
    data = oscillator(CASES["white"][0], realizations=12)
    data["simulation"] = {**data["simulation"], "duration": 200.0}
    data["output"] = {"spectra": {"signals": ["x1"]}}
    data["ensemble"] = {**data["ensemble"], "chunk": 2}
    reference = run(data, tmp_path / "ref", workers=2)
    run_interrupted(monkeypatch, data, tmp_path / "cut", 3, workers=2)
    assert not (tmp_path / "cut" / "spectra.parquet").exists()
    resumed = run(data, tmp_path / "cut", workers=2, resume=True)
    pd.testing.assert_frame_equal(resumed.spectra, reference.spectra, check_exact=True)
