"""Shared helpers: scenario text builders and a runner for one realisation."""

from __future__ import annotations

import pytest

from vines_stoch import parse_scenario
from vines_stoch.kernels import SLOTS, simulate
from vines_stoch.scene import build_scene


def scene_of(text: str, point: int = 0):
    """The Scene of one sweep point of scenario text."""
    return build_scene(parse_scenario(text).points[point])


def raw_metrics(scene, generator=None) -> dict[str, float]:
    """Raw kernel slots of one realisation, by name."""
    return dict(zip(SLOTS, simulate(scene, generator)))


@pytest.fixture
def write(tmp_path):
    """Write scenario text to a file and return its path."""

    def _write(text: str, name: str = "scenario.toml"):
        path = tmp_path / name
        path.write_text(text)
        return path

    return _write
