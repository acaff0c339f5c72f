"""The exact first-passage probability of a linear structure's discrete-time Gaussian response,
the reference of the rare-event estimates (``rare.py``; its tests and ``make bench``).

A linear primary from rest under white noise alone is linear in its standard normal increments:
``x_k = sum_j h_{k-j} u_j``, ``h`` the step loop's response to one unit increment (read from the
engine: the map is the engine's discrete process, whatever its scheme).  Its failure set
``max_k |x_k| > b`` is the union of the ``2 n`` half-spaces ``+-a_k . u > b``, and importance
sampling using elementary events (Au and Beck, Probab. Eng. Mech. 16 (2001) 193) gives
``P = (sum_k P(E_k)) E[1 / #events hit]`` under the mixture of the events' conditional laws: a
coefficient of variation of about 1 % from a few thousand samples at any probability.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from ..kernels import simulate


def response_matrix(scene) -> np.ndarray:
    """``A`` with ``x_k = (A u)_{k-1}``, ``k = 1..n``, for a scene whose only randomness is white
    noise on one floor: the step loop's response to one unit increment at the first step,
    shifted (the scheme is time-invariant: checked against the loop on a random input, a
    ``ValueError`` otherwise)."""
    n = scene.n_steps
    unit = np.zeros(n)
    unit[0] = 1.0
    h = np.zeros((n + 1, 1))
    simulate(scene, normals=unit, history=h, signals=("x1",))
    a = np.zeros((n, n))
    for k in range(1, n + 1):
        a[k - 1, :k] = h[k:0:-1, 0]
    u = np.random.default_rng(0).standard_normal(n)
    x = np.zeros((n + 1, 1))
    simulate(scene, normals=u, history=x, signals=("x1",))
    if not np.allclose(a @ u, x[1:, 0], rtol=0, atol=1e-9 * np.abs(x).max()):
        raise ValueError("response_matrix: the scene's response is not linear and time-invariant in its "
                         "increments")
    return a


def isee(a: np.ndarray, b: float, samples: int = 4000, seed: int = 1) -> tuple[float, float]:
    """``P(max_k |(A u)_k| > b)`` for standard normal ``u`` by importance sampling using
    elementary events, with its standard error."""
    n = a.shape[0]
    norms = np.linalg.norm(a, axis=1)
    events = stats.norm.sf(b / norms)  # P(a_k u > b) = P(-a_k u > b)
    total = 2 * events.sum()
    rng = np.random.default_rng(seed)
    pick = rng.choice(2 * n, samples, p=np.concatenate([events, events]) / total)
    k, sign = pick % n, np.where(pick < n, 1.0, -1.0)
    direction = a[k] / norms[k, None]
    beyond = stats.norm.isf(rng.random(samples) * events[k])  # the component along a_k, given the event
    z = rng.standard_normal((samples, n))
    u = z - direction * np.sum(direction * z, axis=1)[:, None] + (sign * beyond)[:, None] * direction
    hits = np.sum(np.abs(u @ a.T) > b, axis=1)
    if hits.min() < 1:
        raise ArithmeticError("isee: a sample outside the event it was drawn from")
    weights = total / hits
    return float(weights.mean()), float(weights.std(ddof=1) / math.sqrt(samples))
