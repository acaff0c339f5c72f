"""The exact first-passage probability of a linear structure's discrete-time Gaussian response,
the reference of the rare-event estimates (``rare.py``; its tests and ``make bench``).

A linear primary from rest under white noise alone is linear in its standard normal increments:
``x_k = sum_j h_{k-j} u_j``, ``h`` the step loop's response to one unit increment (read from the
engine: the map is the engine's discrete process, whatever its scheme); under filtered loads it
is linear in the filters' normals too (``x = A u`` with a column a normal).  Its failure set
``max_k |x_k| > b`` is the union of the ``2 n`` half-spaces ``+-a_k . u > b``, and importance
sampling using elementary events (Au and Beck, Probab. Eng. Mech. 16 (2001) 193) gives
``P = (sum_k P(E_k)) E[1 / #events hit]`` under the mixture of the events' conditional laws: a
coefficient of variation of about 1 % from a few thousand samples at any probability.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from ..kernels import filter_draws, simulate
from ..streams import Streams
from ..streams.rng import tape


def response_matrix(scene) -> np.ndarray:
    """``A`` with ``x_k = (A u)_{k-1}``, ``k = 1..n``, for a scene whose only randomness is white
    noise on one floor and filtered loads, ``u`` its standard normal inputs: the white-noise
    increments (columns: the step loop's response to one unit increment at the first step,
    shifted, the scheme being time-invariant), then the filters' normals (``kernels.filter_draws``,
    replayed from a tape; columns: the response to each, one run a column, enveloped filters
    being time-varying).  Checked against the loop on a random input (a ``ValueError``
    otherwise)."""
    n = scene.n_steps
    white, filtered = (n if scene.has_white_noise else 0), filter_draws(scene)

    def response(u: np.ndarray) -> np.ndarray:
        x = np.zeros((n + 1, 1))
        streams = Streams(None, None, tape(u[white:])) if filtered else None
        simulate(scene, streams, normals=u[:white] if white else None, history=x, signals=("x1",))
        return x[1:, 0]

    a = np.zeros((n, white + filtered))
    for j in (range(white + filtered) if white == 0 else [0, *range(white, white + filtered)]):
        a[:, j] = response(np.eye(1, white + filtered, j)[0])
    for k in range(1, white):  # (the white-noise columns: the first one, shifted)
        a[k:, k] = a[:n - k, 0]
    u = np.random.default_rng(0).standard_normal(white + filtered)
    x = response(u)
    if not np.allclose(a @ u, x, rtol=0, atol=1e-9 * np.abs(x).max()):
        raise ValueError("response_matrix: the scene's response is not linear in its inputs, or its "
                         "white-noise response not time-invariant")
    return a


def isee(a: np.ndarray, b: float, samples: int = 4000, seed: int = 1) -> tuple[float, float]:
    """``P(max_k |(A u)_k| > b)`` for standard normal ``u`` by importance sampling using
    elementary events, with its standard error."""
    n = a.shape[0]
    norms = np.linalg.norm(a, axis=1)
    # P(a_k u > b) = P(-a_k u > b); none where x_k takes no input (a path from rest at its start)
    events = stats.norm.sf(np.divide(b, norms, out=np.full(n, np.inf), where=norms > 0))
    total = 2 * events.sum()
    rng = np.random.default_rng(seed)
    pick = rng.choice(2 * n, samples, p=np.concatenate([events, events]) / total)
    k, sign = pick % n, np.where(pick < n, 1.0, -1.0)
    direction = a[k] / norms[k, None]
    beyond = stats.norm.isf(rng.random(samples) * events[k])  # the component along a_k, given the event
    z = rng.standard_normal((samples, a.shape[1]))
    u = z - direction * np.sum(direction * z, axis=1)[:, None] + (sign * beyond)[:, None] * direction
    hits = np.sum(np.abs(u @ a.T) > b, axis=1)
    if hits.min() < 1:
        raise ArithmeticError("isee: a sample outside the event it was drawn from")
    weights = total / hits
    return float(weights.mean()), float(weights.std(ddof=1) / math.sqrt(samples))
