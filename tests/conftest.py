"""Fixtures shared by the tests (helpers that are plain functions live in ``tests/helpers.py``)."""

from __future__ import annotations

import os

# The cuda backend's tests run on numba-cuda's simulator where no GPU is (NUMBA_ENABLE_CUDASIM=0
# runs them on a GPU); numba reads the switch once, when first imported: before anything else.
os.environ.setdefault("NUMBA_ENABLE_CUDASIM", "1")
# `make test` runs one worker process per core: there, numpy's and scipy's BLAS take one thread
# each (read when numpy loads, which no worker has done yet). With a thread per core in every
# worker, BLAS threads spin on cores the other workers need: the Welch test of the wind loads
# took 6-8 s beside the others against 2.5-3.5 s alone, and the warm suite 70 s against 64 s.
if os.environ.get("PYTEST_XDIST_WORKER"):
    for _blas in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_blas, "1")

# A short run takes the loops specialised to its structures where they are compiled already, on
# disk or in this process (``ensemble.planning.specialised_loops``), unless
# VINES_STOCH_GENERAL_WORK is set: set to its default here, so that which loop a test's run takes
# does not depend on what other tests compiled before it (the tests of the choice unset it).
os.environ.setdefault("VINES_STOCH_GENERAL_WORK", "100000000")

import pytest  # noqa: E402


@pytest.fixture
def write(tmp_path):
    """Write scenario text to a file and return its path."""

    def _write(text: str, name: str = "scenario.toml"):
        path = tmp_path / name
        path.write_text(text)
        return path

    return _write
