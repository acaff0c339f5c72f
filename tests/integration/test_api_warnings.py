"""Warnings reach Python users (a notebook, a script) as the command line prints them: each
through ``warnings.warn`` with a category of the package's own, filterable as usual."""

from __future__ import annotations

import warnings

import pytest

import vines_stoch
from tests.helpers import cli, toml_text


def coarse(realizations: int = 1) -> dict:
    """An oscillator of period 6.28 with dt = 0.5: stable, coarse (12.6 steps a period), and its
    energy balance off by 0.65 %."""
    return {"name": "coarse", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.05},
            "loads": [{"type": "impulse", "velocity": 1.0}], "simulation": {"duration": 50.0, "dt": 0.5},
            "ensemble": {"realizations": realizations}}


def test_a_coarse_step_warns_in_python():
    with pytest.warns(vines_stoch.CoarseStepWarning, match=r"simulation.dt = 0.5: coarse") as caught:
        vines_stoch.run(coarse())
    ours = [w for w in caught if issubclass(w.category, vines_stoch.VinesStochWarning)]
    assert vines_stoch.EnergyBalanceWarning in {w.category for w in ours}
    assert all(w.filename == __file__ for w in ours)  # (they point at the user's call)


def test_identical_realisations_warn_and_filter_as_usual():
    with pytest.warns(vines_stoch.IdenticalRealizationsWarning, match="every realisation would be the same"):
        vines_stoch.run(coarse(realizations=5))
    with warnings.catch_warnings():
        warnings.simplefilter("error", vines_stoch.VinesStochWarning)
        with pytest.raises(vines_stoch.CoarseStepWarning):
            vines_stoch.run(coarse())


def test_the_command_line_prints_each_warning_once(tmp_path):
    path = tmp_path / "coarse.toml"
    path.write_text(toml_text(coarse()))
    code, err = cli("run", path, "--out", tmp_path / "out", "--quiet")
    assert code == 0, err
    assert err.count("simulation.dt = 0.5: coarse") == 1 and err.count("energy balance does not close") == 1
    assert "Warning" not in err  # (no duplicate from the warnings module)


def test_short_text_and_html_views_for_notebooks():
    """``Results``, ``Study`` and ``Solution`` print a few lines (what ran, sizes, the headline
    metrics with their interval), not their tables and the scenario's text; ``Results`` and
    ``Study`` have HTML views."""
    from tests.helpers import ROOT

    path = ROOT / "scenarios" / "parallel_nes_impulse.toml"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vines_stoch.VinesStochWarning)
        results = vines_stoch.run(path)
    text = repr(results).splitlines()
    assert len(text) == 2 + 8 + 1  # the line, the header, 8 of the 15 points, "7 more"
    assert text[0].startswith("Results of 'parallel-nes-impulse' (in memory): 15 sweep point(s)")
    assert "edm_ci95_lo" in text[1] and text[-1] == "... 7 more sweep point(s)"
    html = results._repr_html_()
    assert html.startswith("<p>Results of") and html.count("<tr>") == 8 and "7 more sweep point(s)" in html
    study = repr(results.scenario)
    assert len(study.splitlines()) == 1 and "15 sweep point(s) over loads.0.velocity" in study
    assert "absorbers: cubic, impact" in study and results.scenario._repr_html_().startswith("<p>Study")
    solution = repr(vines_stoch.solve(path, point=3, points=11))
    assert len(solution.splitlines()) == 1
    assert solution.startswith("Solution of sweep point 3, realisation 0: 11 times")


def test_the_loop_a_run_compiles_or_loads_is_logged():
    """Python users see what a run compiles through ``logging`` (the command line prints it):
    in a fresh process, one INFO record on the ``vines_stoch`` logger for the step loop, compiled
    or loaded from the cache."""
    import subprocess
    import sys

    script = ("import logging, warnings, vines_stoch\n"
              "logging.basicConfig(level=logging.INFO, format='%(name)s %(levelname)s %(message)s')\n"
              "warnings.simplefilter('ignore')\n"
              f"vines_stoch.run({ {**coarse(), 'simulation': {'duration': 5.0, 'dt': 0.01}}!r})\n")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    records = [line for line in done.stderr.splitlines() if line.startswith("vines_stoch INFO step loop: ")]
    assert len(records) == 1, done.stderr
    assert "loaded from the cache" in records[0] or "compiled (cached on disk" in records[0]
