"""Random streams: one per purpose, each derived from (seed, purpose, realisation).

Realisation ``r`` draws the Wiener increments of its steps, the seed of the Brownian trees
inside its steps (``kernels/brownian.py``: impacts and Hertz contact under white noise), its
filter noise (and the stationary start of its filters) and its uncertain
parameters from four independent streams, ``PCG64(SeedSequence(seed, spawn_key=(purpose,
r)))``.  How the impacts and contacts cut the steps therefore never moves the increments: with
common random numbers (the default) realisation ``r`` sees the same noise at every sweep
point, whatever the impacts.  The sweep point enters the key (``(purpose, point, r)``) only
when a scenario turns common random numbers off.  The increment stream is the one earlier
versions drew everything from, so scenes without impacts and filters keep their numbers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Purposes of the streams (the first element of their spawn key); ``RARE``: the paths, choices
#: and inputs of rare-event estimates (``rare.py``, keyed further by point, replica and draw).
INCREMENTS, PARAMETERS, BRIDGE, FILTER, RARE = 0, 1, 2, 3, 4


def generator(seed: int, point: int, realization: int, purpose: int = INCREMENTS,
              common: bool = True) -> np.random.Generator:
    """The stream of one purpose of one realisation: with common random numbers the same at
    every sweep point, otherwise its own per point."""
    key = (purpose, realization) if common else (purpose, point, realization)
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=key)))


@dataclass(frozen=True)
class Streams:
    """The generators a realisation's kernel draws from (``None``: a purpose the scene has no
    use for, never created: each costs about 13 us)."""

    increments: np.random.Generator | None = None
    bridge: np.random.Generator | None = None
    filter: np.random.Generator | None = None

    @classmethod
    def shared(cls, gen: np.random.Generator) -> Streams:
        """One generator for every purpose (quick experiments; an ensemble uses ``streams``)."""
        return cls(gen, gen, gen)


def streams(seed: int, point: int, realization: int, *, increments: bool = True, bridge: bool = True,
            filters: bool = True, common: bool = True) -> Streams:
    """The streams of one realisation, each only where asked for."""
    def make(wanted: bool, purpose: int) -> np.random.Generator | None:
        return generator(seed, point, realization, purpose, common) if wanted else None

    return Streams(make(increments, INCREMENTS), make(bridge, BRIDGE), make(filters, FILTER))
