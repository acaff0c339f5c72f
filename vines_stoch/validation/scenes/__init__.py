"""The scenes of the validation floor, one scenario file each (``<name>.toml`` beside this
module, every one complete and valid on its own).  Studies read a scene as a dict, change it by
dotted keys (``{"simulation.dt": 1e-3, "absorbers.1.restitution": 0.0}``) or plain dict edits,
and validate the result as a scenario::

    scene("impulse", {"simulation.dt": 0.01})                  # the Scene a kernel runs
    study("smooth", {"ensemble.realizations": 20})             # a Study for vines_stoch.run
    data = scene_data("ssvi"); data["loads"].append(noise)     # edit, then study(data)
"""

from __future__ import annotations

import copy
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ...scenario.study import Study
from ...scenario.sweeps import get_path, set_path

if TYPE_CHECKING:
    from ...scene import Scene

#: The folder of the scene files.
FOLDER = Path(__file__).resolve().parent


def names() -> list[str]:
    """The names of the scene files, sorted."""
    return sorted(path.stem for path in FOLDER.glob("*.toml"))


def scene_data(name: str) -> dict[str, Any]:
    """The tables of ``<name>.toml``, a fresh dict at each call (edit it freely)."""
    path = FOLDER / f"{name}.toml"
    if not path.is_file():
        raise KeyError(f"no scene {name!r}: the scenes are {', '.join(names())}")
    return tomllib.loads(path.read_text())


def changed(data: Mapping[str, Any], changes: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """A deep copy of ``data`` with each dotted key of ``changes`` set to (a copy of) its value;
    tables missing on the way are created (``ensemble.realizations`` on a scene without
    ``[ensemble]``), list indices must exist."""
    data = copy.deepcopy(dict(data))
    for key, value in (changes or {}).items():
        parts = key.split(".")
        for depth in range(1, len(parts)):
            try:
                get_path(data, ".".join(parts[:depth]))
            except KeyError:
                set_path(data, ".".join(parts[:depth]), {})
        set_path(data, key, copy.deepcopy(value))
    return data


def text(data: Mapping[str, Any]) -> str:
    """Scenario TOML text of ``data`` (what a run records as its scenario, or a file to write)."""
    import tomlkit

    return tomlkit.dumps(dict(data))


def study(scene: str | Mapping[str, Any], changes: Mapping[str, Any] | None = None, *,
          source: str | None = None, directory: Path = Path(".")) -> Study:
    """The validated Study of the scene named ``scene`` (or of scene data) with ``changes``
    (dotted keys) applied; ``source`` names it in messages (default: its file, or its name),
    record files are found relative to ``directory``."""
    if isinstance(scene, str):
        data, default = scene_data(scene), str(FOLDER / f"{scene}.toml")
    else:
        data, default = dict(scene), str(scene.get("name", "<scene>"))
    data = changed(data, changes)
    return Study(source or default, text(data), data, Path(directory))


def scene(scene: str | Mapping[str, Any], changes: Mapping[str, Any] | None = None, *,
          directory: Path = Path(".")) -> Scene:
    """The Scene (kernel arrays) of the first sweep point of ``study(scene, changes)``."""
    from ...scene import build_scene

    return build_scene(study(scene, changes, directory=directory).points[0])


__all__ = ["FOLDER", "changed", "names", "scene", "scene_data", "study", "text"]
