"""Bad input ends in one clear line, never a traceback; output folders are owned by one run.

Every case goes through the command line's entry point in-process (``cli.main``): the
property is exit status 2 with a message that names the file (and the key, where there is
one), or a clean result.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.helpers import ROOT, cli, toml_text, two_dof_data
from vines_stoch import parse_scenario
from vines_stoch.scenario.bodies import eigenfrequencies
from vines_stoch.store import LOCK, FolderInUse, lock_folder

#: Scenario text (the cases below change its lines): the primary with a cubic NES under an impulse.
BASE = """[primary]
mass = 1.0
stiffness = 1.0
damping = 0.02
[[absorbers]]
type = "cubic"
mass = 0.05
stiffness = 1.0
damping = 0.01
[[loads]]
type = "impulse"
velocity = 0.5
[simulation]
duration = 2.0
dt = 0.01
[ensemble]
realizations = 2
"""


def refused(path: Path, *fragments: str, command: str = "validate") -> str:
    """Run ``command`` on ``path``; assert exit 2 with one ``error:`` message naming the file and
    holding every fragment; return the message."""
    code, err = cli(command, path)
    assert code == 2, (code, err)
    assert err.startswith("error: ") and "Traceback" not in err, err
    assert str(path) in err, err
    for fragment in fragments:
        assert fragment in err, (fragment, err)
    return err


def scenario(text: str) -> str:
    return 'name = "hardening"\n' + text


# ------------------------------------------------------------------------------------ types

@pytest.mark.parametrize("line, replacement, fragments", [
    ("mass = 1.0", 'mass = "1.0"', ("primary.mass = '1.0': must be a number, not a string",)),
    ("stiffness = 1.0\ndamping = 0.02", "stiffness = true\ndamping = 0.02",
     ("primary.stiffness = True: must be a number, not true or false",)),
    ("realizations = 2", "realizations = 2.0", ("ensemble.realizations = 2.0: must be an integer",)),
    ("realizations = 2", "realizations = 100000000000",
     ("ensemble.realizations", "must be in [1, 10000000]")),
    ("duration = 2.0", "duration = 1e12", ("simulation.dt = 0.01", "steps a path", "at most")),
    ("mass = 1.0", "mass = 1e308", ("primary.mass = 1e+308: must be in [1e-15, 1e+15] (use other units)",)),
    ("velocity = 0.5", "velocity = nan", ("loads.0.velocity = nan: must be a finite number",)),
    ("realizations = 2", "realizations = 2\nseed = 1.5", ("ensemble.seed = 1.5: must be an integer",)),
    ("realizations = 2", "realizations = 2\nmax_path_steps = 10.0",
     ("ensemble.realizations = 2", "path-steps", "raise that if the run is meant")),
])
def test_types_and_magnitudes_are_strict(write, line, replacement, fragments):
    assert line in BASE
    refused(write(scenario(BASE.replace(line, replacement, 1))), *fragments)


def test_values_are_never_converted():
    """What validation accepts is what runs: a float field given an integer holds a float, and
    nothing else changes type."""
    study = parse_scenario(scenario(BASE.replace("mass = 1.0", "mass = 1")))
    assert type(study.base.primary.mass) is float and study.base.primary.mass == 1.0
    assert type(study.base.ensemble.realizations) is int


@pytest.mark.parametrize("extra, fragments", [
    ('[uncertain]\n"ensemble.realizations" = { distribution = "uniform", low = 1.0, high = 3.0 }\n',
     ("uncertain.ensemble.realizations", "integer field")),
    ('[uncertain]\n"absorbers.0.damping" = { distribution = "normal", mean = 1e15, std = 1e15 }\n',
     ("uncertain.absorbers.0.damping",)),
    ('[uncertain]\n"loads.0.velocity" = { distribution = "normal", mean = 1e14, std = 1e14 }\n',
     ("uncertain.loads.0.velocity", "10 standard deviations", "largest magnitude")),
    ('[sweep]\n"ensemble.realizations" = [1.0, 2.5]\n', ("sweep.ensemble.realizations", "whole numbers")),
    ('[sweep]\n"absorbers.0.damping" = { linspace = [0.0, 1.0, 100000000] }\n',
     ("sweep.absorbers.0.damping.linspace", "at most 10000 points")),
    ('[sweep]\n"absorbers.0.damping" = { linspace = [0.0, 1.0, 1000] }\n'
     '"absorbers.0.stiffness" = { linspace = [0.1, 1.0, 1000] }\n', ("sweep", "1000000 points")),
    ('[sweep]\n"absorbers.0.damping" = { linspace = [0.0, 1.0, true] }\n', ("count an integer >= 1",)),
    ('[sweep]\n"loads.-1.velocity" = [0.1, 0.2]\n', ("sweep.loads.-1.velocity", "existing numeric field")),
])
def test_sweeps_and_distributions_are_checked_before_computing(write, extra, fragments):
    refused(write(scenario(BASE + extra)), *fragments)


def test_integer_fields_sweep_whole_numbers():
    study = parse_scenario(scenario(BASE + '[sweep]\n"ensemble.realizations" = [1.0, 3.0]\n'))
    assert [p.ensemble.realizations for p in study.points] == [1, 3]


# ------------------------------------------------------------------------------------ sizes

@pytest.mark.parametrize("text, fragments", [
    ("a = " + "[" * 1000 + "]" * 1000 + "\n", ("nest too deep",)),
    ("a = " + "{b = " * 1000 + "1" + "}" * 1000 + "\n", ("nest too deep",)),
    (".".join(["a"] * 100_000) + " = 1\n", ("line 2", "dotted key of more than 12 parts")),
    ("[" + ".".join(["a"] * 40) + "]\nb = 1\n", ("dotted key",)),
    ("a = " + "[" * 20 + "]" * 20 + "\n", ("nests more than 12 levels",)),
])
def test_nesting_has_a_limit(write, text, fragments):
    start = time.perf_counter()
    refused(write(scenario(text)), *fragments)
    assert time.perf_counter() - start < 10.0  # refused, not parsed for minutes


def test_absorber_count_has_a_limit(write):
    absorber = '[[absorbers]]\ntype = "cubic"\nmass = 0.05\nstiffness = 1.0\n'
    refused(write(scenario(BASE + absorber * 20_000)),
            "absorbers: holds 20001 entries; it may hold at most 100")


def test_long_values_and_keys_are_cut_in_messages(write):
    err = refused(write(scenario(BASE.replace("velocity = 0.5", "velocity = [" + "1.0, " * 5000 + "]"))),
                  "loads.0.velocity")
    assert len(err) < 400, err
    key = ".".join(["a"] * 100_000)
    err = refused(write(scenario(BASE + f'[sweep]\n"{key}" = [1.0]\n')), "sweep.a.a.a")
    assert len(err) < 600, len(err)


# ------------------------------------------------------------------------------------ files

def test_encodings_and_binary_content(tmp_path):
    text = scenario(BASE).replace('"hardening"', '"h\u00e9"')
    cases = {"utf16.toml": (text.encode("utf-16"), "UTF-16 text; save it as UTF-8"),
             "latin1.toml": (text.encode("latin-1"), "byte 0xE9 is not UTF-8"),
             "binary.toml": (bytes(range(256)) * 4, "a NUL byte at line 1"),
             "utf16le.toml": (text.encode("utf-16-le"), "a NUL byte")}
    for name, (data, fragment) in cases.items():
        path = tmp_path / name
        path.write_bytes(data)
        refused(path, fragment)
    bom = tmp_path / "bom.toml"
    bom.write_bytes(b"\xef\xbb\xbf" + text.encode())
    assert cli("validate", bom)[0] == 0  # a UTF-8 byte-order mark is dropped


def test_special_files_are_refused_without_reading(tmp_path):
    pipe = tmp_path / "pipe.toml"
    os.mkfifo(pipe)
    refused(pipe, "is a named pipe, not a file")  # (reading it would block forever)
    refused(Path("/dev/zero"), "is a device, not a file")
    refused(tmp_path, "is a folder, not a file")
    loop = tmp_path / "loop.toml"
    loop.symlink_to(tmp_path / "loop2.toml")
    (tmp_path / "loop2.toml").symlink_to(loop)
    refused(loop, "a loop of symbolic links")
    refused(tmp_path / "missing.toml", "no such file")


RECORD = '[[loads]]\ntype = "force-record"\nfile = "{file}"\ndt = 0.01\n'


@pytest.mark.parametrize("file, fragments", [
    ("missing.txt", ("loads.1.file", "no such file")),
    ("records", ("is a folder, not a file",)),
    ("secret.txt", ("line 1", "a 39-character token is not a number")),
    ("empty.AT2", ("NPTS = 0: must be >= 1",)),
    ("loop.txt", ("a loop of symbolic links",)),
    ("nul\\u0000.txt", ("holds a NUL byte",)),
])
def test_record_files_are_checked_and_never_echoed(tmp_path, file, fragments):
    (tmp_path / "records").mkdir()
    secret = "root:x:0:0:root:/root:/bin/bash-content"
    (tmp_path / "secret.txt").write_text(secret + "\n" + secret + "\n")
    (tmp_path / "empty.AT2").write_text("title\ndate\nunits\nNPTS=    0, DT=   .0100 SEC\n")
    (tmp_path / "loop.txt").symlink_to(tmp_path / "loop.txt")
    path = tmp_path / "s.toml"
    path.write_text(scenario(BASE + RECORD.format(file=file)))
    err = refused(path, *fragments)
    assert "root:" not in err


# ------------------------------------------------------------------------------------ reported cases

@pytest.mark.parametrize("line, replacement, key", [
    ("mass = 1.0", "mass = 1e-320", "primary.mass = 1e-320"),
    ("mass = 1.0", "mass = 5e-324", "primary.mass = 5e-324"),
    ("mass = 0.05", "mass = 1e-320", "absorbers.0.mass = 1e-320"),
    ("mass = 0.05", "mass = 5e-324", "absorbers.0.mass = 5e-324"),
    ("mass = 1.0", "masses = [1.0, 1e-320]\nstiffnesses = [1.0, 1.0]", "primary.masses.1 = 1e-320"),
])
def test_masses_below_the_smallest_are_refused(write, line, replacement, key):
    text = BASE.replace(line, replacement, 1)
    if "masses" in replacement:
        text = text.replace("stiffness = 1.0\ndamping = 0.02\n", "", 1)
    refused(write(scenario(text)), f"{key}: must be in [1e-15, 1e+15] (use other units)")


def test_the_smallest_mass_keeps_the_frequencies_finite():
    """At the bounds (mass 1e-15 beside the largest stiffness, a free absorber of 1e-15) the
    frequencies are finite; far below, the eigenproblem's ratios k / m overflow."""
    text = (BASE.replace("mass = 1.0", "mass = 1e-15", 1).replace("stiffness = 1.0", "stiffness = 1e15", 1)
            .replace("mass = 0.05\nstiffness = 1.0", "mass = 1e-15\nstiffness = 0.0")
            .replace("dt = 0.01", "dt = 1e-16").replace("duration = 2.0", "duration = 1e-9"))
    study = parse_scenario(scenario(text))
    assert np.all(np.isfinite(study.base.natural_frequencies()))
    try:
        with np.errstate(all="ignore"):
            finite = np.all(np.isfinite(eigenfrequencies(np.array([1.0, 1e-320]), np.eye(2))))
    except np.linalg.LinAlgError:  # (where LAPACK refuses the overflowed matrix)
        finite = False
    assert not finite


