"""One array type for every stream a step loop draws from: a ``uint64`` array whose first word
(``KIND``) says what it is, a Philox stream (``rng.py``), a PCG64 stream (``pcg.py``) or a tape of
given normals (``rng.tape``).  A draw reads the kind at run time (a branch every draw takes the
same way), so a loop compiles once for every mix of streams it is given: the general loop
compiled one signature a mix (five in the test suite, about 30 s each) when each kind was a
type of its own.  The price, measured on a 2-core host against the loops of one type a kind
(64 paths, best of three, alternating runs): with every kind's draw inlined, the scalar
executor's smooth scene ran at 0.91x and its impact scene at 0.94x.  Now only the PCG64 draw
is inlined where a loop draws (the scalar executor's streams), the PCG64 branch first; a Philox
or tape draw is a call of one function compiled once (``rng.stream_draw``), and the smooth
scene runs at 0.94x, the impact scene at 0.98x, the filtered-noise scene at 0.94x.  A small
function that draws a normal compiles in 6 s against 9 s, and one more in under a second (the
draw already compiled); a specialised scalar loop of the impact scene compiled in 21 s against
25 s once each, while alternating compiles of three scenes differed by less than the host's
noise.  The cost is the general loop's on Philox streams (a lane scene's short runs): 0.92x on
the smooth scene and 0.95x on the impact scene against every draw inlined.  The SIMD lanes
draw their normals apart (``lanes.lane_normals``) and run as fast as before."""

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
