"""The Philox streams of the GPU ensembles and of the SIMD lanes (streams/rng.py): the generator
against its published known answers and an independent implementation, the normal transform's
polynomials and tails, the draws' laws, and each stream a function of (key, place, draw) alone."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from vines_stoch.streams.rng import (
    DRAWN,
    KEY,
    PLACE,
    TAIL_BLOCK,
    TAIL_WORD,
    block_normals,
    fast_radius,
    log1p_f32,
    log_positive,
    normal,
    philox4x32,
    philox_block,
    philox_normal,
    philox_stream,
    reduced_f32,
    sincos_turn,
    sincos_word,
    stream_key,
    stream_place,
    tail_radius,
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
    later[DRAWN] = 60  # jump straight to the 61st draw
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


def test_four_draws_share_a_block_two_pairs_each_the_cosine_then_the_sine():
    """Draws ``4m .. 4m + 3`` are block ``m``'s normals (``block_normals``): the Box-Muller pairs
    of its first two words and of its last two, the radius ``sqrt(-2 log u1)`` of ``u1 = (w +
    1/2) 2^-32`` within ``float32`` rounding."""
    s = philox_stream(9, 0, 0)
    quads = np.array([[philox_normal(s) for _ in range(4)] for _ in range(50)])
    assert s[DRAWN] == 200
    key, place = U(s[KEY]), U(s[PLACE])
    for m in (0, 7, 49):
        assert tuple(quads[m]) == block_normals(key, place, U(m))
    w = philox_block(key, place, U(7))
    for half in (0, 1):
        u1 = (int(w[2 * half]) + 0.5) * 2.0**-32
        assert math.hypot(*quads[7, 2 * half:2 * half + 2]) == pytest.approx(math.sqrt(-2.0 * math.log(u1)),
                                                                            rel=1e-6)


def _reference_block(key: int, place: int, block: int) -> list[float]:
    """An independent Philox4x32-10 (Python integers, after the Random123 specification) and
    the block's two Box-Muller pairs in ``float64`` (the C library's ``log``, ``cos`` and
    ``sin``): ``u1 = (w + 1/2) 2^-32``, below ``TAIL_WORD`` ``u1 = (w + v) 2^-32`` with ``v`` the
    53-bit uniform of the tail block."""
    mask = 0xFFFFFFFF

    def words(counter: int) -> list[int]:
        c = [counter & mask, counter >> 32, place & mask, place >> 32]
        k0, k1 = key & mask, key >> 32
        for _ in range(10):
            p0, p1 = 0xD2511F53 * c[0], 0xCD9E8D57 * c[2]
            c = [(p1 >> 32) ^ c[1] ^ k0, p1 & mask, (p0 >> 32) ^ c[3] ^ k1, p0 & mask]
            k0, k1 = (k0 + 0x9E3779B9) & mask, (k1 + 0xBB67AE85) & mask
        return c

    w, normals = words(block), []
    for half in (0, 1):
        wa, wb = w[2 * half], w[2 * half + 1]
        u1 = (wa + 0.5) * 2.0**-32
        if wa < int(TAIL_WORD):
            t = words(block + int(TAIL_BLOCK))
            u1 = (wa + ((t[2 * half] << 21 | t[2 * half + 1] >> 11) + 1) * 2.0**-53) * 2.0**-32
        r = math.sqrt(-2.0 * math.log(u1))
        normals += [r * math.cos(2.0 * math.pi * wb * 2.0**-32), r * math.sin(2.0 * math.pi * wb * 2.0**-32)]
    return normals


def test_normals_match_an_independent_implementation():
    """Known answers: the first normals of streams of three seeds, purposes and places against
    ``_reference_block`` within ``float32`` rounding (``1e-6``: a few ``float32`` ulps, ``6e-8``
    each, through ``log``, ``sqrt`` and the polynomials, of normals up to about 3)."""
    for seed, purpose, r in ((0, 0, 0), (2026, 3, 17), (7, 4, 1 << 40)):
        stream = philox_stream(seed, purpose, r)
        drawn = _draws(stream, 40, 0)
        expected = [z for m in range(10) for z in _reference_block(stream_key(seed, purpose), r, m)]
        assert np.allclose(drawn, expected, rtol=1e-6, atol=1e-6)


def _tail_place(key: int) -> tuple[int, int, int]:
    """A place, block and half of the Philox stream ``key`` whose pair is a tail pair."""
    for place in range(1 << 20):
        for block in range(64):
            w = philox_block(U(key), U(place), U(block))
            for half in (0, 1):
                if w[2 * half] < TAIL_WORD:
                    return place, block, half
    raise AssertionError("no tail pair found")


def test_a_tail_pair_is_recomputed_from_its_tail_block_in_every_executor():
    """A pair whose first word is below ``TAIL_WORD`` (radius beyond 4.7) takes its radius from
    the tail block, as the independent reference does (within 4 ulp), in the scalar draws and in
    the lanes alike (bitwise), beside lanes without one."""
    from vines_stoch.kernels.lanes import SPARE_ROWS, lane_normals

    key = stream_key(2026, 0)
    place, block, half = _tail_place(key)
    expected = _reference_block(key, place, block)
    got = block_normals(U(key), U(place), U(block))
    assert math.hypot(*got[2 * half:2 * half + 2]) > 4.7
    assert np.allclose(got, expected, rtol=1e-6, atol=1e-6)
    radius = math.hypot(*expected[2 * half:2 * half + 2])
    assert np.allclose(got[2 * half:2 * half + 2], expected[2 * half:2 * half + 2], rtol=4 * 2.0**-52,
                       atol=4 * 2.0**-52 * radius)
    places = np.arange(place - 5, place + 3, dtype=np.uint64)  # (the tail's lane, and lanes without)
    z, spare = np.zeros((4, places.size)), np.zeros((SPARE_ROWS, places.size))
    for d in range(4 * block, 4 * block + 4):
        lane_normals(z[d - 4 * block], spare, places.size, d, U(key), places, 0)
    for lane, p in enumerate(places):
        assert tuple(z[:, lane]) == block_normals(U(key), p, U(block))
    assert tuple(z[:, 5]) == got


@njit
def _logs(x):
    out = np.empty_like(x)
    for i in range(x.shape[0]):
        out[i] = log_positive(x[i])
    return out


@njit
def _turns(u):
    out = np.empty((u.shape[0], 2))
    for i in range(u.shape[0]):
        out[i, 0], out[i, 1] = sincos_turn(u[i])
    return out


def test_the_branch_free_log_sine_and_cosine_are_within_an_ulp_or_two():
    """The polynomials against numpy's ``log`` (within an ulp of the correctly rounded value:
    2 ulp apart at most) and against ``cos`` and ``sin`` in extended precision (x86's 64-bit
    mantissa: the reference's own error, ``1e-18`` at most, allowed for near the zeros) on a
    million arguments each, the ends and the quadrants' edges included; the turn's quadrant
    points are exact."""
    if np.finfo(np.longdouble).nmant < 63:
        pytest.skip("no extended precision for the sine and cosine reference on this platform")
    rng = np.random.default_rng(5)
    x = np.concatenate([rng.random(500_000), 2.0 ** -rng.uniform(0.0, 53.0, 500_000),
                        [1.0, 2.0**-53, 0.5, 1.0 - 2.0**-53, math.sqrt(0.5), math.sqrt(2.0)]])
    ref = np.log(x)
    assert np.all(np.abs(_logs(x) - ref) <= 2.0 * np.spacing(np.abs(ref)))
    u = np.concatenate([np.floor(rng.random(1_000_000) * 2.0**53) * 2.0**-53,
                        np.arange(16) / 16.0, np.arange(1, 9) / 8.0 - 2.0**-53])
    got = _turns(u)
    turn = 2 * np.longdouble("3.14159265358979323846264338327950288") * u.astype(np.longdouble)
    for k, f in enumerate((np.cos, np.sin)):
        ref = f(turn).astype(np.float64)
        assert np.all(np.abs(got[:, k] - ref) <= 2.0 * np.spacing(np.abs(ref)) + 1e-18)
    quarter = _turns(np.array([0.0, 0.25, 0.5, 0.75]))
    assert np.array_equal(quarter, [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])


def _count_past(radius, r: float, top: int) -> int:
    """The count of points ``m`` in ``0 .. top`` whose ``radius(m)`` exceeds ``r``, ``radius``
    falling in ``m``: bisected."""
    lo, hi = -1, top + 1  # radius(lo) > r >= radius(hi), with radius(-1) = inf, radius(top + 1) = 0
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if radius(mid) > r:
            lo = mid
        else:
            hi = mid
    return hi


def test_the_tails_are_those_of_the_normal_law_to_8_standard_deviations():
    """``P(R > r)`` of a pair's radius ``R = sqrt(-2 log u1)`` is ``exp(-r^2 / 2)`` (with the angle
    uniform, the normal's tails follow from the radius's law exactly).  Beyond 4.7 (``u1 <
    2^-16``, the tail pairs: ``u1 = (w + k 2^-53) 2^-32``, ``w < 2^16``, ``k`` in ``1 .. 2^53``) the
    count of grid points past ``r`` is ``2^85 exp(-r^2 / 2)`` within ``float64`` rounding (a radius
    a few ulps off moves the threshold on ``u1`` by ``r^2`` ulps of it: at 8, within one point of
    about ``4.9e11``) at ``r`` = 5, 6, 7 and 8; below it (``float32`` pairs, ``u1 = (w + 1/2) 2^-32``) the
    count of words past ``r`` is ``2^32 exp(-r^2 / 2)`` within ``float32`` rounding (of ``u1``,
    of its log and of the radius: a few ulps, ``2^-24`` each, of ``u1`` and ``r^2`` of them) at
    ``r`` = 1, 2, 3 and 4.  The largest radius is ``sqrt(170 ln 2)``, 10.8; the
    tail's smallest meets the fast pairs' largest."""
    tail = int(TAIL_WORD)

    def tail_point(m: int) -> float:  # (the m-th point of the tail's grid, w-major)
        return tail_radius(m >> 53, float((m & (2**53 - 1)) + 1))

    for r in (5.0, 6.0, 7.0, 8.0):
        expected = 2.0**85 * math.exp(-0.5 * r * r)
        count = _count_past(tail_point, r, tail * 2**53 - 1)
        # (the radius rounded within a few ulps moves the threshold on u1 by r^2 ulps of it)
        assert abs(count - expected) <= 1.0 + 4 * 2.0**-53 * r * r * expected, r
    for r in (1.0, 2.0, 3.0, 4.0):
        expected = 2.0**32 * math.exp(-0.5 * r * r)
        count = _count_past(lambda w: fast_radius(U(w)), r, 2**32 - 1)
        assert abs(count - expected) <= 1.0 + 4 * 2.0**-24 * (1.0 + r * r) * expected, r
    assert tail_radius(0, 1.0) == pytest.approx(math.sqrt(170.0 * math.log(2.0)), rel=1e-15)
    assert fast_radius(U(tail)) <= tail_radius(tail - 1, 2.0**53) < fast_radius(U(tail)) + 1e-4 < 4.72


@njit
def _fast_radii(w):
    out = np.empty(w.shape[0])
    for i in range(w.shape[0]):
        out[i] = fast_radius(w[i])
    return out


def test_the_fast_radius_is_within_float32_rounding_of_the_exact_one():
    """``rng.fast_radius`` against ``sqrt(-2 log u1)`` in ``float64`` of the same ``u1 = (w + 1/2)
    2^-32``: within ``4e-7`` relative (a few ``float32`` ulps, ``6e-8`` each) on a million words
    and at the ends: the largest words (``u1`` near 1, radii down to ``1.7e-5``), whose small
    ``f = u1 - 1`` the word gives exactly, both sides of ``sqrt(2)/2``, and the tail's edge."""
    rng = np.random.default_rng(8)
    edge = math.ceil(2.0**32 * math.sqrt(0.5))
    w = np.concatenate([rng.integers(int(TAIL_WORD), 2**32, 1_000_000), 2**32 - 1 - np.arange(1000),
                        edge + np.arange(-50, 50), int(TAIL_WORD) + np.arange(10)]).astype(np.uint64)
    exact = np.sqrt(-2.0 * np.log((w.astype(np.float64) + 0.5) * 2.0**-32))
    assert np.all(np.abs(_fast_radii(w) - exact) <= 4e-7 * exact)


