"""Configuration and argument mistakes are clear errors naming the setting and what it takes
(exit 2 from the command line), never "internal error" (exit 3, kept for real bugs)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

import vines_stoch
from tests.helpers import ROOT, cli

SCENARIO = ROOT / "scenarios" / "rare_oscillator.toml"
SMALL = {"name": "small", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.1},
         "loads": [{"type": "white-noise", "intensity": 0.1}], "simulation": {"duration": 1.0, "dt": 0.01},
         "ensemble": {"realizations": 2}}


def command(*args: str, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "vines_stoch.cli", *args], capture_output=True, text=True,
                          timeout=300, env={**os.environ, **env})


@pytest.mark.parametrize("variable, value, words", [
    ("VINES_STOCH_VECTOR_BITS", "333", "give the vector width in bits, one of 128, 256, 512"),
    ("NUMBA_NUM_THREADS", "0", "numba's threads, a whole number >= 1"),
])
def test_a_bad_environment_variable_is_named(tmp_path, variable, value, words):
    done = command("run", str(SCENARIO), "--out", str(tmp_path / "o"), "--quiet", **{variable: value})
    assert done.returncode == 2 and f"environment variable {variable}='{value}': {words}" in done.stderr
    assert "internal error" not in done.stderr
    python = subprocess.run([sys.executable, "-c", "import vines_stoch; vines_stoch.run"],
                            capture_output=True, text=True, timeout=300, env={**os.environ, variable: value})
    assert python.returncode == 1 and f"ValueError: environment variable {variable}" in python.stderr


def test_a_garbage_scheduler_file_is_named(tmp_path):
    garbage = tmp_path / "scheduler.json"
    garbage.write_text("not json at all\n")
    code, err = cli("run", SCENARIO, "--scheduler-file", garbage, "--out", tmp_path / "o", "--quiet")
    assert code == 2 and "not a dask scheduler file" in err and "internal error" not in err


def test_a_report_point_out_of_range_is_named(tmp_path):
    vines_stoch.run(SMALL, tmp_path / "run")
    code, err = cli("report", tmp_path / "run", "--point", "999", "--out", tmp_path / "r")
    assert code == 2 and "--point 999: " in err and "1 sweep point(s), 0 to 0" in err
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("arguments, kind, words", [
    ({"shard": "0/2"}, TypeError, "shard = '0/2': give (i, n)"),
    ({"shard": (0,)}, TypeError, "shard = (0,): give (i, n)"),
    ({"scheduler": 123}, TypeError, "scheduler = 123: give a dask.distributed scheduler's address"),
    ({"overwrite": "yes"}, TypeError, "overwrite = 'yes': must be True or False"),
])
def test_api_arguments_are_named(tmp_path, arguments, kind, words):
    with pytest.raises(kind, match=words.replace("(", r"\(").replace(")", r"\)")):
        vines_stoch.run(SMALL, tmp_path / "o", **arguments)


def test_a_dict_nested_too_deep_is_a_scenario_error():
    deep: dict = {}
    node = deep
    for _ in range(5000):
        node["x"] = {}
        node = node["x"]
    with pytest.raises(vines_stoch.ScenarioError, match="nests more than 12 levels"):
        vines_stoch.run({**SMALL, "extra": deep})


def test_nan_statistics_come_with_their_reason(tmp_path):
    """A sweep point whose loads put no energy in (an impulse of 0) and one realisation: its NaN
    statistics are explained on the console and in the report, not only in ``notes``."""
    from tests.helpers import toml_text
    from vines_stoch.reports import report

    data = {"name": "idle", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.1},
            "loads": [{"type": "impulse", "velocity": 0.0}], "simulation": {"duration": 5.0, "dt": 0.01},
            "sweep": {"loads.0.velocity": [0.0, 1.0]}}
    path = tmp_path / "idle.toml"
    path.write_text(toml_text(data))
    code, err = cli("run", path, "--out", tmp_path / "run")
    assert code == 0
    assert "note: point 0: one realisation ended ok: std, sem and ci95 undefined" in err
    assert "1 realisation(s) without input energy" in err
    text = report([tmp_path / "run"], tmp_path / "r").read_text()
    assert "Why some statistics are undefined (NaN)" in text and "- point 0: one realisation ended ok" in text


def test_work_that_cannot_fit_is_refused_before_it_starts():
    """``paths=True`` for 10^7 realisations (every one's histories: about 150 GiB) and a Sobol
    bootstrap of 2^20 samples x 100,000 resamples are refused before anything runs, with the
    figure and this machine's memory; a run of 10^12 path-steps says its cost first."""
    from vines_stoch.environment import physical_memory

    if physical_memory() == 0:
        pytest.skip("the system does not say its memory")
    with pytest.raises(ValueError, match=r"paths: paths=True .* would take about .* GiB, past 80 % of"):
        vines_stoch.run(SMALL, realizations=10**7, paths=True)
    data = {**SMALL, "uncertain": {"primary.damping": {"distribution": "uniform", "low": 0.05, "high": 0.2}},
            "sensitivity": {"metric": "x1_max", "samples": 1 << 20, "bootstrap": 100_000}}
    with pytest.raises(vines_stoch.ScenarioError, match=r"sensitivity.bootstrap = 100000: the sensitivity "
                                                        r"bootstrap .* GiB, past 80 %"):
        vines_stoch.run(data)
    from tests.helpers import study_from

    long = {**SMALL, "simulation": {"duration": 1e4, "dt": 0.01}, "ensemble": {"realizations": 10**6}}
    warned = study_from(long).warnings  # (validated, not run)
    assert any(w.category is vines_stoch.LongRunWarning and "the run takes 1e+12 path-steps" in w
               for w in warned)


def test_a_failed_scheme_is_diverged_not_ok():
    """A cubic NES with dt = 0.5 (stable for the linear structure, far too coarse for the NES):
    a realisation whose energy balance misses more than half the input energy is ``diverged``, so
    none ended ok carries one (the summary averages only what the scheme computed).  Such a
    balance with finite energies is rare (most unstable paths overflow): 28 of 10,000 realisations
    (the others diverge by growth, three in four), so the run holds some whatever its streams."""
    from vines_stoch.metrics import FAILED_BALANCE

    data = {"name": "unstable", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.05},
            "absorbers": [{"type": "cubic", "mass": 0.05, "stiffness": 1.0, "damping": 0.01}],
            "loads": [{"type": "white-noise", "intensity": 0.1}],
            "simulation": {"duration": 200.0, "dt": 0.5}, "ensemble": {"realizations": 10_000, "seed": 1}}
    with pytest.warns(vines_stoch.VinesStochWarning):
        results = vines_stoch.run(data)
    r = results.realizations
    ok = r[r["status"] == "ok"]
    assert len(ok) > 0 and (ok["energy_residual"].abs() <= FAILED_BALANCE).all()
    assert (r.loc[r["energy_residual"].abs() > FAILED_BALANCE, "status"] == "diverged").all()
    assert (r["energy_residual"].abs() > FAILED_BALANCE).any()  # (the case the rule is for)
    assert results.summary["n_ok"].iloc[0] == len(ok)


