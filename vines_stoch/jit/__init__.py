"""The compile floor: the options the step loops are compiled with (``flags``), the intrinsics
they use (``intrinsics``), numba's on-disk cache keyed by the package's sources and one process
compiling a loop at a time (``cache``), and the faster front end it compiles them with
(``frontend``: in place only while a loop of the package compiles, and loaded only then: the
physics floor, compiled with these options, does not load it).

Nothing here knows the model: the physics floor (``vines_stoch.physics``) and the step loops
(``vines_stoch.kernels``) stand on it.
"""

from __future__ import annotations

from .cache import compile_once, key_by_sources
from .flags import INLINE, KERNEL
from .intrinsics import any_set, copy_into, int_scratch, pick, put, runtime_value, scratch, scratch_within

key_by_sources()  # an edited formula never runs from a stale cache (see ``cache``)

__all__ = ["INLINE", "KERNEL", "any_set", "compile_once", "copy_into", "int_scratch",
           "key_by_sources", "pick", "put", "runtime_value", "scratch", "scratch_within"]
