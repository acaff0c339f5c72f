"""``binding``: a realisation's scene made from the sweep point's scene and the drawn values is,
bit for bit, the scene of the point validated again and built again (``build_scene(
study.realise(point, values))``), for every uncertain key the examples and tests use and every
parameter of each absorber type; drawn values a field does not allow are refused in the same
words as validation refuses them."""

from __future__ import annotations

import dataclasses
import struct

import numpy as np
import pytest

from tests.helpers import ROOT, example_data, study_from
from vines_stoch import ScenarioError
from vines_stoch.binding import binding
from vines_stoch.ensemble import draw_parameters
from vines_stoch.scene import Scene, build_scene

#: Draws compared a sweep point.
DRAWS = 6
PRIMARY = {"mass": 1.0, "stiffness": 1.0, "damping": 0.02}
SHORT = {"duration": 1.0, "dt": 0.01}


def uniform(low: float, high: float) -> dict:
    return {"distribution": "uniform", "low": low, "high": high}


def lognormal(median: float, cov: float = 0.2) -> dict:
    return {"distribution": "lognormal", "median": median, "cov": cov}


HERTZ_DOUBLE = {"type": "hertz", "geometry": "double-sided", "mass": 20.0, "stiffness": 697.0,
                "damping": 19.2, "offset": 0.365, "gap": 0.653,
                "contact_left": {"young": [2.1e11, 2.21e7], "poisson": [0.3, 0.3], "radius": 1.0},
                "contact_right": {"young": [2.1e11, 2.05e7], "poisson": [0.3, 0.3], "radius": 1.0,
                                  "q": 0.318}}
HERTZ_FROM_PRIMARY = {"type": "hertz", "geometry": "single-sided", "obstacle": "from-primary", "mass": 22.68,
                      "stiffness": 2481.0, "damping": 41.4, "offset": 0.046, "gap": 0.0683, "rest": 0.05,
                      "contact_left": {"young": [2.1e11, 2.26e7], "poisson": [0.3, 0.3], "radius": 1.0},
                      "contact_right": {"k": 3e8}}
SEED3_PRIMARY = {"mass": 1000.0, "stiffness": 3.95e4, "damping": 452.0}
CONTACT_SIMULATION = {"duration": 1.0, "dt": 1e-4}
WIND = {"type": "wind", "speed": 30.0, "height": 3.0, "area": 1.0, "drag": 1.3}
CLOSED_FORM = [{"type": "half-sine", "amplitude": 1.0, "duration": 0.2, "start": 0.1},
               {"type": "pulse-train", "amplitude": 1.0, "width": 0.1, "period": 0.3, "start": 0.0},
               {"type": "chirp", "amplitude": 1.0, "f0": 0.1, "f1": 2.0, "duration": 1.0},
               {"type": "harmonic", "amplitude": 1.0, "frequency": 2.0, "phase": 0.5}]
RECORDS = [{"type": "record", "file": "records/synthetic_cp_medium.AT2", "units": "g",
            "sa": {"period": 1.0, "damping": 0.05, "value": 0.3}},
           {"type": "force-record", "file": "records/synthetic_cp_medium_1941.AT2", "scale": 100.0}]

