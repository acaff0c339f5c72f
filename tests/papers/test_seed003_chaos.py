"""Seed 003's chaotic motions (Lizunov, Pogorelova, Postnikova, Gerashchenko 2024).

Fig. 9: DS-4(20) (Table 4) at 5.7 rad/s moves chaotically with impacts on both obstacles (broad
spectra, smeared Poincare maps): here too, with the largest Lyapunov exponent four times the
chaos threshold (0.75-0.80 1/s over the last 32 periods, the threshold 0.20 1/s) and impacts on
both sides, over [100, 400] s and [500, 1000] s.

Fig. 12: DS-4(10) (Table 5:
m2 = 10 kg, k2 = 428 N/m, c2 = 12.6 N s/m, V = 0.0276 m, C = 0.799 m) at 6.1 rad/s moves
chaotically with asymmetric impacts on both obstacles in the paper.  Here, with the printed
values, the damper never reaches an obstacle in the window: T,0,0, from rest and from a start
with the damper at 8 m/s (and, tried beside, primary displacements to 0.3 m).  The cause: a grazing case.  The
damper's non-impacting steady motion stops about 4 % short of the obstacles: with C 4 % smaller
(0.766 m or less) it reaches them and the motion is chaotic with impacts on both sides (in
unequal numbers, measured, as the figure shows); between 0.764 and 0.768 m periodic impacting orbits
(6T,1,2, T,1,1) come and go.  So the printed C sits just past a grazing threshold, and the
paper's chaos rests on its third digit or on a convention for V that moves an obstacle by a few
centimetres.

The labels are held where they are far from their thresholds: T,0,0 with no impact (a count),
and chaotic with an exponent 2.5 times the chaos threshold (0.58 1/s against ``2 ln 32`` over
the last 32 periods, 0.21 1/s)."""

from __future__ import annotations

import tomllib

import pytest

from tests.helpers import ROOT
from vines_stoch import run

#: DS-4(10) of Table 5: m2, k2, c2, V, C.
DS_4_10 = (10.0, 428.0, 12.6, 0.0276, 0.799)


def ds_4_10(gap: float) -> dict:
    """DS-4(10) under 800 cos(6.1 t) N from rest, 1000 s, the regime over the last 32 periods."""
    data = tomllib.loads((ROOT / "scenarios" / "seed003_ds20.toml").read_text())
    data.pop("sweep")
    mass, stiffness, damping, offset, _ = DS_4_10
    data["absorbers"][0].update(mass=mass, stiffness=stiffness, damping=damping, offset=offset, gap=gap)
    data["loads"][0]["frequency"] = 6.1
    data["simulation"] = {"duration": 1000.0, "dt": 1e-3, "metrics_from": 500.0, "scheme": "rk4"}
    return data


@pytest.mark.parametrize("gap, start", [(DS_4_10[4], 0.0), (DS_4_10[4], 8.0), (0.77, 0.0)])
def test_as_printed_the_damper_never_reaches_the_obstacles(gap, start):
    """From rest, or with the damper thrown at 8 m/s (it strikes, then settles): T,0,0."""
    data = ds_4_10(gap)
    data["loads"].append({"type": "initial", "displacement": [0.0, 0.0], "velocity": [0.0, start]})
    row = run(data).realizations.iloc[0]
    assert row["regime"] == "T,0,0" and row["impacts"] == 0


def test_with_the_obstacles_four_percent_nearer_the_motion_is_chaotic_with_asymmetric_impacts():
    row = run(ds_4_10(0.76)).realizations.iloc[0]
    assert row["regime"] == "chaotic"
    assert min(row["impacts_left"], row["impacts_right"]) >= 50  # (measured 143 and 121: not held equal
    # or unequal, a chaotic count)


@pytest.mark.parametrize("window", [(400.0, 100.0), (1000.0, 500.0)])
def test_fig9_ds_4_20_at_5_7_rad_s_is_chaotic_with_impacts_on_both_sides(window):
    data = tomllib.loads((ROOT / "scenarios" / "seed003_ds20.toml").read_text())
    data.pop("sweep")
    data["absorbers"][0].update(stiffness=679.0, damping=10.3, offset=0.00544, gap=0.774)  # DS-4(20)
    data["loads"][0]["frequency"] = 5.7
    data["simulation"] = {"duration": window[0], "dt": 1e-3, "metrics_from": window[1], "scheme": "rk4"}
    row = run(data).realizations.iloc[0]
    assert row["regime"] == "chaotic" and min(row["impacts_left"], row["impacts_right"]) > 50
