"""``jit.intrinsics.larger`` and ``smaller``: ``max`` and ``min`` of two floats as one select in
place, bit for bit numba's builtins (NaN on either side, signed zeros, infinities), so that the
loops that use them give the numbers they gave with the builtins."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from numba import njit
from numba.core.errors import TypingError

from vines_stoch.jit.intrinsics import larger, smaller


@njit
def _pairs(a, b, out):
    for i in range(a.shape[0]):
        out[i, 0], out[i, 1] = larger(a[i], b[i]), max(a[i], b[i])
        out[i, 2], out[i, 3] = smaller(a[i], b[i]), min(a[i], b[i])


def test_larger_and_smaller_are_numba_s_max_and_min_bit_for_bit():
    special = [0.0, -0.0, 1.0, -1.0, np.inf, -np.inf, np.nan, 5e-324, -2.5, 1e308]
    rng = np.random.default_rng(7)
    pairs = list(itertools.product(special, repeat=2)) + list(zip(rng.normal(size=500), rng.normal(size=500)))
    a, b = (np.array(side) for side in zip(*pairs))
    out = np.empty((a.size, 4))
    _pairs(a, b, out)
    bits = out.view(np.uint64)
    assert np.array_equal(bits[:, 0], bits[:, 1]) and np.array_equal(bits[:, 2], bits[:, 3])
    # (the pairs hold both orders of a NaN and of the two zeros, where the order decides)
    assert np.isnan(out[(np.isnan(a)) & ~np.isnan(b), 0]).all()
    assert not np.isnan(out[~np.isnan(a) & np.isnan(b), 0]).any()


def test_larger_and_smaller_take_floats_only():
    with pytest.raises(TypingError):
        njit(lambda: larger(1, 2))()
