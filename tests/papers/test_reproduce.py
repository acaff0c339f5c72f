"""``vines-stoch reproduce`` (``vines_stoch.validation.reproduce``): a smoke test of one section (the whole
report runs for minutes: ``make seeds``)."""

from __future__ import annotations

import re

import pytest

from tests.helpers import ROOT
from vines_stoch.plotting import available
from vines_stoch.validation.reproduce import TABLE_1, _spans, _steady_zone, design, reproduce


def test_one_section_writes_its_table_and_figures(tmp_path):
    out = reproduce(ROOT / "scenarios", tmp_path / "seed-tables.md", sections=("seed000",))
    report = out.read_text()
    assert "## Seed 000" in report and "## Seed 003" not in report
    # every row of its table names its source and carries our number (the fourth column)
    rows = [line.split("|") for line in report.splitlines() if line.startswith("| Fig. 3 |")]
    assert len(rows) == 6
    assert all(re.search(r"\d", row[4]) for row in rows)
    forced = [line.split("|") for line in report.splitlines()
              if line.startswith(("| Figs. 7", "| Figs. 9", "| Fig. 11"))]
    assert len(forced) == 3 and all(re.search(r"\d", row[4]) for row in forced)
    if available():
        assert sorted(p.name for p in (tmp_path / "figures").iterdir()) == [
            "seed000_fig3_edm.png", "seed000_fig4_energy_integral.png", "seed000_figs7_to_11_responses.png"]


def test_an_unknown_section_is_refused(tmp_path):
    with pytest.raises(ValueError, match="unknown section 'seed004': the sections are seed002, seed003"):
        reproduce(ROOT / "scenarios", tmp_path / "seed-tables.md", sections=("seed004",))


def test_an_impact_zone_is_the_walls_the_absorber_met():
    """The impact zones of the report's seed 003 Figs. 3-4, 8 (one case): a run's zone is read
    from the impacts counted on each wall over the
    steady window: a Table 1 double-sided design at the resonance meets both obstacles (the
    paper's T,1,1 zone), and far below it neither (T,0,0, its white zone)."""
    *parameters, _ = next(iter(TABLE_1.values()))
    e1, regime, zone = _steady_zone(design(ROOT / "scenarios", "seed003_ds60", *parameters, frequency=6.3))
    assert zone == "bilateral" and regime == "T,1,1"
    e1, regime, zone = _steady_zone(design(ROOT / "scenarios", "seed003_ds60", *parameters, frequency=5.0))
    assert zone == "none" and regime == "T,0,0"


def test_zones_are_reported_as_spans_of_the_sweep():
    assert _spans([5.0, 5.1, 5.2, 5.5, 5.6, 7.0]) == "5-5.2, 5.5-5.6, 7"
    assert _spans([]) == "-"
