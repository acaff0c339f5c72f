"""Seed 003 (Lizunov, Pogorelova, Postnikova, Gerashchenko 2024, "Influence of mass on the
efficiency and dynamics of single-sided and double-sided VI NES"): the primary alone (section 4,
E1max = 1557 J) and the designs of Table 2 (m2 = 60 kg) and Table 4 (m2 = 20 kg), steady E1max at
6.3 rad/s within 10 % of the printed values for the 15 designs that come so near (``MATCHING``);
SS-4(60), SS-1(20) and SS-4(20) as printed do not (``vines-stoch reproduce`` writes the whole
table; the seed ledger gives their status): the last two are shown here to be no single misprint
of their parameters (``test_table_4_misses_are_no_single_misprint``)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import raw_metrics
from vines_stoch import load_scenario, run
from vines_stoch.scene import build_scene
from vines_stoch.validation.reproduce import PRIMARY_E1MAX, TABLES


def test_primary_alone_matches_seed_003():
    study = load_scenario("scenarios/seed003_primary.toml")
    scene = build_scene(study.points[0])
    assert raw_metrics(scene)["e1_max"] == pytest.approx(PRIMARY_E1MAX, rel=0.01)


# the printed designs that the paper's E1max confirms (reports/seed-tables.md lists all 18)
MATCHING = {"SS-1(60)", "SS-2(60)", "SS-3(60)", "SS-5(60)", "SS-2(20)", "SS-3(20)",
            "DS-1(60)", "DS-2(60)", "DS-3(60)", "DS-4(60)", "DS-5(60)",
            "DS-1(20)", "DS-2(20)", "DS-3(20)", "DS-4(20)"}


@pytest.mark.parametrize("name", list(TABLES))
def test_seed_003_designs_within_ten_percent(name):
    labels, paper = TABLES[name]
    study = load_scenario(f"scenarios/{name}")
    for label, e1_paper, point in zip(labels, paper, study.points):
        if label in MATCHING:
            e1 = raw_metrics(build_scene(point))["e1_max"]
            assert e1 == pytest.approx(e1_paper, rel=0.10), label


#: Table 4's two single-sided designs that miss the printed E1max as printed: (k2, c2, D, C) and
#: the printed E1max (J) at 6.3 rad/s, and the regimes the paper lists for SS-1(20).
MISSED = {"SS-1(20)": ((205.0, 42.1, 0.135, 0.758), 586.0), "SS-4(20)": ((198.0, 36.0, 0.759, 0.871), 526.0)}
SS_1_20_REGIMES = {"T,0,0", "T,1,0", "2T,2,2"}
FIELDS = ("stiffness", "damping", "offset", "gap")


def _misprints(printed: tuple[float, ...]) -> dict[str, tuple[float, ...]]:
    """The design as printed, with one parameter ten times larger or smaller, and with D on a
    grid of [0.002 m, 0.98 C)."""
    found = {"as printed": printed}
    for i, field in enumerate(FIELDS):
        for factor, word in ((10.0, "x 10"), (0.1, "/ 10")):
            found[f"{field} {word}"] = tuple(p * factor if j == i else p for j, p in enumerate(printed))
    for d in np.geomspace(0.002, 0.98 * printed[3], 12):
        found[f"D = {d:.4f}"] = (*printed[:2], float(d), printed[3])
    return found


def test_table_4_misses_are_no_single_misprint():
    """SS-1(20) and SS-4(20) as printed miss Table 4's E1max (+24 %, +136 %).  The cause of
    SS-4(60)'s miss in Table 2, one misprinted decimal point, does not explain them: of the
    eight variants with one of k2, c2, D, C ten times larger or smaller, none of SS-4(20)'s comes
    within 10 % of the printed E1max (the nearest, D / 10: +17 %) and of SS-1(20)'s only k2 / 10
    (+3.9 %), whose regime at 6.3 rad/s, T,1,1, is not among those the paper lists for the
    design; D anywhere on [0.002 m, C) leaves both more than 5 % above (the least, +9 %, near
    D = 0.1 m, amplitude-modulated)."""
    base = tomllib.loads(Path("scenarios/seed003_ss20.toml").read_text())
    del base["sweep"]
    for label, (printed, paper) in MISSED.items():
        variants = _misprints(printed)
        data = {**base, "sweep": {"zip": [f"absorbers.0.{f}" for f in FIELDS],
                                  **{f"absorbers.0.{f}": [v[i] for v in variants.values()]
                                     for i, f in enumerate(FIELDS)}}}
        rows = run(data).realizations
        off = dict(zip(variants, rows["e1_max"].to_numpy() / paper - 1.0))
        regime = dict(zip(variants, rows["regime"]))
        assert off["as printed"] > 0.2, (label, off["as printed"])
        near = {name for name, o in off.items() if abs(o) < 0.10 and not name.startswith("D =")}
        assert near == ({"stiffness / 10"} if label == "SS-1(20)" else set()), (label, off)
        if label == "SS-1(20)":
            assert regime["stiffness / 10"] not in SS_1_20_REGIMES, regime["stiffness / 10"]
        assert min(o for name, o in off.items() if name.startswith("D =")) > 0.05, (label, off)
