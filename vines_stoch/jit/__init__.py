"""The compile floor: the options the step loops are compiled with (``flags``), the intrinsics
they use (``intrinsics``), the package's ``njit`` with numba's on-disk cache keyed by the
package's sources and one process compiling a loop at a time (``cache``), and the faster front
end it compiles them with (``frontend``: in place only while a loop of the package compiles,
and loaded only then: the physics floor, compiled with these options, does not load it).

Nothing here knows the model: the physics floor (``vines_stoch.physics``) and the step loops
(``vines_stoch.kernels``) stand on it.
"""

from __future__ import annotations

from .cache import cache_folder, compile_once, njit
from .flags import INLINE, KERNEL
from .intrinsics import any_set, copy_into, int_scratch, pick, put, runtime_value, scratch, scratch_within

__all__ = ["INLINE", "KERNEL", "any_set", "cache_folder", "compile_once", "copy_into", "int_scratch",
           "njit", "pick", "put", "runtime_value", "scratch", "scratch_within"]
