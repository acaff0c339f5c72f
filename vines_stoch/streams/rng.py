"""Random draws of the kernels from each kind of stream: a PCG64 stream (the CPU ensembles,
``streams/__init__.py``; ``pcg.py``: numpy's generator in compiled code, a ``pcg.PCG_DTYPE`` record
array), a counter-based Philox stream (the GPU ensembles, ``gpu.py``), a tape of given normals
(``tape``: a ``float64`` array, replayed in order; subset simulation's filter noise, ``rare.py``)
or a numpy ``Generator`` (of a bit generator other than ``PCG64``, passed by a user).

A Philox stream is a ``uint64`` array of ``STREAM_WORDS``: the key (two 32-bit words, from the
seed and the purpose), the stream's place (the realisation, and the sweep point without common
random numbers: the counter's upper 64 bits) and the number of draws so far.  Draw ``n`` is
half ``n mod 2`` of block ``n // 2`` of Philox4x32-10 (the block number: the counter's lower
64 bits; Salmon, Moraes, Dror and Shaw, "Parallel random numbers: as easy as 1, 2, 3", SC '11,
doi:10.1145/2063384.2063405; the Random123 reference), so realisation ``r``'s numbers are a
function of (seed, purpose, point, r) and the draw's index alone: the same whatever the launch
configuration, batch or SIMD lane (``kernels/lanes.py`` draws a block's two normals at once).
A block's four words are two 53-bit uniforms: uniform ``n`` is the first or the second; normals
``2m`` and ``2m + 1`` are the Box-Muller pair of block ``m`` (Box and Muller, Ann. Math.
Statist. 29 (1958) 610, doi:10.1214/aoms/1177706645), its cosine and its sine.  The logarithm
and the sine and cosine are branch-free polynomials (``log_positive``, ``sincos_turn``: fdlibm's,
within an ulp or two of the correctly rounded values), so that a loop over SIMD lanes
vectorises them and every lane and every scalar draw computes the same bits.  A stream gives
one kind of draw (a purpose draws normals or uniforms, not both).

The kernels call ``normal`` and ``uniform``; numba picks the implementation by the stream's
type when it compiles a kernel, and plain Python (the CUDA simulator) by ``isinstance`` and
the array's dtype.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types
from numba.extending import overload

from ..jit.flags import INLINE
from ..jit.intrinsics import bits_float, float_bits, fused
from .pcg import PCG_DTYPE, pcg_normal, pcg_uniform

#: Words of a Philox stream: key, place, draws made, and the block (plus one; 0: none) whose
#: second normal the stream holds, with that normal's bits (``philox_normal``).
STREAM_WORDS = 5
KEY, PLACE, DRAWN, PAIRED, SPARE = range(STREAM_WORDS)

_M0, _M1 = np.uint64(0xD2511F53), np.uint64(0xCD9E8D57)  # Philox4x32 multipliers
_W0, _W1 = np.uint64(0x9E3779B9), np.uint64(0xBB67AE85)  # key schedule (Weyl) increments
_LOW = np.uint64(0xFFFFFFFF)
_S32, _S11, _S21 = np.uint64(32), np.uint64(11), np.uint64(21)
_ONE = np.uint64(1)
_ULP53 = 2.0**-53
# fdlibm's (and musl's) log: ln 2 in two parts and the minimax coefficients of
# log((1 + s) / (1 - s)) = 2 s + Lg1 s^3 + ... on the reduced range (e_log.c)
_LN2_HI, _LN2_LO = 6.93147180369123816490e-01, 1.90821492927058770002e-10
_LG1, _LG2, _LG3, _LG4 = 6.666666666666735130e-01, 3.999999999940941908e-01, 2.857142874366239149e-01, \
    2.222219843214978396e-01
_LG5, _LG6, _LG7 = 1.818357216161805012e-01, 1.531383769920937332e-01, 1.479819860511658591e-01
_HIGH_OFFSET = np.uint64(0x3FF00000 - 0x3FE6A09E)  # moves sqrt(2)/2 .. sqrt(2) onto one exponent
_SQRT_HALF_HIGH, _HIGH_MANTISSA = np.uint64(0x3FE6A09E), np.uint64(0x000FFFFF)
_S20 = np.uint64(20)
# fdlibm's sine and cosine kernels on [-pi/4, pi/4] (k_sin.c, k_cos.c)
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11
_HALF_PI = 0.5 * np.pi


@njit(**INLINE)
def philox4x32(c0, c1, c2, c3, k0, k1):
    """Philox4x32-10 of the counter ``(c0, c1, c2, c3)`` under the key ``(k0, k1)`` (32-bit
    words held in ``uint64``): the four 32-bit output words."""
    for _ in range(10):
        p0 = _M0 * c0
        p1 = _M1 * c2
        c0, c1, c2, c3 = (p1 >> _S32) ^ c1 ^ k0, p1 & _LOW, (p0 >> _S32) ^ c3 ^ k1, p0 & _LOW
        k0 = (k0 + _W0) & _LOW
        k1 = (k1 + _W1) & _LOW
    return c0, c1, c2, c3


@njit(**INLINE)
def block_of(stream):
    """The four 32-bit words of the block of the stream's next draw (``draw // 2``), and the
    half of it the draw takes (``draw mod 2``), counting the draw made."""
    n = stream[DRAWN]
    stream[DRAWN] = n + _ONE
    return philox_block(stream[KEY], stream[PLACE], n >> _ONE), n & _ONE


@njit(**INLINE)
def philox_block(key, place, block):
    """Block ``block`` of the Philox stream ``(key, place)``: its four 32-bit words."""
    return philox4x32(block & _LOW, block >> _S32, place & _LOW, place >> _S32, key & _LOW, key >> _S32)


@njit(**INLINE)
def unit_53(high, low) -> float:
    """The 53-bit integer of two 32-bit words' upper bits, as a float (exact)."""
    return float(np.int64((high << _S21) | (low >> _S11)))


