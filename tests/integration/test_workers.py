"""The test run's worker processes (``make test``: one a core, ``tests/conftest.py``)."""

from __future__ import annotations

import ctypes
import os
from pathlib import Path

import numpy as np
import pytest


def _openblas_threads() -> int | None:
    """The thread count of the OpenBLAS numpy's wheels bundle (None for another BLAS)."""
    libs = sorted((Path(np.__file__).parent.parent / "numpy.libs").glob("libscipy_openblas*"))
    for lib in libs:
        get = getattr(ctypes.CDLL(str(lib)), "scipy_openblas_get_num_threads64_", None)
        if get is not None:
            return int(get())
    return None


def test_a_worker_runs_numpy_s_blas_on_one_thread():
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        pytest.skip("not a worker process of pytest-xdist")
    threads = _openblas_threads()
    if threads is None:
        pytest.skip("numpy's BLAS is not the OpenBLAS of its wheels")
    assert threads == 1