@njit
def _logs_f32(x):
    out = np.empty_like(x)
    for i in range(x.shape[0]):
        k, f = reduced_f32(x[i])
        out[i] = log1p_f32(k, f)
    return out


@njit
def _word_turns(w):
    out = np.empty((w.shape[0], 2), np.float32)
    for i in range(w.shape[0]):
        out[i, 0], out[i, 1] = sincos_word(w[i])
    return out


def test_the_float32_log_sine_and_cosine_are_within_a_few_ulps():
    """The ``float32`` polynomials of the fast pairs against ``float64`` references: the log
    (``reduced_f32``, then ``log1p_f32``) within 2 ``float32`` ulps of the exact value (musl's
    ``logf``: below 1 ulp; measured 0.75), on a million arguments over the range of ``u1``
    (``2^-32 .. 1``), the ends included; the sine and cosine of the turn of a 32-bit word within 3
    ulps of the exact value (measured 2.6: the rest's rounding to ``float32``, the quarter turn's
    constant's, the product's and the polynomial's; relative, near the zeros too, down to
    ``|sin| = 1.5e-9``) plus ``1e-15`` (the ``float64`` reference's own error at the exact zeros),
    on a million words and the quadrants' edges, the quarter turns exact."""
    rng = np.random.default_rng(6)
    x = np.concatenate([rng.random(500_000), 2.0 ** -rng.uniform(0.0, 32.0, 500_000),
                        [1.0, 2.0**-32, 0.5, math.sqrt(0.5), math.sqrt(2.0) / 2 + 1e-7]]).astype(np.float32)
    ref = np.log(x.astype(np.float64))
    assert np.all(np.abs(_logs_f32(x) - ref) <= 2.0 * np.spacing(np.abs(ref).astype(np.float32)))
    w = np.concatenate([rng.integers(0, 2**32, 1_000_000), np.arange(16) << 28, (np.arange(1, 9) << 29) - 1,
                        np.arange(-1000, 1000) % 2**32, (1 << 30) + np.arange(-1000, 1000)]).astype(np.uint64)
    got = _word_turns(w).astype(np.float64)
    turn = 2.0 * np.pi * w.astype(np.float64) * 2.0**-32
    for k, f in enumerate((np.cos, np.sin)):
        ref = f(turn)
        assert np.all(np.abs(got[:, k] - ref) <= 3.0 * np.spacing(np.abs(ref).astype(np.float32)) + 1e-15)
    quarter = _word_turns(np.array([0, 1 << 30, 2 << 30, 3 << 30], np.uint64))
    assert np.array_equal(quarter, [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])


