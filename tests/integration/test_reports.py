"""report and compare on small result directories made here."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from tests.helpers import study_from, two_dof_data
from vines_stoch import run
from vines_stoch.reports import Run, compare, effective_range, report


def scenario(name: str, k3: float, seed: int) -> dict:
    """An impulse sweep of the undamped primary with a cubic NES of stiffness ``k3`` and an
    uncertain damping."""
    return {
        "name": name,
        **two_dof_data(0.0, k3),
        "loads": [{"type": "impulse", "velocity": 0.5}],
        "simulation": {"duration": 20.0, "dt": 1e-2, "history": {"points": 50}},
        "ensemble": {"realizations": 12, "seed": seed},
        "sweep": {"loads.0.velocity": [0.1, 0.5, 2.0]},
        "uncertain": {"absorbers.0.damping": {"distribution": "uniform", "low": 0.005, "high": 0.05}},
    }


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("runs")
    for name, k3, seed in (("soft", 1.0, 3), ("stiff", 4.0, 3), ("other-seed", 4.0, 4)):
        run(study_from(scenario(name, k3, seed)), root / name, workers=2)
    return root


def test_compare_pairs_runs_with_common_random_numbers(runs):
    soft, stiff, other = (Run.read(runs / n) for n in ("soft", "stiff", "other-seed"))
    table = compare([soft, stiff, other], ("edm",))
    for p in range(3):
        row = table[table["point"] == p].iloc[0]
        a = soft.realizations[soft.realizations["point"] == p]["edm"].to_numpy()
        b = stiff.realizations[stiff.realizations["point"] == p]["edm"].to_numpy()
        assert row["paired (stiff)"] == "yes"
        assert row["stiff - soft"] == pytest.approx(np.mean(b - a), rel=1e-12)
        assert row["se (stiff)"] == pytest.approx(np.std(b - a, ddof=1) / math.sqrt(12), rel=1e-12)
        # a different seed cannot be paired: independent standard errors combine
        assert row["paired (other-seed)"] == "no"
        sems = [r.summary["edm_sem"].iloc[p] for r in (soft, other)]
        assert row["se (other-seed)"] == pytest.approx(math.hypot(*sems), rel=1e-12)


def test_effective_range_lists_the_points_above_the_level(runs):
    soft = Run.read(runs / "soft")
    s = soft.summary
    above = s[s["edm_mean"] >= 0.3]["loads.0.velocity"]
    text = effective_range(soft, 0.3)["loads.0.velocity where mean EDM >= 0.3"]
    if above.empty:
        assert text == "none"
    else:
        assert text.startswith(f"{above.min():.4g} to {above.max():.4g} ({len(above)} of 3 points)")


def test_report_writes_markdown_and_plots(runs, tmp_path):
    path = report([runs / "soft", runs / "stiff"], tmp_path, ["soft", "stiff"], point=1)
    text = path.read_text()
    assert path == tmp_path / "soft" / "report.md"
    for name in ("edm_vs_input_energy.png", "energy_integral_vs_sweep.png", "edm_histogram.png",
                 "primary_energy_history.png"):
        assert (path.parent / name).stat().st_size > 10_000  # a rendered figure, not an empty file
        assert f"]({name})" in text
    assert "## Where mean EDM >= 0.8" in text and "## Comparison" in text
    assert "stiff - soft" in text


def test_compare_command_prints_and_writes(runs, tmp_path):
    out = tmp_path / "cmp.md"
    done = subprocess.run([sys.executable, "-m", "vines_stoch.cli", "compare", str(runs / "soft"),
                           str(runs / "stiff"), "--out", str(out), "--metric", "edm"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "stiff - soft" in done.stdout and out.read_text().count("| edm |") == 3
    bad = subprocess.run([sys.executable, "-m", "vines_stoch.cli", "compare", str(runs / "soft"),
                          str(tmp_path)], capture_output=True, text=True)
    assert bad.returncode == 2 and "no summary.parquet" in bad.stderr


def test_report_draws_and_words_the_estimates(tmp_path):
    """A noise sweep of an oscillator with a cubic NES, weak to strong: the report's estimates
    section tabulates each estimated metric beside its mean, names in words the points where
    they part by more than 3 standard errors (the strong noise: the response is far from
    Gaussian), and draws the means and estimates on the same axes."""
    data = {"name": "estimated", **two_dof_data(0.02, 1.0),
            "loads": [{"type": "white-noise", "intensity": 0.005}],
            "simulation": {"duration": 400.0, "dt": 1e-2, "metrics_from": 200.0},
            "ensemble": {"realizations": 200, "seed": 3},
            "sweep": {"loads.0.intensity": [0.005, 0.05]}}
    run(study_from(data), tmp_path / "run", workers=2)
    path = report([tmp_path / "run"], tmp_path / "out")
    text = path.read_text()
    assert "## Estimates beside the Monte Carlo: " in text and "x1_rms_estimate" in text
    assert "point 1: x1_rms Monte Carlo" in text and "point 0: x1_rms" not in text
    assert (path.parent / "estimates.png").stat().st_size > 10_000 and "](estimates.png)" in text


def test_compare_takes_exceedance_and_floor_metrics(tmp_path):
    """``compare`` of two designs on common random numbers: a limit's ``p_NAME`` (each run's
    fraction, the paired difference of the exceedance indicators) and a floor's metric; an unknown
    metric is refused with the list of those it takes."""
    roots = []
    for name, k3 in (("soft", 1.0), ("stiff", 4.0)):
        data = {"name": name, **two_dof_data(0.02, k3),
                "loads": [{"type": "white-noise", "intensity": 0.05}],
                "simulation": {"duration": 50.0, "dt": 1e-2}, "ensemble": {"realizations": 40, "seed": 5},
                "limits": {"roof": {"metric": "x1_max", "value": 0.15}}}
        roots.append(tmp_path / name)
        run(study_from(data), roots[-1], workers=1)
    soft, stiff = (Run.read(r) for r in roots)
    table = compare([soft, stiff], ("p_roof", "x_max_1")).set_index("metric")
    assert table.loc["p_roof", "soft"] == soft.summary["p_roof"].iloc[0]
    hit = [r.realizations["first_passage_roof"].notna().to_numpy(dtype=float) for r in (soft, stiff)]
    assert 0 < hit[0].mean() < 1
    assert table.loc["p_roof", "stiff - soft"] == pytest.approx(np.mean(hit[1] - hit[0]), abs=1e-12)
    assert table.loc["p_roof", "paired (stiff)"] == "yes"
    assert table.loc["x_max_1", "soft"] == soft.summary["x_max_1_mean"].iloc[0]
    command = ["compare", *map(str, roots), "--metric", "p_roof", "--label", "k3 = 1", "--label", "k3 = 4",
               "--out", str(tmp_path / "l.md")]
    labelled = subprocess.run([sys.executable, "-m", "vines_stoch.cli", *command], capture_output=True,
                              text=True)
    assert labelled.returncode == 0 and "k3 = 4 - k3 = 1" in labelled.stdout, labelled.stderr
    command = ["compare", *map(str, roots), "--metric", "p_nothing", "--out", str(tmp_path / "c.md")]
    bad = subprocess.run([sys.executable, "-m", "vines_stoch.cli", *command], capture_output=True, text=True)
    assert bad.returncode == 2 and "--metric p_nothing: must be one of" in bad.stderr
    assert "p_roof" in bad.stderr
