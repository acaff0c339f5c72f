"""A chunk of realisations in one compiled call (``kernels/chunk.py``) records what ``simulate``
records for each realisation on its streams (``streams.streams``), bitwise: the metric vector,
the history rows, the event log and the Poincare samples, with and without common random
numbers, from any first realisation; so the numbers of an ensemble depend on no chunk size.
The ground paths, the uncertain parameters' draws and the intensity measures of a chunk are
those of a realisation at a time."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import truncnorm

from tests.helpers import example_scene, study_from, two_dof_data
from vines_stoch.ensemble import chunk_parameters, run_chunk
from vines_stoch.kernels import load_history, sample_buffer, simulate
from vines_stoch.kernels.chunk import ground_paths, lane_scene, realization_streams, simulate_chunk
from vines_stoch.outputs import X1_MAX, new_events
from vines_stoch.physics.spectra import pseudo_acceleration
from vines_stoch.streams import FILTER, PARAMETERS, generator
from vines_stoch.streams.rng import philox_stream

SEED = 11
SIGNALS = ("x1", "e1")
#: Shortened examples: Hertz contact and impacts under white noise (the Brownian trees' seed
#: stream), filtered ground motion with limits (the filter stream and its stationary start),
#: Hertz contact under a harmonic load by RK4 (Poincare samples).
SCENES = {
    "contact under noise": ("contact_noise_parallel", {"simulation.duration": 4.0}, None),
    "filtered ground motion": ("ground_motion", {"simulation.duration": 4.0}, None),
    "harmonic, RK4": ("seed003_ds20", {"simulation.duration": 30.0, "simulation.metrics_from": 10.0}, "rk4"),
}


@pytest.mark.parametrize("common", [True, False])
@pytest.mark.parametrize("case", SCENES)
def test_a_chunk_records_what_simulate_records_bitwise(case, common):
    scene = example_scene(*SCENES[case])
    start, stop, point, stride, size, rows = 3, 7, 2, 10, 25, 6
    chunk = simulate_chunk(scene, SEED, point, start, stop, common, (stride, size), SIGNALS, rows)
    for j, r in enumerate(range(start, stop)):
        gens = realization_streams(scene, SEED, point, r, common)  # (Philox where the scene runs in lanes)
        history, events = np.full((size, len(SIGNALS)), np.nan), new_events(rows)
        samples = sample_buffer(scene)
        raw = simulate(scene, gens, samples=samples, history=history, stride=stride, signals=SIGNALS,
                       events=events)
        assert np.array_equal(chunk.raw[j], raw, equal_nan=True)
        assert np.array_equal(chunk.history[j], history, equal_nan=True)
        assert np.array_equal(chunk.events[j], events, equal_nan=True)
        assert np.array_equal(chunk.samples[j], samples, equal_nan=True)
    assert np.isfinite(chunk.history).all()
    if case == "harmonic, RK4":
        assert np.isfinite(chunk.samples).any()


@pytest.mark.parametrize("philox", [False, True])
def test_ground_paths_are_the_paths_the_realisations_saw(philox):
    scene = example_scene("ground_motion", {"simulation.duration": 3.0})
    start, stop, point = 5, 8, 1
    paths = ground_paths(scene, SEED, point, start, stop, common=False, philox=philox)
    for j, r in enumerate(range(start, stop)):
        gen = (philox_stream(SEED, FILTER, r, point, common=False) if philox
               else generator(SEED, point, r, FILTER, common=False))
        _, _, ground = load_history(scene, gen)
        assert np.array_equal(paths[j], ground)
    assert np.abs(paths).max() > 0


def test_intensity_measures_are_those_of_the_ground_the_realisations_saw():
    """Stochastic ground motion runs in SIMD lanes, its filters on Philox streams: a chunk's
    ``pga`` is the peak of the ground acceleration that each realisation's own filter stream
    gives (``realization_streams``, what ``simulate`` of the realisation draws from)."""
    scene = example_scene("ground_motion", {"simulation.duration": 3.0, "intensity_measures.period": 1.0})
    assert lane_scene(scene) and scene.im_period == 1.0
    frame, _ = run_chunk(scene, SEED, 1, 2, 5)
    for j, r in enumerate(range(2, 5)):  # (fresh streams for each: a draw moves a stream on)
        _, _, ground = load_history(scene, realization_streams(scene, SEED, 1, r))
        assert frame["pga"].iloc[j] == np.abs(ground).max() > 0
        assert frame["x1_max"].iloc[j] == simulate(scene, realization_streams(scene, SEED, 1, r))[X1_MAX]
    assert frame["pga"].nunique() == 3


def test_spectra_of_a_chunk_are_those_of_each_path():
    """``pseudo_acceleration`` of paths in rows (one filter call a chunk) equals it path by
    path, bitwise, for paths at rest at their start and not."""
    rng = np.random.default_rng(2)
    paths = rng.standard_normal((5, 400))
    paths[1, 0] = 0.0
    rows = pseudo_acceleration(paths, 0.01, 0.8, 0.05)
    assert np.array_equal(rows, [pseudo_acceleration(p, 0.01, 0.8, 0.05) for p in paths])


def test_chunk_parameters_are_numpys_draws():
    """One draw a parameter, in file order, from each realisation's parameter stream: the
    values numpy's generator gives drawn one at a time."""
    data = {"name": "uncertain", **two_dof_data(), "loads": [{"type": "impulse", "velocity": 0.5}],
            "simulation": {"duration": 1.0, "dt": 0.01},
            "uncertain": {"loads.0.velocity": {"distribution": "normal", "mean": 1.0, "std": 0.05},
                          "absorbers.0.stiffness": {"distribution": "lognormal", "median": 1.0, "cov": 0.3},
                          "absorbers.0.damping": {"distribution": "uniform", "low": 0.005, "high": 0.02},
                          "primary.damping": {"distribution": "truncated-normal", "mean": 0.02, "std": 0.01,
                                              "low": 0.0, "high": 0.03}}}
    study = study_from(data)
    start, stop, point = 4, 12, 3
    for common in (True, False):
        drawn = chunk_parameters(study, SEED, point, start, stop, common)
        for j, r in enumerate(range(start, stop)):
            gen = generator(SEED, point, r, PARAMETERS, common)
            velocity = 1.0 + 0.05 * gen.standard_normal()
            stiffness = 1.0 * math.exp(math.sqrt(math.log1p(0.3**2)) * gen.standard_normal())
            damping = 0.005 + (0.02 - 0.005) * gen.random()
            primary_damping = float(truncnorm.ppf(gen.random(), -2.0, 1.0, loc=0.02, scale=0.01))
            assert drawn["loads.0.velocity"][j] == velocity
            assert drawn["absorbers.0.stiffness"][j] == stiffness
            assert drawn["absorbers.0.damping"][j] == damping
            assert drawn["primary.damping"][j] == primary_damping