#: name -> (scenario tables, uncertain table, the keys that take the realised path)
CASES = {
    "linear": (
        {"primary": PRIMARY,
         "absorbers": [{"type": "linear", "mass": 0.05, "stiffness": 0.05, "damping": 0.01}],
         "loads": [{"type": "impulse", "velocity": 0.5}]},
        {"absorbers.0.mass": uniform(0.04, 0.06), "absorbers.0.stiffness": lognormal(0.05),
         "absorbers.0.damping": uniform(0.0, 0.02), "primary.mass": uniform(0.9, 1.1),
         "primary.stiffness": lognormal(1.0), "primary.damping": uniform(0.0, 0.05)},
        []),
    "cubic": (
        {"primary": PRIMARY,
         "absorbers": [{"type": "cubic", "mass": 0.05, "stiffness": 1.0, "damping": 0.01,
                        "linear_stiffness": 0.1}],
         "loads": [{"type": "impulse", "velocity": 0.5}]},
        {"absorbers.0.mass": uniform(0.04, 0.06), "absorbers.0.stiffness": lognormal(1.0),
         "absorbers.0.damping": uniform(0.005, 0.02), "absorbers.0.linear_stiffness": uniform(0.05, 0.2),
         "primary.damping": {"distribution": "truncated-normal", "mean": 0.01, "std": 0.01, "low": 0.0,
                             "high": 0.015}},
        []),
    "bistable": (
        {"primary": PRIMARY,
         "absorbers": [{"type": "bistable", "mass": 0.05, "stiffness": 2.0, "damping": 0.01,
                        "linear_stiffness": -0.02}],
         "loads": [{"type": "impulse", "velocity": 0.5}]},
        {"absorbers.0.stiffness": lognormal(2.0), "absorbers.0.linear_stiffness": uniform(-0.03, -0.01),
         "absorbers.0.damping": uniform(0.005, 0.02)},
        []),
    "geometric": (
        {"primary": PRIMARY,
         "absorbers": [{"type": "geometric", "mass": 0.05, "stiffness": 0.02, "damping": 0.01,
                        "free_length": 0.2, "length": 0.25}],
         "loads": [{"type": "impulse", "velocity": 0.5}]},
        {"absorbers.0.stiffness": lognormal(0.02), "absorbers.0.free_length": uniform(0.15, 0.2),
         "absorbers.0.length": uniform(0.2, 0.3), "absorbers.0.damping": uniform(0.005, 0.02)},
        []),
    # rk4 under one harmonic force: its frequency moves the Poincare samples too
    "impact-periodic": (
        {"primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.3},
         "absorbers": [{"type": "impact", "mass": 0.2, "clearance": 0.6, "restitution": 0.6, "damping": 0.3,
                        "stiffness": 0.5}],
         "loads": [{"type": "harmonic", "amplitude": 1.0, "frequency": 1.0, "phase": 0.0}],
         "simulation": {"duration": 300.0, "dt": 1e-2, "scheme": "rk4", "metrics_from": 100.0}},
        {"absorbers.0.mass": uniform(0.1, 0.3), "absorbers.0.clearance": uniform(0.3, 1.5),
         "absorbers.0.restitution": uniform(0.4, 0.9), "absorbers.0.stiffness": lognormal(0.5),
         "absorbers.0.damping": uniform(0.2, 0.5), "loads.0.frequency": uniform(0.8, 1.2),
         "loads.0.amplitude": uniform(0.5, 1.5), "loads.0.phase": uniform(-1.0, 1.0)},
        []),
    # an initial load adds to the absorber's start
    "hertz-double-sided": (
        {"primary": SEED3_PRIMARY, "absorbers": [HERTZ_DOUBLE],
         "loads": [{"type": "harmonic", "amplitude": 800.0, "frequency": 6.3},
                   {"type": "initial", "displacement": [0.001, 0.002], "velocity": [0.0, 0.1]}],
         "simulation": CONTACT_SIMULATION},
        {"absorbers.0.mass": uniform(18.0, 22.0), "absorbers.0.stiffness": lognormal(697.0),
         "absorbers.0.damping": uniform(15.0, 25.0), "absorbers.0.offset": uniform(0.3, 0.4),
         "absorbers.0.gap": uniform(0.6, 0.7), "absorbers.0.contact_left.young.1": lognormal(2.21e7),
         "absorbers.0.contact_left.radius": uniform(0.5, 1.5),
         "absorbers.0.contact_right.poisson.0": uniform(0.25, 0.35),
         "absorbers.0.contact_right.q": uniform(0.3, 0.33)},
        []),
    "hertz-from-primary": (
        {"primary": SEED3_PRIMARY, "absorbers": [HERTZ_FROM_PRIMARY],
         "loads": [{"type": "harmonic", "amplitude": 800.0, "frequency": 6.3}],
         "simulation": CONTACT_SIMULATION},
        {"absorbers.0.offset": uniform(0.04, 0.05), "absorbers.0.gap": uniform(0.06, 0.07),
         "absorbers.0.rest": uniform(0.04, 0.06), "absorbers.0.contact_right.k": lognormal(3e8),
         "absorbers.0.contact_left.young.0": lognormal(2.1e11)},
        []),
    "building-rayleigh": (
        {"primary": {"masses": [2.0, 1.5, 1.0], "stiffnesses": [200.0, 150.0, 100.0],
                     "rayleigh": {"ratio": 0.02, "modes": [1, 2]}},
         "absorbers": [{"type": "linear", "mass": 0.1, "stiffness": 2.0, "floor": 2}],
         "loads": [{"type": "harmonic", "amplitude": 1.0, "frequency": 5.0, "floor": 1}],
         "simulation": {"duration": 1.0, "dt": 1e-3},
         "limits": {"roof": {"metric": "x_max_3", "value": 0.4},
                    "drift": {"metric": "drift_max_1", "value": 0.22}}},
        {"primary.masses.1": uniform(1.2, 1.8), "primary.stiffnesses.0": lognormal(200.0),
         "primary.rayleigh.ratio": uniform(0.01, 0.05), "limits.drift.value": uniform(0.1, 0.3),
         "absorbers.0.stiffness": lognormal(2.0)},
        []),
    "building-dashpots": (
        {"primary": {"masses": [2.0, 1.0], "stiffnesses": [200.0, 120.0], "dampings": [0.8, 0.5]},
         "loads": [{"type": "impulse", "velocity": 0.1}], "simulation": {"duration": 1.0, "dt": 1e-3}},
        {"primary.dampings.1": uniform(0.3, 0.7), "primary.masses.0": uniform(1.5, 2.5),
         "primary.stiffnesses.1": lognormal(120.0)},
        []),
    # the wind's mean force row comes first, the closed-form rows after it
    "closed-form-forces": (
        {"primary": PRIMARY, "loads": [WIND, *CLOSED_FORM]},
        {"loads.1.amplitude": uniform(0.5, 1.5), "loads.1.duration": uniform(0.1, 0.3),
         "loads.1.start": uniform(0.0, 0.2), "loads.2.amplitude": uniform(-1.0, 1.0),
         "loads.2.width": uniform(0.05, 0.1), "loads.2.period": uniform(0.2, 0.4),
         "loads.2.start": uniform(0.0, 0.1), "loads.3.amplitude": uniform(0.5, 1.5),
         "loads.3.f0": uniform(0.0, 0.2), "loads.3.f1": uniform(1.5, 2.5),
         "loads.3.duration": uniform(0.5, 1.5), "loads.4.amplitude": uniform(0.5, 1.5),
         "loads.4.frequency": uniform(1.5, 2.5), "loads.4.phase": uniform(0.0, 1.0)},
        []),
    # a blast after a scaled blast (one row a floor) and base excitation
    "blast-and-base": (
        {"primary": PRIMARY,
         "loads": [{"type": "blast", "amplitude": 2.0, "duration": 0.2, "decay": 1.0, "scales": [0.5]},
                   {"type": "blast", "amplitude": 1.0, "duration": 0.3, "decay": 0.5, "start": 0.1,
                    "floor": 1},
                   {"type": "base-harmonic", "amplitude": 0.3, "frequency": 2.0, "phase": 0.0}]},
        {"loads.1.amplitude": uniform(0.5, 1.5), "loads.1.duration": uniform(0.1, 0.3),
         "loads.1.decay": uniform(0.0, 2.0), "loads.1.start": uniform(0.0, 0.2),
         "loads.2.amplitude": uniform(0.1, 0.5), "loads.2.frequency": uniform(1.5, 2.5),
         "loads.2.phase": uniform(0.0, 1.0), "loads.0.amplitude": uniform(1.0, 3.0)},
        ["loads.0.amplitude"]),
    # sums over the loads: impulses and an initial velocity in v0, white-noise variances in sigma
    "state-and-noise": (
        {"primary": PRIMARY, "absorbers": [{"type": "cubic", "mass": 0.05, "stiffness": 1.0}],
         "loads": [{"type": "impulse", "velocity": 0.5}, {"type": "initial", "velocity": [0.1, 0.2]},
                   {"type": "impulse", "velocity": 0.3, "floor": 1},
                   {"type": "white-noise", "intensity": 0.1}, {"type": "white-noise", "intensity": 0.05}]},
        {"loads.0.velocity": uniform(-1.0, 1.0), "loads.2.velocity": uniform(0.1, 0.4),
         "loads.3.intensity": uniform(0.05, 0.2)},
        []),
    "records": (
        {"primary": {"mass": 1000.0, "stiffness": 39478.4, "damping": 251.3},
         "absorbers": [{"type": "impact", "mass": 50.0, "clearance": 0.02, "restitution": 0.6}],
         "loads": RECORDS, "simulation": {"duration": 2.0, "dt": 2e-3},
         "intensity_measures": {"period": 1.0, "damping": 0.05}},
        {"loads.0.sa.value": uniform(0.2, 0.5), "loads.0.sa.damping": uniform(0.02, 0.1),
         "loads.1.scale": uniform(50.0, 150.0), "intensity_measures.period": uniform(0.5, 2.0),
         "intensity_measures.damping": uniform(0.02, 0.1)},
        []),
    # keys that take the realised path: the time grid, a filter, and with them every other key
    "realised": (
        {"primary": PRIMARY, "absorbers": [{"type": "cubic", "mass": 0.05, "stiffness": 1.0}],
         "loads": [{"type": "filtered-noise", "intensity": 0.1, "frequency": 1.0, "damping": 0.3}]},
        {"simulation.dt": uniform(0.005, 0.01), "loads.0.frequency": uniform(0.8, 1.2),
         "absorbers.0.stiffness": lognormal(1.0)},
        ["simulation.dt", "loads.0.frequency"]),
}
#: The example scenarios with [uncertain] tables, at their first and last sweep points.
EXAMPLES = ["robustness_cubic", "robustness_parallel", "cubic_nes_design"]


