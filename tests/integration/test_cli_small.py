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
