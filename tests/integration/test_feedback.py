"""Feedback on long work: the line while a step loop compiles, a rate that reads right at any
speed, the total time, and the end-of-run table of the metrics the scenario is about."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from tests.helpers import toml_text, two_dof_data
from vines_stoch.progress import Progress, rate_text

DATA = {
    "name": "feedback",
    **two_dof_data(0.02, 1.0),
    "loads": [{"type": "white-noise", "intensity": 0.05}],
    "simulation": {"duration": 10.0, "dt": 1e-2},
    "ensemble": {"realizations": 10, "seed": 2},
    "limits": {"roof": {"metric": "x1_max", "value": 0.3}},
    "sweep": {"loads.0.intensity": [0.02, 0.08]},
}


@pytest.mark.parametrize(("done", "seconds", "text"), [
    (0, 0.0, "measuring"), (0, 5.0, "measuring"), (1, 12.5, "12.5 s each"), (5, 2.0, "2.5/s"),
    (5000, 2.0, "2,500/s"), (150, 1.0, "150/s"),
])
def test_rate_reads_right_at_any_speed(done, seconds, text):
    assert rate_text(done, seconds) == text


def test_progress_ends_with_the_total_time(capsys):
    with Progress(4, enabled=True) as bar:
        bar.advance(4)
    assert re.search(r"done: 4 realisation\(s\) in \d+\.\d s \(", capsys.readouterr().err)
    with pytest.raises(RuntimeError), Progress(4, enabled=True) as bar:  # (no total after an error)
        raise RuntimeError
    assert "done:" not in capsys.readouterr().err


def test_run_names_the_loop_it_compiles_and_shows_the_scenarios_metrics(tmp_path):
    """A fresh process: the step loop's line (compiled, or loaded from numba's cache on disk),
    the total, and a table with the limit's p_roof."""
    path = tmp_path / "feedback.toml"
    path.write_text(toml_text(DATA))
    command = ["run", str(path), "--out", str(tmp_path / "o"), "--workers", "1"]
    done = subprocess.run([sys.executable, "-m", "vines_stoch.cli", *command], capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    assert re.search(r"step loop: \S+ loop, 2 bodies, 1 floor\(s\), white noise: compiling or loading \.\.\. "
                     r"(loaded from the cache|compiled \(cached on disk for later runs\)) in \d+\.\d s",
                     done.stderr), done.stderr
    assert re.search(r"done: 20 realisation\(s\) in \d+\.\d s", done.stderr)
    assert re.search(r"; \d+\.\d s in all", done.stdout)
    header = done.stdout.splitlines()[1].split()
    assert header == ["loads.0.intensity", "n_ok", "n_failed", "edm_mean", "e1_max_mean", "p_roof",
                      "p_roof_lo", "p_roof_hi", "energy_residual_mean"]
