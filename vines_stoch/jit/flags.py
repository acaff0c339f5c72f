"""The options every compiled function of the package is built with."""

from __future__ import annotations

#: Options of every compiled loop: cached on disk, GIL released, IEEE division (no Python
#: ZeroDivisionError checks in hot loops), and fused multiply-adds (``contract``: one rounding
#: instead of two, half the latency on a step's critical path; no other fast-math licence, so
#: NaN and infinity keep their meaning for the divergence checks).
KERNEL = dict(cache=True, nogil=True, error_model="numpy", fastmath={"contract"})
#: Options of the small formula functions the loops inline.  An inlined function that takes
#: arrays, called inside a branch the compiler cannot remove, costs atomic reference counting
#: of those arrays each time the enclosing loop passes it: the step loops call such functions
#: unconditionally or under compile-time flags, and keep rare work out of the step loop.  Each
#: inlined copy also costs compile time: a large inlined function gets one call site, and rare
#: work calls it through an out-of-line wrapper (``rk4.rk4_step``, ``rk4.wall_accelerations``).
INLINE = dict(KERNEL, inline="always")
#: Options of compiled functions that must round as numpy does, operation by operation (no
#: fused multiply-adds): ``pcg``'s ziggurat, ``order``'s quantiles.
ROUNDED = dict(cache=True, nogil=True, error_model="numpy")
