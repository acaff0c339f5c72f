"""One random stream per purpose (vines_stoch.streams): common random numbers whatever the impacts.

A realisation draws its step increments, its Brownian-bridge values at impacts and its filter
noise from separate streams, so the increments it sees do not depend on how many impacts a
sweep point has.
"""

from __future__ import annotations

import numpy as np

from tests.helpers import study_from
from vines_stoch.ensemble import sample
from vines_stoch.kernels import simulate
from vines_stoch.outputs import IMPACTS
from vines_stoch.scene import build_scene
from vines_stoch.streams import BRIDGE, FILTER, INCREMENTS, generator, streams

#: A 1e-6 kg impact absorber, which barely touches the primary, swept over its clearance
#: (impacts at 0.05 and 0.2, none at 100) beside the same cubic NES at every point (the
#: impact-rich bench scene's pair: its loop) under harmonic + white (+ filtered: ``FILTERED``)
#: noise.
DATA = {
    "name": "crn",
    "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.05},
    "absorbers": [{"type": "cubic", "mass": 0.05, "stiffness": 1.0, "damping": 0.01},
                  {"type": "impact", "mass": 1e-6, "clearance": 0.2, "restitution": 0.6}],
    "loads": [{"type": "harmonic", "amplitude": 0.1, "frequency": 1.0},
              {"type": "white-noise", "intensity": 0.05}],
    "simulation": {"duration": 200.0, "dt": 0.01},
    "ensemble": {"realizations": 4, "seed": 7},
    "sweep": {"absorbers.1.clearance": [0.05, 0.2, 100.0]},
}
FILTERED = {"type": "filtered-noise", "intensity": 0.05, "frequency": 2.0, "damping": 0.3}


def test_increment_stream_is_the_same_at_every_sweep_point():
    """At every clearance the kernel takes exactly one increment a step from the increment
    stream (the impacts' bridge draws come from their own stream), and running on the streams
    equals replaying those very increments."""
    study = study_from(DATA)  # (a replayed path drives white noise only)
    impacts = []
    for point, scenario in enumerate(study.points):
        scene = build_scene(scenario)
        gens = streams(7, point, 3)
        raw = simulate(scene, gens)
        impacts.append(raw[IMPACTS])
        # the increment stream advanced by exactly one normal a step, whatever the impacts
        fresh = generator(7, point, 3, INCREMENTS)
        normals = fresh.standard_normal(scene.n_steps)
        assert gens.increments.bit_generator.state == fresh.bit_generator.state
        # and those normals are the increments the path saw
        replayed = simulate(scene, streams(7, point, 3, increments=False), normals=normals)
        np.testing.assert_array_equal(raw, replayed)
    assert impacts[0] > impacts[1] > 0 and impacts[2] == 0  # the sweep does change the impacts


def test_streams_are_independent_of_the_point_and_distinct_by_purpose():
    draws = {p: generator(7, 0, 5, p).standard_normal(4) for p in (INCREMENTS, BRIDGE, FILTER)}
    assert len({tuple(d) for d in draws.values()}) == 3
    np.testing.assert_array_equal(generator(7, 0, 5, INCREMENTS).standard_normal(4),
                                  generator(7, 9, 5, INCREMENTS).standard_normal(4))
    assert not np.array_equal(generator(7, 0, 5, INCREMENTS, common=False).standard_normal(4),
                              generator(7, 9, 5, INCREMENTS, common=False).standard_normal(4))


def test_common_random_numbers_whatever_the_impacts():
    """The primary barely feels a 1e-6 kg absorber, so with common random numbers a
    realisation's roof RMS is the same at every clearance: within 1e-2 relative (one stream for
    every purpose made it differ by up to 143 % once impacts occurred)."""
    frame = sample(study_from(DATA, {"loads": [*DATA["loads"], FILTERED]}), workers=1)
    assert (frame["status"] == "ok").all()
    assert frame.groupby("point")["impacts"].sum().tolist()[2] == 0
    for _, group in frame.groupby("realization"):
        rms = group["x1_rms"].to_numpy()
        assert np.ptp(rms) / rms.mean() < 1e-2