@njit(**INLINE)
def philox_uniform(stream) -> float:
    """A uniform in ``[0, 1)`` on the 53-bit grid: the first or the second half of a block."""
    (w0, w1, w2, w3), half = block_of(stream)
    return (unit_53(w2, w3) if half else unit_53(w0, w1)) * _ULP53


@njit(**INLINE)
def block_uniforms(key, place, block):
    """The two uniforms of block ``block`` of the Philox stream ``(key, place)``: its uniforms
    ``2 block`` and ``2 block + 1`` (``philox_uniform``)."""
    w0, w1, w2, w3 = philox_block(key, place, block)
    return unit_53(w0, w1) * _ULP53, unit_53(w2, w3) * _ULP53


@njit(**INLINE)
def log_positive(x: float) -> float:
    """``log(x)`` for a positive normal ``x``, branch-free (musl's ``log``, after fdlibm's
    ``e_log.c``: ``x = 2^k f`` with ``f`` in ``[sqrt(2)/2, sqrt(2))``, then a minimax polynomial
    in ``s = (f - 1) / (f + 1)``; error below 1 ulp)."""
    bits = float_bits(x)
    high = (bits >> _S32) + _HIGH_OFFSET
    k = float(np.int64(high >> _S20) - 0x3FF)
    high = (high & _HIGH_MANTISSA) + _SQRT_HALF_HIGH
    f = bits_float((high << _S32) | (bits & _LOW)) - 1.0
    hfsq = 0.5 * f * f
    s = f / (2.0 + f)
    z = s * s
    w = z * z
    # (the polynomials' multiply-adds fused, as the lanes compute them fastest: ``intrinsics.fused``)
    t1 = w * fused(w, fused(w, _LG6, _LG4), _LG2)
    t2 = z * fused(w, fused(w, fused(w, _LG7, _LG5), _LG3), _LG1)
    return s * (hfsq + (t2 + t1)) + k * _LN2_LO - hfsq + f + k * _LN2_HI


@njit(**INLINE)
def sincos_turn(u: float):
    """``(cos 2 pi u, sin 2 pi u)`` for ``u`` in ``[0, 1)`` on the 53-bit grid, branch-free: the
    quadrant ``q`` nearest ``4 u`` and ``r = 4 u - q`` in ``[-1/2, 1/2]`` are exact, and fdlibm's
    kernels (``k_sin.c``, ``k_cos.c``) take ``x = r pi / 2`` in ``[-pi/4, pi/4]``."""
    y = 4.0 * u
    q = math.floor(y + 0.5)
    x = (y - q) * _HALF_PI
    z = x * x
    w = z * z
    sr = fused(z * w, fused(z, _S6, _S5), fused(z, fused(z, _S4, _S3), _S2))
    sin_x = fused(z * x, fused(z, sr, _S1), x)
    cr = fused(w * w, fused(z, fused(z, _C6, _C5), _C4), z * fused(z, fused(z, _C3, _C2), _C1))
    hz = 0.5 * z
    one_less = 1.0 - hz
    cos_x = one_less + (((1.0 - one_less) - hz) + z * cr)
    quadrant = np.int64(q) & 3
    swap = (quadrant & 1) == 1
    # the signs as factors of +-1 (exact), not branches: the cosine's negative in quadrants 1
    # and 2, the sine's in 2 and 3
    c = (sin_x if swap else cos_x) * (1.0 - float((quadrant + 1) & 2))
    s = (cos_x if swap else sin_x) * (1.0 - float(quadrant & 2))
    return c, s


@njit(**INLINE)
def box_muller(w0, w1, w2, w3):
    """The Box-Muller pair ``(r cos t, r sin t)`` of a block's words: ``r = sqrt(-2 log u1)``,
    ``u1`` in ``(0, 1]`` from the first two words (its logarithm finite), ``t = 2 pi u2``."""
    u1 = (unit_53(w0, w1) + 1.0) * _ULP53
    r = math.sqrt(-2.0 * log_positive(u1))
    c, s = sincos_turn(unit_53(w2, w3) * _ULP53)
    return r * c, r * s


@njit(**INLINE)
def packed_block(key, place, block):
    """Block ``block`` of the Philox stream ``(key, place)`` as two 64-bit words, the first two
    of its 32-bit words and the last two (what ``packed_pair`` takes)."""
    w0, w1, w2, w3 = philox_block(key, place, block)
    return (w0 << _S32) | w1, (w2 << _S32) | w3


