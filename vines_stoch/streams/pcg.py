"""numpy's CPU streams in compiled code: ``SeedSequence`` hashing, the ``PCG64`` bit generator
and ``Generator.standard_normal`` / ``Generator.random``, bit for bit.

A CPU realisation draws from ``PCG64(SeedSequence(seed, spawn_key=key))`` (``streams/``).
Here the stream is a ``uint64`` array of ``kinds.STREAM_WORDS`` (its kind, ``kinds.PCG_KIND``,
then the generator's 128-bit state and increment as 64-bit halves: ``STATE_HIGH`` ..
``INC_LOW``), made from the key inside the compiled ensemble loop (``seed_stream``: no Python
object per realisation) or taken from a numpy ``Generator`` and written back to it
(``state_of``, ``set_state``), so a loop given a numpy generator and a loop deriving its
streams draw the same numbers.  The algorithms are numpy's:

- ``SeedSequence``: O'Neill's entropy pool (numpy ``bit_generator.pyx``; M. O'Neill,
  "Developing a seed_seq alternative", pcg-random.org, 2015): a pool of four 32-bit words, the
  entropy hashed in (``hashmix``, ``mix``) and the state words hashed out of it.
- ``PCG64``: the 128-bit LCG with the XSL-RR output (M. E. O'Neill, "PCG: a family of simple
  fast space-efficient statistically good algorithms for random number generation",
  HMC-CS-2014-0905; numpy's ``pcg64.h``).
- normals: the ziggurat of numpy's ``random_standard_normal`` (Marsaglia and Tsang, J. Stat.
  Softw. 5(8), 2000, doi:10.18637/jss.v005.i08, in numpy's 256-layer variant), written after
  numba's port (``numba.np.random.distributions``), whose tables it uses: the numbers a numba
  loop draws from a numpy ``Generator``.

``tests/unit/kernels/test_pcg.py`` compares states and draws with numpy's, bitwise.
"""

from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic
from numba.np.random._constants import fi_double, ki_double, wi_double, ziggurat_nor_inv_r, ziggurat_nor_r

from ..jit import njit
from ..jit.flags import INLINE, KERNEL
from .kinds import KIND, PCG_KIND, STREAM_WORDS

#: The words of a PCG64 stream after its kind: the 128-bit state and increment as 64-bit halves.
STATE_HIGH, STATE_LOW, INC_HIGH, INC_LOW = 1, 2, 3, 4

_MASK32 = np.uint64(0xFFFFFFFF)
_INIT_A, _MULT_A = np.uint64(0x43B0D7E5), np.uint64(0x931E8875)
_INIT_B, _MULT_B = np.uint64(0x8B51F9DD), np.uint64(0x58F38DED)
_MIX_L, _MIX_R = np.uint64(0xCA01F9DD), np.uint64(0x4973F715)
_XSHIFT = np.uint64(16)
#: Words of ``SeedSequence``'s pool.
POOL_SIZE = 4
_MUL_HIGH, _MUL_LOW = np.uint64(0x2360ED051FC65DA4), np.uint64(0x4385DF649FCCF645)
_S64, _S58, _S11, _S8 = np.uint64(64), np.uint64(58), np.uint64(11), np.uint64(8)
_S32, _ONE, _BYTE = np.uint64(32), np.uint64(1), np.uint64(0xFF)
_MANTISSA = np.uint64(0x000FFFFFFFFFFFFF)
_ULP53 = 1.0 / 9007199254740992.0
_KI, _WI, _FI = ki_double, wi_double, fi_double


@intrinsic
def mul_high(typingctx, a, b):
    """The upper 64 bits of the 128-bit product of two ``uint64``."""
    def codegen(context, builder, signature, args):
        wide = ir.IntType(128)
        product = builder.mul(builder.zext(args[0], wide), builder.zext(args[1], wide))
        return builder.trunc(builder.lshr(product, ir.Constant(wide, 64)), ir.IntType(64))

    return types.uint64(types.uint64, types.uint64), codegen


# --- SeedSequence -------------------------------------------------------------------------


@njit(**INLINE)
def _hashmix(value, hash_const):
    """numpy's ``hashmix``: ``value`` hashed, and the running constant advanced."""
    value = (value ^ hash_const) & _MASK32
    hash_const = (hash_const * _MULT_A) & _MASK32
    value = (value * hash_const) & _MASK32
    return value ^ (value >> _XSHIFT), hash_const


@njit(**INLINE)
def _mix(x, y):
    result = (_MIX_L * x - _MIX_R * y) & _MASK32
    return result ^ (result >> _XSHIFT)


