"""Seed 003's sweeps over the forcing frequency (Lizunov, Pogorelova, Postnikova, Gerashchenko
2024), 5-8 rad/s every 0.1 rad/s (``reproduce.class_sweep``: each design's run at each frequency,
its zone from the walls it met over [100, 400] s), against the primary alone's
(``reproduce.primary_sweep``).  The paper prints no number for them; its text says:

- Fig. 2 (60 kg): "good mitigation of the PS vibrations similar for SSVI NES and for DSVI NES";
  attaching either "does not change the behavior of the PS energy as a whole";
- Fig. 6 (40 kg): "the pattern of the behavior of the PS energy is similar to that with dampers of
  mass 60 kg"; Table 3 prints c2 and C alone of its designs, so the one printed whole, DS-2(40)
  (Table 1's 40.0 kg design), is held to the 60 kg designs' tests (the double-sided ones');
- Fig. 10 (10 kg): good mitigation by designs of huge clearances and small damping, with
  "different irregular motions" (Table 5's regimes: chaos in seven of its eight designs);
- Figs. 3-4 (60 kg): bilateral impacts in zones bounded near the resonance, the single-sided
  designs' unilateral direct impacts on the primary beside them, no impacts elsewhere; the
  double-sided designs shockless (T,0,0) outside their bilateral zones;
- Fig. 11 (10 kg): extremely narrow bilateral zones; the single-sided designs impact the primary
  alone over a wider range; the double-sided designs shockless elsewhere.

The zones are held by their shapes (one unbroken bilateral run, where it lies, unilateral runs
beside it) and by counts with a frequency step of margin at their edges, where an impacting
motion may turn from one zone to the next on another host's last bits."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tests.helpers import ROOT
from vines_stoch.validation.reproduce import E1MAX_FREQUENCIES, class_sweep, primary_sweep, zones_of

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


@pytest.fixture(scope="module", params=[60, 40, 10], ids=["60 kg", "40 kg", "10 kg"])
def sweeps(request) -> tuple[int, dict[str, pd.DataFrame]]:
    return request.param, class_sweep(ROOT / "scenarios", request.param)


@pytest.fixture(scope="module")
def zones(sweeps) -> tuple[int, dict[str, list[str]]]:
    mass, found = sweeps
    return mass, {label: zones_of(rows) for label, rows in found.items()}


@pytest.fixture(scope="module")
def alone() -> np.ndarray:
    return primary_sweep(ROOT / "scenarios")


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


def test_every_design_cuts_the_resonance_peak_and_keeps_its_shape(sweeps, alone):
    """Figs. 2, 6 and 10, "good mitigation" and "does not change the behavior of the PS energy as a
    whole": each design's highest E1max over the band is at most three quarters of the primary
    alone's peak (measured: 0.37-0.67 of it at 60 kg, 0.65 at 40 kg, 0.49-0.65 at 10 kg), and its
    curve keeps the primary's one resonance: its peak within 0.5 rad/s of the primary's (6.3
    rad/s; measured 6.0-6.4), the band's ends below a fifth of it (measured: below 0.11)."""
    _, found = sweeps
    peak = int(np.argmax(alone))
    assert E1MAX_FREQUENCIES[peak] == 6.3
    for label, rows in found.items():
        e1 = rows["e1_max"].to_numpy(dtype=float)
        assert e1.max() <= 0.75 * alone.max(), label
        assert abs(int(np.argmax(e1)) - peak) <= 5, label
        assert max(e1[0], e1[-1]) < 0.2 * e1.max(), label


def test_single_and_double_sided_designs_mitigate_alike(sweeps):
    """Fig. 2 (60 kg): the mitigation is "similar for SSVI NES and for DSVI NES": the two kinds'
    median peak E1max over the band within a quarter of each other (measured: 815 and 788 J)."""
    mass, found = sweeps
    if mass != 60:
        pytest.skip("the claim is Fig. 2's (60 kg)")
    ss, ds = (np.median([rows["e1_max"].max() for label, rows in found.items() if label.startswith(side)])
              for side in ("SS", "DS"))
    assert 0.8 < ss / ds < 1.25, (ss, ds)


IRREGULAR = {"chaotic", "chatter", "modulated"}


def test_the_light_designs_move_irregularly(sweeps):
    """Fig. 10 (10 kg): "different irregular motions".  Table 5 lists chaos for seven of its eight
    designs; here irregular motion (chaos, chatter, amplitude modulation) appears over the band
    for five of the eight (SS-1, SS-2, DS-2, DS-3, DS-4); SS-3 and SS-4 stay periodic (2T,2,1 and
    4T,4,1 at their richest).  The test holds that at least half the designs move irregularly
    somewhere on the band, and that the 60 kg double-sided designs, which the paper calls quiet
    (T,0,0 and T,1,1), never do, nor DS-2(40) (Fig. 6: the 60 kg pattern; T,0,0 and T,1,1)."""
    mass, found = sweeps
    irregular = [label for label, rows in found.items() if IRREGULAR & set(rows["regime"])]
    if mass == 10:
        assert len(irregular) >= len(found) // 2, irregular
    else:
        assert not [label for label in irregular if label.startswith("DS")], irregular


@pytest.mark.slow  # (eight designs at 31 frequencies over 400 s each: about 15 s on 2 cores)
def test_20_kg_designs_keep_their_bilateral_impacts_near_the_resonance(alone):
    """Figs. 7-8 (20 kg), with the two single-sided designs not reproduced (the report's Table 4:
    SS-1(20) takes another of its regimes from rest, SS-4(20) is unexplained) held to what they do
    here.  Fig. 8, "the areas of bilateral impacts remain narrow": every design's bilateral
    impacts lie within 5.5-6.6 rad/s, at most twelve of the 31 frequencies, a frequency step of
    margin at each edge and two on the count (measured: SS-2(20) 6.2,
    SS-3(20) 6.3 and 6.5, DS-1 and DS-2 6.1-6.4, DS-3 6.0-6.5, DS-4 5.6-6.5, where Fig. 9 shows its
    chaos with impacts on both obstacles at 5.7), and the double-sided designs are shockless
    outside them; SS-1(20) meets the primary alone (5.8-6.7 rad/s, no bilateral impact), SS-4(20)
    never impacts (5-8 rad/s).  Fig. 7: every design cuts the primary alone's peak (measured: the
    highest, SS-4(20)'s, 1240 of 1559 J) and peaks within 0.5 rad/s of its resonance (6.0-6.4)."""
    found = class_sweep(ROOT / "scenarios", 20)
    zones = {label: zones_of(rows) for label, rows in found.items()}
    for label, row in zones.items():
        both = [w for w, z in zip(E1MAX_FREQUENCIES, row) if z == "bilateral"]
        assert all(5.5 <= w <= 6.6 for w in both) and len(both) <= 12, (label, both)
        if label.startswith("DS"):
            (_,) = runs(row, "bilateral")  # (one unbroken zone)
            assert set(row) == {"bilateral", "none"}, label
        e1 = found[label]["e1_max"].to_numpy(dtype=float)
        assert e1.max() < alone.max() and abs(int(np.argmax(e1)) - RESONANCE) <= 5, label
    assert set(zones["SS-4(20)"]) == {"none"}
    assert "bilateral" not in zones["SS-1(20)"] and zones["SS-1(20)"][RESONANCE] == "left"