def assert_same_scene(got: Scene, want: Scene) -> None:
    """Every field of two scenes equal bit for bit (arrays: dtype, shape and bytes)."""
    for f in dataclasses.fields(Scene):
        a, b = getattr(got, f.name), getattr(want, f.name)
        if isinstance(b, dict):
            assert a.keys() == b.keys(), f.name
            for k in b:
                assert_same_array(a[k], b[k], f"{f.name}.{k}")
        elif isinstance(b, np.ndarray):
            assert_same_array(a, b, f.name)
        else:
            assert type(a) is type(b), f.name
            assert (struct.pack("d", a) == struct.pack("d", b)) if isinstance(b, float) else a == b, f.name


def assert_same_array(a: np.ndarray, b: np.ndarray, name: str) -> None:
    assert a.dtype == b.dtype and a.shape == b.shape, name
    assert a.tobytes() == b.tobytes(), f"{name}: {a} != {b}"


def check_points(study, fallback: list[str]) -> None:
    """At the first and last sweep point: the binding's keys on the realised path are
    ``fallback``, and its scenes of ``DRAWS`` draws are those of the realised scenario."""
    for point in sorted({0, len(study.points) - 1}):
        bound = binding(study, point)
        assert bound.fallback == fallback
        for r in range(DRAWS):
            values = draw_parameters(study, 11, point, r)
            assert_same_scene(bound.scene(values), build_scene(study.realise(point, values)))


