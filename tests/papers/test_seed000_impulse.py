"""Seed 000 (Wei, Wei, Zhang, Dong, Peng, Zhang 2019, "Targeted energy transfer of a parallel nonlinear
energy sink"), Figs. 3 and 4: EDM and the energy integral against the impulse strength X for the cubic
NES at its optimum and the parallel NES (``scenarios/seed000_impulse_cubic.toml``, ``_parallel``: a
reconstruction, their headers say what is assumed).  The paper prints no number for these figures;
the tests hold what its text says they show: targeted energy transfer only above an input energy,
its efficiency declining as the energy grows, the parallel NES keeping a high EDM over a wider range
of X and emptying the primary faster; and at X = 1 (Figs. 5 and 6), large jumps of the NES's energy
share at impacts that go on through the run, in a disordered, non-periodic sequence; and (Fig. 2)
the zig-zag function sketching the vibro-impact absorber's relative displacement in the early time.

Tolerances.  The scenes are deterministic; halving dt moves no EDM of the sweep in the third digit.
Below the threshold the cubic spring is too soft to act (its force is ``k u^2 / (c omega)`` = 2e-4
of the dashpot's at X = 0.01), and the absorber is a free mass that the primary drags through the
dashpot: its share of the dissipation is ``c_eff / (c1 + c_eff)``, ``c_eff = c m^2 w^2 / (m^2 w^2 +
c^2)`` (0.3704).  That formula ignores the decay of the primary's motion within a period (total damping
ratio 0.016) and the absorber's mass-loading of the frequency (eps / 2), first-order effects on the
dissipation rate that cancel in the share to second order: it is tested within 0.005.  The other
tests compare curves whose gaps (0.01 to 0.4) exceed the dt error by more than twenty times."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from tests.helpers import example_data, study_from
from vines_stoch.ensemble import run_chunk
from vines_stoch.kernels import simulate
from vines_stoch.outputs import new_events
from vines_stoch.physics.absorbers import CLEARANCE
from vines_stoch.scene import build_scene

#: The impulse strengths of the scenarios' sweep.
X = np.logspace(-2.0, 1.0, 31)


@cache
def sweep(kind: str) -> dict[str, np.ndarray]:
    """EDM, impacts and energy integral per input energy along the sweep of
    ``scenarios/seed000_impulse_<kind>.toml``."""
    points = study_from(example_data(f"seed000_impulse_{kind}")).points
    assert [p.loads[0].velocity for p in points] == pytest.approx(X, rel=1e-12)
    rows = [run_chunk(build_scene(p), 0, 0, 0, 1)[0].iloc[0] for p in points]
    return {"edm": np.array([r["edm"] for r in rows]),
            "impacts": np.array([r["impacts"] for r in rows]),
            "integral": np.array([r["energy_integral"] / r["input_energy"] for r in rows])}


@cache
def edm_at_one(stiffness: float, damping: float) -> float:
    """EDM at X = 1 of the cubic NES with the stiffness and damping given."""
    changes = {"loads.0.velocity": 1.0, "absorbers.0.stiffness": stiffness, "absorbers.0.damping": damping}
    point = study_from(example_data("seed000_impulse_cubic", "sweep"), changes).points[0]
    return float(run_chunk(build_scene(point), 0, 0, 0, 1)[0].iloc[0]["edm"])


def dashpot_share() -> float:
    """The absorbers' share of the dissipation when the cubic spring does not act (module docstring)."""
    data = example_data("seed000_impulse_cubic")
    c1, (nes,) = data["primary"]["damping"], data["absorbers"]
    inertia = (nes["mass"] * 1.0) ** 2
    effective = nes["damping"] * inertia / (inertia + nes["damping"] ** 2)
    return effective / (c1 + effective)


def test_below_the_threshold_the_cubic_nes_takes_its_dashpot_share():
    low = X <= 0.1
    assert sweep("cubic")["edm"][low] == pytest.approx(dashpot_share(), abs=0.005)


