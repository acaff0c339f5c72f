"""Small command-line promises: ``--version``, and ``loads`` writing a CSV that pandas reads."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pandas as pd

import vines_stoch
from tests.helpers import ROOT, cli


def test_version_prints_the_package_version():
    done = subprocess.run([sys.executable, "-m", "vines_stoch.cli", "--version"], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == f"vines-stoch {vines_stoch.__version__}"


def test_loads_csv_reads_as_columns(tmp_path):
    """``vines-stoch loads FILE out.csv``: comma-separated with a header row, so that
    ``pandas.read_csv`` gives the columns ``t``, ``force``, ``ground_acceleration`` (the time grid
    every ``--every`` steps from 0)."""
    out = tmp_path / "loads.csv"
    code, err = cli("loads", ROOT / "scenarios" / "filtered_noise.toml", out, "--every", "10")
    assert code == 0, err
    frame = pd.read_csv(out)
    assert list(frame.columns) == ["t", "force", "ground_acceleration"]
    dt = vines_stoch.load_scenario(ROOT / "scenarios" / "filtered_noise.toml").base.simulation.dt
    np.testing.assert_allclose(frame["t"].to_numpy()[:5], 10 * dt * np.arange(5), rtol=1e-12)
    assert frame["force"].abs().max() > 0 and (frame["ground_acceleration"] == 0).all()


def test_validate_prints_the_modes_and_the_work(tmp_path):
    """``validate`` on a 3-storey frame: the bare structure's periods against scipy's generalised
    eigenproblem ``K phi = w^2 M phi``, the effective masses summing to 100 %, and the work."""
    import re

    from scipy.linalg import eigh

    from tests.helpers import toml_text

    m, k = [2.0, 2.0, 1.5], [900.0, 800.0, 700.0]
    data = {"name": "frame", "primary": {"masses": m, "stiffnesses": k, "dampings": [3.0, 2.5, 2.0]},
            "loads": [{"type": "white-noise", "intensity": 1.0}],
            "simulation": {"duration": 20.0, "dt": 0.005}, "ensemble": {"realizations": 8, "seed": 1}}
    path = tmp_path / "frame.toml"
    path.write_text(toml_text(data))
    done = subprocess.run([sys.executable, "-m", "vines_stoch.cli", "validate", str(path)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    stiffness = np.array([[k[0] + k[1], -k[1], 0], [-k[1], k[1] + k[2], -k[2]], [0, -k[2], k[2]]])
    w2, phi = eigh(stiffness, np.diag(m))
    printed = [float(t) for t in re.findall(r"T\d = ([0-9.e+-]+) s", done.stdout)]
    np.testing.assert_allclose(printed, 2 * np.pi / np.sqrt(w2), rtol=5e-4)  # (4 digits printed)
    shares = [float(s) for s in re.findall(r"\(([0-9.]+) %\)", done.stdout)]
    gamma = (phi.T @ np.array(m)) ** 2 / np.einsum("ij,i,ij->j", phi, m, phi) / sum(m)
    np.testing.assert_allclose(shares, 100 * gamma, atol=0.051)
    assert "work: 1 sweep point(s) x 8 realisation(s) x 4,000 step(s) = 3.2e+04 path-steps" in done.stdout
