"""Feedback on long work: the line while a step loop compiles, a rate that reads right at any
speed, the total time, and the end-of-run table of the metrics the scenario is about."""

from __future__ import annotations

import os
import re
import subprocess
import sys

import pytest

from tests.helpers import cli, toml_text, two_dof_data
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
    """A fresh process: the step loop's line (a short run's: the general loop of its scheme,
    compiled, or loaded from numba's cache on disk), the total, and a table with the limit's
    p_roof."""
    path = tmp_path / "feedback.toml"
    path.write_text(toml_text(DATA))
    command = ["run", str(path), "--out", str(tmp_path / "o"), "--workers", "1"]
    done = subprocess.run([sys.executable, "-m", "vines_stoch.cli", *command], capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    assert re.search(r"step loop: the general euler-maruyama loop \(every structure\): "
                     r"compiling or loading \.\.\. "
                     r"(loaded from the cache|compiled \(cached on disk for later runs\)) in \d+\.\d s",
                     done.stderr), done.stderr
    assert re.search(r"done: 20 realisation\(s\) in \d+\.\d s", done.stderr)
    assert re.search(r"; \d+\.\d s in all", done.stdout)
    header = done.stdout.splitlines()[1].split()
    assert header == ["loads.0.intensity", "n_ok", "n_failed", "edm_mean", "e1_max_mean", "p_roof",
                      "p_roof_lo", "p_roof_hi", "energy_residual_mean"]


def test_compile_puts_the_loops_a_run_needs_in_the_cache(tmp_path):
    """``vines-stoch compile FILE`` in a fresh process compiles the loop a run of the file needs
    into the cache on disk (an empty one here, ``NUMBA_CACHE_DIR``) and runs nothing; the run in
    the next process loads it.  (The smallest scene: a primary alone after an impulse.)"""
    path = tmp_path / "small.toml"
    path.write_text(toml_text({"name": "small", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.1},
                               "loads": [{"type": "impulse", "velocity": 1.0}],
                               "simulation": {"duration": 2.0, "dt": 1e-2}}))
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}

    def cli_run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "vines_stoch.cli", *args], capture_output=True,
                              text=True, timeout=600, env=env)

    first = cli_run("compile", str(path))
    assert first.returncode == 0 and "compiled (cached on disk for later runs)" in first.stderr, first.stderr
    assert not (tmp_path / "results").exists() and first.stdout == ""
    second = cli_run("run", str(path), "--out", str(tmp_path / "o"))
    assert second.returncode == 0 and "loaded from the cache" in second.stderr, second.stderr
    wrong = cli_run("compile", str(path), "--executor", "simd")
    assert wrong.returncode != 0 and "executor = 'simd'" in wrong.stderr


def test_compile_specialised_readies_the_structure_s_own_loop_which_a_short_run_then_takes(tmp_path):
    """``vines-stoch compile FILE --specialised`` compiles the loop specialised to the file's
    structure (into an empty cache here), not the general one; a short run in the next process,
    ``VINES_STOCH_GENERAL_WORK`` unset, loads it and compiles nothing (the same numbers as the
    general loop's: ``test_general_loop.py``)."""
    path = tmp_path / "small.toml"
    path.write_text(toml_text({"name": "small", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.1},
                               "loads": [{"type": "impulse", "velocity": 1.0}],
                               "simulation": {"duration": 2.0, "dt": 1e-2}}))
    env = {**{k: v for k, v in os.environ.items() if k != "VINES_STOCH_GENERAL_WORK"},
           "NUMBA_CACHE_DIR": str(tmp_path / "cache")}

    def cli_run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "vines_stoch.cli", *args], capture_output=True,
                              text=True, timeout=600, env=env)

    first = cli_run("compile", str(path), "--specialised")
    assert first.returncode == 0 and "step loop: rk4 loop, 1 bodies" in first.stderr, first.stderr
    assert "compiled (cached on disk" in first.stderr and "the general" not in first.stderr, first.stderr
    second = cli_run("run", str(path), "--out", str(tmp_path / "o"))
    assert second.returncode == 0, second.stderr
    assert re.search(r"step loop: rk4 loop, 1 bodies, 1 floor\(s\): loaded from the cache in \d+\.\d s "
                     r"\(a short run takes the loop specialised to its structure where it is on disk\)",
                     second.stderr), second.stderr
    assert "compiled (" not in second.stderr and "the general" not in second.stderr, second.stderr


def test_compile_general_readies_every_scheme_and_compile_asks_for_something():
    """``vines-stoch compile --general`` readies the general loop of each scheme for paths and for
    chunks of both executors, and the pass loop (a line each); ``compile`` with neither files nor
    ``--general`` is an error that says what it takes."""
    code, err = cli("compile", "--general")
    assert code == 0, err
    for scheme in ("euler-maruyama", "sra", "rk4"):
        assert f"the general {scheme} loop for paths" in err
        assert f"the general {scheme} loop (every structure)" in err
    assert "the pass loop (every smooth kick-drift-kick structure)" in err
    code, err = cli("compile")
    assert code == 2 and "name scenario files, or --general" in err
