"""Seed 002 (Lizunov, Pogorelova, Postnikova 2023, "Selection of the optimal design for a
vibro-impact nonlinear energy sink"): the four seven-parameter SSVI NES designs
(``scenarios/seed002_*.toml``, obstacle at C from the primary), Table 3 (the wane of the primary's
steady E1max with the 39.7 kg and 62.0 kg designs) and the regimes nT,k,m of Tables 1-2.

Tolerances.  The paper solves with MATLAB at an unstated tolerance, over an unstated window, and
prints E1max wane to three digits.  We assume its E1max carries up to about 1 % of solver and
window error (its primary alone at 6.3 rad/s, seed 003, is 1557 J; ours over [100, 400] s is
1559.4 J, +0.15 %).  The wane ``w = 100 (1 - E / E0)`` moves by ``(100 - w) (dE / E - dE0 / E0)``:
1 % in each of E and E0 moves it by at most 1.7 points (w = 13.7), so the wane is tested within
2 points (measured: within 0.8 point at all twelve entries).  The ``from-rest`` obstacle misses
the 39.7 kg design at 6.2 rad/s by 9 points.  A regime is a label (period, impact counts) and is
tested exactly, in the classes of ``dynamics.refine_regimes`` (a period up to 8T within 1e-3 of
the amplitude, ``metrics.regime``; otherwise transient, chaotic by the largest Lyapunov exponent,
modulated or chatter).  At dt = 5e-4 s and over a 2000 s run (window [1700, 2000] s) the periodic
labels tested here stay the same and the wanes move by under 0.1 point.

The 22.7 kg design at 6.4 rad/s is not the paper's cell (paper 4T,8,8; here 2T,4,4, the same
impacts a period with half the period) but sits on a period-doubling cascade: T,2,2 up to 6.399
rad/s, 2T,4,4 at 6.400-6.403, 4T,8,8 at 6.404-6.405, irregular at 6.406 (the same at dt = 5e-4
s and over 1000 s), so the printed 4T,8,8 is this model's 0.005 rad/s (0.08 %) higher, far
inside what the paper's rounding moves (parameters printed to 3-4 digits, its q = 0.319 against
MODEL.md's 0.318): ``test_table_1_22_7_kg_at_6_4_rad_s_is_a_period_doubling_from_the_paper_s``.
Its three labels hold with margin: the samples repeat within 1e-5 of the amplitude at their period,
and the doubled orbits miss the period before the doubling by 3e-2 or more (the tolerance: 1e-3).
The 62.0 kg design at 7.0 rad/s is not the paper's T,2,1 (two impacts on the primary, one on the
obstacle a period) but that orbit with its second impact on the primary a grazing contact that
comes in some periods only: every period has one impact on the obstacle and one on the primary at
0.27 m/s, and 60-63 % of them (at frequencies within 1e-6 of 7.0 rad/s) a second one on the
primary under 0.037 m/s, none between 0.05 and 0.2 m/s; so the motion is irregular here (chaotic,
exponent 0.49 1/s): ``test_table_2_62_kg_at_7_rad_s_misses_t_2_1_by_a_grazing_impact``.
Not reproduced, so not tested as a cell: the 37.9 kg design at 6.4 rad/s (paper transient
chaos then T,2,3; here still irregular at the run's end, chatter: exponent 0.19 1/s over the
last 32 periods, below the chaos threshold; over [700, 1000] s of a 1000-s run it keeps T,2,3's
impacts, two on the primary and three on the obstacle, in every period, its section within 7e-4
of the primary's mean and 3 mm of the absorber's, at 10 of 12 frequencies within 1e-6 of 6.4
rad/s, and moves on a wider irregular motion at the other two; started on that near-T,2,3 motion
it leaves it within 400 s at 3 of 8: it does not settle here); the 62.0 kg design at 6.2 and 6.4
rad/s (paper "chatter", a motion it reads as deviating somewhat from periodic; here chaotic,
exponents 0.62 and 0.60 1/s; over [700, 1000] s of a 1000-s run 0.45-0.65 1/s against 0.81-2.28
1/s at the paper's five chaotic cells, the impacts of its commonest period, (3,3) and (2,2), in
65-77 % of the periods; no measure
tried, the exponent, the spread of the primary's section or that share, separates the paper's
chatter from its chaos with a margin).  The 37.9 kg design at 7.0 rad/s, paper chaotic, is
chaotic here too (1.16 1/s).  Exponents over the last 32 forcing periods of the scenario's
window, as the regimes, unless said."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from tests.helpers import ROOT, changed, example_data, study_from
from vines_stoch import load_scenario, run
from vines_stoch.ensemble import run_chunk
from vines_stoch.scene import build_scene
from vines_stoch.validation.reproduce import REGIMES_MISSED, REGIMES_PRINTED, WANE
from vines_stoch.validation.reproduce import SEED002_FREQUENCIES as FREQUENCIES

#: Wane agreement in percentage points (module docstring).
WANE_POINTS = 2.0
#: The 62.0 kg design at 7.0 rad/s: impacts on the primary slower than this are grazing
#: (measured: at most 0.037 m/s), those at least ``FAST`` its period's main one (measured: 0.270
#: m/s or faster); none falls between (module docstring).
GRAZING, FAST = 0.05, 0.2
#: Tables 1-2 as printed, where this model reproduces them.
REGIMES = {name: tuple(None if (name, omega) in REGIMES_MISSED else regime
                       for omega, regime in zip(FREQUENCIES, row))
           for name, row in REGIMES_PRINTED.items()}


@cache
def steady(name: str, index: int) -> tuple[float, str]:
    """Steady ``e1_max`` and regime of sweep point ``index`` of ``scenarios/<name>.toml``."""
    point = load_scenario(ROOT / "scenarios" / f"{name}.toml").points[index]
    assert point.loads[0].frequency == FREQUENCIES[index]
    row = run_chunk(build_scene(point), 0, 0, 0, 1)[0].iloc[0]
    return float(row["e1_max"]), str(row["regime"])


@pytest.mark.parametrize("name, index", [(name, i) for name in WANE for i in range(len(FREQUENCIES))])
def test_table_3_wane_within_two_points(name, index):
    alone, _ = steady("seed002_primary", index)
    with_damper, _ = steady(name, index)
    wane = 100.0 * (1.0 - with_damper / alone)
    assert wane == pytest.approx(WANE[name][index], abs=WANE_POINTS)


@pytest.mark.parametrize("name, index", [(name, i) for name, row in REGIMES.items()
                                         for i, regime in enumerate(row) if regime is not None])
def test_tables_1_and_2_regimes(name, index):
    assert steady(name, index)[1] == REGIMES[name][index]


def regime_at(name: str, frequency: float) -> str:
    """Steady regime of ``scenarios/<name>.toml``'s design at ``frequency`` (rad/s)."""
    point = study_from(example_data(name, "sweep"), {"loads.0.frequency": frequency}).points[0]
    return str(run_chunk(build_scene(point), 0, 0, 0, 1)[0].iloc[0]["regime"])


