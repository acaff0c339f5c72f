"""``jit.intrinsics.copy_into``: the step loops' ``dst[:] = src`` without numba's shape-formatting error."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from vines_stoch.jit.intrinsics import copy_into


@njit
def _copied(dst, src):
    copy_into(dst, src)
    return dst


def test_copy_into_copies_every_item_and_refuses_other_lengths():
    src = np.array([1.5, -2.25, np.pi, np.nan, 1e-300])
    dst = np.zeros(5)
    out = _copied(dst, src)
    assert out is dst or np.shares_memory(out, dst)
    assert dst.tobytes() == src.tobytes()  # bitwise, NaN included
    assert _copied(np.zeros(0), np.zeros(0)).shape == (0,)
    shorter = np.full(4, 7.0)
    with pytest.raises(ValueError, match="different lengths"):
        _copied(shorter, src)
    assert np.all(shorter == 7.0)  # nothing written


def test_the_copy_does_not_compile_numba_s_shape_mismatch_message():
    """No ``raise_with_shape_context`` (integer and string formatting, about 2 s of a cold
    compile) in the compiled code, where a slice assignment has it."""

    @njit
    def sliced(dst, src):
        dst[:] = src
        return dst

    for f in (_copied, sliced):
        f(np.zeros(2), np.ones(2))
    assert "raise_with_shape_context" in sliced.inspect_llvm(sliced.signatures[0])
    assert "raise_with_shape_context" not in _copied.inspect_llvm(_copied.signatures[0])
