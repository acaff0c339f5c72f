"""Fixtures shared by the tests (helpers that are plain functions live in ``tests/helpers.py``)."""

from __future__ import annotations

import os

# The cuda backend's tests run on numba-cuda's simulator where no GPU is (NUMBA_ENABLE_CUDASIM=0
# runs them on a GPU); numba reads the switch once, when first imported: before anything else.
os.environ.setdefault("NUMBA_ENABLE_CUDASIM", "1")

import pytest  # noqa: E402


@pytest.fixture
def write(tmp_path):
    """Write scenario text to a file and return its path."""

    def _write(text: str, name: str = "scenario.toml"):
        path = tmp_path / name
        path.write_text(text)
        return path

    return _write
