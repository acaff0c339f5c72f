"""A path run in stretches (``kernels.start_path``, ``kernels.advance``) ends in the state, with
the metrics, history rows, Poincare samples and event log of the same path run in one go, bitwise: the step
loops carry their accumulators and hidden state across a split (``kernels/carry.py``), and the
generators continue where the last stretch stopped.  The splits fall before, at and after the
metrics window's opening, off the divergence checks' grid (1024 steps) and across it."""

from __future__ import annotations

import numpy as np
import pytest

from tests.helpers import example_data, example_scene, scene_from
from vines_stoch.kernels import advance, sample_buffer, simulate, start_path
from vines_stoch.outputs import ENERGY_INT, new_events
from vines_stoch.streams import Streams
from vines_stoch.validation import scenes

#: Example scenarios, shortened, and the scheme each runs with: the RK4 loop with Hertz contact
#: and Poincare samples, with impacts and sticking; the kick-drift-kick loop with impacts
#: (deterministic), with Hertz contact and impacts under white noise (the Brownian tree),
#: with filtered ground motion and first-passage limits.
EXAMPLES = {
    "rk4 Hertz contact, harmonic": ("seed003_ds20", "rk4"),
    "rk4 impacts": ("parallel_nes_impulse", "rk4"),
    "kdk impacts, deterministic": ("parallel_nes_impulse", "euler-maruyama"),
    "kdk Hertz contact and impacts under white noise": ("contact_noise_parallel", None),
    "kdk filtered ground motion with limits": ("ground_motion", None),
}


#: Declared metrics (``[output] metrics``), folded into the metric vector at every step end.
DECLARED = ["x_1_rms", "e1_mean", "v_1_peak"]


def _example(name: str, scheme: str | None):
    return example_scene(name, {"simulation.duration": 10.0, "simulation.metrics_from": 2.5,
                                "output.metrics": DECLARED}, scheme)


def _sra():
    """The smooth scene (cubic NES, harmonic load and white noise) with the SRA3 step."""
    return scenes.scene("smooth", {"simulation.duration": 6.0, "simulation.metrics_from": 2.5,
                                   "simulation.scheme": "sra"})


def _run(scene, stops, seed: int = 7):
    """State, metrics, history, samples and event log of the path run to each of ``stops`` in
    turn (one stop: in one go, by ``simulate``)."""
    history = np.zeros((8, 2 + scene.n_floors))
    samples = sample_buffer(scene)
    events = new_events(64)
    stride = scene.n_steps // 7
    if len(stops) == 1:
        final = np.zeros((2, scene.mass.shape[0]))
        out = simulate(scene, np.random.default_rng(seed), final=final, history=history, stride=stride,
                       samples=samples, events=events)
        return final[0], final[1], out, history, samples, events
    path = start_path(scene, np.random.default_rng(seed), history=history, stride=stride, samples=samples,
                      events=events)
    for stop in stops:
        advance(path, stop)
    assert path.step == scene.n_steps and path.t == scene.n_steps * scene.dt
    return path.x, path.v, path.out, history, samples, events


def _splits(scene) -> list[int]:
    i0 = scene.i0
    assert 1024 < i0 < scene.n_steps - 1501  # the splits below fall where the docstring says
    return [777, i0, i0 + 1501, scene.n_steps]


def _assert_same(one_go, stretched):
    for whole, parts in zip(one_go, stretched):
        np.testing.assert_array_equal(parts, whole)  # (NaN equal to NaN: unpassed limits, no samples)


@pytest.mark.parametrize("case", list(EXAMPLES))
def test_a_path_split_in_stretches_ends_as_in_one_go(case):
    scene = _example(*EXAMPLES[case])
    one_go = _run(scene, [scene.n_steps])
    _assert_same(one_go, _run(scene, _splits(scene)))
    assert np.isfinite(one_go[2][:6]).all() and one_go[0].any()


def test_the_sra_step_continues_its_stream_across_a_split():
    scene = _sra()
    _assert_same(_run(scene, [scene.n_steps]), _run(scene, _splits(scene)))