def test_targeted_energy_transfer_only_above_an_input_energy():
    edm = sweep("cubic")["edm"]
    peak = int(np.argmax(edm))
    assert 0.6 < X[peak] < 1.6
    assert edm[peak] >= 2.0 * dashpot_share()
    # below half the peak's X the spring is still idle: EDM stays near the dashpot share
    assert np.all(edm[X < X[peak] / 2.0] < dashpot_share() + 0.05)


def test_above_the_threshold_the_efficiency_declines():
    edm = sweep("cubic")["edm"]
    peak = int(np.argmax(edm))
    assert np.all(np.diff(edm[peak:]) < 0.0)
    assert edm[-1] < dashpot_share()


def test_the_cubic_nes_is_at_its_optimum():
    best = edm_at_one(0.025, 0.0125)
    # a step of 1.5 times either way in stiffness or damping
    for stiffness, damping in ((0.0375, 0.0125), (0.025 / 1.5, 0.0125), (0.025, 0.01875),
                               (0.025, 0.0125 / 1.5)):
        assert best > edm_at_one(stiffness, damping) + 0.005, (stiffness, damping)
    assert best > edm_at_one(1.0, 0.01) + 0.4   # the earlier representative values (MODEL.md section 5)


def test_without_impacts_the_parallel_nes_is_the_cubic_nes():
    quiet = sweep("parallel")["impacts"] == 0
    assert X[quiet].max() >= 0.1   # the primary's swing stays inside the cavity up to X = 0.2
    assert sweep("parallel")["edm"][quiet] == pytest.approx(sweep("cubic")["edm"][quiet], rel=1e-12)


def test_the_parallel_nes_keeps_a_high_edm_over_a_wider_range():
    cubic, parallel = sweep("cubic")["edm"], sweep("parallel")["edm"]
    assert np.all(parallel >= cubic - 1e-12)
    below = (X >= 0.25) & (X <= 0.65)   # impacts, but the cubic NES below its threshold
    assert np.all(parallel[below] >= 0.6) and np.all(cubic[below] < 0.45)
    above = X >= 3.0
    assert np.all(parallel[above] > cubic[above] + 0.05)


def test_the_parallel_nes_empties_the_primary_faster():
    """Fig. 4: the integral of the primary's energy, per input energy, is smaller with impacts."""
    cubic, parallel = sweep("cubic")["integral"], sweep("parallel")["integral"]
    assert np.all(parallel <= cubic * (1.0 + 1e-9))
    below = (X >= 0.25) & (X <= 0.65)
    assert np.all(parallel[below] < 0.7 * cubic[below])