@njit(**INLINE)
def mix_words(pool, hash_const, words, n_words: int):
    """Mix ``words[:n_words]`` into ``pool`` after the pool's first words (numpy's
    ``mix_entropy``, its last loop); returns the running constant."""
    for k in range(n_words):
        for d in range(POOL_SIZE):
            hashed, hash_const = _hashmix(words[k], hash_const)
            pool[d] = _mix(pool[d], hashed)
    return hash_const


def seed_pool(seed: int) -> tuple[np.ndarray, int]:
    """The pool of ``SeedSequence(seed, spawn_key=key)`` before the key's words are mixed in
    (every key's pool starts so), and the running constant: ``(pool, hash_const)``."""
    run = _words(int(seed))
    run = run + [0] * (POOL_SIZE - len(run))  # (with a spawn key numpy pads the run entropy)
    pool = np.zeros(POOL_SIZE, np.uint64)
    hash_const = _INIT_A
    for i in range(POOL_SIZE):
        pool[i], hash_const = _hashmix(np.uint64(run[i]), hash_const)
    for src in range(POOL_SIZE):
        for dst in range(POOL_SIZE):
            if src != dst:
                hashed, hash_const = _hashmix(pool[src], hash_const)
                pool[dst] = _mix(pool[dst], hashed)
    rest = np.array(run[POOL_SIZE:], np.uint64)
    hash_const = mix_words(pool, hash_const, rest, rest.shape[0])
    return pool, int(hash_const)


def _words(value: int) -> list[int]:
    """numpy's 32-bit words of a non-negative integer, lowest first (0: one word)."""
    words = [value & 0xFFFFFFFF]
    value >>= 32
    while value:
        words.append(value & 0xFFFFFFFF)
        value >>= 32
    return words


@njit(**INLINE)
def key_words(words, at: int, value: int) -> int:
    """Write the 32-bit words of ``value`` (a ``uint64``) into ``words`` from ``at`` as numpy
    coerces an integer of a spawn key; returns the index after them."""
    words[at] = value & _MASK32
    if value >> _S32:
        words[at + 1] = value >> _S32
        return at + 2
    return at + 1


@njit(**INLINE)
def seed_stream(stream, pool0, hash0, purpose, point, realization, common: bool, pool, words) -> None:
    """Set ``stream`` (a PCG64 stream's words) to ``PCG64(SeedSequence(seed, spawn_key=key))`` with
    ``key = (purpose, realization)``, or ``(purpose, point, realization)`` without common
    random numbers (``streams.generator``), from the seed's pool ``pool0, hash0``
    (``seed_pool``); ``pool`` (4) and ``words`` (8) are scratch."""
    for d in range(POOL_SIZE):
        pool[d] = pool0[d]
    n = key_words(words, 0, np.uint64(purpose))
    if not common:
        n = key_words(words, n, np.uint64(point))
    n = key_words(words, n, np.uint64(realization))
    mix_words(pool, np.uint64(hash0), words, n)
    # generate_state(4, uint64): eight 32-bit words, little-endian pairs
    hash_const = _INIT_B
    for w in range(8):
        value = (pool[w % POOL_SIZE] ^ hash_const) & _MASK32
        hash_const = (hash_const * _MULT_B) & _MASK32
        value = (value * hash_const) & _MASK32
        words[w] = value ^ (value >> _XSHIFT)
    seed_pcg(stream, words[0] | (words[1] << _S32), words[2] | (words[3] << _S32),
             words[4] | (words[5] << _S32), words[6] | (words[7] << _S32))


# --- PCG64 --------------------------------------------------------------------------------


@njit(**INLINE)
def _step(stream) -> None:
    """The LCG's step: ``state = state * MULT + inc`` (mod 2^128)."""
    high, low = stream[STATE_HIGH], stream[STATE_LOW]
    new_low = low * _MUL_LOW
    new_high = mul_high(low, _MUL_LOW) + high * _MUL_LOW + low * _MUL_HIGH
    low = new_low + stream[INC_LOW]
    stream[STATE_HIGH] = new_high + stream[INC_HIGH] + (_ONE if low < new_low else np.uint64(0))
    stream[STATE_LOW] = low