def test_the_memory_share_is_a_documented_setting(monkeypatch):
    """``VINES_STOCH_MEMORY_SHARE`` raises (or lowers) the memory a study may plan to keep; a
    value that is not a share > 0 is named."""
    from vines_stoch import environment

    monkeypatch.delenv("VINES_STOCH_MEMORY_SHARE", raising=False)
    need = 0.5 * environment.physical_memory()
    assert environment.memory_problem("x", need) is None  # (half the machine: under 80 %)
    monkeypatch.setenv("VINES_STOCH_MEMORY_SHARE", "0.25")
    assert "past 25 % of this machine's" in environment.memory_problem("x", need)
    monkeypatch.setenv("VINES_STOCH_MEMORY_SHARE", "4")
    assert environment.memory_problem("x", 3 * environment.physical_memory()) is None
    for bad in ("0", "-1", "lots", "inf"):
        monkeypatch.setenv("VINES_STOCH_MEMORY_SHARE", bad)
        assert environment.problems() == [
            f"environment variable VINES_STOCH_MEMORY_SHARE='{bad}': the share of this machine's memory a "
            "study may plan to keep, a number > 0 (default 0.8; above 1 counts on swap)"]


def test_a_swept_value_out_of_range_is_named_at_its_sweep_key(tmp_path):
    """A value a ``[sweep]`` entry gives (a logspace overflowing the magnitude limit) is named at
    ``sweep.KEY``, where the file writes it; mistakes of two swept keys at different points are
    both named."""
    path = tmp_path / "sweep.toml"
    path.write_text('name = "s"\n[primary]\nmass = 1.0\nstiffness = 1.0\ndamping = 0.01\n'
                    '[[loads]]\ntype = "impulse"\nvelocity = 1.0\n[simulation]\nduration = 1.0\ndt = 0.01\n'
                    '[sweep]\n"loads.0.velocity" = {logspace = [1.0, 1e300, 3]}\n'
                    '"primary.damping" = [0.1, -1.0]\n')
    code, err = cli("validate", path)
    assert code == 2 and sorted(err.removeprefix("error: ").splitlines()) == [
        f"{path}: sweep.loads.0.velocity = {{'logspace': [1.0, 1e+300, 3]}}: its value 1e+150: its "
        "magnitude must be <= 1e+15 (use other units)",
        f"{path}: sweep.primary.damping = [0.1, -1.0]: its value -1.0: must be >= 0"]