@cache
def impulse_path(velocity: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The parallel NES's energy share (eq. 21: the signal ``share``) at every step end and its
    impacts' times (the event log) at the impulse ``velocity``, and the step."""
    changes = {"loads.0.velocity": velocity}
    scene = build_scene(study_from(example_data("seed000_impulse_parallel", "sweep"), changes).points[0])
    share, events = np.full((scene.n_steps + 1, 1), np.nan), new_events(1000)
    simulate(scene, history=share, stride=1, signals=["share"], events=events)
    times = events[~np.isnan(events[:, 0]), 0]
    assert times.shape[0] < events.shape[0]  # (the log held every impact)
    return share[:, 0], times, scene.dt


#: The impulse of Figs. 5 and 6 (the paper's Section 2 case, X = 1) and two others a hair away: the
#: late impacts of a disordered sequence move with them (the last: 274, 310 and 240 s), so a claim
#: tested here holds on all three, not by the rounding of one run.
NEAR_ONE = (1.0, 1.0 + 1e-9, 1.0 - 1e-9)


@pytest.mark.parametrize("velocity", NEAR_ONE)
def test_the_nes_energy_share_jumps_at_impacts_throughout_the_run(velocity):
    """Fig. 5 (eq. 21, X = 1): the impacts go on over the whole run (some in its second half:
    2-3 of 30-31), and the energy exchange at an impact is very large: the NES's share of the
    energy jumps by more than 0.3 across an impact's step (0.415 measured), against at most
    1e-3 over a step away from impacts (3.6e-4: the exchange through the cubic spring)."""
    share, times, dt = impulse_path(velocity)
    assert np.sum(times > 0.5 * dt * (share.shape[0] - 1)) >= 1
    at = np.round(times / dt).astype(int)
    jumps = np.abs(share[np.minimum(at + 1, share.shape[0] - 1)] - share[np.maximum(at - 1, 0)])
    quiet = np.ones(share.shape[0] - 1, bool)
    for step in at:
        quiet[max(step - 2, 0):step + 2] = False
    assert jumps.max() > 0.3 and np.abs(np.diff(share))[quiet].max() < 1e-3


@pytest.mark.parametrize("velocity", NEAR_ONE)
def test_the_impacts_under_the_impulse_are_not_periodic(velocity):
    """Fig. 6 (X = 1): the impacts are disordered, not periodic: the times between them spread
    (their coefficient of variation above 1.5: 2.0-2.4 measured; a periodic sequence of one or
    two impacts a period stays below 1) and hardly repeat (at least 85 % of them distinct to 1 %:
    27-29 of 29-30)."""
    _, times, _ = impulse_path(velocity)
    gaps = np.diff(times)
    assert gaps.std() / gaps.mean() > 1.5
    assert len(np.unique(np.round(np.log(gaps) / 0.01))) >= 0.85 * gaps.shape[0]


@cache
def stroke_path(velocity: float) -> tuple[np.ndarray, float, float]:
    """The vibro-impact absorber's displacement relative to the primary, ``w`` (the signal
    ``stroke_2``), at every step end at the impulse ``velocity``; the step and the clearance."""
    changes = {"loads.0.velocity": velocity}
    scene = build_scene(study_from(example_data("seed000_impulse_parallel", "sweep"), changes).points[0])
    w = np.full((scene.n_steps + 1, 1), np.nan)
    simulate(scene, history=w, stride=1, signals=["stroke_2"])
    return w[:, 0], scene.dt, float(scene.rows[1, CLEARANCE])


def zig_zag_misfit(velocity: float, periods: tuple[int, int]) -> float:
    """The RMS misfit, over the RMS of ``w`` itself, of the zig-zag function ``2 D / pi arcsin(cos(t
    - theta))`` (clearance ``D``; time in the primary's radians) to ``w`` over the primary's periods
    ``periods[0] .. periods[1] - 1`` after the impulse, at the best of 720 phases ``theta``."""
    w, dt, clearance = stroke_path(velocity)
    t = dt * np.arange(w.shape[0])
    part = (t >= 2 * np.pi * periods[0]) & (t < 2 * np.pi * periods[1])
    misfit = min(np.sqrt(np.mean((w[part] - 2 * clearance / np.pi * np.arcsin(np.cos(t[part] - theta))) ** 2))
                 for theta in np.linspace(0.0, 2 * np.pi, 720, endpoint=False))
    return misfit / np.sqrt(np.mean(w[part] ** 2))


@pytest.mark.parametrize("velocity", NEAR_ONE)
def test_the_zig_zag_function_sketches_w_in_the_early_time(velocity):
    """Fig. 2 (X = 1): "the zig-zag function sketches the rough outline of the displacement
    response of the relative variable w0 in the early time of simulation".  Its misfit to ``w``
    over the primary's first two periods is below 0.55 of ``w``'s RMS (0.44 measured: the outline),
    and above 0.7 over the next two and the four after (0.82 and 0.95: later it is no outline).
    A sine of the same period and amplitude fits the first two periods as well (0.42): the
    zig-zag is an outline, no closer a likeness."""
    assert zig_zag_misfit(velocity, (0, 2)) < 0.55
    assert zig_zag_misfit(velocity, (2, 4)) > 0.7 and zig_zag_misfit(velocity, (4, 8)) > 0.7
