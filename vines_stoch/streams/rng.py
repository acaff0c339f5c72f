"""Random draws of the kernels from each kind of stream: a PCG64 stream (the CPU ensembles,
``streams/__init__.py``; ``pcg.py``: numpy's generator in compiled code), a counter-based Philox
stream (the SIMD lanes and the GPU ensembles, ``gpu.py``), a tape of given normals (``tape``,
replayed in order; subset simulation's filter noise, ``rare.py``), each a ``uint64`` array whose
first word says its kind (``kinds.py``: one type, so a loop compiles once for every mix of
streams), or a numpy ``Generator`` (of a bit generator other than ``PCG64``, passed by a user).

A Philox stream is a ``uint64`` array of ``STREAM_WORDS``: its kind, the key (two 32-bit words,
from the seed and the purpose), the stream's place (the realisation, and the sweep point without common
random numbers: the counter's upper 64 bits), the number of draws so far and the normals kept
from the last block.  Its draws come from blocks of Philox4x32-10 (the block number: the
counter's lower 64 bits; Salmon, Moraes, Dror and Shaw, "Parallel random numbers: as easy as
1, 2, 3", SC '11, doi:10.1145/2063384.2063405; the Random123 reference), so realisation ``r``'s
numbers are a function of (seed, purpose, point, r) and the draw's index alone: the same
whatever the launch configuration, batch or SIMD lane (``kernels/lanes.py`` draws a block's
normals at once).  A block's four 32-bit words are two 53-bit uniforms (uniform ``n``: the first
or the second half of block ``n // 2``) or four normals: normals ``4m .. 4m + 3`` are the
Box-Muller pairs (Box and Muller, Ann. Math. Statist. 29 (1958) 610,
doi:10.1214/aoms/1177706645) of block ``m``'s first two words and of its last two, each the
cosine then the sine (``block_normals``).

A pair's radius ``sqrt(-2 log u1)`` takes ``u1 = (w + 1/2) 2^-32`` from its first word ``w`` and
its angle ``2 pi w' 2^-32`` from the second, computed in ``float32`` arithmetic (``fast_pair``:
musl's ``logf`` after fdlibm, Cephes' single-precision sine and cosine polynomials; all
branch-free, so that a loop over SIMD lanes vectorises them with twice the numbers a vector of
``float64`` holds, and every lane and every scalar draw computes the same bits).  Its relative
error, a few ``float32`` ulp (below 1e-6), is far below a step's (``docs/numerics.md``).  The
exact tail: where ``w < 2^16`` (``u1 < 2^-16``, a radius beyond 4.7, one pair in 65,536) the
32-bit grid of ``u1`` is too coarse for the normal law's tail, and the pair is recomputed in
``float64`` (``tail_pair``) with ``u1 = (w + v) 2^-32``, ``v`` a 53-bit uniform in ``(0, 1]`` from
the block's tail block (block ``m + 2^63`` of the stream): ``u1`` is then uniform below
``2^-16`` to a ``float64``'s last bit (its smallest value ``2^-85``), and the radius reaches 10.8
standard deviations, its law exact to 8 and beyond.
A stream gives one kind of draw (a purpose draws normals or uniforms, not both).

The kernels call ``normal`` and ``uniform``, which read a stream's kind at run time (numba
picks a numpy ``Generator``'s methods by its type when it compiles a kernel), and plain Python
(the CUDA simulator) likewise.
"""

from __future__ import annotations

import math

import numpy as np
from numba import types
from numba.extending import overload

from ..jit import njit
from ..jit.flags import INLINE, KERNEL
from ..jit.intrinsics import bits_float, float_bits, fused
from .kinds import KIND, PCG_KIND, PHILOX_KIND, STREAM_WORDS, TAPE_KIND, kind_of
from .pcg import pcg_normal, pcg_uniform

