"""Helpers of the tests: scenes from dicts or scenario text, one realisation's metrics by name, the
command line run in-process."""

from __future__ import annotations

import contextlib
import io
import sys
from pathlib import Path

from vines_stoch import parse_scenario
from vines_stoch.cli import main
from vines_stoch.kernels import SLOTS, simulate
from vines_stoch.scenario.study import Study
from vines_stoch.scene import build_scene

#: The repository's root folder (scenario examples under ``scenarios/``; ``../shared`` beside it).
ROOT = Path(__file__).resolve().parents[1]


def two_dof(primary_damping: float = 0.02, stiffness: str = "1.0", damping: str = "0.01") -> str:
    """Scenario text of the primary (m = k = 1) with one cubic NES (m = 0.05): the bodies of the
    ensemble tests (values as TOML text, so templates may leave placeholders)."""
    return (f"[primary]\nmass = 1.0\nstiffness = 1.0\ndamping = {primary_damping}\n"
            f"[[absorbers]]\ntype = \"cubic\"\nmass = 0.05\nstiffness = {stiffness}\ndamping = {damping}\n")


def scene_of(text: str, point: int = 0):
    """The Scene of one sweep point of scenario text."""
    return build_scene(parse_scenario(text).points[point])


def scene_from(data: dict, point: int = 0):
    """The Scene of one sweep point of a scenario given as a dict (the tables of a scenario file)."""
    return build_scene(Study("<test scenario>", "", data).points[point])


def raw_metrics(scene, generator=None) -> dict[str, float]:
    """Raw kernel slots of one realisation, by name."""
    return dict(zip(SLOTS, simulate(scene, generator)))


def cli(*args: str) -> tuple[int, str]:
    """Exit status and standard error of ``vines-stoch ARGS`` run in-process."""
    err, out = io.StringIO(), io.StringIO()
    argv = sys.argv
    sys.argv = ["vines-stoch", *map(str, args)]
    code = 0
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            main()
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    finally:
        sys.argv = argv
    return code, err.getvalue()