def test_table_1_22_7_kg_at_6_4_rad_s_is_a_period_doubling_from_the_paper_s():
    """The module docstring's cascade: T,2,2, then the table's 2T,4,4, then the paper's 4T,8,8."""
    assert [regime_at("seed002_m22", w) for w in (6.398, 6.400, 6.405)] == ["T,2,2", "2T,4,4", "4T,8,8"]


def test_table_2_62_kg_at_7_rad_s_misses_t_2_1_by_a_grazing_impact():
    """The module docstring's 62.0 kg design at 7.0 rad/s (paper T,2,1): every forcing period of the
    window has one impact on the obstacle and one on the primary at 0.27 m/s, and some a second
    impact on the primary, a grazing contact under 0.037 m/s (none between 0.05 and 0.2 m/s):
    T,2,1 in the periods that have it (60-63 % of them, measured at frequencies within 1e-6 of
    7.0 rad/s), T,1,1 in the others.  Tested: the one fast impact on each side in every period, the
    grazing one in 40-80 % of them, the motion irregular."""
    data = changed(example_data("seed002_m62", "sweep"), {"loads.0.frequency": 7.0, "output.events": 5000})
    result = run(data)
    grid = result.scenario.base.simulation
    events = result.events
    period = 2.0 * np.pi / 7.0
    n = int((grid.duration - grid.metrics_from) // period)
    which = np.floor((events["t"].to_numpy() - grid.metrics_from) / period).astype(int)
    primary = (events["wall"] == "left").to_numpy()
    speed = np.abs(events["speed"].to_numpy())
    assert not (primary & (speed >= GRAZING) & (speed < FAST)).any()
    for side, fast in ((primary, speed >= FAST), (~primary, speed >= 0.0)):
        assert np.array_equal(np.bincount(which[side & fast], minlength=n)[:n], np.ones(n, int))
    grazing = np.bincount(which[primary & (speed < GRAZING)], minlength=n)[:n]
    assert grazing.max() == 1 and 0.4 < grazing.mean() < 0.8, grazing.mean()
    assert result.realizations["regime"][0] in ("chaotic", "chatter")