#: Words of a Philox stream after its kind (``kinds.KIND``): key, place, draws made, and the block
#: (plus one; 0: none) whose last three normals the stream holds, with those normals' bits
#: (``philox_normal``), ``kinds.STREAM_WORDS`` in all.
KEY, PLACE, DRAWN, PAIRED, SPARE = range(1, 6)
#: Words of a tape after its kind: the count drawn, then the values' bits.
TAPE_DRAWN, TAPE_VALUES = 1, 2
#: Normals of a block (``block_normals``).
BLOCK_NORMALS = 4
#: The definition of the normals a run draws, part of its key (``store.run_key``), so that a run
#: begun on other normals is not resumed on these: the Philox streams' (two a block in ``float64``,
#: before) and the Brownian trees' nodes (``brownian.node_normal``; libm's ``float64`` before).
NORMALS = ("philox4x32-10, four normals a block, float32 pairs, float64 tail pairs below 2^-16; "
           "tree nodes: splitmix64, the float32 pair's cosine, float64 below 2^-16")

_M0, _M1 = np.uint64(0xD2511F53), np.uint64(0xCD9E8D57)  # Philox4x32 multipliers
_W0, _W1 = np.uint64(0x9E3779B9), np.uint64(0xBB67AE85)  # key schedule (Weyl) increments
_LOW = np.uint64(0xFFFFFFFF)
_S32, _S11, _S21 = np.uint64(32), np.uint64(11), np.uint64(21)
_ONE = np.uint64(1)
_TWO_BITS, _THREE = np.uint64(2), np.uint64(3)
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
_F = np.float32
# musl's logf (after fdlibm's e_logf.c): ln 2 in two parts, the minimax coefficients on the
# reduced range, and the bits that move sqrt(2)/2 .. sqrt(2) onto one exponent
_LN2_HI_F, _LN2_LO_F = _F(6.9313812256e-01), _F(9.0580006145e-06)
_LG1_F, _LG2_F, _LG3_F, _LG4_F = _F(0.66666662693), _F(0.40000972152), _F(0.28498786688), _F(0.24279078841)
_OFFSET_F, _SQRT_HALF_F = np.uint32(0x3F800000 - 0x3F3504F3), np.uint32(0x3F3504F3)
_MANTISSA_F, _S23 = np.uint32(0x007FFFFF), np.uint32(23)
# Cephes' sinf and cosf polynomials on [-pi/4, pi/4] (Moshier, Cephes Math Library, sinf.c)
_SA_F, _SB_F, _SC_F = _F(-1.9515295891e-4), _F(8.3321608736e-3), _F(-1.6666654611e-1)
_CA_F, _CB_F, _CC_F = _F(2.443315711809948e-5), _F(-1.388731625493765e-3), _F(4.166664568298827e-2)
_ZERO_F, _ONE_F, _HALF_F, _MINUS_TWO_F = _F(0.0), _F(1.0), _F(0.5), _F(-2.0)
#: The first word whose ``u1`` is ``sqrt(2)/2`` or more (``fast_radius``).
_WORD_SQRT_HALF = np.uint64(math.ceil(2.0**32 * math.sqrt(0.5)))
_TURN_F = _F(2.0**-32)
_QUARTER_TURN_F = _F(2.0**-30 * np.pi / 2)
_EIGHTH, _QUARTER_BITS, _S30 = np.uint64(1 << 29), np.uint64((1 << 30) - 1), np.uint64(30)
#: A pair's first word below this is a tail pair (``tail_pair``): ``u1 < 2^-16``.
TAIL_WORD = np.uint64(1 << 16)
#: Added to a block's number, the number of its tail block (``tail_pair``).
TAIL_BLOCK = np.uint64(1 << 63)


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
def reduced_f32(x):
    """``(k, f)`` with ``x = 2^k (1 + f)``, ``1 + f`` in ``[sqrt(2)/2, sqrt(2))``, of a positive
    normal ``float32`` (from its bits: exact), the range reduction of musl's ``logf`` (after
    fdlibm's ``e_logf.c``; ``log x = log1p_f32(k, f)``, error below 1 ulp)."""
    bits = np.uint32(float_bits(x) + _OFFSET_F)
    k = _F(np.int32(bits >> _S23) - np.int32(0x7F))
    return k, bits_float(np.uint32((bits & _MANTISSA_F) + _SQRT_HALF_F)) - _ONE_F