@pytest.mark.parametrize("case", CASES)
def test_bound_scenes_are_the_realised_scenes_bitwise(case):
    tables, uncertain, fallback = CASES[case]
    data = {"name": case, "simulation": SHORT, **tables, "uncertain": uncertain}
    check_points(study_from(data, directory=ROOT / "scenarios"), fallback)


@pytest.mark.parametrize("name", EXAMPLES)
def test_examples_bound_scenes_are_the_realised_scenes_bitwise(name):
    data = example_data(name)
    assert data["uncertain"]
    check_points(study_from(data, directory=ROOT / "scenarios"), [])


def test_bound_scenes_at_the_ends_of_the_ranges():
    """Values at the ends of their fields' ranges, -0.0 included (a one-storey primary reads a
    stiffness or damping of -0.0 as 0.0)."""
    tables, uncertain, _ = CASES["linear"]
    study = study_from({"name": "ends", "simulation": SHORT, **tables, "uncertain": uncertain})
    for end in (0.0, -0.0, 1e15):
        values = {key: max(end, 1e-15) if key.endswith("mass") else end for key in uncertain}
        assert_same_scene(binding(study, 0).scene(values), build_scene(study.realise(0, values)))


def test_a_binding_is_made_once_a_study_and_sweep_point():
    study = study_from(example_data("robustness_cubic"))
    assert binding(study, 0) is binding(study, 0)
    assert binding(study, 1) is not binding(study, 0)
    assert binding(study, 1).base.v0.tolist() != binding(study, 0).base.v0.tolist()  # (the swept impulse)


