"""Parallel NES under an impulse (no noise) against the independent scipy reference.

The impulses stay below the level (about X = 2) where the impact NES starts chattering: the
reference has no sticking law and would need infinitely many impacts there.
"""

from __future__ import annotations

import pytest

from vines_stoch import load_scenario, parse_scenario, run

from vines_stoch.validation.reference import parallel_nes_reference

DURATION = 100.0


@pytest.mark.parametrize("impulse", [0.3, 0.5, 1.0, 1.6])
def test_parallel_nes_matches_scipy_reference(tmp_path, impulse):
    study = load_scenario("scenarios/parallel_nes_impulse.toml")
    text = study.text.replace("duration = 300.0", f"duration = {DURATION}")
    text = text.split("[sweep]")[0].replace("velocity = 1.0", f"velocity = {impulse}")
    realizations, _ = run(parse_scenario(text), tmp_path)
    row = realizations.iloc[0]
    edm, impacts = parallel_nes_reference(1.0, 1.0, 0.0, (0.05, 1.0, 0.01), (0.05, 0.2, 0.6),
                                          impulse, DURATION)
    assert row["impacts"] == impacts
    assert abs(row["edm"] - edm) < 1e-4, (row["edm"], edm)