def test_a_stretch_leaves_the_metrics_of_the_path_so_far():
    """After a stretch the metric vector holds the metrics of the path ended there: those of
    the same scene with the shorter duration, run in one go."""
    scene = _example("parallel_nes_impulse", "euler-maruyama")
    path = start_path(scene)
    advance(path, 4000)
    shorter = scene_from(example_data("parallel_nes_impulse", "sweep"),
                         changes={"simulation.duration": 4.0, "simulation.metrics_from": 2.5,
                                  "simulation.scheme": "euler-maruyama", "output.metrics": DECLARED})
    assert shorter.n_steps == 4000
    so_far = simulate(shorter)
    np.testing.assert_array_equal(path.out, so_far)
    advance(path, scene.n_steps)
    assert path.out[ENERGY_INT] > so_far[ENERGY_INT] > 0.0  # (the integral of E1 grew after the split)


def test_advance_refuses_stops_outside_the_path_and_paths_without_a_carry():
    scene = _example("parallel_nes_impulse", "euler-maruyama")
    path = start_path(scene)
    with pytest.raises(ValueError, match="stop -1 must lie between"):
        advance(path, -1)
    with pytest.raises(ValueError, match=f"scene's step count \\({scene.n_steps}\\)"):
        advance(path, scene.n_steps + 1)
    once = start_path(scene, stretches=False)
    once.step = 10  # (as after a first stretch)
    with pytest.raises(ValueError, match="keeps no carry"):
        advance(once, 20)


def _started(scene, split: int, seed: int = 7):
    """A path with history rows, samples and an event log run to step ``split``."""
    history = np.zeros((8, 2 + scene.n_floors))
    path = start_path(scene, Streams.shared(np.random.default_rng(seed)), history=history,
                      stride=scene.n_steps // 7, samples=sample_buffer(scene), events=new_events(64))
    return advance(path, split)


@pytest.mark.parametrize("case", ["rk4 Hertz contact, harmonic",
                                  "kdk Hertz contact and impacts under white noise",
                                  "kdk filtered ground motion with limits"])
def test_a_branch_runs_on_as_its_path_would(case):
    """A branch on copies of its path's generators is a restart from the path's state, time and
    stream position: run on to the end, it and its path agree bitwise."""
    scene = _example(*EXAMPLES[case])
    path = _started(scene, scene.i0 + 1501)
    twin = path.branch()
    assert twin.step == path.step and twin.x is not path.x
    for p in (path, twin):
        advance(p, scene.n_steps)
    for a, b in [(path.x, twin.x), (path.v, twin.v), (path.out, twin.out),
                 (path.args[6].history, twin.args[6].history), (path.args[6].samples, twin.args[6].samples),
                 (path.args[6].events, twin.args[6].events)]:
        np.testing.assert_array_equal(a, b)
    assert path.args[6].events is not twin.args[6].events


@pytest.mark.parametrize("case", ["kdk Hertz contact and impacts under white noise",
                                  "kdk filtered ground motion with limits"])
def test_a_branch_on_new_streams_keeps_the_past_and_draws_its_own_future(case):
    """Branches on other streams share the history rows before the branching step and go their
    own ways after it (the Brownian trees' seed redrawn too); the same streams give the same
    branch."""
    scene = _example(*EXAMPLES[case])
    split = scene.n_steps // 2
    stride = scene.n_steps // 7
    path = _started(scene, split)
    first, second, again = (path.branch(Streams.shared(np.random.default_rng(s))) for s in (11, 12, 11))
    for p in (path, first, second, again):
        advance(p, scene.n_steps)
    rows = split // stride + 1  # (the rows at or before the branching step)
    past = [p.args[6].history[:rows] for p in (path, first, second)]
    np.testing.assert_array_equal(past[0], past[1])
    np.testing.assert_array_equal(past[0], past[2])
    assert not np.array_equal(first.x, second.x) and not np.array_equal(first.x, path.x)
    np.testing.assert_array_equal(first.out, again.out)
    np.testing.assert_array_equal(first.x, again.x)