@pytest.mark.parametrize("extra, fragments", [
    ('[uncertain]\n"simulation.dt" = { distribution = "uniform", low = 0.01, high = 3.0 }\n',
     ("uncertain.simulation.dt", "uniform draws reach 3, where simulation.dt = 3 is past the stability "
      "limit of the rk4 scheme", "dt < 2.828")),
    ('[optimize]\nparameters = { "simulation.dt" = { low = 0.01, high = 3.0 } }\n',
     ("optimize.parameters.simulation.dt", "the bound 3 is not allowed: simulation.dt = 3 is past the "
      "stability limit")),
    ('[uncertain]\n"simulation.dt" = { distribution = "uniform", low = 0.01, high = 2.0 }\n'
     '[sweep]\n"primary.stiffness" = [1.0, 4.0]\n',
     ("uncertain.simulation.dt", "uniform draws reach 2 (at sweep point {'primary.stiffness': 4.0}), where "
      "simulation.dt = 2 is past the stability limit", "dt < 2.828 / omega = 1.414")),
])
def test_uncertain_and_optimised_ranges_stay_within_the_stability_limit(write, extra, fragments):
    text = BASE.replace("duration = 2.0", "duration = 10.0")
    refused(write(scenario(text + extra)), *fragments)
    within = extra.replace("high = 3.0", "high = 2.0").replace("[1.0, 4.0]", "[1.0, 1.5]")
    assert cli("validate", write(scenario(text + within), "within.toml"))[0] == 0


