"""Seed 003 (Lizunov, Pogorelova, Postnikova, Gerashchenko 2024): Table 1 (double-sided designs
of 40, 49.3 and 66.1 kg from the five-parameter optimisation), the double-sided rows of Table 5
(m2 = 10 kg), SS-4(60) of Table 2 read with D = 0.0759 m, and Table 6 (the "normal" 10 kg
designs), each on the seed 003 primary under 800 cos(6.3 t) N from rest, steady E1max over
[100, 400] s.  The designs are the Table 2 and 4 scenarios with the printed parameters set.

Tolerances. The paper solves with MATLAB's ode23s at unstated tolerances and prints E1max to three
digits (0.5 % at most). Our RK4 values are converged: halving dt or running 2000 s (window [1700,
2000] s) moves every value tested here by under 1e-5 relative. Ours sit above the paper's at the 8
designs here (+0.9 % to +4.8 %) and at 14 of the 15 of Tables 2 and 4 that come within 10 % (+0.3
% to +4.9 %; SS-2(60) is 2.3 % below, unexplained), but only +0.15 % for the primary alone, whose
energy hardly swings within a period at resonance: we assume the paper's E1max reads up to 5 % low
where an impacting absorber makes the primary's energy swing within a period (a maximum taken at a
variable-step solver's steps falls short of the peak), plus the 0.5 % rounding, so E1max is tested
within 6 % (measured: within 4.8 %). Table 6 prints no E1max; its text says the mitigation by the
"normal" designs is "very weak, almost non-existent", tested as E1max at least 80 % of the primary
alone's (measured 91 % and 88 %). It places narrow bands of bilateral impacts near the resonance,
symmetric for the double-sided design and asymmetric for the single-sided one: tested at 6.3 rad/s
on the regime nT,k,m (k == m > 0, and k, m > 0 with k != m).

Not reproduced, so not tested: Table 5 prints one E1max row (428, 603, 411, 560 J) under both the
single-sided and the double-sided designs; we read it as the double-sided designs' (they come
within 3.5 %, tested below; the reading itself is not demonstrated); the single-sided ones give
949, 571, 818 and 621 J (+122 %, -5.3 %, +99 %, +10.8 %; with the obstacle from the primary 1105,
764, 993 and 929 J).  SS-4(60) as printed (D = 0.759 m) gives 1071 J against
145 J, SS-1(20) 727 J against 586 J (+24 %; its other steady regime's 602 J is the paper's,
``test_seed003_tables_2_and_4.py``) and SS-4(20) 1240 J against 526 J
(``reports/seed-tables.md``)."""

from __future__ import annotations

import re
from functools import cache

import pytest

from tests.helpers import ROOT
from tests.papers.test_seed003_tables_2_and_4 import _from, _states
from vines_stoch import run
from vines_stoch.ensemble import run_chunk
from vines_stoch.scene import build_scene
from vines_stoch.validation.reproduce import (
    PRIMARY_E1MAX,
    SS_4_60,
    TABLE_1,
    TABLE_5,
    TABLE_5_SS,
    TABLE_6,
    WEAK,
    design,
)

#: Agreement of E1max with the printed value (module docstring).
REL = 0.06

REGIME = re.compile(r"(\d*)T,(\d+),(\d+)")


@cache
def steady(scenario: str, mass: float, stiffness: float, damping: float, offset: float,
           gap: float) -> tuple[float, str]:
    """Steady ``e1_max`` and regime of ``scenarios/<scenario>.toml`` (its first design) with the
    absorber's parameters set, at 6.3 rad/s."""
    point = design(ROOT / "scenarios", scenario, mass, stiffness, damping, offset, gap)
    row = run_chunk(build_scene(point), 0, 0, 0, 1)[0].iloc[0]
    return float(row["e1_max"]), str(row["regime"])


@pytest.mark.parametrize("label", list(TABLE_1))
def test_table_1_double_sided_designs(label):
    *design, paper = TABLE_1[label]
    assert steady("seed003_ds60", *design)[0] == pytest.approx(paper, rel=REL)


@pytest.mark.parametrize("label", list(TABLE_5))
def test_table_5_double_sided_designs(label):
    *design, paper = TABLE_5[label]
    assert steady("seed003_ds20", *design)[0] == pytest.approx(paper, rel=REL)


def test_table_2_ss_4_60_with_the_decimal_point_moved():
    *design, paper = SS_4_60
    assert steady("seed003_ss60", *design)[0] == pytest.approx(paper, rel=REL)


@pytest.mark.parametrize("label", list(TABLE_6))
def test_table_6_normal_designs_mitigate_little(label):
    assert steady(*TABLE_6[label])[0] >= WEAK * PRIMARY_E1MAX


@pytest.mark.parametrize("label", list(TABLE_6))
def test_table_6_normal_designs_impact_both_sides_at_resonance(label):
    match = REGIME.fullmatch(steady(*TABLE_6[label])[1])
    assert match is not None
    left, right = int(match[2]), int(match[3])
    assert left > 0 and right > 0
    assert (left == right) == label.startswith("DS")


def test_table_5_single_sided_misses_are_no_other_steady_regime():
    """Table 5's one E1max row under the single-sided designs: SS-1(10) and SS-3(10) miss it by
    +122 % and +99 % from rest, and from no other start do they come near it: of 20 initial
    states drawn as for SS-1(20)'s second regime (``test_seed003_tables_2_and_4._states``),
    every steady E1max stays 50 % above the printed value (measured: SS-1(10) 936-949 J against
    428 J, SS-3(10) 818 J against 411 J over 40 states).  So no coexisting regime explains them,
    unlike SS-1(20)'s; the row being the double-sided designs' alone stays the reading."""
    for label, paper in (("SS-1(10)", 428.0), ("SS-3(10)", 411.0)):
        mass, *printed = TABLE_5_SS[label]
        e1 = []
        for state in _states(tuple(printed), 20, 11):
            data = _from(tuple(printed), tuple(state))
            data["absorbers"][0]["mass"] = mass
            e1.append(run(data).realizations["e1_max"][0])
        assert min(e1) > 1.5 * paper, (label, min(e1))