def test_a_noise_intensity_drawn_to_zero_takes_the_realised_path():
    """Noise or none decides the scheme: a white-noise intensity drawn to 0 gives the scene
    of the realised scenario, run by another scheme."""
    tables, uncertain, _ = CASES["state-and-noise"]
    loads = [{"type": "impulse", "velocity": 0.5}, {"type": "white-noise", "intensity": 0.1}]
    study = study_from({"name": "noise", "simulation": SHORT, **tables, "loads": loads,
                        "uncertain": {"loads.1.intensity": uniform(0.0, 0.2)}})
    bound = binding(study, 0)
    silent = bound.scene({"loads.1.intensity": 0.0})
    assert_same_scene(silent, build_scene(study.realise(0, {"loads.1.intensity": 0.0})))
    assert silent.scheme != bound.base.scheme and not silent.has_noise


@pytest.mark.parametrize("case,values", [
    ("linear", {"absorbers.0.mass": 1e-20}),
    ("linear", {"absorbers.0.mass": 2e15}),
    ("linear", {"absorbers.0.stiffness": -0.5}),
    ("linear", {"primary.damping": float("nan")}),
    ("linear", {"primary.mass": float("inf")}),
    ("impact-periodic", {"absorbers.0.restitution": 1.4}),
    ("impact-periodic", {"absorbers.0.clearance": 0.0}),
    ("building-rayleigh", {"primary.rayleigh.ratio": 1.0}),
    ("building-rayleigh", {"primary.masses.1": 0.0}),
    ("building-rayleigh", {"primary.stiffnesses.0": 0.0}),  # (Rayleigh damping needs every storey > 0)
    ("hertz-from-primary", {"absorbers.0.offset": 0.069}),  # (past the gap: the obstacle check)
    ("hertz-from-primary", {"absorbers.0.offset": 0.05, "absorbers.0.gap": 0.045}),
    ("hertz-double-sided", {"absorbers.0.contact_right.poisson.0": 0.5}),
    ("closed-form-forces", {"loads.2.width": 0.35}),  # (wider than the period)
    ("records", {"intensity_measures.damping": 1.0}),
    ("bistable", {"absorbers.0.linear_stiffness": 0.01}),
    ("geometric", {"absorbers.0.free_length": 0.3, "absorbers.0.length": 0.25}),  # (springs in compression)
])
def test_drawn_values_are_refused_in_the_words_of_validation(case, values):
    """A value its field does not allow, set in a realisation, is refused with the line that
    validating the realised scenario gives (file, key, value, rule)."""
    tables, uncertain, _ = CASES[case]
    study = study_from({"name": case, "simulation": SHORT, **tables, "uncertain": uncertain},
                       directory=ROOT / "scenarios")
    drawn = {**draw_parameters(study, 11, 0, 0), **values}
    with pytest.raises(ScenarioError) as realised:
        study.realise(0, drawn)
    with pytest.raises(ScenarioError) as bound:
        binding(study, 0).scene(drawn)
    assert str(bound.value) == str(realised.value)
    assert str(bound.value).startswith("<test scenario>: ")


@pytest.mark.parametrize("case,values,message", [
    ("linear", {"absorbers.0.mass": 1e-20},
     "<test scenario>: absorbers.0.mass = 1e-20: must be in [1e-15, 1e+15] (use other units)"),
    ("hertz-from-primary", {"absorbers.0.offset": 0.069, "absorbers.0.gap": 0.0683},
     "<test scenario>: absorbers.0.offset = 0.069: must be < gap (0.0683) with obstacle = 'from-primary' "
     "(the absorber would start inside the obstacle)"),
    # (validation words a table of named limits less well: "Input should be greater than 0")
    ("building-rayleigh", {"limits.drift.value": -1.0},
     "<test scenario>: limits.drift.value = -1.0: must be > 0"),
])
def test_a_refused_value_is_named_with_its_file_key_value_and_range(case, values, message):
    tables, uncertain, _ = CASES[case]
    study = study_from({"name": case, "simulation": SHORT, **tables, "uncertain": uncertain})
    with pytest.raises(ScenarioError) as bound:
        binding(study, 0).scene({**draw_parameters(study, 11, 0, 0), **values})
    assert str(bound.value) == message
