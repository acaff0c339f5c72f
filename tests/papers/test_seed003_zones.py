"""Seed 003's maps of impact zones against the forcing frequency (Lizunov, Pogorelova,
Postnikova, Gerashchenko 2024), 5-8 rad/s every 0.1 rad/s (``reproduce.zone_sweep``: the zone of
each design at each frequency from the walls it met over [100, 400] s).  The paper prints no
number for them; its text says:

- Figs. 3-4 (60 kg): bilateral impacts in zones bounded near the resonance, the single-sided
  designs' unilateral direct impacts on the primary beside them, no impacts elsewhere; the
  double-sided designs shockless (T,0,0) outside their bilateral zones;
- Fig. 11 (10 kg): extremely narrow bilateral zones; the single-sided designs impact the primary
  alone over a wider range; the double-sided designs shockless elsewhere.

The zones are held by their shapes (one unbroken bilateral run, where it lies, unilateral runs
beside it) and by counts with a frequency step of margin at their edges, where an impacting
motion may turn from one zone to the next on another host's last bits."""

from __future__ import annotations

import pytest

from tests.helpers import ROOT
from vines_stoch.validation.reproduce import E1MAX_FREQUENCIES, zone_sweep

RESONANCE = E1MAX_FREQUENCIES.index(6.3)


def runs(zones: list[str], kind: str) -> list[range]:
    """The unbroken runs of ``kind`` in a design's zones, as index ranges."""
    found, start = [], None
    for i, zone in enumerate([*zones, None]):
        if zone == kind and start is None:
            start = i
        elif zone != kind and start is not None:
            found.append(range(start, i))
            start = None
    return found


@pytest.fixture(scope="module", params=[60, 10], ids=["60 kg", "10 kg"])
def zones(request) -> tuple[int, dict[str, list[str]]]:
    return request.param, zone_sweep(ROOT / "scenarios", request.param)


def test_single_sided_designs_meet_the_primary_beside_a_bounded_bilateral_zone(zones):
    mass, found = zones
    for label, row in found.items():
        if not label.startswith("SS"):
            continue
        (both,) = runs(row, "bilateral")  # (one unbroken zone)
        assert abs(both.start - RESONANCE) <= 8 and abs(both.stop - 1 - RESONANCE) <= 8, label  # (0.8 rad/s)
        assert "right" not in row, label
        left = row.count("left")
        assert row[both.start - 1] == "left" and row[both.stop] == "left", label  # (beside it)
        assert row[0] == "none" and row[-1] == "none", label  # (no impacts far from the resonance)
        if mass == 10:  # (extremely narrow: one or two frequencies; unilateral over a wider range)
            assert len(both) <= 3 and left >= 2 * len(both) + 3, label


def test_double_sided_designs_are_shockless_outside_their_bilateral_zone(zones):
    _, found = zones
    for label, row in found.items():
        if not label.startswith("DS"):
            continue
        assert set(row) <= {"bilateral", "none"}, label
        for both in runs(row, "bilateral"):
            assert abs(both.start - RESONANCE) <= 4 and len(both) <= 6, label
