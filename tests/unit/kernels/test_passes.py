"""The pass loop (kernels/passes.py): one compiled loop for the lane realisations of every smooth
structure of three bodies or more (filtered loads included), and of one or two bodies in a
short run (``test_general_loop.py``), in chunks of ``PASS_LANES``
realisations or more (a smaller one runs in the general scalar loop).  Each realisation's metric vector,
history rows and declared metrics are, bitwise, the scalar loop's on its Philox streams,
whatever the structure; and structures that differ in storeys, absorbers, loads and outputs run
it without compiling anything."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tests.helpers import changed, scene_from
from tests.unit.kernels.test_lanes import FILTERED, FRAME, SEED, philox_streams, same
from vines_stoch.kernels import chunk as chunk_module
from vines_stoch.kernels import chunk_runner, simulate
from vines_stoch.kernels.chunk import PASS_LANES, lane_runner, simulate_chunk
from vines_stoch.kernels.driver import step_loop
from vines_stoch.kernels.lanes import lane_loop
from vines_stoch.kernels.passes import pass_loop, pass_scene
from vines_stoch.outputs import STATUS, STATUS_DIVERGED


def frame(storeys: int, absorbers: list[dict], loads: list[dict], **changes) -> dict:
    """A shear frame of ``storeys`` storeys (masses 1, storey stiffnesses 40 to 30, dashpots 0.1)
    with ``absorbers`` under ``loads``, 1.2 s at dt = 2e-3 (over a divergence check's phasor
    reset), ``changes`` applied."""
    data = {"name": f"passes-{storeys}",
            "primary": {"masses": [1.0] * storeys, "stiffnesses": list(np.linspace(40.0, 30.0, storeys)),
                        "dampings": [0.1] * storeys},
            "absorbers": absorbers, "loads": loads,
            "simulation": {"duration": 1.2, "dt": 2e-3, "scheme": "euler-maruyama"}}
    return changed(data, changes)


CUBIC = {"type": "cubic", "mass": 0.05, "stiffness": 100.0, "damping": 0.02}
BISTABLE = {"type": "bistable", "mass": 0.02, "stiffness": 50.0, "linear_stiffness": -0.2, "damping": 0.01}
GEOMETRIC = {"type": "geometric", "mass": 0.05, "stiffness": 1.0, "free_length": 0.9, "length": 1.0,
             "damping": 0.01}
GAP = {"type": "gap", "mass": 0.05, "stiffness": 60.0, "gap": 0.002, "damping": 0.02}
LINEAR = {"type": "linear", "mass": 0.1, "stiffness": 2.0, "damping": 0.05}
NOISE = {"type": "white-noise", "intensity": 0.3}
HARMONIC = {"type": "harmonic", "amplitude": 0.5, "frequency": 3.0}
GROUND = {"type": "base-harmonic", "amplitude": 0.3, "frequency": 2.0}
BLAST = {"type": "blast", "amplitude": 2.0, "start": 0.3, "duration": 0.2, "decay": 1.0}
#: Stochastic ground motion (filtered, with an envelope): each lane advances its own filters.
CLOUGH_PENZIEN = {"type": "ground-motion", "model": "clough-penzien", "soil": "medium", "intensity": 0.3,
                  "envelope": {"type": "jennings", "rise": 0.5, "hold": 1.0, "decay": 0.5}}
#: Declared metrics (the energy share among them) and limits.
RECORDED = {"output.metrics": ["x_2_rms", "drift_2_peak", "stroke_1_max", "share_peak", "e1_mean"],
            "limits": {"drift": {"metric": "drift_max_2", "value": 0.001},
                       "e1": {"metric": "e1_max", "value": 1e-3}}}

#: Structures of the pass loop: storeys, absorbers of every smooth law (none, one, two at once),
#: loads (white noise on some floors or all, harmonic and blast forces, a harmonic ground
#: acceleration, filtered noise from its stationary law, stochastic ground motion), a metrics
#: window, limits and declared metrics.
SCENES = {
    "frame": FRAME,
    "3 storeys, bare": frame(3, [], [HARMONIC, NOISE]),
    "1 storey, two absorbers": frame(1, [CUBIC, LINEAR], [HARMONIC, NOISE],
                                     **{"simulation.metrics_from": 0.5}),
    "2 storeys, ground, geometric, gap": frame(2, [GEOMETRIC, {**GAP, "floor": 1}], [GROUND, NOISE]),
    "5 storeys, bistable, recorded": frame(5, [BISTABLE, {**CUBIC, "floor": 3}],
                                           [{**NOISE, "floor": 2}, BLAST], **RECORDED),
    "9 storeys, six absorbers": frame(9, [{**CUBIC, "floor": k} for k in (9, 9, 8, 8, 7, 7)],
                                      [HARMONIC, NOISE, {**BLAST, "floor": 4}]),
    "4 storeys, deterministic": frame(4, [{**GEOMETRIC, "floor": 2}], [HARMONIC, BLAST]),
    "filtered noise, stationary start": FILTERED,
    "3 storeys, Clough-Penzien ground motion": frame(3, [{**CUBIC, "mass": 0.1}],
                                                     [CLOUGH_PENZIEN, {**NOISE, "floor": 1}],
                                                     **{"simulation.duration": 2.5}),
}


@pytest.mark.parametrize("name", list(SCENES))
def test_a_pass_lane_is_the_scalar_loop_on_its_philox_streams(name):
    scene = scene_from(SCENES[name])
    assert pass_scene(scene) and chunk_runner(scene) is pass_loop
    rows = simulate_chunk(scene, SEED, 0, 0, PASS_LANES).raw
    for r in range(PASS_LANES):
        scalar = simulate(scene, philox_streams(r))
        assert same(rows[r], scalar), (r, np.flatnonzero(rows[r] != scalar))
    assert not np.isnan(rows).any() or scene.limits.shape[0] > 0
    if scene.has_noise:  # the realisations differ (the noise is theirs)
        assert not np.array_equal(rows[0], rows[1])


def test_the_pass_loop_keeps_the_scalar_loop_s_history_rows():
    """History rows of every signal of a structure (the energy share among them), each
    realisation's bitwise ``simulate``'s on its Philox streams, its metric rows those of a chunk
    that keeps none."""
    scene = scene_from(SCENES["5 storeys, bistable, recorded"])
    signals = ("x1", "e1", "share", "x_2", "v_5", "drift_3", "xa_1", "va_2", "stroke_2")
    plain = simulate_chunk(scene, SEED, 0, 0, PASS_LANES).raw
    kept = simulate_chunk(scene, SEED, 0, 0, PASS_LANES, history=(40, 16), signals=signals)
    assert same(kept.raw, plain)
    for r in range(3):
        history = np.full((16, len(signals)), np.nan)
        simulate(scene, philox_streams(r), history=history, stride=40, signals=signals)
        assert same(kept.history[r], history) and not np.isnan(history).any()


def test_a_path_that_diverges_ends_in_the_pass_loop_as_in_the_scalar_loop():
    base = scene_from(changed(FRAME, {"simulation.duration": 3.0}))
    scene = dataclasses.replace(base, storey_k=base.storey_k * 4e5)  # past the step's stability limit
    rows = simulate_chunk(scene, SEED, 0, 0, PASS_LANES).raw
    for r in range(PASS_LANES):
        assert rows[r][STATUS] == STATUS_DIVERGED
        assert same(rows[r], simulate(scene, philox_streams(r)))


def test_one_pass_loop_serves_every_structure(monkeypatch):
    """Structures that differ in storeys (1 to 9), absorbers (none, cubic, bistable, linear,
    geometric, gap, two and six at once), loads and what a run records run the one compiled pass
    loop: every chunk runs in SIMD lanes and takes the pass loop (the loops a chunk ran, spied on,
    so that a loop an earlier test of the process made is counted too), no other loop is made,
    and the pass loop keeps one compiled signature."""
    ran = []  # (the lane loop each chunk ran)
    monkeypatch.setattr(chunk_module, "lane_runner", lambda *args, **kwargs: ran.append(
        lane_runner(*args, **kwargs)) or ran[-1])
    before = (lane_loop.cache_info().currsize, step_loop.cache_info().currsize)
    for data in SCENES.values():
        scene = scene_from(changed(data, {"simulation.duration": 1.0}))
        simulate_chunk(scene, SEED, 0, 0, PASS_LANES, history=(10, 5), signals=("x1", "e1"))
        simulate_chunk(scene, SEED, 0, 0, PASS_LANES)
    assert len(ran) == 2 * len(SCENES) and all(run is pass_loop for run in ran)
    assert (lane_loop.cache_info().currsize, step_loop.cache_info().currsize) == before
    assert len(pass_loop.overloads) == 1


def test_the_pass_loop_takes_no_scene_with_events_nor_one_of_two_bodies_but_in_a_short_run():
    assert not pass_scene(scene_from(frame(1, [CUBIC], [NOISE])))
    assert pass_scene(scene_from(frame(1, [CUBIC], [NOISE])), general=True)
    assert pass_scene(scene_from(frame(1, [], [NOISE])), general=True)
    impact = scene_from(frame(3, [{"type": "impact", "mass": 0.05, "clearance": 0.05, "restitution": 0.6}],
                              [NOISE]))
    assert not pass_scene(impact) and not pass_scene(impact, general=True)
    assert pass_scene(scene_from(frame(2, [CUBIC], [CLOUGH_PENZIEN])))
