"""numpy's CPU streams in compiled code (``streams/pcg.py``): ``SeedSequence`` hashing, the
``PCG64`` state and ``Generator.standard_normal`` / ``Generator.random`` agree with numpy's,
bitwise, and a numpy generator handed to the step loops ends where numpy would have left it."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit
from numba.np.random._constants import ziggurat_nor_r

from tests.helpers import scene_from, two_dof_data
from vines_stoch.kernels import simulate
from vines_stoch.streams import Streams
from vines_stoch.streams.pcg import (
    new_stream,
    pcg_normal,
    pcg_uniform,
    seed_pool,
    seed_stream,
    set_state,
    state_of,
)

#: Seeds of one to five 32-bit words (numpy pads a seed shorter than its pool of four words).
SEEDS = [0, 1, 2026, 2**32 + 5, 2**70 + 3, 2**130 + 11]
#: Spawn keys (purpose, realisation) and, without common random numbers, (purpose, point,
#: realisation): words of zero, one and two 32-bit words.
KEYS = [(0, 0), (1, 7), (3, 2**32 + 1), (2, 5, 9), (0, 2**33, 2**40 - 1)]


@njit
def _seeded(stream, pool0, hash0, purpose, point, realization, common):
    seed_stream(stream, pool0, hash0, purpose, point, realization, common, np.zeros(4, np.uint64),
                np.zeros(8, np.uint64))
    return stream


@njit
def _draws(stream, n, normals=True):
    out = np.empty(n)
    for i in range(n):
        out[i] = pcg_normal(stream) if normals else pcg_uniform(stream)
    return out


def _normals(stream, n):
    return _draws(stream, n)


def _uniforms(stream, n):
    return _draws(stream, n, False)


def _numpy(seed: int, key: tuple) -> np.random.Generator:
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=key)))


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("key", KEYS)
def test_seeded_streams_are_numpys(seed, key):
    pool, hash_const = seed_pool(seed)
    common = len(key) == 2
    stream = _seeded(np.zeros_like(new_stream()), pool, hash_const, key[0], 0 if common else key[1], key[-1],
                     common)
    gen = _numpy(seed, key)
    assert np.array_equal(stream, state_of(gen))
    assert np.array_equal(_normals(stream, 2000), gen.standard_normal(2000))
    assert np.array_equal(_uniforms(stream, 500), gen.random(500))


def test_normals_through_every_branch_of_the_ziggurat_are_numpys():
    """Two million normals: the layers' fast path, their wedges, and the tail beyond the base
    layer's edge (about 500 draws past ``ziggurat_nor_r``)."""
    gen = _numpy(7, (0, 0))
    stream = state_of(gen)
    drawn, expected = _normals(stream, 2_000_000), gen.standard_normal(2_000_000)
    assert np.array_equal(drawn, expected)
    assert (np.abs(drawn) > ziggurat_nor_r).sum() > 100
    assert np.array_equal(stream, state_of(gen))


def test_a_numpy_generator_ends_where_numpy_leaves_it():
    """A step loop given a PCG64 generator draws from its state and writes the state back: one
    normal a step under white noise (kick-drift-kick), so afterwards the generator stands where
    numpy's would after as many draws."""
    data = {"name": "white noise", **two_dof_data()}
    data["loads"] = [{"type": "white-noise", "intensity": 0.1}]
    data["simulation"] = {"duration": 2.0, "dt": 0.01}
    scene = scene_from(data)
    gen, twin = np.random.default_rng(5), np.random.default_rng(5)
    simulate(scene, Streams.shared(gen))
    twin.standard_normal(scene.n_steps)
    assert gen.bit_generator.state == twin.bit_generator.state
    assert gen.standard_normal() == twin.standard_normal()


def test_state_round_trip_keeps_the_generators_other_fields():
    gen = np.random.default_rng(3)
    gen.integers(0, 2**31, dtype=np.uint32)  # (fills PCG64's 32-bit buffer)
    before = gen.bit_generator.state
    stream = state_of(gen)
    _normals(stream, 10)
    set_state(gen, stream)
    after = gen.bit_generator.state
    assert (after["has_uint32"], after["uinteger"]) == (before["has_uint32"], before["uinteger"])
    twin = np.random.default_rng(3)
    twin.integers(0, 2**31, dtype=np.uint32)
    twin.standard_normal(10)
    assert after == twin.bit_generator.state


def test_other_bit_generators_are_left_to_numpy():
    assert state_of(np.random.Generator(np.random.MT19937(1))) is None