@njit(**INLINE)
def log1p_f32(k, f):
    """``k log 2 + log(1 + f)`` in ``float32`` for ``1 + f`` in ``[sqrt(2)/2, sqrt(2))``: musl's
    minimax polynomial in ``s = f / (2 + f)``, ``log 2`` in two parts, musl's sum
    ``s (f^2/2 + R) + k ln2_lo - f^2/2 + f + k ln2_hi`` with every product that meets a sum fused
    (``fused``): no product is left for a compiler to fuse where it chooses (NVVM does, on a
    GPU), so the GPU computes the CPU's bits."""
    s = f / (_F(2.0) + f)
    z = s * s
    w = z * z
    half_f = _HALF_F * f
    r = fused(z, fused(w, _LG3_F, _LG1_F), w * fused(w, _LG4_F, _LG2_F))
    total = fused(-half_f, f, fused(s, fused(half_f, f, r), k * _LN2_LO_F))
    return fused(k, _LN2_HI_F, total + f)


@njit(**INLINE)
def sincos_word(w):
    """``(cos 2 pi t, sin 2 pi t)`` in ``float32`` of the turn ``t = w 2^-32`` of a 32-bit word
    ``w``, branch-free: the quadrant ``q`` nearest ``4 t`` and the rest ``x`` in ``[-pi/4, pi/4)``
    from the word's bits (the quadrant and the rest's 30-bit integer exact, ``x`` rounded once to
    ``float32``), then Cephes' polynomials of ``sinf`` and ``cosf``, every product that meets a
    sum fused (``log1p_f32``)."""
    shifted = (w + _EIGHTH) & _LOW
    quadrant = np.int64(shifted >> _S30)
    x = _F(np.int64(shifted & _QUARTER_BITS) - np.int64(1 << 29)) * _QUARTER_TURN_F
    z = x * x
    sin_x = fused(fused(fused(_SA_F, z, _SB_F), z, _SC_F) * z, x, x)
    cos_x = fused(fused(fused(_CA_F, z, _CB_F), z, _CC_F) * z, z, fused(-_HALF_F, z, _ONE_F))
    swap = (quadrant & 1) == 1
    # the signs as factors of +-1 (exact), not branches: the cosine's negative in quadrants 1
    # and 2, the sine's in 2 and 3
    c = (sin_x if swap else cos_x) * (_ONE_F - _F((quadrant + 1) & 2))
    s = (cos_x if swap else sin_x) * (_ONE_F - _F(quadrant & 2))
    return c, s


@njit(**INLINE)
def fast_radius(wa):
    """A fast pair's radius ``sqrt(-2 log u1)`` in ``float32``, ``u1 = (wa + 1/2) 2^-32``
    (``fast_pair``).  Where ``u1 >= sqrt(2)/2`` its log is ``log1p_f32`` of ``f = u1 - 1`` taken
    from the word (rounded once, to ``float32``): ``u1`` rounded to ``float32`` would keep a small
    ``f``, a small radius, to ``2^-24`` only (a radius of 0.01 within 3e-4); so every radius is
    within a few ``float32`` ulps, branch-free."""
    k, f = reduced_f32((_F(np.int64(wa)) + _HALF_F) * _TURN_F)
    near = wa >= _WORD_SQRT_HALF
    f_near = (_F(np.int64(wa) - np.int64(1 << 32)) + _HALF_F) * _TURN_F
    return math.sqrt(_MINUS_TWO_F * log1p_f32(_ZERO_F if near else k, f_near if near else f))


@njit(**INLINE)
def fast_pair(wa, wb):
    """The Box-Muller pair ``(r cos t, r sin t)`` in ``float32`` of two 32-bit words:
    ``r = sqrt(-2 log u1)``, ``u1 = (wa + 1/2) 2^-32`` (``fast_radius``), ``t = 2 pi wb 2^-32``
    (``sincos_word``; the module's docstring: the normal law's where ``wa >= TAIL_WORD``)."""
    r = fast_radius(wa)
    c, s = sincos_word(wb)
    return r * c, r * s


