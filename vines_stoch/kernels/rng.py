"""Random draws of the kernels from each kind of stream: a PCG64 stream (the CPU ensembles,
``streams.py``; ``pcg.py``: numpy's generator in compiled code, a ``pcg.PCG_DTYPE`` record
array), a counter-based Philox stream (the GPU ensembles, ``gpu.py``), a tape of given normals
(``tape``: a ``float64`` array, replayed in order; subset simulation's filter noise, ``rare.py``)
or a numpy ``Generator`` (of a bit generator other than ``PCG64``, passed by a user).

A Philox stream is a ``uint64`` array of ``STREAM_WORDS``: the key (two 32-bit words, from the
seed and the purpose), the stream's place (the realisation, and the sweep point without common
random numbers: the counter's upper 64 bits) and the number of blocks drawn so far (its lower
64 bits).  Each draw is one block of Philox4x32-10 (Salmon, Moraes, Dror and Shaw, "Parallel
random numbers: as easy as 1, 2, 3", SC '11, doi:10.1145/2063384.2063405; the Random123
reference), so realisation ``r``'s numbers are a function of (seed, purpose, point, r) and
the draw's index alone: the same whatever the launch configuration or batch.  A normal is the
Box-Muller cosine of one block's two 53-bit uniforms (Box and Muller, Ann. Math. Statist. 29
(1958) 610, doi:10.1214/aoms/1177706645).

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
from .pcg import PCG_DTYPE, pcg_normal, pcg_uniform

#: Words of a Philox stream: key, place, blocks drawn.
STREAM_WORDS = 3
KEY, PLACE, DRAWN = range(STREAM_WORDS)

_M0, _M1 = np.uint64(0xD2511F53), np.uint64(0xCD9E8D57)  # Philox4x32 multipliers
_W0, _W1 = np.uint64(0x9E3779B9), np.uint64(0xBB67AE85)  # key schedule (Weyl) increments
_LOW = np.uint64(0xFFFFFFFF)
_S32, _S11, _S21 = np.uint64(32), np.uint64(11), np.uint64(21)
_ONE = np.uint64(1)
_TWO_PI = 2.0 * np.pi
_ULP53 = 2.0**-53


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
def next_block(stream):
    """The stream's next block (its four 32-bit words), counting it drawn."""
    n = stream[DRAWN]
    place = stream[PLACE]
    key = stream[KEY]
    stream[DRAWN] = n + _ONE
    return philox4x32(n & _LOW, n >> _S32, place & _LOW, place >> _S32, key & _LOW, key >> _S32)


@njit(**INLINE)
def philox_uniform(stream) -> float:
    """A uniform in ``[0, 1)`` on the 53-bit grid, from the first two words of a block."""
    w0, w1, _, _ = next_block(stream)
    return float((w0 << _S21) | (w1 >> _S11)) * _ULP53


@njit(**INLINE)
def philox_normal(stream) -> float:
    """A standard normal: the Box-Muller cosine of a block's two uniforms (the first in
    ``(0, 1]``, so its logarithm is finite)."""
    w0, w1, w2, w3 = next_block(stream)
    u1 = (float((w0 << _S21) | (w1 >> _S11)) + 1.0) * _ULP53
    u2 = float((w2 << _S21) | (w3 >> _S11)) * _ULP53
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(_TWO_PI * u2)


@njit(**INLINE)
def open_stream(stream, key, place) -> None:
    """Set ``stream`` (``STREAM_WORDS`` words) to the start of the stream ``(key, place)``."""
    stream[KEY] = key
    stream[PLACE] = place
    stream[DRAWN] = 0


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


def philox_stream(seed: int, purpose: int, realization: int, point: int = 0,
                  common: bool = True) -> np.ndarray:
    """A realisation's Philox stream of one purpose, before its first draw."""
    return np.array([stream_key(seed, purpose), stream_place(realization, point, common), 0], np.uint64)
