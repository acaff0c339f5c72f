"""The options every compiled function of the package is built with."""

from __future__ import annotations

import os

from ..environment import VECTOR_SWITCH, vector_problem

#: Options of every compiled loop: cached on disk, GIL released, IEEE division (no Python
#: ZeroDivisionError checks in hot loops) and no fast-math licence: every operation rounds as
#: written, so that two loops that write the same arithmetic compute the same bits however the
#: compiler unrolls or vectorises them (the scalar loop, the SIMD lanes, the pass loop, the
#: general loop: LLVM's own fused multiply-adds, ``contract``, fused different products where
#: a loop was unrolled).  The multiply-adds on a step's critical path are fused where written
#: (``intrinsics.fused``: one rounding, half the latency).
KERNEL = dict(cache=True, nogil=True, error_model="numpy")
#: Options of the small formula functions the loops inline.  An inlined function that takes
#: arrays, called inside a branch the compiler cannot remove, costs atomic reference counting
#: of those arrays each time the enclosing loop passes it: the step loops call such functions
#: unconditionally or under compile-time flags, and keep rare work out of the step loop.  Each
#: inlined copy also costs compile time: a large inlined function gets one call site, and rare
#: work calls it through an out-of-line wrapper (``rk4.rk4_step``, ``rk4.wall_accelerations``).
INLINE = dict(KERNEL, inline="always")



def vector_bits() -> int:
    """The vector width (bits) that the loops over SIMD lanes (``kernels/lanes.py``) ask LLVM to
    prefer, by the function attribute ``prefer-vector-width`` (``intrinsics.prefer_vectors``):
    ``VINES_STOCH_VECTOR_BITS``, default 512.  LLVM's own choice on AVX-512 hosts is 256 bits
    (the frequency cost of 512-bit instructions on early AVX-512 chips); the lane loops are
    long runs of vector arithmetic that gain from the wider registers (1.3-1.4x on an Emerald
    Rapids host).  A host without AVX-512 keeps its widest vectors whatever is asked.  The width
    changes no number: the loops allow no reassociation, so lane ``l`` computes the same bits in
    any width.  It is part of the cache key (``jit.cache.digest``)."""
    why = vector_problem()
    if why:
        raise ValueError(why)
    return int(os.environ.get(VECTOR_SWITCH, "512").strip())


#: The vector width the lane loops ask for (``vector_bits``, read once at import).
VECTOR_BITS = vector_bits()
