"""Quantiles of large samples in compiled code: numpy's ``quantile`` (its default ``linear``
method, Hyndman and Fan's type 7), bit for bit, without partitioning the whole sample.

``np.quantile`` partitions a copy of the sample around each order statistic it needs (about
1.5 ms for 1e5 values and three quantiles: a summary's quantiles cost more than a short path's
steps).  Here the values are counted into buckets of equal width between their minimum and
maximum (one pass), the buckets holding the wanted ranks are gathered (a second pass) and only
those are searched again or sorted: the same order statistics, interpolated as numpy does
(``tests/unit/statistics/test_summary_tables.py`` compares them bitwise).
"""

from __future__ import annotations

import numpy as np

from .jit import njit
from .jit.flags import KERNEL

#: Buckets of one counting pass.
BUCKETS = 4096
#: Samples at most this size are sorted instead of counted into buckets.
SMALL = 256
#: Counting passes of one rank before its bucket is sorted whatever its size.
MAX_LEVELS = 6


@njit(**KERNEL)
def _counts(a, lo, scale):
    """How many of ``a`` fall in each bucket ``int((x - lo) * scale)`` (the last one holding
    the maximum too): the bucket of ``x`` never decreases as ``x`` grows."""
    counts = np.zeros(BUCKETS + 1, np.int64)
    for x in a:
        counts[min(int((x - lo) * scale), BUCKETS)] += 1
    return counts


@njit(**KERNEL)
def _select(a, k):
    """The ``k``-th smallest of ``a`` (from 0; no NaN)."""
    for _ in range(MAX_LEVELS):
        if a.size <= SMALL:
            break
        lo, hi = a.min(), a.max()
        if lo == hi:
            return lo
        scale = BUCKETS / (hi - lo)
        if not np.isfinite(scale) or scale == 0.0:
            break
        counts = _counts(a, lo, scale)
        b = 0
        while k >= counts[b]:
            k -= counts[b]
            b += 1
        kept = np.empty(counts[b], a.dtype)
        i = 0
        for x in a:
            if min(int((x - lo) * scale), BUCKETS) == b:
                kept[i] = x
                i += 1
        a = kept
    return np.sort(a)[k]


@njit(**KERNEL)
def _order_statistics(values, ranks, out):
    """``out[i]``: the ``ranks[i]``-th smallest of ``values`` (from 0; no NaN): one pass
    for the extremes, one counting the buckets, one gathering the buckets that hold a rank."""
    lo, hi = values[0], values[0]
    for x in values:
        lo, hi = min(lo, x), max(hi, x)
    scale = BUCKETS / (hi - lo) if hi > lo else 0.0
    if hi == lo or not np.isfinite(scale) or scale == 0.0:  # (one value; a width past the
        # largest double, or an infinite value: the bucket of a value would be undefined)
        for i in range(ranks.size):
            out[i] = lo if hi == lo else _select(values, ranks[i])
        return
    counts = _counts(values, lo, scale)
    first = np.zeros(BUCKETS + 2, np.int64)  # (the rank of each bucket's first value)
    first[1:] = np.cumsum(counts)
    slot = np.full(BUCKETS + 1, -1, np.int64)
    offset = np.zeros(ranks.size + 1, np.int64)  # (where each gathered bucket starts)
    held = np.empty(ranks.size, np.int64)
    kept = 0
    for i in range(ranks.size):
        b = np.searchsorted(first, ranks[i], side="right") - 1
        held[i] = b
        if slot[b] < 0:
            slot[b] = kept
            offset[kept + 1] = offset[kept] + counts[b]
            kept += 1
    gathered = np.empty(offset[kept], values.dtype)
    fill = offset[:kept].copy()
    for x in values:
        s = slot[min(int((x - lo) * scale), BUCKETS)]
        if s >= 0:
            gathered[fill[s]] = x
            fill[s] += 1
    for i in range(ranks.size):
        s = slot[held[i]]
        out[i] = _select(gathered[offset[s]:offset[s + 1]], ranks[i] - first[held[i]])


@njit(**KERNEL)
def _quantiles(values, q, out):
    """``out[i] = np.quantile(values, q[i])`` for ``values`` without NaN (two or more): numpy's
    virtual index ``(n - 1) q``, its neighbouring order statistics (both the last where it is
    past it, both the first where it is before it), and its ``_lerp`` (from the upper one where
    the weight is one half or more)."""
    n = values.size
    virtual = np.empty(q.size)
    ranks = np.empty(2 * q.size, np.int64)
    for i in range(q.size):
        virtual[i] = (n - 1) * q[i]
        below = int(np.floor(virtual[i]))
        ranks[2 * i], ranks[2 * i + 1] = below, below + 1
        if virtual[i] >= n - 1:
            ranks[2 * i], ranks[2 * i + 1] = n - 1, n - 1
        elif virtual[i] < 0:
            ranks[2 * i], ranks[2 * i + 1] = 0, 0
    order = np.empty(ranks.size)
    _order_statistics(values, ranks, order)
    for i in range(q.size):
        a, b = order[2 * i], order[2 * i + 1]
        t = virtual[i] - np.floor(virtual[i])
        diff = b - a
        out[i] = b - diff * (1.0 - t) if t >= 0.5 else a + diff * t


def quantiles(values: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``np.quantile(values, q)`` (``linear``) of ``values`` without NaN, bit for bit."""
    # (contiguous and writable: a read-only array, a column of a table read back, would be
    # another numba type, and compile the loops again)
    values = np.require(values, np.float64, ["C", "W"])
    q = np.require(q, np.float64, ["C", "W"])
    if values.size < 2:
        return np.quantile(values, q)
    out = np.empty(q.size)
    _quantiles(values, q, out)
    return out


__all__ = ["quantiles"]