@njit(**INLINE)
def tail_radius(wa, k: float) -> float:
    """A tail pair's radius ``sqrt(-2 log u1)``, ``u1 = (wa + v) 2^-32`` with ``v = k 2^-53``
    (``k`` in ``1 .. 2^53``: ``tail_pair``)."""
    return math.sqrt(-2.0 * log_positive((float(wa) + k * _ULP53) * 2.0**-32))


@njit(**INLINE)
def tail_pair(key, place, block, half, wa, wb):
    """The Box-Muller pair of a tail pair (``wa < TAIL_WORD``), the ``half``-th of block ``block``
    of the stream ``(key, place)``, in ``float64``: ``u1 = (wa + v) 2^-32`` with ``v`` in
    ``(0, 1]`` the ``half``-th 53-bit uniform of the block's tail block (``TAIL_BLOCK``), so that
    ``u1`` is uniform below ``2^-16`` to a ``float64``'s last bit (``tail_radius``); the angle as
    ``fast_pair``'s, in ``float64``."""
    t0, t1, t2, t3 = philox_block(key, place, block + TAIL_BLOCK)
    r = tail_radius(wa, (unit_53(t2, t3) if half else unit_53(t0, t1)) + 1.0)
    c, s = sincos_turn(float(wb) * 2.0**-32)
    return r * c, r * s


@njit(**INLINE)
def packed_block(key, place, block):
    """Block ``block`` of the Philox stream ``(key, place)`` as two 64-bit words, the first two
    of its 32-bit words and the last two (what ``packed_normals`` takes)."""
    w0, w1, w2, w3 = philox_block(key, place, block)
    return (w0 << _S32) | w1, (w2 << _S32) | w3


@njit(**INLINE)
def packed_normals(a, b):
    """The ``fast_pair`` normals of a block given as ``packed_block``'s two words (``float64``),
    and whether either pair is a tail pair (``tail_pair``: to recompute)."""
    wa0, wa1 = a >> _S32, b >> _S32
    c0, s0 = fast_pair(wa0, a & _LOW)
    c1, s1 = fast_pair(wa1, b & _LOW)
    return float(c0), float(s0), float(c1), float(s1), (wa0 < TAIL_WORD) | (wa1 < TAIL_WORD)


@njit(**INLINE)
def block_normals(key, place, block):
    """Normals ``4 block .. 4 block + 3`` of the Philox stream ``(key, place)``: the Box-Muller
    pairs of block ``block``'s first two words and of its last two (``fast_pair``, or
    ``tail_pair`` for a tail pair)."""
    a, b = packed_block(key, place, block)
    z0, z1, z2, z3, tail = packed_normals(a, b)
    if tail:
        if a >> _S32 < TAIL_WORD:
            z0, z1 = tail_pair(key, place, block, 0, a >> _S32, a & _LOW)
        if b >> _S32 < TAIL_WORD:
            z2, z3 = tail_pair(key, place, block, 1, b >> _S32, b & _LOW)
    return z0, z1, z2, z3


@njit(**INLINE)
def philox_normal(stream) -> float:
    """A standard normal: normal ``n mod 4`` of block ``n // 4`` (``block_normals``) at the
    stream's ``n``-th draw.  A block's last three normals are kept in the stream, so that a
    stream drawn in order computes each block once."""
    n = stream[DRAWN]
    stream[DRAWN] = n + _ONE
    block, q = n >> _TWO_BITS, n & _THREE
    if q > 0 and stream[PAIRED] == block + _ONE:
        return bits_float(stream[SPARE + np.int64(q) - 1])
    z0, z1, z2, z3 = block_normals(stream[KEY], stream[PLACE], block)
    stream[PAIRED] = block + _ONE
    stream[SPARE], stream[SPARE + 1], stream[SPARE + 2] = float_bits(z1), float_bits(z2), float_bits(z3)
    return z0 if q == 0 else z1 if q == 1 else z2 if q == 2 else z3


