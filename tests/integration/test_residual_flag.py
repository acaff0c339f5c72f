"""Realisations whose energy balance does not close are flagged (``simulation.residual_tolerance``,
default 1e-3): in the summary's ``notes`` with their count and the largest ``|energy_residual|``,
and in one ``warning:`` line per sweep point from ``vines-stoch run``.

The scene: a primary with a cubic absorber under white noise on the Euler-Maruyama scheme, whose
residual is the scheme's O(dt) error, a few 1e-4 at dt = 1e-2 over 20 s.  A tolerance below every
realisation's residual flags all of them, one above the largest none, and the default none; the
counts come from the realisations table written by the same run.
"""

from __future__ import annotations

import pandas as pd
import pytest

from tests.helpers import cli, toml_text, two_dof_data
from vines_stoch.metrics import residual_notes


def scenario(tolerance: float | None, points: int = 1) -> dict:
    data = {"name": "residuals", **two_dof_data(),
            "loads": [{"type": "white-noise", "intensity": 0.3}],
            "simulation": {"duration": 20.0, "dt": 1e-2},
            "ensemble": {"realizations": 8, "seed": 3}}
    if tolerance is not None:
        data["simulation"]["residual_tolerance"] = tolerance
    if points > 1:
        data["sweep"] = {"loads.0.intensity": [0.3, 0.4][:points]}
    return data


def test_notes_count_the_realisations_above_the_tolerance():
    frame = pd.DataFrame({"status": ["ok", "ok", "ok", "diverged"],
                          "energy_residual": [2e-3, -5e-3, 1e-4, float("nan")]})
    note = residual_notes(frame[frame["status"] == "ok"], 1e-3)
    assert note.startswith("2 of 3 realisation(s) with |energy_residual| above 0.001 (largest 0.005)")
    assert residual_notes(frame[frame["status"] == "ok"], 1e-2) == ""


@pytest.mark.parametrize("points", [1, 2])
def test_run_flags_each_point_in_notes_and_on_the_console(tmp_path, points):
    path = tmp_path / "s.toml"
    path.write_text(toml_text(scenario(None, points)))
    code, err = cli("run", path, "--out", tmp_path / "default", "--quiet", "--workers", "1")
    assert code == 0, err
    realizations = pd.read_parquet(tmp_path / "default" / "realizations.parquet")
    residual = realizations["energy_residual"].abs()
    assert residual.max() < 1e-3 and "energy_residual" not in err  # the default: none flagged
    for tolerance, flagged in ((0.5 * residual.min(), len(realizations) // points),
                               (2.0 * residual.max(), 0)):
        path.write_text(toml_text(scenario(tolerance, points)))
        out = tmp_path / f"tol{tolerance:g}"
        code, err = cli("run", path, "--out", out, "--quiet", "--workers", "1")
        assert code == 0, err
        summary = pd.read_parquet(out / "summary.parquet")
        warnings = [line for line in err.splitlines() if "|energy_residual| above" in line]
        if flagged:
            assert len(warnings) == points
            for p, line in enumerate(warnings):
                assert line.startswith(f"warning: {path}: " + (f"sweep point {p}: " if points > 1 else "")
                                       + f"{flagged} of {flagged} realisation(s)")
                assert f"{flagged} of {flagged} realisation(s)" in summary["notes"].iloc[p]
        else:
            assert warnings == [] and not summary["notes"].str.contains("energy_residual").any()
