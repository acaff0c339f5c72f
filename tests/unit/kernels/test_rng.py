"""The Philox streams of the GPU ensembles (kernels/rng.py): the generator against its published
known answers, the draws' laws, and each stream a function of (key, place, draw) alone."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from vines_stoch.kernels.rng import (
    DRAWN,
    normal,
    philox4x32,
    philox_normal,
    philox_stream,
    stream_key,
    stream_place,
    uniform,
)

U = np.uint64

#: Random123's known-answer vectors of Philox4x32-10 (its tests/kat_vectors): counter, key,
#: output words.
KNOWN_ANSWERS = [
    ((0, 0, 0, 0), (0, 0), (0x6627E8D5, 0xE169C58D, 0xBC57AC4C, 0x9B00DBD8)),
    ((0xFFFFFFFF,) * 4, (0xFFFFFFFF,) * 2, (0x408F276D, 0x41C83B0E, 0xA20BC7C6, 0x6D5451FD)),
    ((0x243F6A88, 0x85A308D3, 0x13198A2E, 0x03707344), (0xA4093822, 0x299F31D0),
     (0xD16CFE09, 0x94FDCCEB, 0x5001E420, 0x24126EA1)),
]


@pytest.mark.parametrize(("counter", "key", "expected"), KNOWN_ANSWERS)
def test_philox_matches_the_random123_known_answers(counter, key, expected):
    words = philox4x32(*(U(c) for c in counter), *(U(k) for k in key))
    assert tuple(int(w) for w in words) == expected


@njit
def _draws(stream, n, kind):
    out = np.empty(n)
    for i in range(n):
        out[i] = normal(stream) if kind == 0 else uniform(stream)
    return out


def test_normals_have_the_standard_law():
    n = 200_000
    x = _draws(philox_stream(2026, 0, 17), n, 0)
    # mean and variance within 5 standard errors (var of the sample variance: 2 / n)
    assert abs(x.mean()) < 5.0 / math.sqrt(n)
    assert abs(x.var() - 1.0) < 5.0 * math.sqrt(2.0 / n)
    # the tails of the normal law: P(|x| > 2) = 0.0455 within 5 binomial standard errors
    p = 0.04550026389635842
    assert abs(np.mean(np.abs(x) > 2.0) - p) < 5.0 * math.sqrt(p * (1 - p) / n)
    assert np.isfinite(x).all()


def test_uniforms_cover_the_unit_interval_evenly():
    n = 100_000
    u = _draws(philox_stream(3, 2, 0), n, 1)
    assert u.min() >= 0.0 and u.max() < 1.0
    counts, _ = np.histogram(u, bins=10, range=(0.0, 1.0))
    expected = n / 10
    chi2 = float(((counts - expected) ** 2 / expected).sum())
    assert chi2 < 33.7  # the 0.9999 quantile of chi-square with 9 degrees of freedom


def test_python_and_compiled_draws_agree_and_numpy_generators_pass_through():
    a, b = philox_stream(5, 3, 9), philox_stream(5, 3, 9)
    compiled = _draws(a, 10, 0)
    assert np.array_equal(compiled, [normal(b) for _ in range(10)])
    assert a[DRAWN] == b[DRAWN] == 10
    g1, g2 = np.random.default_rng(4), np.random.default_rng(4)
    assert np.array_equal(_draws(g1, 5, 0), g2.standard_normal(5))


def test_a_draw_depends_on_key_place_and_index_alone():
    s = philox_stream(11, 0, 42)
    first = _draws(s.copy(), 100, 0)
    later = s.copy()
    later[DRAWN] = 60  # jump straight to the 61st block
    assert np.array_equal(_draws(later, 40, 0), first[60:])
    # other realisations, purposes, seeds and (without common random numbers) points differ
    others = [philox_stream(11, 0, 43), philox_stream(11, 3, 42), philox_stream(12, 0, 42),
              philox_stream(11, 0, 42, point=1, common=False)]
    for other in others:
        assert not np.array_equal(_draws(other, 100, 0), first)
    # with common random numbers every sweep point sees the same stream
    assert np.array_equal(_draws(philox_stream(11, 0, 42, point=3, common=True), 100, 0), first)
    assert stream_place(7, 3, common=False) == 7 | 3 << 32 and stream_place(7, 3, common=True) == 7
    assert stream_key(11, 0) != stream_key(11, 2)


def test_streams_of_neighbouring_realisations_are_uncorrelated():
    n, m = 400, 2000
    x = np.array([_draws(philox_stream(1, 0, r), m, 0) for r in range(n)])
    corr = np.corrcoef(x)[np.triu_indices(n, 1)]
    # each sample correlation has standard error 1 / sqrt(m); the largest of 79,800 stays under 5.5 of them
    assert np.abs(corr).max() < 5.5 / math.sqrt(m)
    assert abs(corr.mean()) < 5.0 / math.sqrt(m * corr.size)


def test_philox_normal_takes_one_block_a_draw():
    s = philox_stream(9, 0, 0)
    philox_normal(s)
    philox_normal(s)
    assert s[DRAWN] == 2


def test_a_tape_replays_the_filter_noise_a_stream_draws():
    """A scene under a filtered load (from its stationary law) and white noise: its path on a
    tape of the normals a PCG64 filter stream draws is that stream's path, bitwise, and the
    tape is read to its end (``kernels.filter_draws``, the stationary start included); past its
    end a tape gives NaN, and no uniforms."""
    from tests.helpers import scene_from
    from vines_stoch.kernels import filter_draws, simulate
    from vines_stoch.kernels.rng import tape
    from vines_stoch.streams import Streams

    filtered = {"type": "filtered-noise", "intensity": 3.0, "frequency": 6.0, "damping": 0.3,
                "start": "stationary"}
    scene = scene_from({"name": "tape", "primary": {"mass": 1.0, "stiffness": 40.0, "damping": 0.3},
                        "loads": [filtered, {"type": "white-noise", "intensity": 0.5}],
                        "simulation": {"duration": 1.0, "dt": 0.01}})
    drawn = filter_draws(scene)
    assert drawn == 2 * (scene.n_steps + 1)
    streams = Streams(np.random.default_rng(1), None, np.random.default_rng(2))
    out = simulate(scene, streams)
    replayed = tape(np.random.default_rng(2).standard_normal(drawn))
    again = simulate(scene, Streams(np.random.default_rng(1), None, replayed))
    assert np.array_equal(out, again, equal_nan=True)
    assert replayed[0] == drawn
    short = tape([0.5])
    assert normal(short) == 0.5 and math.isnan(normal(short))
    with pytest.raises(TypeError, match="normals only"):
        uniform(short)