def test_a_record_shorter_than_a_step_is_refused(tmp_path):
    (tmp_path / "tiny.AT2").write_text("title\ndate\nunits\nNPTS=    4, DT=   1e-300 SEC\n1.0 2.0 3.0 4.0\n")
    path = tmp_path / "s.toml"
    path.write_text(scenario(BASE + RECORD.format(file="tiny.AT2").replace("dt = 0.01\n", "")))
    refused(path, "loads.1.file = 'tiny.AT2'", "the record spans 3e-300 s (4 samples), less than one step "
            "of the run (simulation.dt = 0.01)")


def test_every_mistake_of_a_file_is_reported_at_once(write):
    text = scenario(BASE.replace("damping = 0.01", "dampnig = 0.01")
                    + '[sweep]\n"absorbers.0.stifness" = [1.0, 2.0]\n'
                    + '[uncertain]\n"loads.0.velocty" = { distribution = "uniform", low = 0.1, high = 1.0 }\n'
                    + '[optimize]\nparameters = { "loads.5.velocity" = { low = 0.1, high = 1.0 } }\n')
    err = refused(write(text), "absorbers.0.dampnig = 0.01: unknown key",
                  "sweep.absorbers.0.stifness = [1.0, 2.0]: must name an existing numeric field",
                  "uncertain.loads.0.velocty = ", "optimize.parameters.loads.5.velocity = ")
    assert len(err.strip().splitlines()) == 4, err


