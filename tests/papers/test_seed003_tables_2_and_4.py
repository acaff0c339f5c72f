"""Seed 003 (Lizunov, Pogorelova, Postnikova, Gerashchenko 2024, "Influence of mass on the
efficiency and dynamics of single-sided and double-sided VI NES"): the primary alone (section 4,
E1max = 1557 J) and the designs of Table 2 (m2 = 60 kg) and Table 4 (m2 = 20 kg), steady E1max at
6.3 rad/s within 10 % of the printed values for the 15 designs that come so near (``MATCHING``);
SS-4(60), SS-1(20) and SS-4(20) as printed do not from rest (``vines-stoch reproduce`` writes the
whole table; the seed ledger gives their status): the last two are shown here to be no single
misprint of their parameters (``test_table_4_misses_are_no_single_misprint``), and SS-1(20) to have
a second steady regime whose E1max is the paper's
(``test_ss_1_20_has_two_steady_regimes_and_the_paper_s_e1max_is_the_other_s``)."""

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
    design; D on a grid of 12 values over [0.002 m, 0.98 C) leaves both more than 5 % above (the
    least, +9 %, near D = 0.1 m, amplitude-modulated)."""
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


def test_ss_4_20_is_no_double_misprint_of_its_geometry():
    """SS-4(20) beyond one misprint: D read as printed, ten or a hundred times smaller (its D is
    SS-4(60)'s misprinted one, 0.759 m), C as printed or ten times smaller, and the obstacle
    from the rest position or from the primary (seed 002's convention): none of the eleven
    variants comes within 15 % of the printed 526 J (measured: the nearest, D / 10, +17.4 %, the
    others +35 to +160 %); D / 10 from 12 initial states reaches one regime (2T,2,1, 618 J)."""
    printed, paper = MISSED["SS-4(20)"]
    base = tomllib.loads(Path("scenarios/seed003_ss20.toml").read_text())
    del base["sweep"]
    variants = [(d, c, obstacle) for d in (0.759, 0.0759, 0.00759) for c in (0.871, 0.0871)
                for obstacle in ("from-rest", "from-primary") if obstacle == "from-rest" or d < c]
    data = {**base, "sweep": {"zip": ["absorbers.0.offset", "absorbers.0.gap", "absorbers.0.obstacle"],
                              "absorbers.0.offset": [v[0] for v in variants],
                              "absorbers.0.gap": [v[1] for v in variants],
                              "absorbers.0.obstacle": [v[2] for v in variants]}}
    data["absorbers"][0].update(zip(FIELDS, printed), obstacle="from-rest")
    off = run(data).realizations["e1_max"].to_numpy() / paper - 1.0
    assert len(variants) == 11 and (off > 0.15).all(), dict(zip(variants, off))
    tenth = (*printed[:2], printed[2] / 10.0, printed[3])
    e1 = [run(_from(tenth, tuple(s))).realizations["e1_max"][0] for s in _states(tenth, 12, 5)]
    assert np.ptp(e1) < 1e-6 * paper and e1[0] / paper - 1 > 0.15


def _from(printed: tuple[float, ...], state: tuple[float, float, float, float]) -> dict:
    """The SS design ``printed`` (k2, c2, D, C) of ``seed003_ss20.toml`` started from ``state``:
    the primary's displacement and velocity, the absorber's relative to the primary."""
    data = tomllib.loads(Path("scenarios/seed003_ss20.toml").read_text())
    del data["sweep"]
    data["absorbers"][0].update(zip(FIELDS, printed))
    x1, v1, u, w = state
    data["loads"].append({"type": "initial", "displacement": [x1, x1 + u], "velocity": [v1, v1 + w]})
    return data


def _states(printed: tuple[float, ...], n: int, seed: int) -> np.ndarray:
    """``n`` initial states drawn uniformly: the primary within +-0.4 m and +-2.5 m/s, the
    absorber within its stroke (and 0.2 m beyond) and +-2.5 m/s relative to the primary."""
    return np.random.default_rng(seed).uniform((-0.4, -2.5, -printed[2] - 0.2, -2.5),
                                               (0.4, 2.5, printed[3] - printed[2] + 0.2, 2.5), (n, 4))


def test_ss_1_20_has_two_steady_regimes_and_the_paper_s_e1max_is_the_other_s():
    """SS-1(20) at 6.3 rad/s has two steady regimes: from rest (MODEL.md's start) T,1,0 with
    E1max 727 J (+24 %); from other initial states 2T,2,2 with 602 J, within 10 % of the printed
    586 J (+2.7 %), as the matching designs. Both are among the regimes Table 4 lists for the
    design (its sweep's T,0,0, T,1,0, 2T,2,2), so the paper's E1max is the 2T,2,2 one, reached
    from a start it does not print; of 40 initial states drawn uniformly (``_states``) each
    regime takes at least 5. SS-4(20) has one: 1240 J (+136 %) from rest and from every one of 12
    such states."""
    printed = MISSED["SS-1(20)"][0]
    rows = run(_from(printed, (0.0, 0.0, 0.0, 0.0))).realizations
    rest = rows["e1_max"][0]
    assert rows["regime"][0] == "T,1,0" and rest / 586.0 - 1 > 0.2
    rows = run(_from(printed, (0.098, 2.445, -0.086, -1.699))).realizations
    other = rows["e1_max"][0]
    assert rows["regime"][0] == "2T,2,2" and other == pytest.approx(586.0, rel=0.10)
    assert {"T,1,0", "2T,2,2"} <= SS_1_20_REGIMES
    e1 = np.array([run(_from(printed, tuple(s))).realizations["e1_max"][0] for s in _states(printed, 40, 7)])
    assert (abs(e1 - rest) < 1.0).sum() >= 5 and (abs(e1 - other) < 1.0).sum() >= 5, np.round(e1)
    printed, paper = MISSED["SS-4(20)"]
    e1 = [run(_from(printed, tuple(s))).realizations["e1_max"][0] for s in _states(printed, 12, 5)]
    assert np.ptp(e1) < 1e-6 * paper and e1[0] / paper - 1 > 1.0
