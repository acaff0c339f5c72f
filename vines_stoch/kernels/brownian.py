"""The Brownian path inside a step: a virtual Brownian tree on counter-based normals.

A step's Wiener increment ``dW`` (drawn from the increment stream, or replayed) pins the path
at both ends of the step.  Inside the step the path is fixed by bisection: on an interval
``[lo, hi]`` with known ends, the value at the midpoint is the Brownian bridge's,
``W(mid) = (W(lo) + W(hi)) / 2 + sigma sqrt((hi - lo) / 4) Z(node)`` (Levy's construction), and
the normal ``Z(node)`` is a pure function of the stream's key, the step and the node of the
binary tree (a counter-based generator: splitmix64, Steele, Lea and Flood, "Fast splittable
pseudorandom number generators", OOPSLA 2014, doi:10.1145/2660193.2660195; Box-Muller).  So
``W(t)`` is one function of ``t`` however often and wherever it is queried: an impact's root
search, the sub-steps of a Hertz contact and a finer time step all see the same path (the
virtual Brownian tree of Gaines and Lyons, "Variable step size control in the numerical
solution of stochastic differential equations", SIAM J. Appl. Math. 57(5) 1997,
doi:10.1137/S0036139995286515; Li, Wong, Chen and Duvenaud, AISTATS 2020).  Below
``TREE_DEPTH`` levels the path is linear, so it is exactly the same path for every query
pattern (at ``dt = 1e-3`` its pieces last 61 ns).

With a replayed path of ``refine`` fine normals a step, the tree hangs below each fine
interval, keyed by the fine interval's index: a coarse run and the fine run of the same
normals see the same path, the basis of the strong convergence studies.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit
from ..jit.flags import INLINE
from ..streams.rng import TAIL_WORD, fast_pair, log_positive, sincos_turn

#: Levels of bisection below a (fine) step; the path is linear between the leaves.
TREE_DEPTH = 14

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_LOW32 = np.uint64(0xFFFFFFFF)
_S30, _S27, _S31, _S32 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(32)


@njit(**INLINE)
def mix(z):
    """splitmix64's output function of ``z + golden``: a bijective 64-bit hash (of ``z`` as an
    unsigned 64-bit integer: a signed one would shift arithmetically)."""
    z = np.uint64(z) + _GOLDEN
    z = (z ^ (z >> _S30)) * _MIX1
    z = (z ^ (z >> _S27)) * _MIX2
    return z ^ (z >> _S31)


@njit(**INLINE)
def interval_key(seed, interval: int, floor: int):
    """Key of the tree below (fine) step ``interval`` of floor ``floor``'s Wiener process."""
    return mix(mix(np.uint64(seed) ^ np.uint64(interval)) ^ np.uint64(floor))


@njit(**INLINE)
def node_normal(key, node: int) -> float:
    """The standard normal of tree node ``node``: the cosine half of the Box-Muller pair of the
    hash's two 32-bit halves in ``rng.fast_pair``'s ``float32`` transform, and where the first
    half is below ``rng.TAIL_WORD`` (radius beyond 4.7, one node in 65,536) in ``float64``, with
    ``u1 = (w + 1/2) 2^-32``.  (With libm's ``float64`` logarithm and cosine a plastic impact under
    noise cost 2.7 us and a steel Hertz contact 46 us, against 1.7 and 36 with this: each
    contact sub-step and each root-search trial queries the tree.)"""
    h = mix(key ^ (np.uint64(node) * _GOLDEN))
    wa, wb = h >> _S32, h & _LOW32
    if wa >= TAIL_WORD:
        return float(fast_pair(wa, wb)[0])
    u1 = (np.float64(wa) + 0.5) * 2.0**-32
    return math.sqrt(-2.0 * log_positive(u1)) * sincos_turn(np.float64(wb) * 2.0**-32)[0]


@njit(**INLINE)
def tree_seed(high: float, low: float):
    """The seed of a path's trees from two uniforms of its bridge stream (``[0, 1)``): their
    upper 32 bits each, as one ``uint64``."""
    return (np.uint64(high * 2.0**32) << np.uint64(32)) | np.uint64(low * 2.0**32)