def test_record_files_of_the_system_are_never_quoted(tmp_path):
    """A record path at a system file: the message names the file and line, never its content
    (the first token of /etc/hostname or /proc/self/status)."""
    (tmp_path / "hostname").write_text("vm\n")
    status = Path("/proc/self/status")
    for file, token in [(tmp_path / "hostname", "vm")] + ([(status, "Name:")] if status.exists() else []):
        path = tmp_path / "s.toml"
        path.write_text(scenario(BASE + RECORD.format(file=file)))
        err = refused(path, f"{file}: line 1: a {len(token)}-character token is not a number")
        assert repr(token) not in err, err


# ------------------------------------------------------------------------------------ runs

def test_validate_imports_no_engine():
    """``vines-stoch validate`` stays light: no numba, dask, pandas or scipy."""
    code = ("import sys\nfrom vines_stoch.cli import main\n"
            "sys.argv = ['vines-stoch', 'validate', 'scenarios/parallel_nes_impulse.toml']\n"
            "try:\n    main()\nexcept SystemExit as exc:\n    assert not exc.code, exc.code\n"
            "heavy = [m for m in ('numba', 'dask', 'pandas', 'scipy', 'pyarrow') if m in sys.modules]\n"
            "assert not heavy, heavy\n")
    subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True, capture_output=True)


def test_undefined_statistics_say_why(write, tmp_path):
    """A sweep point whose loads put no energy in: ``edm`` undefined, with the reason noted."""
    path = write(scenario(BASE + '[sweep]\n"loads.0.velocity" = [0.0, 0.5]\n'))
    code, err = cli("run", path, "--out", tmp_path / "out", "--quiet", "--workers", "1")
    assert code == 0, err
    summary = pd.read_parquet(tmp_path / "out" / "summary.parquet")
    idle, moving = summary.iloc[0], summary.iloc[1]
    assert pd.isna(idle["edm_mean"]) and "without input energy" in idle["notes"]
    assert moving["edm_mean"] > 0 and "input energy" not in moving["notes"]


def test_a_scene_without_loads_notes_why_edm_is_undefined(write, tmp_path):
    path = write(scenario(BASE.replace('[[loads]]\ntype = "impulse"\nvelocity = 0.5\n', "")))
    code, err = cli("run", path, "--out", tmp_path / "out", "--quiet", "--workers", "1")
    assert code == 0, err
    summary = pd.read_parquet(tmp_path / "out" / "summary.parquet")
    assert pd.isna(summary["edm_mean"].iloc[0]) and "without input energy" in summary["notes"].iloc[0]


# ------------------------------------------------------------------------------------ locks

