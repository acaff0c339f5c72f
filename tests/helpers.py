"""Helpers of the tests: scenes and studies from dicts (the tables of a scenario file), one
realisation's metrics by name, the command line run in-process."""

from __future__ import annotations

import contextlib
import io
import sys
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from vines_stoch.cli import main
from vines_stoch.kernels import SLOTS, simulate
from vines_stoch.scenario.study import Study
from vines_stoch.scene import build_scene
from vines_stoch.validation.scenes import changed
from vines_stoch.validation.scenes import text as toml_text

#: The repository's root folder (scenario examples under ``scenarios/``; ``../shared`` beside it).
ROOT = Path(__file__).resolve().parents[1]

__all__ = ["ROOT", "changed", "cli", "example_data", "lane_metrics", "raw_metrics", "scene_from",
           "run_interrupted", "sdof_fragility_run", "study_from", "toml_text",
           "two_dof_data"]


def two_dof_data(primary_damping: float = 0.02, stiffness: float = 1.0,
                 damping: float = 0.01) -> dict[str, Any]:
    """The primary (m = k = 1) with one cubic NES (m = 0.05): the ``primary`` and ``absorbers``
    tables of the ensemble tests (add a name, loads and a simulation)."""
    return {"primary": {"mass": 1.0, "stiffness": 1.0, "damping": primary_damping},
            "absorbers": [{"type": "cubic", "mass": 0.05, "stiffness": stiffness, "damping": damping}]}


def example_data(name: str, *drop: str) -> dict[str, Any]:
    """The tables of the example scenario ``scenarios/<name>.toml``, those named in ``drop``
    (e.g. ``"sweep"``) left out."""
    data = tomllib.loads((ROOT / "scenarios" / f"{name}.toml").read_text())
    for table in drop:
        del data[table]
    return data


def study_from(data: Mapping[str, Any], changes: Mapping[str, Any] | None = None, *,
               source: str = "<test scenario>", directory: Path = Path(".")) -> Study:
    """The validated Study of a scenario given as a dict, with ``changes`` (dotted keys, as
    ``changed``) applied; its text (what a run records) is the TOML of the tables."""
    data = changed(data, changes)
    return Study(source, toml_text(data), data, Path(directory))


def scene_from(data: Mapping[str, Any], point: int = 0, changes: Mapping[str, Any] | None = None):
    """The Scene of one sweep point of a scenario given as a dict (with ``changes`` applied)."""
    return build_scene(study_from(data, changes).points[point])


def example_scene(name: str, changes: Mapping[str, Any], scheme: str | None = None):
    """The scene of the example scenario ``scenarios/<name>.toml`` without its sweep, with
    ``changes`` (dotted keys) applied and run by ``scheme`` (None: the file's)."""
    data = example_data(name)
    data.pop("sweep", None)
    return scene_from(data, changes={**changes, **({"simulation.scheme": scheme} if scheme else {})})


def raw_metrics(scene, generator=None, **options) -> dict[str, float]:
    """Raw kernel slots of one realisation, by name (``options``: those of ``simulate``, e.g.
    ``final``)."""
    return dict(zip(SLOTS, simulate(scene, generator, **options)))


def lane_metrics(scene, seed: int, n: int) -> list[dict[str, float]]:
    """Raw kernel slots, by name, of realisations ``0 .. n - 1`` of an ensemble chunk
    (``simulate_chunk``: in SIMD lanes where the scene runs there, on its Philox streams)."""
    from vines_stoch.kernels.chunk import simulate_chunk

    return [dict(zip(SLOTS, row)) for row in simulate_chunk(scene, seed, 0, 0, n).raw]


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


def sdof_fragility_run(folder: Path, name: str, realizations: int, points: int, samples: int) -> Path:
    """Run a linear SDOF (1 Hz, 5 % damping) under white noise swept over ``points`` intensities
    from 0.2 to 2.0, with the limit ``roof`` on ``x1_max`` at 0.25, through the command line
    into ``folder / "run"``, then ``vines-stoch fragility`` on it with ``samples`` bootstrap
    samples; returns the run's folder."""
    scenario = folder / "s.toml"
    scenario.write_text(f"""
name = "{name}"
[primary]
mass = 1.0
stiffness = 39.47841760435743
damping = 0.6283185307179586
[[loads]]
type = "white-noise"
intensity = 1.0
[simulation]
duration = 5.0
dt = 0.005
[ensemble]
realizations = {realizations}
seed = 3
[sweep]
"loads.0.intensity" = {{ logspace = [0.2, 2.0, {points}] }}
[limits]
roof = {{ metric = "x1_max", value = 0.25 }}
""")
    out = folder / "run"
    assert cli("run", scenario, "--out", out, "--quiet")[0] == 0
    code, err = cli("fragility", out, "--limit", "roof", "--im", "loads.0.intensity", "--samples",
                    str(samples))
    assert code == 0, err
    return out


def run_interrupted(monkeypatch: Any, scenario: Any, folder: Path, after: int, **options: Any) -> None:
    """Run ``scenario`` into ``folder`` (``vines_stoch.run``, a checkpoint after every fold)
    until its ``after``-th table write, which raises ``KeyboardInterrupt`` as Ctrl-C would:
    the folder a resume starts from."""
    import pytest

    from vines_stoch import run, store

    writes, real_write = [], store.write_table

    def interrupting(frame, path, meta=None):
        if len(writes) == after:
            raise KeyboardInterrupt
        writes.append(path)
        real_write(frame, path, meta)

    monkeypatch.setattr(store, "write_table", interrupting)
    with pytest.raises(KeyboardInterrupt):
        run(scenario, folder, checkpoint_seconds=0.0, **options)
    monkeypatch.setattr(store, "write_table", real_write)
