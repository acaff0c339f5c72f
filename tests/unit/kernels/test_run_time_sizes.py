"""The scalar loop's run-time sizes: the number of closed-form load rows is read from the
scene's arrays, not compiled in (``paths.spec_of``, ``jit.intrinsics.scratch`` with a run-time
size), so a scene with one more force runs the loop that the first compiled."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from tests.helpers import example_scene
from vines_stoch.kernels import kernel_for, simulate

AMPLITUDE = 1  # (the amplitude's column of a closed-form force row: ``scene.closed_form_rows``)


@pytest.mark.parametrize("scheme", ["euler-maruyama", "sra"])
def test_a_force_split_in_two_rows_runs_the_same_loop_with_the_same_load(scheme):
    """The seed 000 harmonic force split into two rows of half its amplitude: the same loop,
    on the signature already compiled, and the same path to the rounding of the load's sum (the
    halves' products may fuse into the sum: within 1e-9 relative, as recorded numbers are
    checked; the path is not chaotic)."""
    scene = example_scene("seed000_harmonic_noise_none", {"simulation.duration": 2.0,
                                                           "simulation.metrics_from": 0.5}, scheme)
    half = scene.forces.copy()
    half[:, AMPLITUDE] *= 0.5
    split = replace(scene, forces=np.vstack([half, half]))
    kernel = kernel_for(scene)
    whole = simulate(scene, np.random.default_rng(3))
    signatures = len(kernel.overloads)
    halves = simulate(split, np.random.default_rng(3))
    assert kernel_for(split) is kernel and len(kernel.overloads) == signatures
    assert not np.array_equal(simulate(replace(scene, forces=half), np.random.default_rng(3)), whole)
    scale = np.abs(whole[np.isfinite(whole)]).max()
    np.testing.assert_allclose(halves, whole, rtol=1e-9, atol=1e-12 * scale)
