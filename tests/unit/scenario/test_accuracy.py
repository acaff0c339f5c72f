"""The accuracy guard: warnings on a ``dt`` inside the stability limit but coarse for the scene,
and on realisations that would all be the same; the example scenarios raise none."""

from __future__ import annotations

import pytest

from tests.helpers import ROOT, cli, raw_metrics, scene_from, study_from
from vines_stoch import load_scenario

#: A 1 rad/s primary under an impulse (RK4 without noise).
PRIMARY = {"name": "guard", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.0},
           "loads": [{"type": "impulse", "velocity": 1.0}],
           "simulation": {"duration": 20.0, "dt": 2.5, "scheme": "rk4"}}

#: The primary (damping 0.02) with a vibro-impact NES (clearance 0.02, restitution 0.6).
IMPACT = {"name": "impacts", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.02},
          "absorbers": [{"type": "impact", "mass": 0.05, "clearance": 0.02, "restitution": 0.6}],
          "loads": [{"type": "impulse", "velocity": 1.0}],
          "simulation": {"duration": 100.0, "dt": 0.1}}


def test_rk4_at_two_and_a_half_steps_a_period_is_coarse():
    warnings = study_from(PRIMARY).warnings
    assert warnings == ["<test scenario>: simulation.dt = 2.5: coarse: 2.51 steps a period of the highest "
                        "mode, 1 rad/s; results (energy balance, peaks, EDM) may be wrong without other "
                        "sign: use dt <= 0.314 (20 steps a period) or less"]
    assert study_from(PRIMARY, {"simulation.dt": 0.3}).warnings == []


def test_the_coarse_step_loses_the_energy_and_the_advised_one_keeps_it():
    """What the warning is about: at dt = 2.5 most of the impulse's energy is unaccounted for;
    at the advised dt (20 steps a period) the residual is below 1 % of the input."""
    coarse = raw_metrics(scene_from(PRIMARY))
    fine = raw_metrics(scene_from(PRIMARY, changes={"simulation.dt": 0.314}))
    assert coarse["final_energy"] < 0.1 * coarse["input_energy"]
    assert abs(fine["final_energy"] - fine["input_energy"]) < 0.01 * fine["input_energy"]


@pytest.mark.parametrize("load, what", [
    ({"type": "harmonic", "amplitude": 1.0, "frequency": 20.0}, "loads.1 (harmonic forcing), 20 rad/s"),
    ({"type": "chirp", "amplitude": 1.0, "f0": 0.1, "f1": 5.0, "duration": 10.0},
     "loads.1 (chirp's highest frequency), 31.42 rad/s"),
    ({"type": "half-sine", "amplitude": 1.0, "duration": 0.05},
     "loads.1 (half-sine (a period twice its duration)), 62.83 rad/s"),
    ({"type": "filtered-noise", "intensity": 0.1, "frequency": 10.0, "damping": 2.0},
     "loads.1 (filter's fastest pole), 37.32 rad/s"),
    ({"type": "ground-motion", "soil": "firm", "intensity": 0.1},
     "loads.1 (filter's fastest pole), 15 rad/s"),
])
def test_a_load_faster_than_the_structure_sets_the_time_scale(load, what):
    data = {**PRIMARY, "loads": PRIMARY["loads"] + [load], "simulation": {"duration": 20.0, "dt": 0.05}}
    warnings = study_from(data).warnings
    assert len(warnings) == 1 and f"steps a period of {what}" in warnings[0], warnings


def test_a_swept_dt_names_the_coarsest_point():
    warnings = study_from({**PRIMARY, "sweep": {"simulation.dt": [0.01, 1.0, 2.5]}}).warnings
    assert len(warnings) == 1
    assert warnings[0].startswith("<test scenario> (sweep point {'simulation.dt': 2.5}): "
                                  "simulation.dt = 2.5: coarse")


def test_impact_absorbers_at_a_tenth_of_a_second():
    """The reported scene: at dt = 0.1 an impact slower than a tenth of the speed scale sticks,
    so chatter sequences stop sooner; the guard asks for 100 steps a period."""
    warnings = study_from(IMPACT).warnings
    assert warnings == ["<test scenario>: simulation.dt = 0.1: coarse for impact absorbers: 62.8 steps a "
                        "period of the primary's fundamental mode, 1 rad/s; an impact slower than the "
                        "relative velocity the loads add in one step (about omega dt = 0.1 of the speed "
                        "scale) is plastic and starts sticking, so chatter ends sooner and 'impacts' counts "
                        "fewer: use dt <= 0.0628 (100 steps a period) or less"]
    assert study_from(IMPACT, {"simulation.dt": 1e-3}).warnings == []


def test_chatter_counts_fewer_impacts_at_the_coarse_step():
    """Why: the same energies at dt = 0.1 and 1e-3 (impact loss within 2 %), far fewer impacts."""
    coarse = raw_metrics(scene_from(IMPACT))
    fine = raw_metrics(scene_from(IMPACT, changes={"simulation.dt": 1e-3}))
    assert coarse["impacts"] < 0.5 * fine["impacts"]
    assert coarse["impact_loss"] == pytest.approx(fine["impact_loss"], rel=0.02)


def test_realisations_of_a_deterministic_scene_say_one_runs():
    data = {**PRIMARY, "simulation": {"duration": 20.0, "dt": 0.01}, "ensemble": {"realizations": 50}}
    assert study_from(data).warnings == [
        "<test scenario>: ensemble.realizations = 50: the scene has neither noise nor uncertain parameters, "
        "so every realisation would be the same: one runs a sweep point"]
    noisy = {**data, "loads": data["loads"] + [{"type": "white-noise", "intensity": 0.1}]}
    law = {"distribution": "uniform", "low": 0.0, "high": 0.1}
    uncertain = {**data, "uncertain": {"primary.damping": law}}
    swept = {**noisy, "sweep": {"loads.1.intensity": [0.0, 0.1]}}  # one point without noise: no warning
    for quiet in (noisy, uncertain, swept, {**data, "ensemble": {"realizations": 1}}):
        assert study_from(quiet).warnings == []


EXAMPLES = sorted(p for p in (ROOT / "scenarios").glob("*.toml") if p.name != "elcentro.toml")


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_scenarios_raise_no_warning(path):
    assert load_scenario(path).warnings == []


def test_validate_and_run_print_the_warnings(write, tmp_path):
    text = ('name = "guard"\n[primary]\nmass = 1.0\nstiffness = 1.0\n[[loads]]\ntype = "impulse"\n'
            'velocity = 1.0\n[simulation]\nduration = 20.0\ndt = 2.5\n[ensemble]\nrealizations = 50\n')
    path = write(text)
    code, err = cli("validate", path)
    assert code == 0
    lines = err.splitlines()
    assert len(lines) == 2 and all(line.startswith(f"warning: {path}: ") for line in lines), err
    assert "simulation.dt = 2.5: coarse" in lines[0] and "ensemble.realizations = 50" in lines[1]
    code, err = cli("run", path, "--out", tmp_path / "out", "--quiet", "--workers", "1")
    # the same two before the run; after it, the realisation the coarse step made diverge (its
    # energy balance off by more than half its input)
    assert code == 0 and err.splitlines()[:2] == lines and len(err.splitlines()) == 3, err
    assert err.splitlines()[2].startswith(f"warning: {path}: 1 of 1 realisation(s) diverged"), err
