"""The scalar loop's run-time sizes: the number of closed-form load rows is read from the
scene's arrays, not compiled in (``paths.spec_of``, ``jit.intrinsics.scratch`` with a run-time
size), so a scene with one more force runs the loop that the first compiled."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from tests.helpers import example_scene
from vines_stoch.kernels import chunk_runner, simulate_chunk

AMPLITUDE = 1  # (the amplitude's column of a closed-form force row: ``scene.closed_form_rows``)


@pytest.mark.parametrize("scheme", ["euler-maruyama", "sra"])
def test_a_force_split_in_two_rows_runs_the_same_loop_with_the_same_load(scheme):
    """The seed 000 harmonic force split into two rows of half its amplitude: the same loop
    specialised to the scene (the scalar chunk's), on the signature already compiled, and the
    same path to the rounding of the load's sum (within 1e-9 relative, as recorded numbers are
    checked; the path is not chaotic)."""
    scene = example_scene("seed000_harmonic_noise_none", {"simulation.duration": 2.0,
                                                           "simulation.metrics_from": 0.5}, scheme)
    half = scene.forces.copy()
    half[:, AMPLITUDE] *= 0.5
    split = replace(scene, forces=np.vstack([half, half]))
    run = chunk_runner(scene, "scalar")
    whole = simulate_chunk(scene, 3, 0, 0, 1, executor="scalar").raw[0]
    signatures = len(run.overloads)
    halves = simulate_chunk(split, 3, 0, 0, 1, executor="scalar").raw[0]
    assert signatures > 0 and chunk_runner(split, "scalar") is run and len(run.overloads) == signatures
    halved = simulate_chunk(replace(scene, forces=half), 3, 0, 0, 1, executor="scalar").raw[0]
    assert not np.array_equal(halved, whole)
    scale = np.abs(whole[np.isfinite(whole)]).max()
    np.testing.assert_allclose(halves, whole, rtol=1e-9, atol=1e-12 * scale)