def test_three_mistakes_in_three_tables_are_all_named(tmp_path):
    """A floor below 1, a text where a number belongs and an unknown key: three lines, the floor
    named beside the others with the primary's floors (``model.floor_mistakes``)."""
    path = tmp_path / "three.toml"
    path.write_text('name = "t"\n[primary]\nmasses = [1.0, 1.0]\nstiffnesses = [1.0, 1.0]\n'
                    '[[absorbers]]\nfloor = -1\ntype = "linear"\nmass = 0.1\nstiffness = 0.1\n'
                    'damping = 0.01\n'
                    '[[loads]]\ntype = "harmonic"\namplitude = 1.0\nfrequency = "oops"\n'
                    '[simulation]\nduration = 1.0\ndt = 0.01\nzz = 1\n')
    code, err = cli("validate", path)
    lines = err.removeprefix("error: ").splitlines()
    assert code == 2 and len(lines) == 3, err
    assert any("absorbers.0.floor = -1: must be in [1, 2] (the primary has 2 floors)" in x for x in lines)
    assert any("loads.0.frequency = 'oops'" in line for line in lines)
    assert any("simulation.zz = 1: unknown key" in line for line in lines)


def test_a_cluster_without_the_cluster_extra_says_what_to_install(monkeypatch, tmp_path):
    """dask.distributed is the ``cluster`` extra's: without it, ``--scheduler`` names the extra
    (an ImportError from Python, exit 2 from the command line), not an internal error."""
    import sys

    monkeypatch.setitem(sys.modules, "dask.distributed", None)  # (as if not installed)
    with pytest.raises(ImportError, match=r"scheduler tcp://127.0.0.1:1: a dask.distributed cluster needs "
                                          r"the cluster extra: pip install 'vines-stoch\[cluster\]'"):
        vines_stoch.run(SMALL, tmp_path / "api", scheduler="tcp://127.0.0.1:1")
    assert not (tmp_path / "api").exists()  # (refused before anything is written)
    code, err = cli("run", SCENARIO, "--scheduler", "tcp://127.0.0.1:1", "--out", tmp_path / "o", "--quiet")
    assert code == 2 and "needs the cluster extra" in err and "internal error" not in err


def test_a_later_swept_mistake_is_named_after_an_earlier_points_other_mistake(tmp_path):
    """Point 0 breaks a rule of a key not swept (dt past the stability limit of its tiny mass);
    point 3 gives a swept value out of range: both are named."""
    path = tmp_path / "sweep.toml"
    path.write_text('name = "s"\n[primary]\nmass = 1.0\nstiffness = 1.0\ndamping = 0.01\n'
                    '[[loads]]\ntype = "impulse"\nvelocity = 1.0\n[simulation]\nduration = 10.0\ndt = 0.01\n'
                    '[sweep]\n"primary.mass" = [1e-6, 1.0]\n"primary.damping" = [0.1, -1.0]\n')
    code, err = cli("validate", path)
    lines = err.removeprefix("error: ").splitlines()
    assert code == 2 and len(lines) == 2, err
    assert "(sweep point {'primary.mass': 1e-06, 'primary.damping': 0.1}): simulation.dt = 0.01" in lines[0]
    assert lines[1] == f"{path}: sweep.primary.damping = [0.1, -1.0]: its value -1.0: must be >= 0"


def test_poincare_samples_that_cannot_fit_are_refused(monkeypatch):
    """``[output] poincare`` keeps every realisation's state once a forcing period over the
    window: past the memory share (here set tiny) it is refused before anything runs, naming
    ``poincare_periods``."""
    from vines_stoch.scenario import parse_scenario

    text = ('name = "p"\n[primary]\nmass = 1.0\nstiffness = 1.0\ndamping = 0.1\n'
            '[[loads]]\ntype = "harmonic"\namplitude = 1.0\nfrequency = 1.0\n'
            '[simulation]\nduration = 1000.0\ndt = 0.05\nscheme = "rk4"\n[output]\npoincare = true\n')
    parse_scenario(text)  # (160 periods of 4 numbers: fits)
    monkeypatch.setenv("VINES_STOCH_MEMORY_SHARE", "1e-12")
    words = r"output.poincare = True: the Poincare samples kept .* set \[output\] poincare_periods"
    with pytest.raises(vines_stoch.ScenarioError, match=words):
        parse_scenario(text)
