"""One array type for every stream a step loop draws from: a ``uint64`` array whose first word
(``KIND``) says what it is, a Philox stream (``rng.py``), a PCG64 stream (``pcg.py``) or a tape of
given normals (``rng.tape``).  A draw reads the kind at run time (a branch every draw takes the
same way), so a loop compiles once for every mix of streams it is given: the general loop
compiled one signature a mix (five in the test suite, about 30 s each) when each kind was a
type of its own.  The price, measured on a 2-core host: a scalar loop on PCG64 streams holds
every kind's draw, and the scalar executor's smooth scene ran at 0.91x and its impact scene at
0.94x (the PCG64 branch first; 0.90x and 0.88x with the Philox branch first); the SIMD lanes
draw their normals apart (``lanes.lane_normals``) and ran as fast as before.  Only the PCG64
draw is inlined where a loop draws (the scalar executor's streams); a Philox or tape draw is a
call of one function compiled once (``rng.stream_draw``): a small function that draws a normal
compiled in 6 s against 9 s, a specialised scalar loop in 20-21 s against 25 s, at the same
speed."""

from __future__ import annotations

import numpy as np

#: The word of a stream that holds its kind, and the kinds (``uint64``, as the words).
KIND = 0
PHILOX_KIND, PCG_KIND, TAPE_KIND = np.uint64(0), np.uint64(1), np.uint64(2)
#: Words of a Philox or a PCG64 stream (the kind, then the kind's words).
STREAM_WORDS = 8


def kind_of(stream: object) -> int | None:
    """The kind of ``stream`` (``PHILOX_KIND``, ``PCG_KIND``, ``TAPE_KIND``), None for anything
    that is not a stream array (a numpy ``Generator``, None)."""
    if isinstance(stream, np.ndarray) and stream.dtype == np.uint64 and stream.ndim == 1 and stream.size:
        return int(stream[KIND])
    return None
