"""Parallel NES under an impulse (no noise) against the independent scipy reference.

The impulses stay below the level (about X = 2) where the impact NES starts chattering: the
reference has no sticking law and would need infinitely many impacts there.
"""

from __future__ import annotations

import pytest

from tests.helpers import example_data, study_from
from vines_stoch import run
from vines_stoch.validation.reference import parallel_nes_reference

DURATION = 100.0


@pytest.mark.parametrize("impulse", [0.3, 0.5, 1.0, 1.6])
def test_parallel_nes_matches_scipy_reference(tmp_path, impulse):
    data = example_data("parallel_nes_impulse", "sweep", "output")
    study = study_from(data, {"simulation.duration": DURATION, "loads.0.velocity": impulse})
    realizations, _ = run(study, tmp_path)
    row = realizations.iloc[0]
    edm, impacts = parallel_nes_reference(1.0, 1.0, 0.0, (0.05, 1.0, 0.01), (0.05, 0.2, 0.6),
                                          impulse, DURATION)
    assert row["impacts"] == impacts
    assert abs(row["edm"] - edm) < 1e-4, (row["edm"], edm)