def test_lock_refuses_a_live_owner_and_takes_over_a_dead_one(tmp_path):
    with lock_folder(tmp_path):
        owner = json.loads((tmp_path / LOCK).read_text())
        assert owner["pid"] == os.getpid() and owner["host"] == socket.gethostname()
        with pytest.raises(FolderInUse, match=f"in use by the run of process {os.getpid()}"):
            with lock_folder(tmp_path):
                pass
    assert not (tmp_path / LOCK).exists()
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (tmp_path / LOCK).write_text(json.dumps({"pid": dead.pid, "host": socket.gethostname(), "started": None}))
    with lock_folder(tmp_path):  # the dead run's lock is taken over
        assert json.loads((tmp_path / LOCK).read_text())["pid"] == os.getpid()


def slow(intensity: float) -> str:
    """Scenario text of 200 realisations of 10^5 steps, one a chunk, under white noise."""
    return toml_text({"name": "hardening", **two_dof_data(),
                      "loads": [{"type": "white-noise", "intensity": intensity}],
                      "simulation": {"duration": 100.0, "dt": 0.001},
                      "ensemble": {"realizations": 200, "chunk": 1}})


def _start(path: Path, out: Path, *extra: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "vines_stoch.cli", "run", str(path), "--out", str(out),
                             "--quiet", "--workers", "1", *extra], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _wait_for_parts(out: Path, count: int, process: subprocess.Popen) -> None:
    deadline = time.monotonic() + 300
    while len(list((out / "parts").glob("point*.parquet"))) < count:
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline
        time.sleep(0.05)


def test_two_runs_into_one_folder_and_a_killed_run_resumed(tmp_path):
    """Two processes: the second run into a folder in use is refused and changes nothing; a run
    killed with SIGKILL leaves its lock, which --resume takes over, and the resumed results
    equal those of a run never interrupted (these two run in the test's process).  The first run
    is paused (SIGSTOP) once it has written two parts: alive and holding its lock, it cannot
    finish while the second starts."""
    first, second = tmp_path / "first.toml", tmp_path / "second.toml"
    first.write_text(slow(0.1))
    second.write_text(slow(0.2))
    out = tmp_path / "out"
    a = _start(first, out)
    _wait_for_parts(out, 2, a)
    a.send_signal(signal.SIGSTOP)
    b = _start(second, out)
    _, err = b.communicate(timeout=120)
    assert b.returncode == 2 and "in use by the run of process" in err and str(a.pid) in err, err
    a.send_signal(signal.SIGKILL)
    a.wait()
    assert (out / LOCK).exists()  # left behind by the killed run
    kept = len(list((out / "parts").glob("point*.parquet")))
    assert 2 <= kept < 200
    # the resumed and the uninterrupted runs in this process (a process of their own only adds start-up)
    code, err = cli("run", first, "--out", out, "--quiet", "--workers", "1", "--resume")
    assert code == 0, err
    assert not (out / LOCK).exists()
    code, err = cli("run", first, "--out", tmp_path / "clean", "--quiet", "--workers", "1")
    assert code == 0, err
    got = pd.read_parquet(out / "realizations.parquet")
    want = pd.read_parquet(tmp_path / "clean" / "realizations.parquet")
    pd.testing.assert_frame_equal(got.drop(columns=["wall_time"], errors="ignore"),
                                  want.drop(columns=["wall_time"], errors="ignore"))


def test_one_version_string_from_the_package_metadata():
    """``__version__`` is the installed distribution's version (pyproject.toml's), and the
    results' metadata carry it."""
    import tomllib

    import vines_stoch
    from vines_stoch.store import provenance

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert vines_stoch.__version__ == project["version"]
    assert provenance("", "", 0, "embedded")["vines_stoch.version"] == project["version"]


def test_a_run_key_holds_the_definition_of_every_normal_it_draws(monkeypatch):
    """A run begun on other normals is not resumed on these: the key changes with ``rng.NORMALS``,
    which names both the Philox streams' normals and the Brownian trees' node normals."""
    from vines_stoch import store
    from vines_stoch.streams.rng import NORMALS

    assert "philox" in NORMALS and "tree nodes" in NORMALS
    key = store.run_key("scenario", [(0, 0, 4)])
    monkeypatch.setattr(store, "NORMALS", NORMALS.replace("float32 pair's cosine", "float64 cosine"))
    assert store.run_key("scenario", [(0, 0, 4)]) != key