#: Entries of a floor's memo of its last descent (``tree_value``): ``lo, hi, W(lo), W(hi)`` and
#: the node of each level, then the number of levels kept and the interval they belong to.
MEMO = 5 * (TREE_DEPTH + 1) + 2


def new_memo(n_floors: int) -> np.ndarray:
    """An empty descent memo for ``n_floors`` floors (``tree_value``)."""
    return np.zeros(n_floors * MEMO)


@njit(**INLINE)
def forget(memo) -> None:
    """Empty every floor's descent memo (``tree_value``): its next query is another path's."""
    for base in range(0, memo.shape[0], MEMO):
        memo[base + MEMO - 2] = 0.0


@njit(**INLINE)
def tree_value(total: float, length: float, tau: float, scale: float, key, interval: int, memo,
               base: int) -> float:
    """``W(tau)`` of ``scale`` times a Brownian motion on ``[0, length]`` with ``W(0) = 0``,
    ``W(length) = total``: the virtual Brownian tree of ``key``.

    ``memo[base:base + MEMO]`` keeps the intervals of the last descent in the tree of
    ``interval`` (any other interval starts afresh): a query resumes below the deepest kept
    interval that holds ``tau`` strictly inside, where a descent from the root would pass through
    the same intervals with the same values (the ones stored), so the value does not depend on
    the queries before it.  Sub-steps of a contact query nearby instants, a few levels each.
    (Inlined: as a function of its own, compiled once for every loop, the scalar loop of the
    impact-rich scene ran at 0.91x.)"""
    if tau <= 0.0:
        return 0.0
    if tau >= length:
        return total
    levels = base + MEMO - 2
    if memo[levels] == 0.0 or memo[levels + 1] != interval:
        (memo[base], memo[base + 1], memo[base + 2], memo[base + 3],
         memo[base + 4]) = 0.0, length, 0.0, total, 1.0
        memo[levels], memo[levels + 1] = 1.0, interval
    level = int(memo[levels]) - 1
    while level > 0 and not (memo[base + 5 * level] < tau < memo[base + 5 * level + 1]):
        level -= 1
    row = base + 5 * level
    lo, hi, w_lo, w_hi, node = memo[row], memo[row + 1], memo[row + 2], memo[row + 3], int(memo[row + 4])
    for depth in range(level, TREE_DEPTH):
        mid = 0.5 * (lo + hi)
        w_mid = 0.5 * (w_lo + w_hi) + scale * math.sqrt(0.25 * (hi - lo)) * node_normal(key, node)
        if tau == mid:
            memo[levels] = depth + 1.0
            return w_mid
        if tau < mid:
            hi, w_hi, node = mid, w_mid, 2 * node
        else:
            lo, w_lo, node = mid, w_mid, 2 * node + 1
        row = base + 5 * (depth + 1)
        memo[row], memo[row + 1], memo[row + 2], memo[row + 3], memo[row + 4] = lo, hi, w_lo, w_hi, node
    memo[levels] = TREE_DEPTH + 1.0  # every level down to the leaf is kept
    return w_lo + (w_hi - w_lo) * ((tau - lo) / (hi - lo))


@njit(**INLINE)
def path_value(seed, step: int, k: int, total: float, dt: float, tau: float, scale: float, normals,
               refine: int, stride: int, slot: int, replay: bool, memo) -> float:
    """``W_k(tau)`` of floor ``k`` inside step ``step`` (``0 <= tau <= dt``; ``total``: the step's
    increment, ``scale``: ``sigma_k``).  With ``replay``, ``refine`` fine normals a step, floor
    ``k``'s at ``normals[fine * stride + slot]``.  ``memo``: each floor's descent memo
    (``new_memo``)."""
    if not replay or refine == 1:
        return tree_value(total, dt, tau, scale, interval_key(seed, step, k), step, memo, k * MEMO)
    h = dt / refine
    j = min(int(tau / h), refine - 1)
    root = scale * math.sqrt(h)
    base = 0.0
    first = step * refine
    for f in range(first, first + j):
        base += root * normals[f * stride + slot]
    fine = root * normals[(first + j) * stride + slot]
    return base + tree_value(fine, h, tau - j * h, scale, interval_key(seed, first + j, k), first + j, memo,
                             k * MEMO)