def test_lane_normals_have_the_standard_law_and_no_correlations():
    """Four million normals of 1,024 lanes (realisations) and 4,096 draws, as the lane loop draws them, each
    lane's the scalar draws of its stream (bitwise): mean, variance, skewness and excess kurtosis within 5
    standard errors, the frequencies of ``|z| > 3`` and ``> 4`` within 5 binomial standard errors, and no
    correlation between neighbouring lanes, between successive draws (the two halves of a pair among them) or
    between a pair's squares."""
    from vines_stoch.kernels.lanes import SPARE_ROWS, lane_normals

    lanes, draws = 1024, 4096
    key, places = U(stream_key(2026, 0)), np.arange(lanes, dtype=np.uint64)
    z, spare = np.zeros((draws, lanes)), np.zeros((SPARE_ROWS, lanes))
    for d in range(draws):
        lane_normals(z[d], spare, lanes, d, key, places, 0)
    x = z.ravel()
    n = x.size
    assert abs(x.mean()) < 5.0 / math.sqrt(n)
    assert abs(x.var() - 1.0) < 5.0 * math.sqrt(2.0 / n)
    assert abs(np.mean(x**3)) < 5.0 * math.sqrt(15.0 / n)
    assert abs(np.mean(x**4) - 3.0) < 5.0 * math.sqrt(96.0 / n)
    for edge, p in ((3.0, 0.0026997960632601866), (4.0, 6.334248366623996e-05)):
        assert abs(np.mean(np.abs(x) > edge) - p) < 5.0 * math.sqrt(p * (1 - p) / n)

    def corr(a, b):
        return float(np.mean((a - a.mean()) * (b - b.mean())) / (a.std() * b.std()))

    for lane in (0, 1, 511, 1023):  # (tail pairs among these blocks: the batch's scalar draw too)
        assert np.array_equal(z[:, lane], _draws(philox_stream(2026, 0, lane), draws, 0)), lane
    pairs = n // 2
    assert abs(corr(z[:, 1:].ravel(), z[:, :-1].ravel())) < 5.0 / math.sqrt(n)  # neighbouring lanes
    assert abs(corr(z[1:].ravel(), z[:-1].ravel())) < 5.0 / math.sqrt(n)  # successive draws
    assert abs(corr(z[2:].ravel(), z[:-2].ravel())) < 5.0 / math.sqrt(n)
    assert abs(corr(z[0::2].ravel() ** 2, z[1::2].ravel() ** 2)) < 5.0 / math.sqrt(pairs)
    radii = z[0::2] ** 2 + z[1::2] ** 2  # (a block's two pairs: radii from words of their own)
    assert abs(corr(radii[0::2].ravel(), radii[1::2].ravel())) < 5.0 / math.sqrt(pairs // 2)


def test_a_tape_replays_the_filter_noise_a_stream_draws():
    """A scene under a filtered load (from its stationary law) and white noise: its path on a
    tape of the normals a PCG64 filter stream draws is that stream's path, bitwise, and the
    tape is read to its end (``kernels.filter_draws``, the stationary start included); past its
    end a tape gives NaN, and no uniforms."""
    from tests.helpers import scene_from
    from vines_stoch.kernels import filter_draws, simulate
    from vines_stoch.streams import Streams
    from vines_stoch.streams.rng import TAPE_DRAWN, tape

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
    assert replayed[TAPE_DRAWN] == drawn
    short = tape([0.5])
    assert normal(short) == 0.5 and math.isnan(normal(short))
    with pytest.raises(TypeError, match="normals only"):
        uniform(short)