@njit(**INLINE)
def packed_pair(a, b):
    """The Box-Muller pair of a block given as ``packed_block``'s two words."""
    return box_muller(a >> _S32, a & _LOW, b >> _S32, b & _LOW)


@njit(**INLINE)
def philox_pair(key, place, block):
    """The two normals of block ``block`` of the Philox stream ``(key, place)``: draws
    ``2 block`` and ``2 block + 1`` of its normals."""
    a, b = packed_block(key, place, block)
    return packed_pair(a, b)


@njit(**INLINE)
def philox_normal(stream) -> float:
    """A standard normal: the cosine or the sine of the Box-Muller pair of its block.  The
    sine of the last pair computed is kept in the stream, so that a stream drawn in order
    computes each block once."""
    n = stream[DRAWN]
    stream[DRAWN] = n + _ONE
    block = n >> _ONE
    if n & _ONE and stream[PAIRED] == block + _ONE:
        return bits_float(stream[SPARE])
    c, s = philox_pair(stream[KEY], stream[PLACE], block)
    stream[PAIRED] = block + _ONE
    stream[SPARE] = float_bits(s)
    return s if n & _ONE else c


@njit(**INLINE)
def open_stream(stream, key, place) -> None:
    """Set ``stream`` (``STREAM_WORDS`` words) to the start of the stream ``(key, place)``."""
    stream[KEY] = key
    stream[PLACE] = place
    stream[DRAWN] = 0
    stream[PAIRED] = 0


def tape(values: np.ndarray) -> np.ndarray:
    """A stream that replays ``values`` as its normals, in order: the count drawn so far, then
    the values (a ``float64`` array).  Draws past its end are NaN (a path that diverges, not
    numbers from elsewhere); it gives no uniforms."""
    return np.concatenate([[0.0], np.asarray(values, dtype=np.float64)])


@njit(**INLINE)
def tape_normal(stream) -> float:
    """The tape's next value (NaN past its end), counting it drawn."""
    i = int(stream[0]) + 1
    stream[0] += 1.0
    return stream[i] if i < stream.shape[0] else math.nan


def normal(gen) -> float:
    """One standard normal from ``gen`` (a PCG64 or Philox stream, a tape, or a numpy Generator)."""
    if isinstance(gen, np.ndarray):
        if gen.dtype == PCG_DTYPE:
            return pcg_normal(gen)
        return tape_normal(gen) if gen.dtype == np.float64 else philox_normal(gen)
    return gen.standard_normal()


def uniform(gen) -> float:
    """One uniform in ``[0, 1)`` from ``gen`` (a PCG64 or Philox stream, or a numpy Generator)."""
    if isinstance(gen, np.ndarray):
        if gen.dtype == np.float64:
            raise TypeError("uniform: a tape replays normals only")
        return pcg_uniform(gen) if gen.dtype == PCG_DTYPE else philox_uniform(gen)
    return gen.random()


@overload(normal)
def _normal(gen):
    if isinstance(gen, types.Array):
        if isinstance(gen.dtype, types.Record):
            return lambda gen: pcg_normal(gen)
        if isinstance(gen.dtype, types.Float):
            return lambda gen: tape_normal(gen)
        return lambda gen: philox_normal(gen)
    return lambda gen: gen.standard_normal()


@overload(uniform)
def _uniform(gen):
    if isinstance(gen, types.Array):
        if isinstance(gen.dtype, types.Record):
            return lambda gen: pcg_uniform(gen)
        if isinstance(gen.dtype, types.Float):
            return None  # (a tape replays normals only)
        return lambda gen: philox_uniform(gen)
    return lambda gen: gen.random()


def stream_key(seed: int, *purpose: int) -> int:
    """The Philox key of a purpose's streams: two 32-bit words hashed from (seed, purpose) by
    numpy's ``SeedSequence`` (as the CPU streams' keys are; ``purpose``: one number, or a key of
    several, the rare-event estimates' ``rare.rare_streams``)."""
    low, high = np.random.SeedSequence(seed, spawn_key=purpose).generate_state(2, np.uint32)
    return int(low) | int(high) << 32


@njit(**INLINE)
def stream_place(realization: int, point: int, common: bool) -> int:
    """The counter's upper 64 bits of a realisation's stream: the realisation, and with common
    random numbers off the sweep point above it (as in ``streams.generator``)."""
    if common:
        return realization
    return realization | (point << 32)


def keyed_stream(key: int, place: int) -> np.ndarray:
    """The Philox stream ``(key, place)`` before its first draw (``STREAM_WORDS`` words: build
    streams here, never by hand, the kernels reading every word)."""
    stream = np.zeros(STREAM_WORDS, np.uint64)
    stream[KEY], stream[PLACE] = key, place
    return stream


def philox_stream(seed: int, purpose: int, realization: int, point: int = 0,
                  common: bool = True) -> np.ndarray:
    """A realisation's Philox stream of one purpose, before its first draw."""
    return keyed_stream(stream_key(seed, purpose), stream_place(realization, point, common))