@njit(**INLINE)
def open_stream(stream, key, place) -> None:
    """Set ``stream`` (``STREAM_WORDS`` words) to the start of the Philox stream ``(key, place)``."""
    stream[KIND] = PHILOX_KIND
    stream[KEY] = key
    stream[PLACE] = place
    stream[DRAWN] = 0
    stream[PAIRED] = 0


def tape(values: np.ndarray) -> np.ndarray:
    """A stream that replays ``values`` as its normals, in order: its kind (``kinds.TAPE_KIND``),
    the count drawn so far, then the values' bits.  Draws past its end are NaN (a path that
    diverges, not numbers from elsewhere), and so are its uniforms (it gives none)."""
    values = np.ascontiguousarray(values, dtype=np.float64)
    stream = np.zeros(TAPE_VALUES + values.shape[0], np.uint64)
    stream[KIND] = TAPE_KIND
    stream[TAPE_VALUES:] = values.view(np.uint64)
    return stream


@njit(**INLINE)
def tape_normal(stream) -> float:
    """The tape's next value (NaN past its end), counting it drawn."""
    at = TAPE_VALUES + np.int64(stream[TAPE_DRAWN])
    stream[TAPE_DRAWN] += np.uint64(1)
    return bits_float(stream[at]) if at < stream.shape[0] else math.nan


def normal(gen) -> float:
    """One standard normal from ``gen`` (a PCG64 or Philox stream, a tape, or a numpy Generator)."""
    kind = kind_of(gen)
    if kind is None:
        return gen.standard_normal()
    if kind == PCG_KIND:
        return pcg_normal(gen)
    return tape_normal(gen) if kind == TAPE_KIND else philox_normal(gen)


def uniform(gen) -> float:
    """One uniform in ``[0, 1)`` from ``gen`` (a PCG64 or Philox stream, or a numpy Generator; a
    tape replays normals only: ``TypeError`` here, NaN in compiled code)."""
    kind = kind_of(gen)
    if kind is None:
        return gen.random()
    if kind == TAPE_KIND:
        raise TypeError("uniform: a tape replays normals only")
    return pcg_uniform(gen) if kind == PCG_KIND else philox_uniform(gen)


@njit(**INLINE)
def stream_draw(gen, normals: bool) -> float:
    """``normal`` (``normals``) or ``uniform`` of a stream array, its kind read at run time (a
    tape's uniform: NaN).  The PCG64 draw (the scalar executor's) is inlined; the others are a
    call of ``other_draw``, compiled once and cached for every loop, not copied into each place
    that draws (``streams.kinds``: the compile times)."""
    if gen[KIND] == PCG_KIND:
        return pcg_normal(gen) if normals else pcg_uniform(gen)
    return other_draw(gen, normals)


@njit(**KERNEL)
def other_draw(gen, normals: bool) -> float:
    """``stream_draw`` of a Philox stream or a tape (a function of its own, not inlined: the
    lanes draw their Philox normals apart, ``lanes.lane_normals``, and the scalar loop on Philox
    streams pays a call a draw)."""
    if gen[KIND] == PHILOX_KIND:
        return philox_normal(gen) if normals else philox_uniform(gen)
    return tape_normal(gen) if normals else math.nan


@overload(normal)
def _normal(gen):
    if isinstance(gen, types.Array):
        return lambda gen: stream_draw(gen, True)
    return lambda gen: gen.standard_normal()


@overload(uniform)
def _uniform(gen):
    if isinstance(gen, types.Array):
        return lambda gen: stream_draw(gen, False)
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
    stream[KIND], stream[KEY], stream[PLACE] = PHILOX_KIND, key, place
    return stream


def philox_stream(seed: int, purpose: int, realization: int, point: int = 0,
                  common: bool = True) -> np.ndarray:
    """A realisation's Philox stream of one purpose, before its first draw."""
    return keyed_stream(stream_key(seed, purpose), stream_place(realization, point, common))