@njit(**INLINE)
def seed_pcg(stream, state_high, state_low, seq_high, seq_low) -> None:
    """numpy's ``pcg64_set_seed``: the stream of the 128-bit seed ``state`` and sequence."""
    stream[KIND] = PCG_KIND
    stream[INC_HIGH] = (seq_high << _ONE) | (seq_low >> np.uint64(63))
    stream[INC_LOW] = (seq_low << _ONE) | _ONE
    stream[STATE_HIGH] = np.uint64(0)
    stream[STATE_LOW] = np.uint64(0)
    _step(stream)
    low = stream[STATE_LOW] + state_low
    stream[STATE_HIGH] = stream[STATE_HIGH] + state_high + (_ONE if low < state_low else np.uint64(0))
    stream[STATE_LOW] = low
    _step(stream)


@njit(**INLINE)
def next_uint64(stream):
    """The next 64 random bits (XSL-RR output of the stepped state)."""
    _step(stream)
    high = stream[STATE_HIGH]
    word = high ^ stream[STATE_LOW]
    rot = high >> _S58
    return (word >> rot) | (word << ((_S64 - rot) & np.uint64(63)))


@njit(**INLINE)
def pcg_uniform(stream) -> float:
    """``Generator.random()``: a uniform on the 53-bit grid of ``[0, 1)``."""
    return float(next_uint64(stream) >> _S11) * _ULP53


@njit(**INLINE)
def _layer(r):
    """A draw's layer, magnitude and value from its 64 bits (numpy's ``random_standard_normal``:
    the low byte the layer, the next bit the sign, the next 52 the magnitude)."""
    idx = r & _BYTE
    r >>= _S8
    rabs = (r >> _ONE) & _MANTISSA
    x = float(rabs) * _WI[idx]
    return idx, rabs, -x if r & _ONE else x


@njit(**INLINE)
def pcg_normal(stream) -> float:
    """``Generator.standard_normal()``: numpy's ziggurat, its fast path (99.3 % of the draws)
    inline, the wedges and the tail out of line (``_normal_rest``), so a step loop holds only
    the few instructions of the fast path."""
    idx, rabs, x = _layer(next_uint64(stream))
    if rabs < _KI[idx]:
        return x
    return _normal_rest(stream, idx, rabs, x)


@njit(**KERNEL)
def _normal_rest(stream, idx, rabs, x) -> float:
    """The ziggurat from a draw its fast path did not accept: the tail beyond the base layer
    (``idx`` 0) or the layer's wedge, then fresh draws until one is accepted."""
    while True:
        if idx == 0:
            while True:
                xx = -ziggurat_nor_inv_r * math.log1p(-pcg_uniform(stream))
                yy = -math.log1p(-pcg_uniform(stream))
                if yy + yy > xx * xx:
                    return -(ziggurat_nor_r + xx) if (rabs >> _S8) & _ONE else ziggurat_nor_r + xx
        if (_FI[idx - 1] - _FI[idx]) * pcg_uniform(stream) + _FI[idx] < math.exp(-0.5 * x * x):
            return x
        idx, rabs, x = _layer(next_uint64(stream))
        if rabs < _KI[idx]:
            return x


# --- numpy generators ---------------------------------------------------------------------


def new_stream() -> np.ndarray:
    """An unseeded PCG64 stream (``kinds.STREAM_WORDS`` words, its kind ``kinds.PCG_KIND``)."""
    stream = np.zeros(STREAM_WORDS, np.uint64)
    stream[KIND] = PCG_KIND
    return stream


_LOW64 = 0xFFFFFFFFFFFFFFFF


def state_of(gen: np.random.Generator, stream: np.ndarray | None = None) -> np.ndarray | None:
    """The stream of a numpy generator whose bit generator is ``PCG64`` (into ``stream`` where
    given), or None for any other bit generator."""
    if type(gen.bit_generator) is not np.random.PCG64:
        return None
    st = gen.bit_generator.state["state"]
    stream = new_stream() if stream is None else stream
    stream[KIND] = PCG_KIND
    stream[STATE_HIGH], stream[STATE_LOW] = st["state"] >> 64, st["state"] & _LOW64
    stream[INC_HIGH], stream[INC_LOW] = st["inc"] >> 64, st["inc"] & _LOW64
    return stream


def set_state(gen: np.random.Generator, stream: np.ndarray) -> None:
    """Move a ``PCG64`` numpy generator to where ``stream`` stands (its 32-bit buffer kept)."""
    state = gen.bit_generator.state
    state["state"] = {"state": int(stream[STATE_HIGH]) << 64 | int(stream[STATE_LOW]),
                      "inc": int(stream[INC_HIGH]) << 64 | int(stream[INC_LOW])}
    gen.bit_generator.state = state
