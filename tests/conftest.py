"""Fixtures shared by the tests (helpers that are plain functions live in ``tests/helpers.py``)."""

from __future__ import annotations

import pytest


@pytest.fixture
def write(tmp_path):
    """Write scenario text to a file and return its path."""

    def _write(text: str, name: str = "scenario.toml"):
        path = tmp_path / name
        path.write_text(text)
        return path

    return _write
